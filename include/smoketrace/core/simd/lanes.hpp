#pragma once
// Lanes: the one way the kernels use SIMD registers (docs/simd.md). A kernel is written once over
// Lanes<T, N> (Floats<N>, Doubles<N>, UInts<N>, Bytes<N>) and its Mask<T, N>; every width compiles on
// every build: where the build targets an instruction set that holds N lanes of T in a register, each
// operation is one instruction of that set (lanes_sse2.hpp, lanes_avx2.hpp, lanes_avx512.hpp,
// lanes_neon.hpp), elsewhere it is its definition, lane by lane in plain C++ (lanes_scalar.hpp). The two
// give the same bits.
//
// Kernels over many independent rays take the widest registers the build targets: kFloatLanes floats
// (or 32-bit integers) and kDoubleLanes doubles per operation, and loop over blocks of that many lanes.
// NEON's 128-bit registers give 4 and 2. On x86 without AVX2 both are 1: such a kernel compiles to its
// scalar twin, one lane per block (SSE2's four floats are used only by kernels of four lanes by nature,
// the 4-wide BVH's box test).
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/core/simd/lanes_scalar.hpp>
#include <smoketrace/core/simd/lanes_sse2.hpp>
#include <smoketrace/core/simd/lanes_avx2.hpp>
#include <smoketrace/core/simd/lanes_avx512.hpp>
#include <smoketrace/core/simd/lanes_neon.hpp>

namespace smoketrace::simd {

#if defined(SMOKETRACE_SIMD_AVX512)
inline constexpr unsigned kFloatLanes = 16;
inline constexpr unsigned kDoubleLanes = 8;
#elif defined(SMOKETRACE_SIMD_AVX2)
inline constexpr unsigned kFloatLanes = 8;
inline constexpr unsigned kDoubleLanes = 4;
#elif defined(SMOKETRACE_SIMD_NEON)
inline constexpr unsigned kFloatLanes = 4;
inline constexpr unsigned kDoubleLanes = 2;
#else
inline constexpr unsigned kFloatLanes = 1;
inline constexpr unsigned kDoubleLanes = 1;
#endif
inline constexpr unsigned kUIntLanes = kFloatLanes;

}  // namespace smoketrace::simd
