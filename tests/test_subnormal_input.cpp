// Numbers near 0 in scene files: subnormal floats (1.4e-45 … 1.2e-38) are read as the floats they are, and
// every consumer stays correct with them; a number that rounds to 0 in float (1e-50) reads as 0 where 0 is
// allowed and is an error where the value must be > 0; a radius must be a normal float. Directions are
// normalised from the numbers as written.
#include "support/cli_runner.hpp"
#include "support/fixtures.hpp"

#include <smoketrace/render/camera.hpp>
#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/render/sixway_texture.hpp>
#include <smoketrace/io/sixway_files.hpp>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <glm/geometric.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

using namespace smoketrace;
using nlohmann::json;

namespace {

std::string error_of(const json& j) {
    try {
        (void)parse_scene(j.dump(), "tiny.json");
    } catch (const SceneFileError& e) {
        return e.what();
    }
    return "(no error)";
}

// The message names the file, then the path, then says the problem.
void require_error(const json& j, const std::string& path, const std::string& problem) {
    const std::string message = error_of(j);
    INFO("message: " << message);
    CHECK(message.rfind("tiny.json: " + path + ": ", 0) == 0);
    CHECK(message.find(problem) != std::string::npos);
}

json base() {
    return json::parse(R"({ "light": { "direction": [0, 1, 0] },
        "smoke": { "particles": [ { "center": [0, 0, 0], "radius": 0.5 }, { "center": [0, 0.6, 0], "radius": 0.4 },
                                  { "center": [0.1, 1.3, 0], "radius": 0.5 } ] },
        "ground": { "corners": [[-4, -1, 4], [4, -1, 4], [4, -1, -4], [-4, -1, -4]] } })");
}

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

const SixwayTexture& texture() {
    static const SixwayTexture t =
        load_sixway_texture(std::filesystem::path(SMOKETRACE_ASSET_DIR) / std::string(kSixwayLayoutFile));
    return t;
}

// Renders frame 0 of `s` at 8x8 in `mode` and requires every pixel finite and >= 0.
void require_finite_render(const SceneDescription& s, RenderMode mode) {
    RenderOptions o = RenderOptions::from_scene(s);
    o.width = o.height = 8;
    o.render.mode = mode;
    FrameRenderer renderer(s, o, texture());
    ImageRgba image;
    renderer.render(0, image);
    for (const glm::vec4& px : image.pixels)
        for (int c = 0; c < 4; ++c) REQUIRE((std::isfinite(px[c]) && px[c] >= 0.0f));
}

}  // namespace

