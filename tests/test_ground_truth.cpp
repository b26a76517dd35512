// The ground truth (truth/ground_truth.hpp) against closed forms: scenes built here from uniform densities
// (PuffVolume::uniform_ball / uniform_cube) whose optical depths are σ·chord exactly and whose images are
// one-dimensional integrals evaluated here in double to 1e-9. Tolerances are the truth's own stated bound.
#include <smoketrace/render/camera.hpp>
#include <smoketrace/render/pixel_samples.hpp>
#include <smoketrace/render/puff_density.hpp>
#include <smoketrace/render/sixway_baker.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/truth/ground_truth.hpp>

#include <catch2/catch.hpp>
#include <tbb/task_arena.h>

#include <glm/geometric.hpp>

#include <array>
#include <cmath>
#include <cstring>

using namespace smoketrace;

namespace {

// One particle of radius 1 at the origin, seen from +z, lit from +y; no ground, black sky, no ambient unless set.
SceneDescription ball_scene(float sigma, glm::vec3 light, glm::vec3 ambient) {
    SceneDescription s;
    s.smoke.particles = {Particle{glm::vec3(0.0f), 1.0f}};
    s.smoke.sigma_t = sigma;
    s.light.direction = glm::vec3(0.0f, 1.0f, 0.0f);
    s.light.color = light;
    s.ambient = ambient;
    s.background = glm::vec3(0.0f);
    s.camera.position = glm::vec3(0.0f, 0.0f, 10.0f);
    s.camera.look_at = glm::vec3(0.0f);
    s.camera.fov_deg = 14.0f;  // the ball fills most of the image
    return s;
}

SixwayBakeSettings single_scattering() {
    SixwayBakeSettings s;
    s.scattering_octaves = 1;  // T_ms(τ) = e^{-τ}: the closed forms below
    return s;
}

TruthSettings one_sample(float tolerance = 1.0f / 512.0f) {
    TruthSettings t;
    t.spp = 1;  // the pixel centre: one ray, whose integral the test evaluates
    t.tolerance = tolerance;
    return t;
}

Ray centre_ray(const SceneDescription& s, int w, int h, int x, int y) {
    const Camera camera(s.camera.position, s.camera.look_at, s.camera.up, s.camera.fov_deg, w, h);
    const glm::vec2 o = PixelSamples(1)[0];
    return camera.ray_through(float(x) + o.x, float(y) + o.y, 1e-3f);
}

// [t0, t1] of a ray in the sphere |x - c| < r, in double; false if it misses.
bool sphere_chord(const Ray& ray, glm::dvec3 c, double r, double& t0, double& t1) {
    const glm::dvec3 o(ray.origin), d(glm::normalize(glm::dvec3(ray.direction)));
    const double b = glm::dot(o - c, d), q = glm::dot(o - c, o - c) - r * r, disc = b * b - q;
    if (disc <= 0) return false;
    t0 = -b - std::sqrt(disc);
    t1 = -b + std::sqrt(disc);
    return true;
}

// The single-scattering integral through a uniform ball of radius 1 at the origin lit from +y, in double:
// L = ∫ e^{-σ(t - t0)} σ [c_l e^{-σ ℓ(t)} + c_a] dt, ℓ = the chord from the point up to the sphere (2e5 midpoints:
// error ~1e-10 for these smooth integrands).
double lit_ball(const Ray& ray, double sigma, double c_light, double c_amb) {
    double t0, t1;
    if (!sphere_chord(ray, glm::dvec3(0.0), 1.0, t0, t1)) return 0.0;
    const glm::dvec3 o(ray.origin), d(glm::normalize(glm::dvec3(ray.direction)));
    const int n = 200000;
    const double dt = (t1 - t0) / n;
    double sum = 0.0;
    for (int k = 0; k < n; ++k) {
        const double t = t0 + (k + 0.5) * dt;
        const glm::dvec3 x = o + t * d;
        const double up = std::sqrt(std::max(0.0, 1.0 - x.x * x.x - x.z * x.z)) - x.y;
        sum += std::exp(-sigma * (t - t0)) * sigma * (c_light * std::exp(-sigma * up) + c_amb) * dt;
    }
    return sum;
}

}  // namespace

