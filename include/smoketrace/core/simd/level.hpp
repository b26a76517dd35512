#pragma once
// Kernel levels: the instruction sets a kernel can be compiled for, and the one this process runs
// (docs/simd.md, "One binary, every CPU"). A dispatching build (CMake option SMOKETRACE_DISPATCH, the
// default on x86-64) compiles the hot passes once per level and runs, in every pass, the highest level
// the CPU has; a build for one level (SMOKETRACE_NATIVE, other architectures) holds only its own.
//
// The level is chosen once per process, on first use. SMOKETRACE_SIMD=<name> chooses a lower one (for
// tests and comparisons); a level the binary lacks or the CPU cannot run is an error, never a silent
// fallback, so that a figure labelled AVX2 is an AVX2 figure.
#include <smoketrace/core/simd/isa.hpp>

#include <optional>
#include <span>
#include <string_view>

namespace smoketrace::simd {

// Ordered: each x86 level runs everything the levels below it run.
enum class Level : int {
    scalar = 0,  // no vector unit the kernels use (an architecture without a lanes file)
    sse2 = 1,    // every x86-64: one-lane kernels, the 4-wide node test in SSE2
    avx2 = 2,    // x86-64-v3: AVX2, FMA, BMI1/2, LZCNT, MOVBE, F16C
    avx512 = 3,  // x86-64-v4: AVX-512 F, BW, CD, DQ, VL
    neon = 4,    // aarch64: Advanced SIMD (every aarch64 CPU)
};

// The level the code being compiled targets: in a dispatching build, the level of the copy of a kernel
// this translation unit is (the build compiles it once per level); elsewhere the build's own.
#if defined(SMOKETRACE_SIMD_AVX512)
inline constexpr Level kCompiledLevel = Level::avx512;
#elif defined(SMOKETRACE_SIMD_AVX2)
inline constexpr Level kCompiledLevel = Level::avx2;
#elif defined(SMOKETRACE_SIMD_NEON)
inline constexpr Level kCompiledLevel = Level::neon;
#elif defined(SMOKETRACE_SIMD_SSE2)
inline constexpr Level kCompiledLevel = Level::sse2;
#else
inline constexpr Level kCompiledLevel = Level::scalar;
#endif

// "sse2", "avx2", "avx512", "neon", "scalar"; parse_level() is its inverse.
std::string_view level_name(Level level) noexcept;
std::optional<Level> parse_level(std::string_view name) noexcept;

// The levels this binary holds kernels for, lowest first (one, unless the build dispatches).
std::span<const Level> levels_in_binary() noexcept;

// Whether this CPU (and its operating system, which must save the wider registers) runs `level`. From the
// CPU's own feature flags (cpuid on x86): no /proc, no operating-system query beyond that.
bool cpu_runs(Level level) noexcept;

// The level every pass of this process runs: SMOKETRACE_SIMD's where set, else the highest level of the
// binary that the CPU runs. Chosen on the first call, the same ever after. std::runtime_error (naming the
// variable, the value and the levels there are) when SMOKETRACE_SIMD names no level, one the binary lacks
// or one this CPU cannot run; and when the CPU runs no level of the binary at all.
Level active_level();

}  // namespace smoketrace::simd