TEST_CASE("subnormal numbers are read as the floats they are", "[scene][subnormal]") {
    // Each used to be "too close to 0 for single precision".
    json j = base();
    j["light"]["direction"] = {1e-38, 1, 1e-38};
    j["light"]["color"] = {1e-40, 1, 1};
    j["light"]["rotation_per_frame_deg"] = 1e-41;
    j["ambient"] = {1e-45, 0, 0};
    j["background"] = {0, 3e-39, 0};
    j["smoke"]["particles"][0]["center"] = {1e-40, -2e-39, 0};
    j["smoke"]["particles"][0]["velocity"] = {0, 1e-40, 0};
    j["smoke"]["particles"][0]["spin"] = 1e-42;
    j["smoke"]["particles"][0]["growth"] = -1e-40;
    j["smoke"]["particles"][0]["rotation"] = 1e-39;
    j["smoke"]["sigma_t"] = 1e-40;
    j["ground"]["color"] = {1e-44, 0, 0};
    j["camera"] = {{"position", {0, 0.5, 5}}, {"look_at", {1e-40, 0, 0}}, {"up", {1e-39, 1, 0}}};
    j["render"] = {{"softness", 1e-42}, {"transmittance_threshold", 1e-43}};
    const SceneDescription s = parse_scene(j.dump(), "tiny.json");
    // Rounded once to float (nearest), and nonzero.
    CHECK(s.light.direction == glm::vec3(1e-38f, 1.0f, 1e-38f));
    CHECK(s.light.color.x == 1e-40f);
    CHECK(s.light.rotation_per_frame_deg == 1e-41f);
    CHECK(s.ambient.x == 1e-45f);
    CHECK(s.ambient.x > 0.0f);
    CHECK(s.background.y == 3e-39f);
    const Particle& p = s.smoke.particles[0];
    CHECK(p.center == glm::vec3(1e-40f, -2e-39f, 0.0f));
    CHECK(p.velocity.y == 1e-40f);
    CHECK(p.spin == 1e-42f);
    CHECK(p.growth == -1e-40f);
    CHECK(p.rotation == 1e-39f);
    CHECK(s.smoke.sigma_t == 1e-40f);
    CHECK(s.ground->color.x == 1e-44f);
    CHECK(s.camera.look_at.x == 1e-40f);
    CHECK(s.camera.up == glm::vec3(1e-39f, 1.0f, 0.0f));
    CHECK(s.render.softness == 1e-42f);
    CHECK(s.render.transmittance_threshold == 1e-43f);
    // Tubes: sizes and speeds.
    json t = base();
    t["smoke"].erase("particles");
    t["smoke"]["tubes"] = {{"count", 20}, {"tube_radius", 1e-40}, {"tube_length", 2e-40}, {"separation", 1e-39},
                           {"jitter_speed", 1e-41}, {"drift", {1e-40, 0, 0}}};
    const SceneDescription tubes = parse_scene(t.dump(), "tiny.json");
    REQUIRE(tubes.smoke.tubes.has_value());
    CHECK(tubes.smoke.tubes->tube_radius == 1e-40f);
    CHECK(tubes.smoke.particles.size() == 20);
    for (const Particle& q : tubes.smoke.particles) {
        // Inside the tubes: every coordinate within a few subnormal steps of 0 (tube radius, length, separation).
        CHECK(glm::length(glm::dvec3(q.center)) < 1e-38);
        CHECK(q.radius == TubeSettings{}.particle_radius);
    }
}

TEST_CASE("a number that rounds to 0 in float reads as 0 where 0 is allowed", "[scene][subnormal]") {
    // 1e-50 is below half the smallest subnormal float (2^-150 ≈ 7e-46): the nearest float is 0, which is
    // what a coordinate, a speed, a colour, an absorption or a softness of 1e-50 means to float precision.
    json j = base();
    j["smoke"]["particles"][1]["center"] = {1e-50, 0.6, -1e-50};
    j["smoke"]["particles"][1]["velocity"] = {-1e-50, 0, 0};
    j["smoke"]["particles"][1]["growth"] = 1e-50;
    j["smoke"]["sigma_t"] = 1e-50;
    j["ambient"] = {1e-50, 0, 0};
    j["light"]["rotation_per_frame_deg"] = -1e-50;
    j["render"] = {{"softness", 1e-50}};
    const SceneDescription s = parse_scene(j.dump(), "tiny.json");
    const Particle& p = s.smoke.particles[1];
    CHECK(p.center.x == 0.0f);
    CHECK(!std::signbit(p.center.z));  // +0, not -0: the value is 0
    CHECK(p.velocity.x == 0.0f);
    CHECK(!std::signbit(p.velocity.x));
    CHECK(p.growth == 0.0f);
    CHECK(s.smoke.sigma_t == 0.0f);
    CHECK(s.ambient.x == 0.0f);
    CHECK(s.light.rotation_per_frame_deg == 0.0f);
    CHECK(s.render.softness == 0.0f);
    // But a negative number is still negative where the value must be >= 0.
    json neg = base();
    neg["smoke"]["sigma_t"] = -1e-50;
    require_error(neg, "/smoke/sigma_t", "must be >= 0 (got -1e-50)");
    json neg_colour = base();
    neg_colour["ambient"] = {0, -1e-50, 0};
    require_error(neg_colour, "/ambient/1", "must be >= 0 (got -1e-50)");
}

