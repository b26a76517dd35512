// run_at_level LEVEL PROGRAM [ARGS...]: runs PROGRAM with SMOKETRACE_SIMD=LEVEL, or exits with 77 (ctest's
// "skipped", tests/CMakeLists.txt) when this CPU cannot run LEVEL. It is compiled for the baseline, so that
// the check itself runs anywhere: a test program compiled for AVX-512 may use AVX-512 before its main().
#include <smoketrace/core/simd/level.hpp>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <unistd.h>

int main(int argc, char** argv) {
    namespace simd = smoketrace::simd;
    if (argc < 3) {
        std::fprintf(stderr, "usage: run_at_level LEVEL PROGRAM [ARGS...]\n");
        return 2;
    }
    const auto level = simd::parse_level(argv[1]);
    if (!level) {
        std::fprintf(stderr, "run_at_level: '%s' is no kernel level\n", argv[1]);
        return 2;
    }
    if (!simd::cpu_runs(*level)) {
        std::printf("skipped: this CPU cannot run the %s kernels\n", argv[1]);
        return 77;
    }
    ::setenv("SMOKETRACE_SIMD", argv[1], 1);
    ::execv(argv[2], argv + 2);
    std::fprintf(stderr, "run_at_level: cannot run %s: %s\n", argv[2], std::strerror(errno));
    return 2;
}
