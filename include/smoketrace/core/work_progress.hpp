#pragma once
// How far a long piece of work has come, for a progress display: the work names its stage and the stage's
// units (particles traced, pixels drawn), its workers count units as they finish them, and a display reads
// the counts from a thread of its own. Workers count at a coarse grain (a task's chunk of particles, a 16x16
// tile), never per ray, and nothing is counted when no display asked (a null WorkProgress*).
#include <atomic>
#include <cstdint>

namespace smoketrace {

class WorkProgress {
public:
    // A stage begins: `name` (a string literal: it is kept by pointer) with `total` units of work (0: not
    // counted, only named).
    void begin(const char* name, std::uint64_t total) {
        done_.store(0, std::memory_order_relaxed);
        total_.store(total, std::memory_order_relaxed);
        stage_.store(name, std::memory_order_release);
    }
    void add(std::uint64_t units) { done_.fetch_add(units, std::memory_order_relaxed); }

    // Read while the work goes on: a stage that has just begun may show the previous one's counts for a moment,
    // which a display can bear.
    [[nodiscard]] const char* stage() const { return stage_.load(std::memory_order_acquire); }
    [[nodiscard]] std::uint64_t done() const { return done_.load(std::memory_order_relaxed); }
    [[nodiscard]] std::uint64_t total() const { return total_.load(std::memory_order_relaxed); }

private:
    std::atomic<const char*> stage_{nullptr};
    std::atomic<std::uint64_t> done_{0}, total_{0};
};

}  // namespace smoketrace
