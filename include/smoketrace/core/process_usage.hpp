#pragma once
// What the process has spent besides wall time: CPU time in user and in kernel (system) mode, and page faults,
// over all its threads (getrusage(RUSAGE_SELF)). A stage that touches fresh memory pays a minor fault per page
// it first writes, counted as system time: on a virtual machine that can cost more than the stage's own work,
// so stage reports (frame_timings.hpp) give these beside the wall time.
#include <cstdint>

namespace smoketrace {

struct ProcessUsage {
    double user_ms = 0.0;
    double system_ms = 0.0;
    std::int64_t minor_faults = 0;  // pages mapped without I/O: fresh memory, or a file already in the page cache
    std::int64_t major_faults = 0;  // pages that had to be read from disk

    // The process's totals since it started; all zero where the system keeps none (kProcessUsageCounted).
    [[nodiscard]] static ProcessUsage now();

    friend ProcessUsage operator-(const ProcessUsage& a, const ProcessUsage& b) {
        return {a.user_ms - b.user_ms, a.system_ms - b.system_ms, a.minor_faults - b.minor_faults,
                a.major_faults - b.major_faults};
    }
};

// Whether ProcessUsage::now() reports anything: getrusage() exists on Linux, macOS and the BSDs. Elsewhere the
// reports leave the counts out rather than print zeros that look measured.
#if defined(__unix__) || defined(__APPLE__)
inline constexpr bool kProcessUsageCounted = true;
#else
inline constexpr bool kProcessUsageCounted = false;
#endif

}  // namespace smoketrace