TEST_CASE("truth: a particle's optical depth from its centre is σ·radius, and σ·(r + 2r') below another",
          "[truth]") {
    SceneDescription s = ball_scene(0.8f, glm::vec3(1.0f), glm::vec3(0.0f));
    s.smoke.particles.push_back(Particle{glm::vec3(0.1f, 3.0f, 0.0f), 0.5f});  // above: its full chord counts
    std::vector<PuffVolume> book{PuffVolume::uniform_ball(1.0f)};
    const GroundTruth truth(s, single_scattering(), book, 0, 8, 8, one_sample());
    const std::vector<double> tau = truth.particle_optical_depths();
    REQUIRE(tau.size() == 2);
    // The upper particle: its own exit only, σ·0.5. The lower: its exit (σ·1) and the upper one's chord at
    // offset 0.1 from its centre, 2·sqrt(0.25 - 0.01). A uniform ball's chord is closed form: rounding only.
    CHECK(tau[1] == Approx(0.8 * 0.5).epsilon(1e-6));
    CHECK(tau[0] == Approx(0.8 * (1.0 + 2.0 * std::sqrt(0.25 - 0.01))).epsilon(1e-5));
}

TEST_CASE("truth: a baked puff's optical depth toward the light is its density's integral along the light ray",
          "[truth]") {
    // Two turned puffs of different flipbook frames, seen from off the axes and lit obliquely, so that each
    // one's tangent frame, radius and frame all matter; the reference marches the density the camera samples.
    SceneDescription s = ball_scene(1.3f, glm::vec3(1.0f), glm::vec3(0.0f));
    s.smoke.particles = {Particle{glm::vec3(0.0f), 0.35f}, Particle{glm::vec3(0.12f, 0.5f, -0.07f), 0.3f}};
    s.smoke.particles[0].rotation = 0.7f;
    s.smoke.particles[1].rotation = 2.1f;
    s.light.direction = glm::normalize(glm::vec3(0.3f, 1.0f, -0.2f));
    s.camera.position = glm::vec3(3.0f, 2.0f, 9.0f);
    SixwayBakeSettings bake;
    bake.tile = 24;
    bake.depth_samples = 20;
    const std::vector<PuffVolume> book{PuffVolume::baked(bake, 0), PuffVolume::baked(bake, 1)};
    const GroundTruth truth(s, single_scattering(), book, 0, 8, 8, one_sample());
    const std::vector<double> tau = truth.particle_optical_depths();
    REQUIRE(tau.size() == 2);
    // Particle i shows flipbook frame i at frame 0, in its billboard's frame (x right, y up, z to the eye).
    std::array<AffineTransform, 2> frames;
    for (std::size_t i = 0; i < 2; ++i)
        frames[i] = SmokeScene::billboard_transform(s.smoke.particles[i], s.camera.position);
    // σ·ρ_i at a float point, as the camera's march samples it.
    auto sigma = [&](int i, const glm::vec3& x) {
        const Particle& p = s.smoke.particles[std::size_t(i)];
        const AffineTransform& m = frames[std::size_t(i)];
        const glm::vec3 d = x - p.center;
        auto axis = [&](int a) { return glm::vec3(glm::normalize(m.linear[a])); };
        const glm::vec3 q(glm::dot(d, axis(0)), glm::dot(d, axis(1)), glm::dot(d, axis(2)));
        return 1.3 * double(book[std::size_t(i)].density(q / p.radius));
    };
    // Midpoint sums over 3 units (past both spheres) on 3·10⁵ panels. Each float density is within 2·10⁻⁵
    // (density() within 1.5·10⁻⁵, test_puff_volume.cpp, and the float tangent transform moves its point by
    // some 4·10⁻⁶ voxels), over at most 1.3 units of density; the panels' error at the voxel kinks is far
    // below (h²·|ρ' jump| ≈ 10⁻¹⁰·80 at each of some 150): within 1.3·(2.6·10⁻⁵ + 10⁻⁶) < 4·10⁻⁵.
    constexpr int kPanels = 300000;
    constexpr double kMarchTolerance = 4e-5;
    const glm::dvec3 to_light = glm::normalize(glm::dvec3(s.light.direction));
    for (int i = 0; i < 2; ++i) {
        const glm::dvec3 o(s.smoke.particles[std::size_t(i)].center);
        std::array<double, 2> sum{0.0, 0.0};
        for (int k = 0; k < kPanels; ++k) {
            const glm::vec3 x(o + (3.0 * (k + 0.5) / kPanels) * to_light);
            for (int j = 0; j < 2; ++j) sum[std::size_t(j)] += sigma(j, x) * 3.0 / kPanels;
        }
        INFO("particle " << i << ": puff 0 gives " << sum[0] << ", puff 1 " << sum[1]);
        CHECK(sum[std::size_t(i)] > 0.05);  // its own puff
        if (i == 0) CHECK(sum[1] > 0.05);   // and the lower one's light ray crosses the upper puff
        CHECK(std::abs(tau[std::size_t(i)] - (sum[0] + sum[1])) <= kMarchTolerance);
    }
}