TEST_CASE("a number that rounds to 0 in float is an error where the value must be > 0", "[scene][subnormal]") {
    json fov = base();
    fov["camera"] = {{"fov_deg", 1e-50}};
    require_error(fov, "/camera/fov_deg",
                  "too close to 0 for single precision (got 1e-50, which rounds to 0; must be in (0, 180))");
    json radius = base();
    radius["smoke"]["particles"][2]["radius"] = 1e-50;
    const std::string rounds_to_0 = "too close to 0 for single precision (got 1e-50, which rounds to 0; must be > 0)";
    require_error(radius, "/smoke/particles/2/radius", rounds_to_0);
    for (const char* key : {"tube_radius", "tube_length", "particle_radius"}) {
        json t = base();
        t["smoke"].erase("particles");
        t["smoke"]["tubes"] = {{key, 1e-50}};
        require_error(t, std::string("/smoke/tubes/") + key, rounds_to_0);
    }
    // A subnormal field of view is a float, but far too small for a camera.
    fov["camera"]["fov_deg"] = 1e-40;
    require_error(fov, "/camera/fov_deg", "too small for a usable camera (got 1e-40)");
}

TEST_CASE("a radius must be at least the smallest normal float", "[scene][subnormal]") {
    // Below 1.1754944e-38 a particle's object space (1/radius) overflows float: the icosahedron test would
    // see an infinite direction. The particle system keeps every radius at or above it (kMinParticleRadius).
    json j = base();
    j["smoke"]["particles"][0]["radius"] = 1e-40;
    require_error(j, "/smoke/particles/0/radius",
                  "must be at least 1.1754944e-38, the smallest normal float (got 1e-40): the particle is scaled by "
                  "1/radius");
    json t = base();
    t["smoke"].erase("particles");
    t["smoke"]["tubes"] = {{"particle_radius", 1e-39}};
    require_error(t, "/smoke/tubes/particle_radius",
                  "must be at least 1.1754944e-38, the smallest normal float (got 1e-39)");
    j["smoke"]["particles"][0]["radius"] = 1.1754944e-38;
    const SceneDescription s = parse_scene(j.dump(), "tiny.json");
    CHECK(s.smoke.particles[0].radius == kMinParticleRadius);
}

TEST_CASE("a number that rounds out of its interval in float names its rounded value", "[scene][subnormal]") {
    json j = base();
    j["render"] = {{"transmittance_threshold", 0.99999999999}};
    require_error(j, "/render/transmittance_threshold",
                  "must be in [0, 1) (got 0.99999999999, which rounds to 1 in single precision)");
    json f = base();
    f["camera"] = {{"fov_deg", 179.9999999999}};
    require_error(f, "/camera/fov_deg",
                  "must be in (0, 180) (got 179.9999999999, which rounds to 180 in single precision)");
}

TEST_CASE("directions are normalised from the numbers as written", "[scene][subnormal]") {
    // Rounding each component to float first made [1e-50, 0, 0] the zero vector; it points along +x.
    const struct {
        json direction;
        glm::vec3 want;
    } cases[] = {
        {{1e-50, 0, 0}, {1, 0, 0}},
        {{0, -1e-300, 0}, {0, -1, 0}},
        {{1e-200, 1e-200, 0}, {float(std::sqrt(0.5)), float(std::sqrt(0.5)), 0}},  // |d|² underflows in double
        {{1e-50, 1, 0}, {0, 1, 0}},
        {{3e38, 0, 3e38}, {float(std::sqrt(0.5)), 0, float(std::sqrt(0.5))}},
    };
    for (const auto& c : cases) {
        INFO("direction " << c.direction.dump());
        json j = base();
        j["light"]["direction"] = c.direction;
        CHECK(parse_scene(j.dump(), "tiny.json").light.direction == c.want);
        json u = base();
        u["camera"] = {{"position", {0.5, 0.5, 5}}, {"up", c.direction}};
        if (c.want.z == 0.0f) CHECK(parse_scene(u.dump(), "tiny.json").camera.up == c.want);
    }
    json zero = base();
    zero["light"]["direction"] = {0, -0.0, 0};
    require_error(zero, "/light/direction", "must not be the zero vector");
    json up = base();
    up["camera"] = {{"up", {0, 0, 0}}};
    require_error(up, "/camera/up", "must not be the zero vector");
    json big = base();
    big["light"]["direction"] = {1e39, 1, 0};
    require_error(big, "/light/direction/0", "too large for single precision");
}

