// Kernel levels: which the CPU runs and which this process uses (see core/simd/level.hpp).
#include <smoketrace/core/simd/level.hpp>

#include <array>
#if defined(__x86_64__)
#include <cpuid.h>
#endif
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace smoketrace::simd {
namespace {

constexpr std::array<std::pair<Level, std::string_view>, 5> kNames{{
    {Level::scalar, "scalar"}, {Level::sse2, "sse2"}, {Level::avx2, "avx2"}, {Level::avx512, "avx512"},
    {Level::neon, "neon"}}};

// Every level a kernel source is compiled for in this build (CMake: SMOKETRACE_DISPATCH).
#if defined(SMOKETRACE_DISPATCH) && defined(SMOKETRACE_DISPATCH_AVX512)
constexpr std::array kBinaryLevels{Level::sse2, Level::avx2, Level::avx512};
#elif defined(SMOKETRACE_DISPATCH)
constexpr std::array kBinaryLevels{Level::sse2, Level::avx2};
#else
constexpr std::array kBinaryLevels{kCompiledLevel};
#endif

#if defined(__x86_64__)
// What the CPU reports of itself through cpuid (leaves 1, 7 and 0x80000001), and whether the operating
// system saves the AVX and AVX-512 registers on a context switch (XCR0, read with xgetbv): a CPU with
// AVX-512 under a system that does not save its registers must not run AVX-512 code.
struct X86Features {
    bool v3 = false;  // x86-64-v3: AVX, AVX2, FMA, BMI1, BMI2, LZCNT, MOVBE, F16C, POPCNT
    bool v4 = false;  // x86-64-v4: v3 and AVX-512 F, BW, CD, DQ, VL
};

X86Features read_x86_features() {
    unsigned a, b, c, d;
    if (!__get_cpuid(1, &a, &b, &c, &d)) return {};
    const auto bit = [](unsigned r, int i) { return ((r >> i) & 1u) != 0; };
    const bool fma = bit(c, 12), movbe = bit(c, 22), popcnt = bit(c, 23), osxsave = bit(c, 27), avx = bit(c, 28),
               f16c = bit(c, 29);
    if (!osxsave) return {};
    unsigned xcr0_lo, xcr0_hi;
    __asm__("xgetbv" : "=a"(xcr0_lo), "=d"(xcr0_hi) : "c"(0));
    const bool os_avx = (xcr0_lo & 0x6u) == 0x6u;        // XMM and YMM state
    const bool os_avx512 = (xcr0_lo & 0xE0u) == 0xE0u;   // opmask, upper ZMM halves, ZMM16-31
    if (!__get_cpuid_count(7, 0, &a, &b, &c, &d)) return {};
    const bool bmi1 = bit(b, 3), avx2 = bit(b, 5), bmi2 = bit(b, 8), avx512f = bit(b, 16), avx512dq = bit(b, 17),
               avx512cd = bit(b, 28), avx512bw = bit(b, 30), avx512vl = bit(b, 31);
    const bool lzcnt = __get_cpuid(0x80000001u, &a, &b, &c, &d) && bit(c, 5);
    X86Features f;
    f.v3 = os_avx && avx && avx2 && fma && bmi1 && bmi2 && lzcnt && movbe && f16c && popcnt;
    f.v4 = f.v3 && os_avx512 && avx512f && avx512bw && avx512cd && avx512dq && avx512vl;
    return f;
}

const X86Features& x86_features() {
    static const X86Features f = read_x86_features();
    return f;
}
#endif

std::string names_of(std::span<const Level> levels) {
    std::string s;
    for (Level l : levels) s += (s.empty() ? "" : ", ") + std::string(level_name(l));
    return s;
}

Level choose_level() {
    const std::span<const Level> built = levels_in_binary();
    const char* forced = std::getenv("SMOKETRACE_SIMD");
    if (forced && *forced) {
        const std::optional<Level> level = parse_level(forced);
        const auto in_binary = [&](Level l) {
            for (Level b : built)
                if (b == l) return true;
            return false;
        };
        if (!level)
            throw std::runtime_error(std::string("SMOKETRACE_SIMD=") + forced +
                                     ": no such kernel level (this binary has " + names_of(built) + ")");
        if (!in_binary(*level)) {
            const char* why = built.size() == 1 ? ": a build without SMOKETRACE_DISPATCH holds one level)" : ")";
            throw std::runtime_error(std::string("SMOKETRACE_SIMD=") + forced + ": this binary has no " + forced +
                                     " kernels (it has " + names_of(built) + why);
        }
        if (!cpu_runs(*level))
            throw std::runtime_error(std::string("SMOKETRACE_SIMD=") + forced + ": this CPU cannot run the " +
                                     forced + " kernels");
        return *level;
    }
    for (auto l = built.rbegin(); l != built.rend(); ++l)
        if (cpu_runs(*l)) return *l;
    throw std::runtime_error("this CPU runs none of this binary's kernel levels (" + names_of(built) +
                             "): it was built for a newer CPU (SMOKETRACE_NATIVE); rebuild with the default options");
}

}  // namespace

std::string_view level_name(Level level) noexcept {
    for (const auto& [l, name] : kNames)
        if (l == level) return name;
    return "unknown";
}

std::optional<Level> parse_level(std::string_view name) noexcept {
    for (const auto& [l, n] : kNames)
        if (n == name) return l;
    return std::nullopt;
}

std::span<const Level> levels_in_binary() noexcept { return kBinaryLevels; }

bool cpu_runs(Level level) noexcept {
    switch (level) {
    case Level::scalar: return true;
#if defined(__x86_64__)
    case Level::sse2: return true;  // part of x86-64
    case Level::avx2: return x86_features().v3;
    case Level::avx512: return x86_features().v4;
#endif
#if defined(__aarch64__)
    case Level::neon: return true;  // Advanced SIMD is part of every aarch64 CPU
#endif
    default: return false;
    }
}

Level active_level() {
    static const Level level = choose_level();  // a throw leaves it unset: the next call throws again
    return level;
}

}  // namespace smoketrace::simd