TEST_CASE("truth: emission-absorption through a uniform ball and a uniform cube (slab) is c·(1 - e^{-σ·chord})",
          "[truth]") {
    const int w = 16, h = 16;
    const double amb = 0.7;
    for (const bool cube : {false, true}) {
        SceneDescription s = ball_scene(1.3f, glm::vec3(0.0f), glm::vec3(float(amb)));
        std::vector<PuffVolume> book{cube ? PuffVolume::uniform_cube(0.5f) : PuffVolume::uniform_ball(1.0f)};
        const TruthSettings settings = one_sample();
        const GroundTruth truth(s, single_scattering(), book, 0, w, h, settings);
        ImageRgba image;
        const TruthReport report = truth.render(image);
        CHECK(report.unconverged_pixels == 0);
        // The cube's frame is the billboard's: axes of SmokeScene::billboard_transform (here the world's, the
        // eye on +z), half side 0.5.
        const AffineTransform m = SmokeScene::billboard_transform(s.smoke.particles[0], s.camera.position);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const Ray ray = centre_ray(s, w, h, x, y);
                double chord = 0.0, t0, t1;
                if (cube) {
                    // Slab test in the billboard's frame, in double.
                    const glm::dvec3 o(ray.origin), d(glm::normalize(glm::dvec3(ray.direction)));
                    double lo = -1e30, hi = 1e30;
                    for (int a = 0; a < 3; ++a) {
                        const glm::dvec3 axis = glm::normalize(m.linear[a]);
                        const double oa = glm::dot(o, axis), da = glm::dot(d, axis);
                        const double ta = (-0.5 - oa) / da, tb = (0.5 - oa) / da;
                        lo = std::max(lo, std::min(ta, tb));
                        hi = std::min(hi, std::max(ta, tb));
                    }
                    chord = std::max(0.0, hi - lo);
                } else if (sphere_chord(ray, glm::dvec3(0.0), 1.0, t0, t1)) {
                    chord = t1 - t0;
                }
                const double expected = amb * (1.0 - std::exp(-1.3 * chord));
                INFO("cube " << cube << " pixel " << x << "," << y << " chord " << chord);
                CHECK(std::abs(double(image.at(x, y).x) - expected) <= double(settings.tolerance));
            }
    }
}

TEST_CASE("truth: single scattering in a lit uniform ball, and pixel() with exact light rays agrees with render()",
          "[truth]") {
    const int w = 12, h = 12;
    SceneDescription s = ball_scene(1.0f, glm::vec3(1.0f), glm::vec3(0.05f));
    std::vector<PuffVolume> book{PuffVolume::uniform_ball(1.0f)};
    const TruthSettings settings = one_sample();
    const GroundTruth truth(s, single_scattering(), book, 0, w, h, settings);
    ImageRgba image;
    const TruthReport report = truth.render(image);
    // A uniform ball's τ toward the light has a square-root edge at its silhouette (the chord √(1 − u²)), which
    // no interpolation resolves: the samples next to it take exact light rays, and every pixel is converged.
    CHECK(report.unconverged_pixels == 0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double expected = lit_ball(centre_ray(s, w, h, x, y), 1.0, 1.0, 0.05);
            INFO("pixel " << x << "," << y << " estimate " << report.pixel_error_estimate[std::size_t(y * w + x)]);
            CHECK(std::abs(double(image.at(x, y).y) - expected) <= double(settings.tolerance));
            if ((x + 2 * y) % 5 == 0) {  // a fifth of the pixels: exact light rays cost a light march per step
                CHECK(std::abs(double(truth.pixel(x, y).y) - expected) <= double(settings.tolerance));
            }
        }
}

