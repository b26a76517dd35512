#pragma once
// Small helpers shared by the bench sections: CSV files written whole or not at all, the log-log growth
// exponent, the scene and textures every frame-level section starts from.
#include "bench_registry.hpp"

#include <smoketrace/io/output_path.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>
#include <smoketrace/render/sixway_texture.hpp>
#include <smoketrace/smoke/tube_generator.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <ostream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace smoketrace::bench {

// The scene file assets/scenes/`name` of the run's assets folder (BenchOptions::assets, bench_assets.hpp).
inline SceneDescription bench_scene_file(const BenchOptions& options, std::string_view name) {
    return load_scene_file(options.assets / "scenes" / name);
}

// The six-way texture of the run's assets folder, read once (the folder does not change during a run).
inline const SixwayTexture& bench_texture(const BenchOptions& options) {
    static const SixwayTexture texture = load_sixway_texture(options.assets / "sixway.json");
    return texture;
}

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

// Large particle counts (10k, 100k) are measured on tubes of the same size whose particle radius shrinks
// with the count, r = 0.35·√(750/N): the particles' total cross-section stays that of the thesis's 750,
// so a light ray crosses about as many surfaces as at 750 (from above: 16.7 at 750, 17.8 at 10k, 17.9 at
// 100k; from the scene files' right: 21.8, 22.3, 22.6), and no cutoff is needed. With the radius kept, a
// ray at 100k crosses ~130 times as many: under the thesis's cutoff of 60 every particle was cut off, and
// a time taken that way measured rays that stop early.
inline constexpr std::uint32_t kLargeSceneFrom = 10'000;
inline constexpr std::uint32_t kThesisParticleCount = 750;

// The particle radius of a `count`-particle bench scene whose radius at 750 particles is `radius_at_750`:
// unchanged below kLargeSceneFrom (tables B.1-B.3 vary the count alone), shrunk as above from there on.
inline float bench_particle_radius(std::uint32_t count, float radius_at_750) {
    if (count < kLargeSceneFrom) return radius_at_750;
    return float(double(radius_at_750) * std::sqrt(double(kThesisParticleCount) / double(count)));
}

// Mean of `counts` (surfaces per ray, from an optical-depth pass's hit counts); 0 for none.
inline double mean_of(const std::vector<std::uint32_t>& counts) {
    double sum = 0;
    for (const std::uint32_t c : counts) sum += c;
    return counts.empty() ? 0.0 : sum / double(counts.size());
}

// The animated scene of the frame-level sections ("error", "scaling"): assets/scenes/two_tubes_right.json
// (the thesis's view 2, light from the right) with `count` particles, the light turning about +z by
// kLightDegreesPerFrame (from the right toward above, thesis 4.1 and 5.2.2) and a little motion (per-particle
// drift and billboard spin), so that every frame refits the TLAS and traces optical depths, as in a game.
inline constexpr float kLightDegreesPerFrame = 1.0f;
inline constexpr float kJitterPerFrame = 0.002f;  // world units per frame, per axis (particle radius 0.35)
inline constexpr float kSpinPerFrame = 0.02f;     // radians per frame

// From kLargeSceneFrom particles on, the radius shrinks (bench_particle_radius) and the cutoff is off.
inline SceneDescription animated_scene(const BenchOptions& options, std::uint32_t count, int size) {
    SceneDescription d = bench_scene_file(options, "two_tubes_right.json");
    TubeSettings t = d.smoke.tubes.value_or(TubeSettings{});
    t.particles = count;
    t.particle_radius = bench_particle_radius(count, t.particle_radius);
    if (count >= kLargeSceneFrom) d.render.cutoff = 0;
    t.jitter_speed = kJitterPerFrame;
    t.spin_speed = kSpinPerFrame;
    d.smoke.tubes = t;
    d.smoke.particles = generate_tubes(t);
    d.light.rotation_per_frame_deg = kLightDegreesPerFrame;
    d.camera.width = d.camera.height = std::uint32_t(size);
    return d;
}

}  // namespace smoketrace::bench
