/* Compiler hints shared by the hot loops (the rasterizer, the resolve, the SLEFE rows).
 * ALWAYS_INLINE: inlined even where GCC's size heuristics would not (the constant-argument
 * copies rely on it); UNROLL(n): GCC's unroll pragma for the loop that follows, nothing with
 * other compilers. Neither changes what the code computes. */
#ifndef CRISP_CORE_COMPILER_H
#define CRISP_CORE_COMPILER_H

#if defined(__GNUC__)
#define ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define ALWAYS_INLINE inline
#endif

#if defined(__GNUC__) && !defined(__clang__)
#define CRISP_PRAGMA(x) _Pragma(#x)
#define UNROLL(n) CRISP_PRAGMA(GCC unroll n)
#else
#define UNROLL(n)
#endif

#endif