TEST_CASE("truth: a light volume too coarse alone is mended by exact light rays, to pixel() and the closed form",
          "[truth]") {
    const int w = 12, h = 12;
    SceneDescription s = ball_scene(1.5f, glm::vec3(1.0f), glm::vec3(0.05f));
    std::vector<PuffVolume> book{PuffVolume::uniform_ball(1.0f)};
    TruthSettings settings = one_sample();
    settings.light_spacing_voxels = 4.0f;  // nodes 1/16 of the radius apart: the volume alone is above the tolerance
    const GroundTruth truth(s, single_scattering(), book, 0, w, h, settings);
    ImageRgba image;
    const TruthReport report = truth.render(image);
    INFO("volume alone " << report.light_volume_error_estimate << ", exact rays " << report.exact_light_samples
                         << " of " << report.light_samples);
    CHECK(double(report.light_volume_error_estimate) > double(settings.tolerance));
    CHECK(report.exact_light_samples > 0);
    CHECK(report.exact_light_samples < report.light_samples);  // only where the estimates call for them
    CHECK(report.unconverged_pixels == 0);
    CHECK(double(report.max_error_estimate) <= double(settings.tolerance));
    // render() is within the tolerance of the exact image; pixel() (exact light, its steps converged to half
    // the tolerance) within half of it: the two within one and a half.
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            INFO("pixel " << x << "," << y);
            const double expected = lit_ball(centre_ray(s, w, h, x, y), 1.5, 1.0, 0.05);
            CHECK(std::abs(double(image.at(x, y).y) - expected) <= double(settings.tolerance));
            CHECK(std::abs(double(image.at(x, y).y) - double(truth.pixel(x, y).y)) <= 1.5 * double(settings.tolerance));
        }
}

TEST_CASE("truth: check() holds render() to pixel() on a sample of pixels, and finds a wrong image", "[truth]") {
    const int w = 12, h = 12;
    SceneDescription s = ball_scene(1.5f, glm::vec3(1.0f), glm::vec3(0.05f));
    std::vector<PuffVolume> book{PuffVolume::uniform_ball(1.0f)};
    TruthSettings settings = one_sample();
    settings.light_spacing_voxels = 4.0f;  // the coarse volume of the test above: exact light rays mend it
    const GroundTruth truth(s, single_scattering(), book, 0, w, h, settings);
    ImageRgba image;
    const TruthReport report = truth.render(image);
    const TruthCheck c = truth.check(image, report, 3);
    CHECK(c.pixels == 16);  // the centres of the 3x3 blocks: x, y in {1, 4, 7, 10}
    CHECK(c.above_tolerance == 0);
    CHECK(c.above_estimate == 0);
    CHECK(double(c.largest_difference) <= double(settings.tolerance));
    // One checked pixel made wrong by twice the tolerance: found, where it is.
    ImageRgba wrong = image;
    wrong.at(4, 7).y += 2.0f * settings.tolerance;
    const TruthCheck bad = truth.check(wrong, report, 3);
    CHECK(bad.above_tolerance == 1);
    CHECK(bad.above_estimate == 1);
    CHECK(bad.x == 4);
    CHECK(bad.y == 7);
    CHECK_THROWS_AS(truth.check(image, report, 0), std::invalid_argument);
}

TEST_CASE("truth: the error falls with the tolerance and stays below it", "[truth]") {
    const int w = 6, h = 6;
    SceneDescription s = ball_scene(2.0f, glm::vec3(1.0f), glm::vec3(0.0f));
    std::vector<PuffVolume> book{PuffVolume::uniform_ball(1.0f)};
    double previous = 1.0;
    for (const float tol : {1.0f / 32.0f, 1.0f / 256.0f, 1.0f / 2048.0f}) {
        TruthSettings settings = one_sample(tol);
        settings.step_voxels = 32.0f;  // a coarse first step, so that the tolerance decides the levels
        const GroundTruth truth(s, single_scattering(), book, 0, w, h, settings);
        ImageRgba image;
        (void)truth.render(image);
        double worst = 0.0;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                worst = std::max(worst, std::abs(double(image.at(x, y).x) - lit_ball(centre_ray(s, w, h, x, y), 2.0, 1.0, 0.0)));
        INFO("tolerance " << tol << " error " << worst);
        CHECK(worst <= double(tol));
        CHECK(worst <= previous);
        previous = worst;
    }
}

