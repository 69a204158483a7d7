# cmake --install: libcrisp (static and shared), the public headers (crisp/crisp.h includes them
# all), the crisp command, crisp.pc for pkg-config and crispConfig.cmake for find_package(crisp).
# The GL apps embed their shaders, so there are no data files to install.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

install(TARGETS crisp crisp_shared
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(TARGETS crisp_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/crisp DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
        FILES_MATCHING PATTERN "*.h")
install(FILES ${PROJECT_BINARY_DIR}/include/crisp/version.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/crisp)

# What a program linking the static libcrisp.a also needs (the shared library carries these
# itself): libpng, the OpenEXR C core, OpenSubdiv and the C++ runtime when built with it, libm,
# pthreads. A module that links another system library (the GL backend: EGL, OpenGL, GLFW) adds
# it to both lists below, under if(TARGET crisp_<module>); tests/install checks the static link.
set(CRISP_PC_LIBS_PRIVATE "-lpng -lOpenEXRCore")
if(TARGET crisp_osd)
  string(APPEND CRISP_PC_LIBS_PRIVATE " -losdCPU -lstdc++")
endif()
if(TARGET crisp_gl)
  string(APPEND CRISP_PC_LIBS_PRIVATE " -lEGL") # the headless GL context (GL itself is loaded by glad)
endif()
string(APPEND CRISP_PC_LIBS_PRIVATE " -lm -pthread")
set(CRISP_STATIC_LINK png OpenEXRCore)
if(TARGET crisp_osd)
  list(APPEND CRISP_STATIC_LINK osdCPU stdc++)
endif()
if(TARGET crisp_gl)
  list(APPEND CRISP_STATIC_LINK EGL)
endif()
list(APPEND CRISP_STATIC_LINK m pthread)

# The prefix relative to the .pc file's folder, so an installed tree can be moved (or installed
# with --prefix at install time) and pkg-config still finds the headers and libraries.
file(RELATIVE_PATH CRISP_PC_TO_PREFIX /prefix/${CMAKE_INSTALL_LIBDIR}/pkgconfig /prefix)
configure_file(${PROJECT_SOURCE_DIR}/cmake/crisp.pc.in ${PROJECT_BINARY_DIR}/crisp.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/crisp.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

set(CRISP_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/crisp)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/crispConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/crispConfig.cmake
                              INSTALL_DESTINATION ${CRISP_CMAKE_DIR}
                              PATH_VARS CMAKE_INSTALL_INCLUDEDIR CMAKE_INSTALL_LIBDIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/crispConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/crispConfig.cmake ${PROJECT_BINARY_DIR}/crispConfigVersion.cmake
        DESTINATION ${CRISP_CMAKE_DIR})