TEST_CASE("subnormal inputs: optical depths and frames stay exact and finite", "[scene][subnormal]") {
    // The light [1e-38, 1, 1e-38] is +y turned by 1.4e-38 radians: every hit distance it gives rounds to the
    // same float as for +y (the tiny components add ~1e-38 to sums of order 1), so the optical depths are the
    // same bits, and the pass's box tests, whose 1/d is 1e38 here (inf for +y), find the same hits.
    json straight = base();
    json tilted = base();
    tilted["light"]["direction"] = {1e-38, 1, 1e-38};
    const SceneDescription a = parse_scene(straight.dump(), "tiny.json");
    const SceneDescription b = parse_scene(tilted.dump(), "tiny.json");
    auto depths = [](const SceneDescription& s) {
        std::optional<GroundQuad> ground;
        if (s.ground) ground = GroundQuad{s.ground->corners};
        SmokeScene scene(s.smoke.particles, s.smoke.shape, ground, false);
        scene.update(s.smoke.particles, s.camera.position);
        OpticalPathLengths od(s.smoke.particles.size());
        FrameTimings timings;
        od.update(scene, s.smoke.particles, test::all_of(s.smoke.particles.size()), s.light.direction,
                  OpticalDepthSettings{}, HitSort::adaptive, timings);
        return od;
    };
    const OpticalPathLengths da = depths(a), db = depths(b);
    for (std::size_t i = 0; i < a.smoke.particles.size(); ++i) {
        INFO("particle " << i << ": " << da.lengths()[i] << " vs " << db.lengths()[i]);
        CHECK(da.status()[i] == db.status()[i]);
        CHECK(da.hit_counts()[i] == db.hit_counts()[i]);
        CHECK(same_bits(da.lengths()[i], db.lengths()[i]));
    }
    CHECK(da.lengths()[0] > 0.5f);  // particle 0 lies under the other two: the check is not of zeros

    // Frames of scenes full of subnormals: light, colours, coordinates, sizes; the camera looking at a
    // point a subnormal distance away from its position (in float, |look_at − position|² was 0: "position
    // and look_at coincide").
    json every = base();
    every["light"] = {{"direction", {1e-39, 1, -1e-45}}, {"color", {1e-40, 1e-45, 1}}};
    every["ambient"] = {1e-42, 0, 0};
    every["background"] = {1e-40, 1e-40, 1e-40};
    every["smoke"]["particles"][0]["center"] = {1e-40, 1e-39, -1e-41};
    every["smoke"]["particles"].push_back({{"center", {1e-40, 0, 0}}, {"radius", 1.1754944e-38}});
    every["smoke"]["sigma_t"] = 1e-40;
    every["ground"]["color"] = {1e-44, 1e-40, 0};
    every["render"] = {{"softness", 1e-42}};
    const SceneDescription s = parse_scene(every.dump(), "tiny.json");
    for (const RenderMode mode : {RenderMode::basic, RenderMode::simple_shadow, RenderMode::full})
        require_finite_render(s, mode);
    json near = base();
    near["camera"] = {{"position", {0, 0, 1e-40}}, {"look_at", {0, 0, 0}}};
    const SceneDescription n = parse_scene(near.dump(), "tiny.json");
    CHECK_NOTHROW(Camera(n.camera.position, n.camera.look_at, n.camera.up, n.camera.fov_deg, 8, 8));
    require_finite_render(n, RenderMode::full);
    json tubes = base();
    tubes["smoke"].erase("particles");
    tubes["smoke"]["tubes"] = {{"count", 16}, {"tube_radius", 1e-40}, {"tube_length", 1e-40}, {"separation", 0}};
    require_finite_render(parse_scene(tubes.dump(), "tiny.json"), RenderMode::full);
}

