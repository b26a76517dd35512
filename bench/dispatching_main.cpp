// smoketrace_bench's main(): the benchmark (bench_main.cpp) at the process's kernel level, so that our trace
// headers, which the sections call directly, run at the level the library's passes run at
// (core/simd/dispatch.hpp; SMOKETRACE_SIMD forces a lower level).
#include "bench_registry.hpp"

#include <smoketrace/core/simd/dispatch.hpp>

#include <exception>
#include <iostream>

int main(int argc, char** argv) {
    namespace simd = smoketrace::simd;
    try {
        return simd::at_active_level(
            [&]<simd::Level L> { return smoketrace::bench::bench_main_at_level<L>(argc, argv); });
    } catch (const std::exception& e) {
        std::cerr << "smoketrace_bench: " << e.what() << "\n";
        return 2;
    }
}
