#pragma once
// Wall-clock timing for benchmarks: medians over repeats, because the machine is shared and noisy.
#include <algorithm>
#include <chrono>
#include <vector>

namespace smoketrace::bench {

struct Stats {
    double median = 0, min = 0, max = 0;
};

inline Stats stats_of(std::vector<double> v) {
    if (v.empty()) return {};
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    const double med = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
    return {med, v.front(), v.back()};
}

// Milliseconds of wall time since `since`.
inline double elapsed_ms(std::chrono::steady_clock::time_point since) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since).count();
}

// Runs fn() once and returns its wall time in milliseconds: for contenders timed in interleaved rounds.
template <class Fn>
double time_once_ms(Fn&& fn) {
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    return elapsed_ms(t0);
}

// Runs fn() `repeats` times and returns the statistics of its wall time in milliseconds.
template <class Fn>
Stats time_ms(int repeats, Fn&& fn) {
    std::vector<double> ms;
    for (int i = 0; i < repeats; ++i) {
        const auto t0 = std::chrono::steady_clock::now();
        fn();
        const auto t1 = std::chrono::steady_clock::now();
        ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    }
    return stats_of(ms);
}

}  // namespace smoketrace::bench
