#pragma once
// The Pareto front of run time against error (bench sections "error" and "truth").
#include <algorithm>
#include <cstddef>
#include <limits>
#include <vector>

namespace smoketrace::bench {

// Marks the Pareto front of (time, error) over the candidates: nothing else is both at least as fast and
// at least as accurate, and better in one of the two.
inline void mark_pareto(const std::vector<double>& time, const std::vector<double>& error,
                        const std::vector<bool>& candidate, std::vector<bool>& front) {
    std::vector<std::size_t> order;
    for (std::size_t i = 0; i < time.size(); ++i)
        if (candidate[i]) order.push_back(i);
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return time[a] < time[b] || (time[a] == time[b] && error[a] < error[b]);
    });
    front.assign(time.size(), false);
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i : order)
        if (error[i] < best) {
            front[i] = true;
            best = error[i];
        }
}

}  // namespace smoketrace::bench