TEST_CASE("the command line reads subnormal scenes and names the field of a radius too small",
          "[scene][subnormal][cli]") {
    test::TempDir dir;
    json tilted = base();
    tilted["light"]["direction"] = {1e-38, 1, 1e-38};
    const auto ok = dir.write("tilted.json", tilted.dump());
    const auto csv = dir.path / "d.csv";
    const test::CliRun r = test::run_cli("depths " + ok.string() + " -o " + csv.string());
    INFO(r.err);
    CHECK(r.exit_code == 0);
    std::ifstream in(csv);
    std::string line;
    int rows = 0;
    while (std::getline(in, line)) ++rows;
    CHECK(rows == 1 + 3);  // the header and one row per particle

    json bad = base();
    bad["smoke"]["particles"][1]["radius"] = 1e-40;
    const auto bad_path = dir.write("radius.json", bad.dump());
    const test::CliRun b = test::run_cli("depths " + bad_path.string() + " -o " + (dir.path / "b.csv").string());
    INFO(b.err);
    CHECK(b.exit_code == 1);
    CHECK(b.err.rfind("smoketrace depths: " + bad_path.string() +
                          ": /smoke/particles/1/radius: must be at least 1.1754944e-38, the smallest normal float "
                          "(got 1e-40)",
                      0) == 0);
    CHECK(!std::filesystem::exists(dir.path / "b.csv"));
}

TEST_CASE("particles a few subnormal steps apart: the acceleration structure and the pass", "[subnormal]") {
    // 64 particles of the smallest radius (kMinParticleRadius, 1.2e-38) whose centres are 1e-42 apart along
    // x, a scene file can now hold. The BVH builder's bins per unit of centroid extent, kBins / 6.3e-41,
    // overflowed to inf, and bin_of converted inf·0 = NaN to int (undefined; the sanitizer build stops
    // there, a release build happened to put everything in bin 0). Every particle contains every centre, so
    // each ray toward +x starts inside all 64 stand-ins: 64 exits, no entry, and l is the farthest exit.
    std::vector<Particle> ps;
    for (int k = 0; k < 64; ++k) ps.push_back(test::particle({float(k) * 1e-42f, 0.0f, 0.0f}, kMinParticleRadius));
    const StandInShape shapes[] = {{StandInKind::sphere, 0}, {StandInKind::icosahedron, 0}};
    for (const StandInShape shape : shapes) {
        SmokeScene scene(ps, shape, std::nullopt, false);
        scene.update(ps, glm::vec3(0.0f, 0.0f, 1.0f));
        OpticalPathLengths od(ps.size());
        FrameTimings timings;
        od.update(scene, ps, test::all_of(ps.size()), glm::vec3(1.0f, 0.0f, 0.0f), OpticalDepthSettings{},
                  HitSort::adaptive, timings);
        for (std::size_t k = 0; k < ps.size(); ++k) {
            INFO(shape.name() << ", particle " << k);
            REQUIRE(od.status()[k] == DepthStatus::ok);
            CHECK(od.hit_counts()[k] == 64);
            // The farthest exit: the last particle's, at x_63 + r (sphere) or + the icosahedron's exit
            // distance along +x (between its inradius 0.79·r and r), measured from x_k; 1e-42 is 700 float
            // steps of r, so the spread of the centres shows.
            const double r = double(kMinParticleRadius), ahead = double(ps.back().center.x) - double(ps[k].center.x);
            const double l = od.lengths()[k];
            if (shape.kind == StandInKind::sphere) CHECK(std::abs(l - (ahead + r)) <= 8.0 * 0x1.0p-24 * (ahead + r));
            else CHECK((l >= ahead + 0.79 * r && l <= ahead + r));
        }
    }
}
