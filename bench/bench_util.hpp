#pragma once
// Small helpers shared by the bench sections: CSV files written whole or not at all, the log-log growth
// exponent, the scene and textures every frame-level section starts from.
#include <smoketrace/output_path.hpp>
#include <smoketrace/scene_file.hpp>
#include <smoketrace/tube_generator.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

namespace smoketrace::bench {

// Rows collected in memory and written at the end through a temporary file and a rename, so a results
// folder never holds a half-written CSV (an interrupted run leaves the previous file).
class CsvFile {
public:
    explicit CsvFile(const std::string& header) { rows_ << header << '\n'; rows_.precision(9); }
    // Appends one row: the fields separated by commas.
    template <class... Fields>
    void row(const Fields&... fields) {
        bool first = true;
        ((rows_ << (first ? "" : ",") << fields, first = false), ...);
        rows_ << '\n';
    }
    void write(const std::filesystem::path& path) const {
        const std::string text = rows_.str();
        write_output(path, [&](std::ostream& out) { out << text; });
    }

private:
    std::ostringstream rows_;
};

// Least squares of log(y) = a + b·log(x) over the points with x, y > 0: b, the growth exponent
// (1 = linear in the work, 2 = quadratic). 0 when fewer than two usable points.
inline double fit_exponent(const std::vector<double>& x, const std::vector<double>& y) {
    double mx = 0, my = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < x.size() && i < y.size(); ++i)
        if (x[i] > 0 && y[i] > 0) {
            mx += std::log(x[i]);
            my += std::log(y[i]);
            ++n;
        }
    if (n < 2) return 0.0;
    mx /= double(n);
    my /= double(n);
    double sxy = 0, sxx = 0;
    for (std::size_t i = 0; i < x.size() && i < y.size(); ++i)
        if (x[i] > 0 && y[i] > 0) {
            const double dx = std::log(x[i]) - mx;
            sxy += dx * (std::log(y[i]) - my);
            sxx += dx * dx;
        }
    return sxx > 0 ? sxy / sxx : 0.0;
}

// The animated scene of the frame-level sections ("error", "scaling"): assets/scenes/two_tubes_right.json
// (the thesis's view 2, light from the right) with `count` particles, the light turning about +z by
// kLightDegreesPerFrame (from the right toward above, thesis 4.1 and 5.2.2) and a little motion (per-particle
// drift and billboard spin), so that every frame refits the TLAS and traces optical depths, as in a game.
inline constexpr float kLightDegreesPerFrame = 1.0f;
inline constexpr float kJitterPerFrame = 0.002f;  // world units per frame, per axis (particle radius 0.35)
inline constexpr float kSpinPerFrame = 0.02f;     // radians per frame

inline SceneDescription animated_scene(std::uint32_t count, int size) {
    SceneDescription d =
        load_scene_file(std::filesystem::path(SMOKETRACE_ASSET_DIR) / "scenes" / "two_tubes_right.json");
    TubeSettings t = d.smoke.tubes.value_or(TubeSettings{});
    t.particles = count;
    t.jitter_speed = kJitterPerFrame;
    t.spin_speed = kSpinPerFrame;
    d.smoke.tubes = t;
    d.smoke.particles = generate_tubes(t);
    d.light.rotation_per_frame_deg = kLightDegreesPerFrame;
    d.camera.width = d.camera.height = std::uint32_t(size);
    return d;
}

}  // namespace smoketrace::bench