TEST_CASE("truth: the camera steps converge, and a level's change bounds that level's error", "[truth]") {
    // The truth stops a pixel when the change between two step levels is small, and keeps the finer level: that
    // change bounds the finer level's error whenever a halving at least halves the error (order >= 1). The
    // light is exact here (pixel(): exact light rays to 1e-7) and the tolerance unreachable, so each render
    // stops at its level limit. Two densities: a lit uniform ball, whose light path up to its sphere has a
    // square-root edge where a camera ray enters it (the midpoint rule's order there is 1.5: each halving
    // divides the error by 2^1.5 = 2.8), checked against the closed form; and a baked puff, smooth but for
    // the trilinear kinks, which converges at the midpoint rule's second order (differences fall 4x).
    const int w = 9, h = 9;
    SceneDescription s = ball_scene(1.5f, glm::vec3(1.0f), glm::vec3(0.0f));
    const std::array<std::array<int, 2>, 3> pixels{{{4, 4}, {3, 5}, {4, 3}}};
    auto levels_of = [&](const std::vector<PuffVolume>& book, float step_voxels, int max_levels) {
        std::vector<std::array<double, 3>> values;
        for (int levels = 1; levels <= max_levels; ++levels) {
            TruthSettings settings = one_sample(1e-9f);
            settings.step_voxels = step_voxels;
            settings.max_view_levels = levels;
            const GroundTruth truth(s, single_scattering(), book, 0, w, h, settings);
            std::array<double, 3> v{};
            for (std::size_t k = 0; k < pixels.size(); ++k) v[k] = double(truth.pixel(pixels[k][0], pixels[k][1]).y);
            values.push_back(v);
        }
        return values;
    };
    const auto ball = levels_of({PuffVolume::uniform_ball(1.0f)}, 32.0f, 4);  // first step half the radius
    for (std::size_t k = 0; k < pixels.size(); ++k) {
        const double exact = lit_ball(centre_ray(s, w, h, pixels[k][0], pixels[k][1]), 1.5, 1.0, 0.0);
        for (std::size_t l = 1; l < ball.size(); ++l) {
            const double error = std::abs(ball[l][k] - exact), coarser = std::abs(ball[l - 1][k] - exact);
            INFO("ball, pixel " << k << ", levels " << l + 1 << ": error " << error << ", change "
                                << std::abs(ball[l][k] - ball[l - 1][k]));
            CHECK(error > 1e-5);  // far above the float rounding of the pixel (values ~0.5)
            CHECK(error <= std::abs(ball[l][k] - ball[l - 1][k]));
            CHECK(coarser / error > 2.4);  // order 1.5 (2.83), less what the next terms take at coarse steps
        }
    }
    SixwayBakeSettings bake;
    bake.frames = 1;
    bake.tile = 24;
    // The puff against its own level 8 (steps of 1/128 voxel: its remaining error far below these changes).
    // Its error falls 4x per halving on average (second order), but not level by level: a change can vanish by
    // coincidence (two levels' errors alike), so the change bounds the error only as an estimate. It holds
    // wherever the change is at least kStoppingRegime, the changes the truth stops on (a twentieth of the default
    // tolerance and up); below it a coincidence missed errors of a few 1e-6 here.
    constexpr double kStoppingRegime = 1e-4;
    const auto puff = levels_of({PuffVolume::baked(bake, 0)}, 2.0f, 8);  // the truth's first step, 2 voxels
    for (std::size_t k = 0; k < pixels.size(); ++k) {
        auto error = [&](std::size_t l) { return std::abs(puff[l][k] - puff.back()[k]); };
        for (std::size_t l = 1; l + 1 < puff.size(); ++l) {
            const double change = std::abs(puff[l][k] - puff[l - 1][k]);
            INFO("puff, pixel " << k << ", levels " << l + 1 << ": error " << error(l) << ", change " << change);
            if (change >= kStoppingRegime) CHECK(error(l) <= change);
        }
        const double order = std::log2(error(1) / error(5)) / 4.0;  // levels 2 to 6, four halvings
        INFO("puff, pixel " << k << ": mean order " << order);
        CHECK(order > 1.6);
        CHECK(order < 2.5);
    }
}

TEST_CASE("truth: the ground's shadow under a uniform puff is c·e^{-σ·chord}, and the mask marks it", "[truth]") {
    const int w = 24, h = 24;
    SceneDescription s = ball_scene(0.9f, glm::vec3(1.0f), glm::vec3(0.0f));
    s.ground = GroundDescription{{glm::vec3(-6, -2, -6), glm::vec3(-6, -2, 6), glm::vec3(6, -2, 6), glm::vec3(6, -2, -6)},
                                 glm::vec3(0, 1, 0), glm::vec3(0.5f, 0.25f, 1.0f)};
    s.camera.position = glm::vec3(0.0f, 4.0f, 9.0f);
    s.camera.look_at = glm::vec3(0.0f, -2.0f, 0.0f);
    s.camera.fov_deg = 40.0f;
    std::vector<PuffVolume> book{PuffVolume::uniform_ball(1.0f)};
    const TruthSettings settings = one_sample();
    const GroundTruth truth(s, single_scattering(), book, 0, w, h, settings);
    ImageRgba image;
    (void)truth.render(image);
    const std::vector<std::uint8_t> mask = truth.ground_shadow_mask();
    int shadowed = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const Ray ray = centre_ray(s, w, h, x, y);
            double t0, t1;
            const glm::dvec3 o(ray.origin), d(glm::normalize(glm::dvec3(ray.direction)));
            if (d.y >= 0.0) continue;
            const double tg = (-2.0 - o.y) / d.y;
            const glm::dvec3 g = o + tg * d;
            if (std::abs(g.x) > 6 || std::abs(g.z) > 6) continue;
            const double rho = std::sqrt(g.x * g.x + g.z * g.z);
            if (std::abs(rho - 1.0) < 1e-3) continue;  // the disc's edge: float and double may disagree
            INFO("pixel " << x << "," << y);
            CHECK(int(mask[std::size_t(y * w + x)]) == (rho < 1.0 ? 1 : 0));
            if (sphere_chord(ray, glm::dvec3(0.0), 1.0, t0, t1)) continue;  // the view ray crosses the puff
            const double chord = rho < 1.0 ? 2.0 * std::sqrt(1.0 - rho * rho) : 0.0;
            const double expected = 0.25 * std::exp(-0.9 * chord);  // green: ground 0.25 × light 1 × N·L 1
            shadowed += rho < 1.0 ? 1 : 0;
            CHECK(std::abs(double(image.at(x, y).y) - expected) <= double(settings.tolerance));
        }
    CHECK(shadowed > 0);  // the camera sees part of the shadow beside the puff
}

