#pragma once
// How a pass runs at the process's kernel level (level.hpp; docs/simd.md, "One binary, every CPU").
//
// A kernel is a function template over the level, `template <simd::Level L> R kernel_at_level(...)`,
// defined in a kernel source (the build's SMOKETRACE_KERNEL_SOURCES) that ends with the one explicit
// instantiation `template R kernel_at_level<simd::kCompiledLevel>(...)`. A dispatching build compiles
// that source once per level, each copy closed on itself (cmake/close_level_objects.cmake), so every
// level has its own kernel and its own copy of everything the kernel inlines. The pass's entry point,
// in an ordinary source that never sees the kernel's body, calls
//
//     simd::at_active_level([&]<simd::Level L> { return kernel_at_level<L>(...); });
//
// once per pass: a switch on a value chosen at start-up, nothing per ray.
#include <smoketrace/core/simd/level.hpp>

namespace smoketrace::simd {

template <class Kernel>
decltype(auto) at_active_level(Kernel&& kernel) {
#if defined(SMOKETRACE_DISPATCH)
    switch (active_level()) {
#if defined(SMOKETRACE_DISPATCH_AVX512)
    case Level::avx512: return kernel.template operator()<Level::avx512>();
#endif
    case Level::avx2: return kernel.template operator()<Level::avx2>();
    default: return kernel.template operator()<Level::sse2>();
    }
#else
    (void)active_level();  // SMOKETRACE_SIMD's errors hold here too: the binary has this one level
    return kernel.template operator()<kCompiledLevel>();
#endif
}

}  // namespace smoketrace::simd
