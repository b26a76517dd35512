// The view pass (thesis 4.3.5) and the frame loop: determinism, render-mode relations, the two compositors.
#include <catch2/catch.hpp>

#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/io/png_io.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/trace/trace.hpp>
#include <smoketrace/io/sixway_files.hpp>

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

using namespace smoketrace;

namespace {

const SixwayTexture& texture() {
    static const SixwayTexture t =
        load_sixway_texture(std::filesystem::path(SMOKETRACE_ASSET_DIR) / std::string(kSixwayLayoutFile));
    return t;
}

SceneDescription tubes_scene(const char* file = "two_tubes_above.json") {
    return load_scene_file(std::filesystem::path(SMOKETRACE_ASSET_DIR) / "scenes" / file);
}

// Small images keep CI fast; 96×96 still puts several pixels on every tube cross-section.
constexpr int kSize = 96;

ImageRgba render_once(const SceneDescription& scene, RenderMode mode, CompositorKind compositor = CompositorKind::one_traversal) {
    RenderOptions o = RenderOptions::from_scene(scene);
    o.render.mode = mode;
    o.width = o.height = kSize;
    o.compositor = compositor;
    FrameRenderer r(scene, o, texture());
    ImageRgba img;
    r.render(0, img);
    return img;
}

float luminance(const glm::vec4& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

}  // namespace

TEST_CASE("view: the same image bytes with 1 and 2 threads", "[view]") {
    const SceneDescription scene = tubes_scene();
    Rgba8Image one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = to_srgb8(render_once(scene, RenderMode::full));
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = to_srgb8(render_once(scene, RenderMode::full));
    }
    REQUIRE(one.pixels == two.pixels);
}

TEST_CASE("view: sigma_t = 0 makes full equal basic", "[view]") {
    // With no extinction, exp(-l·σt) = 1 for every particle and every shadow ray: eq. 4.2 and eq. 4.3
    // reduce to basic mode's unattenuated shading, bit for bit.
    SceneDescription scene = tubes_scene();
    scene.smoke.sigma_t = 0.0f;
    const ImageRgba full = render_once(scene, RenderMode::full);
    const ImageRgba basic = render_once(scene, RenderMode::basic);
    REQUIRE(full.pixels == basic.pixels);
    // And with σt > 0 the optical depth darkens the smoke: the images must differ.
    scene.smoke.sigma_t = 1.0f;
    REQUIRE(render_once(scene, RenderMode::full).pixels != basic.pixels);
}

TEST_CASE("view: ground shadows under the tubes in full mode, never darker than simple-shadow", "[view]") {
    const SceneDescription scene = tubes_scene();
    RenderOptions o = RenderOptions::from_scene(scene);
    o.width = o.height = kSize;
    FrameRenderer full_r(scene, o, texture());
    ImageRgba full;
    full_r.render(0, full);
    o.render.mode = RenderMode::simple_shadow;
    FrameRenderer simple_r(scene, o, texture());
    ImageRgba simple;
    simple_r.render(0, simple);

    // Look at ground points directly: shade them through a camera looking straight down at the ground
    // would need another scene; instead compare pixels whose view ray reaches the ground unobstructed by
    // smoke in both images (identical layer sets), classified by whether a stand-in shadows them.
    const Camera cam(scene.camera.position, scene.camera.look_at, scene.camera.up, scene.camera.fov_deg, kSize, kSize);
    const AccelScene& s = full_r.smoke().scene();
    double shadowed = 0, lit = 0;
    int n_shadowed = 0, n_lit = 0, compared = 0;
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
            const Ray r = cam.ray(x, y, kViewRayTmin);
            const TraceResult any_smoke = trace(s, r, ray_flag_none, kBillboardMask, [](const TraceHit&) { return AnyHitDecision::accept_and_end; });
            if (any_smoke.hit) continue;  // smoke in front: not a clean ground pixel
            const TraceResult g = trace(s, r, ray_flag_none, kGroundMask);
            if (!g.hit) continue;
            const glm::vec3 p = r.origin + g.committed.t * r.direction;
            const TraceResult occ = trace(s, Ray{p, 0.0f, scene.light.direction, INFINITY}, ray_flag_force_opaque | ray_flag_accept_first_hit_and_end_search, kStandInMask);
            const float lf = luminance(full.at(x, y)), ls = luminance(simple.at(x, y));
            REQUIRE(lf >= ls);  // exp(-l·σt) >= 0: full shadows are never darker than simple ones
            ++compared;
            if (occ.hit) { shadowed += lf; ++n_shadowed; } else { lit += lf; ++n_lit; }
        }
    REQUIRE(compared > 100);
    REQUIRE(n_shadowed > 20);
    REQUIRE(n_lit > 20);
    REQUIRE(shadowed / n_shadowed < 0.8 * (lit / n_lit));
}

TEST_CASE("view: the one-traversal compositor matches the thesis's re-trace loop", "[view]") {
    // Both composite the same layers in the same order; they differ only where two billboards lie at
    // exactly the same depth along a ray (the re-trace loop steps past the second one). Stated tolerance:
    // every channel within 2e-3 (half an 8-bit step) on all but 0.5 % of the pixels, and the mean
    // absolute difference below 1e-4.
    const SceneDescription scene = tubes_scene("two_tubes_right.json");
    for (RenderMode mode : {RenderMode::basic, RenderMode::full}) {
        const ImageRgba a = render_once(scene, mode, CompositorKind::one_traversal);
        const ImageRgba b = render_once(scene, mode, CompositorKind::retrace);
        int off = 0;
        double sum = 0;
        for (std::size_t i = 0; i < a.pixels.size(); ++i) {
            const glm::vec4 d = glm::abs(a.pixels[i] - b.pixels[i]);
            sum += d.x + d.y + d.z;
            if (std::max({d.x, d.y, d.z}) > 2e-3f) ++off;
        }
        CHECK(off <= int(0.005 * a.pixels.size()));
        CHECK(sum / (3.0 * a.pixels.size()) < 1e-4);
    }
}