TEST_CASE("truth: the same bytes for one thread and two", "[truth]") {
    SceneDescription s = ball_scene(1.0f, glm::vec3(1.0f), glm::vec3(0.05f));
    s.smoke.particles.push_back(Particle{glm::vec3(0.6f, 0.5f, -0.3f), 0.7f});
    std::vector<PuffVolume> book{PuffVolume::uniform_ball(1.0f), PuffVolume::uniform_cube(0.5f)};
    TruthSettings settings = one_sample();
    settings.light_spacing_voxels = 16.0f;  // coarse: some samples take exact light rays
    const GroundTruth truth(s, single_scattering(), book, 0, 16, 16, settings);
    ImageRgba one, two;
    TruthReport r1, r2;
    tbb::task_arena(1).execute([&] { r1 = truth.render(one); });
    tbb::task_arena(2).execute([&] { r2 = truth.render(two); });
    CHECK(r1.exact_light_samples > 0);
    CHECK(r1.exact_light_samples == r2.exact_light_samples);
    REQUIRE(one.pixels.size() == two.pixels.size());
    CHECK(std::memcmp(one.pixels.data(), two.pixels.data(), one.pixels.size() * sizeof(one.pixels[0])) == 0);
}

TEST_CASE("truth: the baked puff is the baker's, and the bake's bytes are those before the puff had its own file",
          "[truth][sixway]") {
    SixwayBakeSettings s;
    s.frames = 3;
    s.tile = 24;
    s.seed = 7;
    const SixwayBake bake = bake_sixway(s);
    // FNV-1a 64 of both atlases, taken from the baker before render/puff_density existed.
    std::uint64_t hash = 1469598103934665603ull;
    for (const Rgba8Image* image : {&bake.positive, &bake.negative})
        for (const std::uint8_t byte : image->pixels) {
            hash ^= byte;
            hash *= 1099511628211ull;
        }
    CHECK(hash == 5489364610169374277ull);
    // At a voxel centre the interpolated density is the puff's value there (up to the rounding of the
    // centre's grid coordinates).
    const PuffVolume v = PuffVolume::baked(s, 1);
    const PuffVoxels g(s);
    const PuffDensity puff(s, 1);
    for (const auto& [k, j, i] : {std::array{12, 11, 10}, std::array{8, 14, 12}, std::array{15, 9, 13}}) {
        const glm::vec3 p = g.centre(k, j, i);
        CHECK(v.density(p) == Approx(puff(p)).margin(1e-5));
    }
}

// ---- The ladder (TruthRung): the frame's approximations of the light put into the volume one at a time ------

namespace {

// lit_ball() with the light's extinction apart from the view's: the light reaching x is e^{-σ_l·ℓ(x)}.
double lit_ball_lights(const Ray& ray, double sigma_view, double sigma_light) {
    double t0, t1;
    if (!sphere_chord(ray, glm::dvec3(0.0), 1.0, t0, t1)) return 0.0;
    const glm::dvec3 o(ray.origin), d(glm::normalize(glm::dvec3(ray.direction)));
    const int n = 200000;
    const double dt = (t1 - t0) / n;
    double sum = 0.0;
    for (int k = 0; k < n; ++k) {
        const double t = t0 + (k + 0.5) * dt;
        const glm::dvec3 x = o + t * d;
        const double up = std::sqrt(std::max(0.0, 1.0 - x.x * x.x - x.z * x.z)) - x.y;
        sum += std::exp(-sigma_view * (t - t0)) * sigma_view * std::exp(-sigma_light * up) * dt;
    }
    return sum;
}

std::array<ImageRgba, kTruthRungs> ladder(const GroundTruth& truth, LadderReport& report) {
    std::array<ImageRgba, kTruthRungs> images;
    report = truth.render_ladder(images);
    return images;
}

}  // namespace

