#pragma once
// Per-frame stage timings, named after the thesis's table B columns (appendix B): build/update of the
// acceleration structure, optical-depth pass, compute (resolve) pass, view pass, total; and beside each
// stage's wall time what the process spent in it (CPU time, page faults: process_usage.hpp).
#include <smoketrace/core/process_usage.hpp>

#include <chrono>
#include <string>
#include <string_view>
#include <vector>

namespace smoketrace {

// The stages of FrameTimings, their CPU time and page faults over the same spans.
struct FrameUsage {
    ProcessUsage tlas_update;
    ProcessUsage od_pass;
    ProcessUsage resolve;
    ProcessUsage view;
    ProcessUsage total;
};

struct FrameTimings {
    double tlas_update = 0.0;  // ms
    double od_pass = 0.0;
    double resolve = 0.0;
    double view = 0.0;
    double total = 0.0;
    FrameUsage usage = {};
};

// Element-wise median over frames (or repeats); a median page-fault count between two counts is rounded.
[[nodiscard]] FrameTimings median(const std::vector<FrameTimings>& frames);
// "tlas_update=… od_pass=… …", one name=value per line, milliseconds with 3 decimals.
[[nodiscard]] std::string format_timings(const FrameTimings& t, bool with_view);
// The same stages' usage, format_stage_usage() of each in format_timings()'s order.
[[nodiscard]] std::string format_usage(const FrameTimings& t, bool with_view);
// Four lines per stage, "STAGE.user_ms=…", "STAGE.system_ms=…" (3 decimals), "STAGE.minor_faults=N",
// "STAGE.major_faults=N"; nothing where the system counts none (kProcessUsageCounted).
[[nodiscard]] std::string format_stage_usage(std::string_view stage, const ProcessUsage& u);

// Measures one stage into a FrameTimings field: its wall time and, over the same span, what the process spent.
class StageClock {
public:
    StageClock() : usage_(ProcessUsage::now()), start_(std::chrono::steady_clock::now()) {}
    // The wall time since the last lap (or since the clock was made), in ms.
    double lap_ms() {
        ProcessUsage ignored;
        return lap_ms(ignored);
    }
    // The same, and what the process spent over it in `usage`.
    double lap_ms(ProcessUsage& usage) {
        const auto now = std::chrono::steady_clock::now();
        const ProcessUsage used = ProcessUsage::now();
        const double ms = std::chrono::duration<double, std::milli>(now - start_).count();
        usage = used - usage_;
        usage_ = used;
        start_ = now;
        return ms;
    }

private:
    ProcessUsage usage_;
    std::chrono::steady_clock::time_point start_;
};

}  // namespace smoketrace
