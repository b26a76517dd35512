#include <smoketrace/core/frame_timings.hpp>

#include <algorithm>
#include <cstdio>

namespace smoketrace {

namespace {
double median_of(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
}  // namespace

FrameTimings median(const std::vector<FrameTimings>& frames) {
    auto field = [&](double FrameTimings::*f) {
        std::vector<double> v;
        for (const auto& t : frames) v.push_back(t.*f);
        return median_of(v);
    };
    return {field(&FrameTimings::tlas_update), field(&FrameTimings::od_pass), field(&FrameTimings::resolve),
            field(&FrameTimings::view), field(&FrameTimings::total)};
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

}  // namespace smoketrace