TEST_CASE("truth ladder: one uniform ball lit along a tangent axis, every rung against its closed form", "[truth]") {
    // One puff: the other puffs' light is 1, so one-transmittance is the truth itself; light-map multiplies it
    // by e^{-σ·r} (τ from the centre of a ball of radius r = 1); the light along the billboard's +y makes the
    // six axis lights the true one (its axis depth is the exact chord), so six-axis equals light-map;
    // bake-extinction lights the ball through the bake's extinction per tangent unit instead of σ·r.
    const int w = 12, h = 12;
    const double sigma = 0.9;
    SceneDescription s = ball_scene(float(sigma), glm::vec3(1.0f), glm::vec3(0.0f));
    std::vector<PuffVolume> book{PuffVolume::uniform_ball(1.0f)};
    const SixwayBakeSettings scattering = single_scattering();
    TruthSettings settings = one_sample();
    // Own light volumes 1/64 of the radius apart: the interpolation estimate below the tolerance even at the
    // ball's square-root silhouette (checked).
    settings.own_light_spacing_voxels = 1.0f;
    const GroundTruth truth(s, scattering, book, 0, w, h, settings);
    LadderReport report;
    const auto images = ladder(truth, report);
    CHECK(report.unconverged_pixels == 0);
    CHECK(double(report.own_light_error_estimate) < double(settings.tolerance));
    // The view steps' share (half the tolerance) plus the own light volume's largest estimate, for the rungs
    // that use that volume; the axis depths are exact for the ball, so the others get the view steps' share.
    const double own_bound = 0.5 * double(settings.tolerance) + double(report.own_light_error_estimate);
    const double axis_bound = 0.5 * double(settings.tolerance);
    const double centre = std::exp(-sigma * 1.0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const Ray ray = centre_ray(s, w, h, x, y);
            const double exact = lit_ball(ray, sigma, 1.0, 0.0);
            INFO("pixel " << x << "," << y);
            auto rung = [&](TruthRung r) { return double(images[std::size_t(r)].at(x, y).y); };
            CHECK(std::abs(rung(TruthRung::one_transmittance) - exact) <= own_bound);
            CHECK(std::abs(rung(TruthRung::light_map) - exact * centre) <= own_bound);
            CHECK(std::abs(rung(TruthRung::six_axis) - exact * centre) <= axis_bound);
            const double bake = lit_ball_lights(ray, sigma, double(scattering.extinction)) * centre;
            CHECK(std::abs(rung(TruthRung::bake_extinction) - bake) <= axis_bound);
        }
}

TEST_CASE("truth ladder: the ground's shadow is the nearest particle's e^{-τ(c)} (eq. 4.3), the truth's its chord's",
          "[truth]") {
    const int w = 20, h = 20;
    SceneDescription s = ball_scene(0.9f, glm::vec3(1.0f), glm::vec3(0.0f));
    s.ground = GroundDescription{{glm::vec3(-6, -2, -6), glm::vec3(-6, -2, 6), glm::vec3(6, -2, 6), glm::vec3(6, -2, -6)},
                                 glm::vec3(0, 1, 0), glm::vec3(0.5f, 0.25f, 1.0f)};
    s.camera.position = glm::vec3(0.0f, 4.0f, 9.0f);
    s.camera.look_at = glm::vec3(0.0f, -2.0f, 0.0f);
    s.camera.fov_deg = 40.0f;
    std::vector<PuffVolume> book{PuffVolume::uniform_ball(1.0f)};
    const TruthSettings settings = one_sample();
    const GroundTruth truth(s, single_scattering(), book, 0, w, h, settings);
    LadderReport report;
    const auto images = ladder(truth, report);
    int shadowed = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const Ray ray = centre_ray(s, w, h, x, y);
            const glm::dvec3 o(ray.origin), d(glm::normalize(glm::dvec3(ray.direction)));
            if (d.y >= 0.0) continue;
            const glm::dvec3 g = o + ((-2.0 - o.y) / d.y) * d;
            if (std::abs(g.x) > 6 || std::abs(g.z) > 6) continue;
            const double rho = std::sqrt(g.x * g.x + g.z * g.z);
            double t0, t1;
            if (std::abs(rho - 1.0) < 1e-3 || sphere_chord(ray, glm::dvec3(0.0), 1.0, t0, t1)) continue;
            // Green: ground 0.25 × light 1 × N·L 1, in the shadow times the ball's e^{-σ·r} from its centre.
            const double expected = 0.25 * (rho < 1.0 ? std::exp(-0.9 * 1.0) : 1.0);
            shadowed += rho < 1.0 ? 1 : 0;
            INFO("pixel " << x << "," << y);
            for (int r = 0; r < kTruthRungs; ++r)
                CHECK(std::abs(double(images[std::size_t(r)].at(x, y).y) - expected) <= 1e-6);
        }
    CHECK(shadowed > 0);
}