TEST_CASE("view: basic mode runs no optical-depth pass", "[view]") {
    SceneDescription scene = tubes_scene();
    RenderOptions o = RenderOptions::from_scene(scene);
    o.width = o.height = 32;
    o.render.mode = RenderMode::basic;
    FrameRenderer r(scene, o, texture());
    ImageRgba img;
    const FrameReport f0 = r.render(0, img);
    REQUIRE(f0.depths_updated == 0);
    REQUIRE(f0.timings.od_pass == 0.0);
    REQUIRE(f0.tlas == TlasUpdate::rebuild);
}

TEST_CASE("view: a still frame skips the TLAS and the optical depths, yet its flipbook animates", "[view]") {
    // Nothing moves and the light stands still (two_tubes_above.json), so the TLAS and the optical
    // depths keep their inputs; the billboards' flipbook frame changes every frame, so the image must too.
    const SceneDescription scene = tubes_scene();
    REQUIRE(texture().frame_count() > 1);
    RenderOptions o = RenderOptions::from_scene(scene);
    o.width = o.height = 32;
    o.render.mode = RenderMode::full;
    FrameRenderer r(scene, o, texture());
    const int period = texture().frame_count();
    std::vector<ImageRgba> images(std::size_t(period) + 2);
    ImageRgba img;
    for (int f = 0; f <= period + 1; ++f) {
        const FrameReport rep = r.render(std::uint64_t(f), img);
        images[std::size_t(f)] = img;
        if (f == 0) continue;
        CAPTURE(f);
        REQUIRE(rep.tlas == TlasUpdate::none);
        REQUIRE(rep.timings.tlas_update == 0.0);
        REQUIRE(rep.depths_updated == 0);
        REQUIRE(rep.timings.od_pass == 0.0);
        REQUIRE_FALSE(rep.reused_previous);
        REQUIRE(rep.timings.view > 0.0);
    }
    CHECK(images[1].pixels != images[0].pixels);  // the flipbook moved on
    // One flipbook period later the view's every input is the same again: the same image, bit for bit.
    CHECK(images[std::size_t(period)].pixels == images[0].pixels);
    CHECK(images[std::size_t(period) + 1].pixels == images[1].pixels);
}

TEST_CASE("view: with a one-frame flipbook a still frame keeps the previous image", "[view]") {
    // Every input of the view is unchanged, so the image already drawn is this frame's.
    const SixwayAtlasGrid grid = texture().grid();
    // Frame 0 of the shipped flipbook, copied texel for texel into one-frame atlases.
    Rgba8Image pos(texture().tile_width(), texture().tile_height());
    Rgba8Image neg(pos.width, pos.height);
    const auto code = [](float v) { return std::uint8_t(std::lround(v * 255.0f)); };
    for (int y = 0; y < pos.height; ++y)
        for (int x = 0; x < pos.width; ++x) {
            const SixwaySample s = texture().texel(x, y, 0);
            const std::uint8_t p[4] = {code(s.pos.x), code(s.pos.y), code(s.pos.z), code(s.alpha)};
            const std::uint8_t n[4] = {code(s.neg.x), code(s.neg.y), code(s.neg.z), code(s.alpha)};
            std::copy(p, p + 4, pos.texel(x, y));
            std::copy(n, n + 4, neg.texel(x, y));
        }
    REQUIRE(grid.frames > 1);
    const SixwayTexture one_frame(pos, neg, SixwayAtlasGrid{1, 1, 1});
    const SceneDescription scene = tubes_scene();
    RenderOptions o = RenderOptions::from_scene(scene);
    o.width = o.height = 32;
    FrameRenderer r(scene, o, one_frame);
    ImageRgba img;
    (void)r.render(0, img);
    const ImageRgba first = img;
    const FrameReport f1 = r.render(1, img);
    REQUIRE(f1.reused_previous);
    REQUIRE(f1.tlas == TlasUpdate::none);
    REQUIRE(f1.timings.view == 0.0);
    REQUIRE(img.pixels == first.pixels);
}

TEST_CASE("view: moving particles refit the TLAS, groups update 1/G of the depths per frame", "[view]") {
    SceneDescription scene = tubes_scene();
    for (auto& p : scene.smoke.particles) p.velocity = glm::vec3(0.001f, 0.0f, 0.0f);
    scene.light.rotation_per_frame_deg = 1.0f;
    RenderOptions o = RenderOptions::from_scene(scene);
    o.width = o.height = 16;
    o.render.groups = 4;
    FrameRenderer r(scene, o, texture());
    ImageRgba img;
    REQUIRE(r.render(0, img).depths_updated == scene.smoke.particles.size());  // first frame: everyone
    const auto before = r.depths().lengths();
    const FrameReport f1 = r.render(1, img);
    REQUIRE(f1.tlas != TlasUpdate::none);
    REQUIRE(f1.depths_updated == (scene.smoke.particles.size() + 2) / 4);
    const auto& after = r.depths().lengths();
    for (std::size_t i = 0; i < after.size(); ++i)
        if (i % 4 != 1) REQUIRE(std::bit_cast<std::uint32_t>(after[i]) == std::bit_cast<std::uint32_t>(before[i]));
}
