#pragma once
// Per-frame stage timings, named after the thesis's table B columns (appendix B): build/update of the
// acceleration structure, optical-depth pass, compute (resolve) pass, view pass, total.
#include <chrono>
#include <string>
#include <vector>

namespace smoketrace {

struct FrameTimings {
    double tlas_update = 0.0;  // ms
    double od_pass = 0.0;
    double resolve = 0.0;
    double view = 0.0;
    double total = 0.0;
};

// Element-wise median over frames (or repeats).
[[nodiscard]] FrameTimings median(const std::vector<FrameTimings>& frames);
// "tlas_update=… od_pass=… …", one name=value per line, milliseconds with 3 decimals.
[[nodiscard]] std::string format_timings(const FrameTimings& t, bool with_view);

// Measures one stage into a FrameTimings field.
class StageClock {
public:
    StageClock() : start_(std::chrono::steady_clock::now()) {}
    double lap_ms() {
        const auto now = std::chrono::steady_clock::now();
        const double ms = std::chrono::duration<double, std::milli>(now - start_).count();
        start_ = now;
        return ms;
    }

private:
    std::chrono::steady_clock::time_point start_;
};

}  // namespace smoketrace
