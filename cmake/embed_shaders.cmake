# Embeds GLSL sources into a C file (run with cmake -P): -DOUT=file.c -DIN="a.glsl;b.glsl".
# Each file becomes `const char crisp__shader_<name>[]` (NUL-terminated), <name> = the file name
# with '.' and '-' turned into '_'.
set(_c "/* Generated from shaders/ by cmake/embed_shaders.cmake; do not edit. */\n")
foreach(f ${IN})
  get_filename_component(_n ${f} NAME)
  string(REGEX REPLACE "[.-]" "_" _n ${_n})
  file(READ ${f} _hex HEX)
  string(LENGTH "${_hex}" _len)
  string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," _hex "${_hex}")
  string(REGEX REPLACE "(0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,)" "\\1\n" _hex "${_hex}")
  string(APPEND _c "extern const char crisp__shader_${_n}[];\nconst char crisp__shader_${_n}[] = {\n${_hex}0x00};\n")
endforeach()
file(WRITE ${OUT}.tmp "${_c}")
file(COPY_FILE ${OUT}.tmp ${OUT} ONLY_IF_DIFFERENT)
