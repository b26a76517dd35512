#include <smoketrace/core/frame_timings.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace smoketrace {

namespace {
double median_of(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

ProcessUsage median_usage(const std::vector<FrameTimings>& frames, ProcessUsage FrameUsage::*stage) {
    auto field = [&](auto ProcessUsage::*f) {
        std::vector<double> v;
        for (const auto& t : frames) v.push_back(double(t.usage.*stage.*f));
        return median_of(v);
    };
    return {field(&ProcessUsage::user_ms), field(&ProcessUsage::system_ms),
            static_cast<std::int64_t>(std::llround(field(&ProcessUsage::minor_faults))),
            static_cast<std::int64_t>(std::llround(field(&ProcessUsage::major_faults)))};
}
}  // namespace

FrameTimings median(const std::vector<FrameTimings>& frames) {
    auto field = [&](double FrameTimings::*f) {
        std::vector<double> v;
        for (const auto& t : frames) v.push_back(t.*f);
        return median_of(v);
    };
    const FrameUsage usage{median_usage(frames, &FrameUsage::tlas_update), median_usage(frames, &FrameUsage::od_pass),
                           median_usage(frames, &FrameUsage::resolve), median_usage(frames, &FrameUsage::view),
                           median_usage(frames, &FrameUsage::total)};
    return {field(&FrameTimings::tlas_update), field(&FrameTimings::od_pass), field(&FrameTimings::resolve),
            field(&FrameTimings::view), field(&FrameTimings::total), usage};
}

std::string format_timings(const FrameTimings& t, bool with_view) {
    char buf[256];
    if (with_view)
        std::snprintf(buf, sizeof buf, "tlas_update=%.3f\nod_pass=%.3f\nresolve=%.3f\nview=%.3f\ntotal=%.3f\n",
                      t.tlas_update, t.od_pass, t.resolve, t.view, t.total);
    else
        std::snprintf(buf, sizeof buf, "tlas_update=%.3f\nod_pass=%.3f\nresolve=%.3f\n", t.tlas_update, t.od_pass,
                      t.resolve);
    return buf;
}

std::string format_usage(const FrameTimings& t, bool with_view) {
    std::string out = format_stage_usage("tlas_update", t.usage.tlas_update) +
                      format_stage_usage("od_pass", t.usage.od_pass) + format_stage_usage("resolve", t.usage.resolve);
    if (with_view) out += format_stage_usage("view", t.usage.view) + format_stage_usage("total", t.usage.total);
    return out;
}

std::string format_stage_usage(std::string_view stage, const ProcessUsage& u) {
    if (!kProcessUsageCounted) return {};
    const auto line = [&](const char* field, const std::string& value) {
        return std::string(stage) + "." + field + "=" + value + "\n";
    };
    const auto ms = [](double v) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.3f", v);
        return std::string(buf);
    };
    return line("user_ms", ms(u.user_ms)) + line("system_ms", ms(u.system_ms)) +
           line("minor_faults", std::to_string(u.minor_faults)) + line("major_faults", std::to_string(u.major_faults));
}

}  // namespace smoketrace
