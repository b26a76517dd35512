#pragma once
// The instruction sets the build targets, as the only macros the code tests (docs/simd.md): the compiler's
// own (__AVX512F__, __AVX2__, …, __ARM_NEON) are read here and nowhere else. Each is defined when the build
// may use that set, and each x86 one implies the x86 ones below it:
//   SMOKETRACE_SIMD_AVX512: AVX-512 F and DQ (every AVX-512 CPU since Skylake-SP; the native build here);
//   SMOKETRACE_SIMD_AVX2:   AVX2 (x86-64-v3, the sanitizers' ASan tree);
//   SMOKETRACE_SIMD_SSE2:   SSE2 (every x86-64, the TSan tree);
//   SMOKETRACE_SIMD_NEON:   AArch64's Advanced SIMD (every 64-bit Arm CPU; scripts/cross_aarch64.sh).
// Code for one of them lives only in files named for it (lanes_avx512.hpp, stable_ranks_avx2.hpp, …),
// whose contents compile to nothing without it.
#if defined(__AVX512F__) && defined(__AVX512DQ__) && defined(__AVX2__)
#define SMOKETRACE_SIMD_AVX512 1
#endif
#if defined(__AVX2__)
#define SMOKETRACE_SIMD_AVX2 1
#endif
#if defined(__SSE2__)
#define SMOKETRACE_SIMD_SSE2 1
#endif
#if defined(__ARM_NEON) && defined(__aarch64__)
#define SMOKETRACE_SIMD_NEON 1
#endif