TEST_CASE("truth ladder: a puff in another's shadow gets the other's light once, at its centre", "[truth]") {
    // Two balls, the upper one shading part of the lower: the lower's one-transmittance light is its own
    // chord plus the upper's τ at the lower's centre, which differs from the truth where the upper ball's
    // shadow does not cover the lower one evenly; both rungs stay within their bounds of each other elsewhere.
    const int w = 16, h = 16;
    SceneDescription s = ball_scene(1.2f, glm::vec3(1.0f), glm::vec3(0.0f));
    s.smoke.particles.push_back(Particle{glm::vec3(0.5f, 1.8f, 0.0f), 0.6f});
    std::vector<PuffVolume> book{PuffVolume::uniform_ball(1.0f)};
    TruthSettings settings = one_sample();
    settings.own_light_spacing_voxels = 1.0f;
    const GroundTruth truth(s, single_scattering(), book, 0, w, h, settings);
    ImageRgba exact;
    (void)truth.render(exact);
    LadderReport report;
    const auto images = ladder(truth, report);
    const std::vector<double> tau = truth.particle_optical_depths();
    // The lower ball's centre lies below the upper ball's edge: the upper one's chord there is
    // 2·sqrt(0.36 − 0.25), so τ(centre) = σ·(1 + 2·sqrt(0.11)).
    CHECK(tau[0] == Approx(1.2 * (1.0 + 2.0 * std::sqrt(0.11))).epsilon(1e-5));
    // Where a camera ray meets the lower ball alone, its light is its own chord's times the constant
    // e^{-τ_others(centre)}: the truth's single-ball integral times that factor.
    const double others = 1.2 * 2.0 * std::sqrt(0.11);
    const double bound = 0.5 * double(settings.tolerance) + double(report.own_light_error_estimate);
    double largest = 0.0;
    int lower_only = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t k = std::size_t(y * w + x);
            largest = std::max(largest, double(std::abs(images[0].pixels[k].y - exact.pixels[k].y)));
            const Ray ray = centre_ray(s, w, h, x, y);
            double t0, t1;
            if (!sphere_chord(ray, glm::dvec3(0.0), 1.0, t0, t1) ||
                sphere_chord(ray, glm::dvec3(0.5, 1.8, 0.0), 0.6, t0, t1))
                continue;
            ++lower_only;
            INFO("pixel " << x << "," << y);
            CHECK(std::abs(double(images[0].pixels[k].y) - lit_ball(ray, 1.2, 1.0, 0.0) * std::exp(-others)) <= bound);
        }
    CHECK(lower_only > 20);
    INFO("largest difference one-transmittance vs truth " << largest);
    CHECK(largest > 10.0 * double(settings.tolerance));  // the approximation shows, far above the bound
}

TEST_CASE("truth ladder: the same bytes for one thread and two", "[truth]") {
    SceneDescription s = ball_scene(1.0f, glm::vec3(1.0f), glm::vec3(0.05f));
    s.smoke.particles.push_back(Particle{glm::vec3(0.6f, 0.5f, -0.3f), 0.7f});
    std::vector<PuffVolume> book{PuffVolume::uniform_ball(1.0f), PuffVolume::uniform_cube(0.5f)};
    const GroundTruth truth(s, single_scattering(), book, 0, 12, 12, one_sample());
    std::array<ImageRgba, kTruthRungs> one, two;
    tbb::task_arena(1).execute([&] { (void)truth.render_ladder(one); });
    tbb::task_arena(2).execute([&] { (void)truth.render_ladder(two); });
    for (int r = 0; r < kTruthRungs; ++r) {
        REQUIRE(one[std::size_t(r)].pixels.size() == two[std::size_t(r)].pixels.size());
        CHECK(std::memcmp(one[std::size_t(r)].pixels.data(), two[std::size_t(r)].pixels.data(),
                          one[std::size_t(r)].pixels.size() * sizeof(one[0].pixels[0])) == 0);
    }
}
