// Scene files: the minimal form, our optional keys and their defaults, the shipped scenes, and one test
// per kind of bad input (each checking that the message names the file and the JSON path).
#include "support/cli_runner.hpp"

#include <smoketrace/render/camera.hpp>
#include <smoketrace/render/pixel_samples.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/smoke/tube_generator.hpp>

#include <catch2/catch.hpp>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

using namespace smoketrace;
using nlohmann::json;

namespace {

// A value read from JSON is rounded once to float: relative error <= 2^-24 ≈ 6e-8. A normalised direction
// is computed in double and rounded once as well. 2e-7 leaves room for both.
constexpr double kFloatRoundingTolerance = 2e-7;

const char* const kMinimal = R"({ "light":  { "direction": [0, 2, 0] },
  "smoke":  { "particles": [ { "center": [1, 2, 3], "radius": 0.5 },
                             { "center": [-1.5, 0.25, 4], "radius": 2 } ] },
  "ground": { "corners": [[-4, -1, -4], [-4, -1, 4], [4, -1, 4], [4, -1, -4]] } })";

json minimal() { return json::parse(kMinimal); }

// A scene with four particles, so that "/smoke/particles/3/..." exists.
json four_particles() {
    json j = minimal();
    j["smoke"]["particles"].push_back({{"center", {0, 0, 0}}, {"radius", 1}});
    j["smoke"]["particles"].push_back({{"center", {0, 1, 0}}, {"radius", 1}});
    return j;
}

std::string error_of(const std::string& text, const std::string& source = "bad.json") {
    try {
        (void)parse_scene(text, source);
    } catch (const SceneFileError& e) {
        return e.what();
    }
    return "(no error)";
}

// The error names the file first, then the JSON path, then contains the problem's wording.
void require_error(const std::string& text, const std::string& path, const std::string& problem) {
    const std::string message = error_of(text);
    INFO("message: " << message);
    CHECK(message.rfind("bad.json: ", 0) == 0);
    CHECK(message.find(" " + path + ": ") != std::string::npos);
    CHECK(message.find(problem) != std::string::npos);
}
void require_error(const json& j, const std::string& path, const std::string& problem) {
    require_error(j.dump(), path, problem);
}

// JSON cannot hold inf; put the literal text in place of a marker string.
std::string with_literal(const json& j, const std::string& literal) {
    std::string text = j.dump();
    const auto at = text.find("\"@\"");
    REQUIRE(at != std::string::npos);
    return text.replace(at, 3, literal);
}

std::filesystem::path asset(const char* name) { return std::filesystem::path(SMOKETRACE_ASSET_DIR) / "scenes" / name; }

}  // namespace

// ---- Reading -----------------------------------------------------------------------------------------

TEST_CASE("the minimal form parses exactly", "[scene]") {
    const SceneDescription s = parse_scene(kMinimal, "minimal.json");
    CHECK(s.source == "minimal.json");
    CHECK(s.light.direction == glm::vec3(0.0f, 1.0f, 0.0f));  // [0, 2, 0] normalised, exactly
    REQUIRE(s.smoke.particles.size() == 2);
    CHECK(s.smoke.particles[0].center == glm::vec3(1.0f, 2.0f, 3.0f));
    CHECK(s.smoke.particles[0].radius == 0.5f);
    CHECK(s.smoke.particles[1].center == glm::vec3(-1.5f, 0.25f, 4.0f));
    CHECK(s.smoke.particles[1].radius == 2.0f);
    for (const Particle& p : s.smoke.particles) {
        CHECK(p.velocity == glm::vec3(0.0f));
        CHECK(p.spin == 0.0f);
        CHECK(p.growth == 0.0f);
        CHECK(p.rotation == 0.0f);
    }
    CHECK_FALSE(s.smoke.tubes.has_value());
    REQUIRE(s.ground.has_value());
    CHECK(s.ground->corners[0] == glm::vec3(-4.0f, -1.0f, -4.0f));
    CHECK(s.ground->corners[2] == glm::vec3(4.0f, -1.0f, 4.0f));
    CHECK(s.ground->normal == glm::vec3(0.0f, 1.0f, 0.0f));  // counter-clockwise seen from above
}

TEST_CASE("the defaults of every optional key", "[scene]") {
    json j = minimal();
    j.erase("ground");
    const SceneDescription s = parse_scene(j.dump(), "defaults.json");
    CHECK_FALSE(s.ground.has_value());
    CHECK(s.light.color == glm::vec3(1.0f));
    CHECK(s.light.rotation_per_frame_deg == 0.0f);
    CHECK(s.ambient == glm::vec3(0.05f));
    CHECK(s.background == glm::vec3(0.53f, 0.81f, 0.92f));
    CHECK(s.smoke.sigma_t == 1.0f);
    CHECK(s.smoke.alpha == 0.5f);
    CHECK(s.smoke.shape == StandInShape{StandInKind::sphere, 0});
    CHECK(s.smoke.kernel == kPoly1Kernel);  // the error study's choice (docs/accuracy.md)
    CHECK(s.render.mode == RenderMode::full);
    CHECK(s.render.cutoff == 0u);
    CHECK(s.render.groups == 1u);
    CHECK(s.render.frames == 1u);
    CHECK(s.render.softness == 0.3f);
    CHECK(s.render.transmittance_threshold == 1.0f / 255.0f);
    CHECK(s.render.compositing == Compositing::over);
    CHECK(s.render.spp == 1u);
    CHECK(s.render.fps == 24u);
    CHECK(s.camera.width == 512u);
    CHECK(s.camera.height == 512u);
    CHECK(s.camera.fov_deg == 45.0f);
    CHECK(s.camera.up == glm::vec3(0.0f, 1.0f, 0.0f));
}

TEST_CASE("every optional key is read", "[scene]") {
    json j = minimal();
    j["light"]["color"] = {0.9, 0.8, 0.7};
    j["light"]["rotation_per_frame_deg"] = -2.5;
    j["ambient"] = {0.1, 0.2, 0.3};
    j["background"] = {0, 0, 0};
    j["smoke"]["particles"][0]["velocity"] = {0.5, 0, -0.25};
    j["smoke"]["particles"][0]["spin"] = 0.125;
    j["smoke"]["particles"][0]["growth"] = -0.5;
    j["smoke"]["particles"][0]["rotation"] = 1.5;
    j["smoke"]["sigma_t"] = 2.5;
    j["smoke"]["alpha"] = 0.25;
    j["smoke"]["shape"] = "icosphere:3";
    j["smoke"]["kernel"] = "poly2";
    j["ground"]["color"] = {0.5, 0.5, 0.5};
    j["camera"] = {{"position", {1, 2, 3}}, {"look_at", {0, 0, -1}}, {"up", {0, 0, 1}},
                   {"fov_deg", 60}, {"width", 640}, {"height", 480}};
    j["render"] = {{"mode", "simple-shadow"}, {"cutoff", 60}, {"groups", 4}, {"frames", 32},
                   {"softness", 0}, {"transmittance_threshold", 0.5}, {"compositing", "thesis"}, {"spp", 16},
                   {"fps", 30}};
    const SceneDescription s = parse_scene(j.dump(), "all.json");
    CHECK(s.light.color == glm::vec3(0.9f, 0.8f, 0.7f));
    CHECK(s.light.rotation_per_frame_deg == -2.5f);
    CHECK(s.ambient == glm::vec3(0.1f, 0.2f, 0.3f));
    CHECK(s.background == glm::vec3(0.0f));
    const Particle& p = s.smoke.particles[0];
    CHECK(p.velocity == glm::vec3(0.5f, 0.0f, -0.25f));
    CHECK(p.spin == 0.125f);
    CHECK(p.growth == -0.5f);
    CHECK(p.rotation == 1.5f);
    CHECK(s.smoke.sigma_t == 2.5f);
    CHECK(s.smoke.alpha == 0.25f);
    CHECK(s.smoke.shape == StandInShape{StandInKind::icosphere, 3});
    CHECK(s.smoke.kernel == kPoly2Kernel);
    CHECK(s.ground->color == glm::vec3(0.5f));
    CHECK(s.camera.position == glm::vec3(1.0f, 2.0f, 3.0f));
    CHECK(s.camera.look_at == glm::vec3(0.0f, 0.0f, -1.0f));
    CHECK(s.camera.up == glm::vec3(0.0f, 0.0f, 1.0f));
    CHECK(s.camera.fov_deg == 60.0f);
    CHECK(s.camera.width == 640u);
    CHECK(s.camera.height == 480u);
    CHECK(s.render.mode == RenderMode::simple_shadow);
    CHECK(s.render.cutoff == 60u);
    CHECK(s.render.groups == 4u);
    CHECK(s.render.frames == 32u);
    CHECK(s.render.softness == 0.0f);
    CHECK(s.render.transmittance_threshold == 0.5f);
    CHECK(s.render.compositing == Compositing::thesis);
    CHECK(s.render.spp == 16u);
    CHECK(s.render.fps == 30u);
}

TEST_CASE("a light direction of any length is stored normalised", "[scene]") {
    json j = minimal();
    j["light"]["direction"] = {3, 0, -4};  // length 5
    const SceneDescription s = parse_scene(j.dump(), "light.json");
    CHECK(s.light.direction.x == Approx(0.6).epsilon(kFloatRoundingTolerance));
    CHECK(s.light.direction.y == 0.0f);
    CHECK(s.light.direction.z == Approx(-0.8).epsilon(kFloatRoundingTolerance));
}

TEST_CASE("the light rotates about +z, from +x toward +y", "[scene]") {
    LightDescription light;
    light.direction = {1.0f, 0.0f, 0.0f};
    light.rotation_per_frame_deg = 30.0f;
    // cos/sin of multiples of 30° in double are within 1e-16 of the exact values; the float result is
    // then rounded once: kFloatRoundingTolerance (as an absolute margin on unit components).
    const glm::vec3 d3 = light.direction_at_frame(3);  // 90°
    CHECK(d3.x == Approx(0.0).margin(kFloatRoundingTolerance));
    CHECK(d3.y == Approx(1.0).margin(kFloatRoundingTolerance));
    const glm::vec3 d1 = light.direction_at_frame(1);
    CHECK(d1.x == Approx(std::sqrt(3.0) / 2.0).margin(kFloatRoundingTolerance));
    CHECK(d1.y == Approx(0.5).margin(kFloatRoundingTolerance));
    CHECK(light.direction_at_frame(0) == light.direction);
    // A whole number of turns later the light is back, however many frames that took.
    const glm::vec3 d = light.direction_at_frame(12 * 1000001);
    CHECK(d.x == Approx(1.0).margin(kFloatRoundingTolerance));
    CHECK(d.y == Approx(0.0).margin(kFloatRoundingTolerance));
}

TEST_CASE("tubes are expanded with the generator, in its order", "[scene]") {
    json j = minimal();
    j["smoke"].erase("particles");
    j["smoke"]["tubes"] = {{"count", 101}, {"seed", 18446744073709551615ull}, {"tube_radius", 0.5},
                           {"tube_length", 3}, {"separation", 0.75}, {"particle_radius", 0.1},
                           {"drift", {0, 0.01, 0}}, {"jitter_speed", 0.001}, {"spin_speed", 0.02},
                           {"growth", 0.001}, {"random_rotation", false}};
    const SceneDescription s = parse_scene(j.dump(), "tubes.json");
    REQUIRE(s.smoke.tubes.has_value());
    const TubeSettings& t = *s.smoke.tubes;
    CHECK(t.particles == 101u);
    CHECK(t.seed == 18446744073709551615ull);
    CHECK(t.tube_radius == 0.5f);
    CHECK(t.tube_length == 3.0f);
    CHECK(t.separation == 0.75f);
    CHECK(t.particle_radius == 0.1f);
    CHECK(t.drift == glm::vec3(0.0f, 0.01f, 0.0f));
    CHECK(t.jitter_speed == 0.001f);
    CHECK(t.spin_speed == 0.02f);
    CHECK(t.growth == 0.001f);
    CHECK_FALSE(t.random_rotation);
    const auto expected = generate_tubes(t);
    REQUIRE(s.smoke.particles.size() == expected.size());
    for (std::size_t i = 0; i < expected.size(); ++i) {
        CHECK(s.smoke.particles[i].center == expected[i].center);
        CHECK(s.smoke.particles[i].velocity == expected[i].velocity);
    }
}

TEST_CASE("an empty tubes object gives the thesis's defaults", "[scene]") {
    json j = minimal();
    j["smoke"].erase("particles");
    j["smoke"]["tubes"] = json::object();
    const SceneDescription s = parse_scene(j.dump(), "tubes.json");
    CHECK(s.smoke.particles.size() == 750u);
    CHECK(s.smoke.tubes->seed == TubeSettings{}.seed);
}

TEST_CASE("an empty particle list is valid", "[scene]") {
    json j = minimal();
    j["smoke"]["particles"] = json::array();
    const SceneDescription s = parse_scene(j.dump(), "empty.json");
    CHECK(s.smoke.particles.empty());
}

TEST_CASE("the default camera frames the smoke from the front, a little above", "[scene]") {
    for (const auto& [width, height] : {std::pair{512u, 512u}, std::pair{800u, 200u}, std::pair{200u, 800u}}) {
        json j = four_particles();
        j["camera"] = {{"width", width}, {"height", height}};
        const SceneDescription s = parse_scene(j.dump(), "camera.json");
        const CameraDescription& c = s.camera;
        const glm::dvec3 eye(c.position), forward = glm::normalize(glm::dvec3(c.look_at) - eye);
        CHECK(c.position.z > c.look_at.z);  // in front (+z)
        CHECK(c.position.y > c.look_at.y);  // above
        const glm::dvec3 right = glm::normalize(glm::cross(forward, glm::dvec3(c.up)));
        const glm::dvec3 up = glm::cross(right, forward);
        const double tan_v = std::tan(0.5 * c.fov_deg * 3.14159265358979323846 / 180.0);
        const double tan_h = tan_v * width / height;
        // Every particle's sphere is inside the view: its centre's projected offset plus its angular radius.
        for (const Particle& p : s.smoke.particles) {
            const glm::dvec3 d = glm::dvec3(p.center) - eye;
            const double depth = glm::dot(d, forward);
            REQUIRE(depth > p.radius);
            const double angular = std::asin(p.radius / glm::length(d));
            CHECK(std::atan(std::abs(glm::dot(d, right)) / depth) + angular < std::atan(tan_h));
            CHECK(std::atan(std::abs(glm::dot(d, up)) / depth) + angular < std::atan(tan_v));
        }
    }
}

TEST_CASE("a partial camera keeps the framing defaults for what it leaves out", "[scene]") {
    json j = minimal();
    j["camera"] = {{"look_at", {1, 2, 3}}};
    const SceneDescription s = parse_scene(j.dump(), "camera.json");
    CHECK(s.camera.look_at == glm::vec3(1.0f, 2.0f, 3.0f));
    json k = minimal();
    k.erase("camera");
    CHECK(s.camera.position == parse_scene(k.dump(), "camera.json").camera.position);
}

// ---- The shipped scenes ------------------------------------------------------------------------------

TEST_CASE("assets/scenes/minimal.json uses only the minimal form", "[scene]") {
    std::ifstream in(asset("minimal.json"));
    REQUIRE(in);
    const json j = json::parse(in);
    CHECK(j.size() == 3);
    CHECK(j["light"].size() == 1);
    CHECK(j["smoke"].size() == 1);
    CHECK(j["ground"].size() == 1);
    for (const json& p : j["smoke"]["particles"]) CHECK(p.size() == 2);
    const SceneDescription s = load_scene_file(asset("minimal.json"));
    CHECK(s.smoke.particles.size() == j["smoke"]["particles"].size());
    CHECK(s.ground->normal == glm::vec3(0.0f, 1.0f, 0.0f));
}

TEST_CASE("the thesis's two scenes: 750 particles over a red ground, lit from above / the right", "[scene]") {
    const SceneDescription above = load_scene_file(asset("two_tubes_above.json"));
    const SceneDescription right = load_scene_file(asset("two_tubes_right.json"));
    for (const SceneDescription* s : {&above, &right}) {
        INFO(s->source);
        CHECK(s->smoke.particles.size() == 750u);  // thesis 5.1
        CHECK(s->render.cutoff == 60u);
        CHECK(s->render.groups == 1u);
        REQUIRE(s->ground.has_value());
        CHECK(s->ground->normal == glm::vec3(0.0f, 1.0f, 0.0f));
        CHECK(s->ground->color.x > 2.0f * std::max(s->ground->color.y, s->ground->color.z));  // red
        // The ground lies under all of the smoke, and covers its footprint.
        const glm::vec3 lo = s->ground->corners[0], hi = s->ground->corners[2];
        for (const Particle& p : s->smoke.particles) {
            CHECK(p.center.y - p.radius > lo.y);
            CHECK(p.center.x > lo.x);
            CHECK(p.center.x < hi.x);
            CHECK(p.center.z > lo.z);
            CHECK(p.center.z < hi.z);
        }
    }
    CHECK(above.light.direction == glm::vec3(0.0f, 1.0f, 0.0f));
    CHECK(right.light.direction.x > 3.0f * right.light.direction.y);  // mostly from +x
    CHECK(right.light.direction.y > 0.0f);                            // grazing the ground, so it is lit
    CHECK(right.light.direction.z == 0.0f);
}

// ---- Errors: the message names the file and the JSON path --------------------------------------------

TEST_CASE("error: the example from the brief", "[scene]") {
    json j = four_particles();
    j["smoke"]["particles"][3]["radius"] = -1;
    CHECK(error_of(j.dump(), "scene.json") == "scene.json: /smoke/particles/3/radius: must be > 0 (got -1)");
}

TEST_CASE("error: radius zero", "[scene]") {
    json j = four_particles();
    j["smoke"]["particles"][1]["radius"] = 0.0;
    require_error(j, "/smoke/particles/1/radius", "must be > 0");
}

TEST_CASE("error: unknown keys, at the top and nested", "[scene]") {
    json j = minimal();
    j["colour"] = {1, 0, 0};
    require_error(j, "/colour", "unknown key");
    json k = minimal();
    k["smoke"]["particles"][0]["radious"] = 1;
    require_error(k, "/smoke/particles/0/radious", "unknown key");
    json t = minimal();
    t["smoke"].erase("particles");
    t["smoke"]["tubes"] = {{"cnt", 5}};
    require_error(t, "/smoke/tubes/cnt", "unknown key");
}

TEST_CASE("error: a key with / or ~ is escaped in the path", "[scene]") {
    json j = minimal();
    j["light"]["a/b~c"] = 1;
    require_error(j, "/light/a~1b~0c", "unknown key");
}

TEST_CASE("error: wrong types", "[scene]") {
    json a = minimal();
    a["smoke"]["particles"][0]["radius"] = "0.5";
    require_error(a, "/smoke/particles/0/radius", "must be a number (got a string, \"0.5\")");
    json b = minimal();
    b["smoke"]["particles"][1]["center"] = {1, 2};
    require_error(b, "/smoke/particles/1/center", "must be an array of 3 numbers");
    json c = minimal();
    c["light"]["direction"][2] = true;
    require_error(c, "/light/direction/2", "must be a number (got true)");
    json d = minimal();
    d["smoke"]["particles"] = json::parse("[[0, 0, 0]]");
    require_error(d, "/smoke/particles/0", "must be an object");
    json e = minimal();
    e["light"] = {0, 1, 0};
    require_error(e, "/light", "must be an object");
    json f = minimal();
    f["smoke"]["particles"] = json::object();
    require_error(f, "/smoke/particles", "must be an array of particles");
    json g = minimal();
    g["smoke"]["shape"] = 3;
    require_error(g, "/smoke/shape", "must be a string");
    json h = minimal();
    h["smoke"].erase("particles");
    h["smoke"]["tubes"] = {{"random_rotation", 1}};
    require_error(h, "/smoke/tubes/random_rotation", "must be true or false");
}

TEST_CASE("error: the document is not an object", "[scene]") {
    require_error(std::string("[1, 2, 3]"), "(document root)", "must be an object");
}

TEST_CASE("error: missing required fields", "[scene]") {
    json a = minimal();
    a.erase("light");
    require_error(a, "/light", "required key is missing");
    json b = minimal();
    b["light"].erase("direction");
    require_error(b, "/light/direction", "required key is missing");
    json c = minimal();
    c.erase("smoke");
    require_error(c, "/smoke", "required key is missing");
    json d = minimal();
    d["smoke"]["particles"][1].erase("center");
    require_error(d, "/smoke/particles/1/center", "required key is missing");
    json e = minimal();
    e["smoke"]["particles"][0].erase("radius");
    require_error(e, "/smoke/particles/0/radius", "required key is missing");
    json f = minimal();
    f["ground"].erase("corners");
    require_error(f, "/ground/corners", "required key is missing");
}

TEST_CASE("error: both or neither of particles and tubes", "[scene]") {
    json both = minimal();
    both["smoke"]["tubes"] = json::object();
    require_error(both, "/smoke", "exactly one");
    json neither = minimal();
    neither["smoke"].erase("particles");
    require_error(neither, "/smoke", "needs \"particles\"");
}

TEST_CASE("error: numbers beyond the double range (1e999 parses to inf)", "[scene]") {
    json j = minimal();
    j["smoke"]["particles"][1]["center"][0] = "@";
    require_error(with_literal(j, "1e999"), "/smoke/particles/1/center/0", "must be finite (got 1e999");
    require_error(with_literal(j, "-1e999"), "/smoke/particles/1/center/0", "must be finite (got -1e999");
    json k = minimal();
    k["smoke"]["sigma_t"] = "@";
    require_error(with_literal(k, "1E+400"), "/smoke/sigma_t", "must be finite (got 1E+400");
}

TEST_CASE("error: numbers beyond the float range", "[scene]") {
    json j = minimal();
    j["smoke"]["sigma_t"] = 1e39;
    require_error(j, "/smoke/sigma_t", "too large for single precision");
    json k = minimal();
    k["smoke"]["particles"][0]["radius"] = 1e-50;
    require_error(k, "/smoke/particles/0/radius", "too close to 0 for single precision");
}

TEST_CASE("error: NaN and Infinity are not JSON, and strings are not numbers", "[scene]") {
    json j = minimal();
    j["ambient"] = {0, 0, "@"};
    const std::string nan_text = error_of(with_literal(j, "NaN"));
    CHECK(nan_text.rfind("bad.json: malformed JSON at byte ", 0) == 0);
    const std::string inf_text = error_of(with_literal(j, "Infinity"));
    CHECK(inf_text.rfind("bad.json: malformed JSON at byte ", 0) == 0);
    j["ambient"][2] = "NaN";
    require_error(j, "/ambient/2", "must be a number (got a string, \"NaN\")");
}

TEST_CASE("error: a zero light direction", "[scene]") {
    json j = minimal();
    j["light"]["direction"] = {0, 0, 0};
    require_error(j, "/light/direction", "must not be the zero vector");
    j["light"]["direction"] = {0.0, -0.0, 0.0};
    require_error(j, "/light/direction", "must not be the zero vector");
}

TEST_CASE("error: a ground quad with zero area", "[scene]") {
    json j = minimal();
    j["ground"]["corners"] = {{1, 0, 1}, {1, 0, 1}, {1, 0, 1}, {1, 0, 1}};
    require_error(j, "/ground/corners", "degenerate quad");
    j["ground"]["corners"] = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};  // collinear
    require_error(j, "/ground/corners", "degenerate quad");
}

TEST_CASE("error: a ground quad that is not planar", "[scene]") {
    json j = minimal();
    j["ground"]["corners"][2] = {4, -0.5, 4};  // lifted by 0.5 on an 8-unit quad: far above 1e-4·8
    require_error(j, "/ground/corners", "not planar");
}

TEST_CASE("error: a ground quad that is not convex", "[scene]") {
    json bowtie = minimal();  // corners 2 and 3 swapped: the edges cross
    bowtie["ground"]["corners"] = {{-4, -1, -4}, {-4, -1, 4}, {4, -1, -4}, {4, -1, 4}};
    const std::string a = error_of(bowtie.dump());
    INFO(a);
    CHECK(a.rfind("bad.json: /ground/corners", 0) == 0);
    CHECK((a.find("not convex") != std::string::npos || a.find("degenerate") != std::string::npos));

    json dart = minimal();  // corner 3 pushed inside: a concave arrowhead
    dart["ground"]["corners"] = {{-4, -1, -4}, {-4, -1, 4}, {4, -1, 4}, {-2, -1, 2}};
    require_error(dart, "/ground/corners/3", "not convex");

    json triangle = minimal();  // corner 1 on the edge from corner 0 to corner 2
    triangle["ground"]["corners"] = {{-4, -1, -4}, {0, -1, 0}, {4, -1, 4}, {4, -1, -4}};
    require_error(triangle, "/ground/corners/1", "not convex");
}

TEST_CASE("error: a ground quad with the wrong number of corners", "[scene]") {
    json j = minimal();
    j["ground"]["corners"].erase(3);
    require_error(j, "/ground/corners", "must be an array of 4 points");
}

TEST_CASE("error: negative or zero where a positive value is needed", "[scene]") {
    json a = minimal();
    a["smoke"]["sigma_t"] = -0.5;
    require_error(a, "/smoke/sigma_t", "must be >= 0 (got -0.5)");
    json b = minimal();
    b["smoke"].erase("particles");
    b["smoke"]["tubes"] = {{"tube_radius", 0}};
    require_error(b, "/smoke/tubes/tube_radius", "must be > 0 (got 0)");
    json c = minimal();
    c["smoke"].erase("particles");
    c["smoke"]["tubes"] = {{"count", -5}};
    require_error(c, "/smoke/tubes/count", "(got -5)");
    json d = minimal();
    d["camera"] = {{"width", 0}};
    require_error(d, "/camera/width", "must be in [1, 16384] (got 0)");
    json e = minimal();
    e["render"] = {{"groups", 0}};
    require_error(e, "/render/groups", "(got 0)");
    json f = minimal();
    f["render"] = {{"frames", 0}};
    require_error(f, "/render/frames", "(got 0)");
    json g = minimal();
    g["ambient"] = {0.1, -0.1, 0.1};
    require_error(g, "/ambient/1", "must be >= 0");
    json h = minimal();
    h["light"]["color"] = {1, 1, -1};
    require_error(h, "/light/color/2", "must be >= 0");
    json i = minimal();
    i["render"] = {{"softness", -0.1}};
    require_error(i, "/render/softness", "must be >= 0");
}

TEST_CASE("error: values outside their interval", "[scene]") {
    json a = minimal();
    a["smoke"]["alpha"] = 1.5;
    require_error(a, "/smoke/alpha", "must be in [0, 1] (got 1.5)");
    json b = minimal();
    b["camera"] = {{"fov_deg", 180}};
    require_error(b, "/camera/fov_deg", "must be in (0, 180)");
    json c = minimal();
    c["render"] = {{"transmittance_threshold", 1}};
    require_error(c, "/render/transmittance_threshold", "must be in [0, 1)");
    json d = minimal();
    d["smoke"]["particles"][0]["growth"] = -1;
    require_error(d, "/smoke/particles/0/growth", "must be > -1");
}

TEST_CASE("error: render.spp outside [1, kMaxSpp] or not an integer", "[scene][spp]") {
    REQUIRE(kMaxSpp == 64);  // the messages below name the range
    json j = minimal();
    j["render"] = {{"spp", 0}};
    require_error(j, "/render/spp", "must be in [1, 64] (got 0)");
    j["render"] = {{"spp", 65}};
    require_error(j, "/render/spp", "must be in [1, 64] (got 65)");
    j["render"] = {{"spp", -4}};
    require_error(j, "/render/spp", "must be in [1, 64] (got -4)");
    j["render"] = {{"spp", 1.5}};
    require_error(j, "/render/spp", "must be an integer (got a number, 1.5)");
    j["render"] = {{"spp", "4"}};
    require_error(j, "/render/spp", "must be an integer (got a string, \"4\")");
    j["render"] = {{"spp", 64}};  // the bounds themselves are accepted
    CHECK(parse_scene(j.dump(), "ok.json").render.spp == 64u);
    j["render"] = {{"spp", 1}};
    CHECK(parse_scene(j.dump(), "ok.json").render.spp == 1u);
}

TEST_CASE("error: render.fps outside [1, kMaxSceneFps] or not an integer", "[scene][apng]") {
    REQUIRE(kMaxSceneFps == 60);  // the messages below name the range
    json j = minimal();
    j["render"] = {{"fps", 0}};
    require_error(j, "/render/fps", "must be in [1, 60] (got 0)");
    j["render"] = {{"fps", 61}};
    require_error(j, "/render/fps", "must be in [1, 60] (got 61)");
    j["render"] = {{"fps", 23.976}};
    require_error(j, "/render/fps", "must be an integer (got a number, 23.976)");
    j["render"] = {{"fps", "24"}};
    require_error(j, "/render/fps", "must be an integer (got a string, \"24\")");
    j["render"] = {{"fps", 60}};  // the bounds themselves are accepted
    CHECK(parse_scene(j.dump(), "ok.json").render.fps == 60u);
    j["render"] = {{"fps", 1}};
    CHECK(parse_scene(j.dump(), "ok.json").render.fps == 1u);
}

TEST_CASE("error: integers written as decimals", "[scene]") {
    json j = minimal();
    j["smoke"].erase("particles");
    j["smoke"]["tubes"] = {{"count", 750.0}};
    require_error(j, "/smoke/tubes/count", "must be an integer (got a number, 750.0)");
}

TEST_CASE("error: too many particles", "[scene]") {
    json j = minimal();
    j["smoke"].erase("particles");
    j["smoke"]["tubes"] = {{"count", 50000001}};
    require_error(j, "/smoke/tubes/count", "too many particles");
    j["smoke"]["tubes"] = {{"count", 18446744073709551615ull}};
    require_error(j, "/smoke/tubes/count", "too many particles");
}

TEST_CASE("error: an image too large", "[scene]") {
    json j = minimal();
    j["camera"] = {{"width", 16384}, {"height", 16384}};
    require_error(j, "/camera", "image too large");
}

TEST_CASE("error: unknown names for shape, kernel, mode and compositing", "[scene]") {
    json a = minimal();
    a["smoke"]["shape"] = "icosphere:5";
    require_error(a, "/smoke/shape", "unknown shape \"icosphere:5\"");
    json k = minimal();
    k["smoke"]["kernel"] = "cubic";
    require_error(k, "/smoke/kernel", "unknown kernel \"cubic\"");
    k["smoke"]["kernel"] = 2;
    require_error(k, "/smoke/kernel", "must be a string");
    json b = minimal();
    b["render"] = {{"mode", "simple_shadow"}};
    require_error(b, "/render/mode", "unknown mode");
    json c = minimal();
    c["render"] = {{"compositing", "under"}};
    require_error(c, "/render/compositing", "unknown compositing");
}

TEST_CASE("error: a degenerate camera", "[scene]") {
    json a = minimal();
    a["camera"] = {{"position", {1, 1, 1}}, {"look_at", {1, 1, 1}}};
    require_error(a, "/camera", "position and look_at are the same point");
    json b = minimal();
    b["camera"] = {{"position", {0, 5, 0}}, {"look_at", {0, 0, 0}}};  // default up (0,1,0) is parallel
    require_error(b, "/camera/up", "parallel to the view direction");
    json c = minimal();
    c["camera"] = {{"up", {0, 0, 0}}};
    require_error(c, "/camera/up", "must not be the zero vector");
}

TEST_CASE("error: duplicate keys", "[scene]") {
    const std::string text = R"({ "light": { "direction": [0, 1, 0] },
        "smoke": { "particles": [ { "center": [0, 0, 0], "radius": 1 },
                                  { "center": [0, 0, 0], "radius": 1, "radius": 2 } ] } })";
    require_error(text, "/smoke/particles/1/radius", "duplicate key");
    const std::string top = R"({ "light": { "direction": [0, 1, 0] }, "smoke": { "particles": [] },
        "light": { "direction": [1, 0, 0] } })";
    require_error(top, "/light", "duplicate key");
}

TEST_CASE("error: malformed JSON names the byte, line and column", "[scene]") {
    // Line 2 is ` "light": x }`: the invalid literal x is its 11th character, byte 2 + 11 = 13.
    const std::string message = error_of("{\n \"light\": x }");
    INFO(message);
    CHECK(message.rfind("bad.json: malformed JSON at byte 13, line 2, column 11: ", 0) == 0);
}

TEST_CASE("error: truncated JSON says the input ended", "[scene]") {
    const std::string text = std::string(kMinimal).substr(0, 60);
    const std::string message = error_of(text);
    INFO(message);
    CHECK(message.rfind("bad.json: malformed JSON at the end of the input (byte 61), line 2, column ", 0) == 0);
    CHECK(error_of("").rfind("bad.json: malformed JSON at the end of the input (byte 1), line 1, column 1", 0) == 0);
}

TEST_CASE("error: load_scene_file names the file when it cannot be read or is bad", "[scene]") {
    const auto dir = std::filesystem::temp_directory_path() / "smoketrace_test_scene_file";
    std::filesystem::create_directories(dir);
    const auto missing = dir / "does_not_exist.json";
    try {
        (void)load_scene_file(missing);
        FAIL("no error");
    } catch (const SceneFileError& e) {
        CHECK(std::string(e.what()).rfind(missing.string() + ": cannot open", 0) == 0);
    }
    CHECK_THROWS_AS(load_scene_file(dir), SceneFileError);

    const auto bad = dir / "bad_radius.json";
    {
        json j = minimal();
        j["smoke"]["particles"][0]["radius"] = -2;
        std::ofstream(bad) << j.dump(2);
    }
    try {
        (void)load_scene_file(bad);
        FAIL("no error");
    } catch (const SceneFileError& e) {
        CHECK(std::string(e.what()) == bad.string() + ": /smoke/particles/0/radius: must be > 0 (got -2)");
    }
    std::filesystem::remove_all(dir);
}

// ---- The field of view -------------------------------------------------------------------------------

TEST_CASE("error: a field of view too small for a usable camera names /camera/fov_deg", "[scene]") {
    // fov_deg 1e-20 used to pass the reader and then fail in the float camera (the default camera backed
    // off to ~1e22, where |look_at − position|² overflows), reported as "/camera/up: ... up is parallel to
    // the view direction". At 512 pixels high the smallest usable fov is 2·atan(2^-21·512) = 0.02798°.
    for (const double fov : {1e-20, 1e-6, 0.0279}) {
        for (const bool with_position : {false, true}) {
            json j = minimal();
            j["camera"] = {{"fov_deg", fov}};
            if (with_position) j["camera"]["position"] = {0, 0, 50};
            INFO("fov_deg " << fov << (with_position ? ", position given" : ""));
            require_error(j, "/camera/fov_deg", "too small for a usable camera");
            const std::string message = error_of(j.dump());
            CHECK(message.find("at 512 pixels high") != std::string::npos);
            CHECK(message.find("fov_deg must be at least 0.028") != std::string::npos);
            CHECK(message.find("/camera/up") == std::string::npos);
        }
    }
    // Just above the bound, and the bound grows with the height: 0.03 is fine at 512 pixels, not at 1024.
    json ok = minimal();
    ok["camera"] = {{"fov_deg", 0.03}};
    CHECK(error_of(ok.dump()) == "(no error)");
    ok["camera"]["height"] = 1024;
    require_error(ok, "/camera/fov_deg", "at 1024 pixels high");
    // One pixel high, a far smaller field of view still gives distinct rays (columns 2^-20 apart).
    json one_row = minimal();
    one_row["camera"] = {{"fov_deg", 1e-4}, {"width", 4}, {"height", 1}};
    const SceneDescription s = parse_scene(one_row.dump(), "one_row.json");
    CHECK_NOTHROW(Camera(s.camera.position, s.camera.look_at, s.camera.up, s.camera.fov_deg, 4, 1));
}

TEST_CASE("error: a field of view that backs the default camera beyond its limit names /camera/fov_deg", "[scene]") {
    // A particle of radius 1e15 at the origin, no camera position: the default camera stands
    // 1.1·1e15/sin(fov/2) away. 45° (the default) puts it at 2.9e15, 2° at 6.3e16 (accepted), 1° at
    // 1.26e17, beyond kMaxDefaultCameraCoordinate (1e17).
    json j = json::parse(R"({ "light": { "direction": [0, 1, 0] },
        "smoke": { "particles": [ { "center": [0, 0, 0], "radius": 1e15 } ] } })");
    CHECK(error_of(j.dump()) == "(no error)");
    j["camera"] = {{"fov_deg", 2}};
    const SceneDescription two = parse_scene(j.dump(), "two.json");
    const double distance = 1.1e15 / std::sin(1.0 * 3.14159265358979 / 180.0);
    CHECK(glm::length(glm::dvec3(two.camera.position)) == Approx(distance).epsilon(1e-6));
    j["camera"] = {{"fov_deg", 1}};
    require_error(j, "/camera/fov_deg", "pushes the default camera beyond the coordinate limit of 1e+17");
    const std::string message = error_of(j.dump());
    CHECK(message.find("it would stand at (0, 4.31e+16, 1.18e+17)") != std::string::npos);
    CHECK(message.find("give camera.position, or a larger fov_deg") != std::string::npos);
    // With a position the default camera is not used: the same field of view is fine.
    j["camera"]["position"] = {0, 0, 1e15};
    CHECK(error_of(j.dump()) == "(no error)");
    // Without fov_deg, a tall narrow image backs the default camera off (the narrower angle frames the
    // smoke): named at /camera.
    json narrow = json::parse(R"({ "light": { "direction": [0, 1, 0] },
        "smoke": { "particles": [ { "center": [0, 0, 0], "radius": 1e15 } ] },
        "camera": { "width": 1, "height": 4096 } })");
    require_error(narrow, "/camera", "the default camera would stand beyond the coordinate limit of 1e+17");
}

TEST_CASE("error: the command line shows the field-of-view message with the file and the path", "[scene][cli]") {
    smoketrace::test::TempDir dir;
    json tiny = minimal();
    tiny["camera"] = {{"fov_deg", 1e-20}};
    const auto tiny_path = dir.write("tiny_fov.json", tiny.dump());
    const auto r = smoketrace::test::run_cli("depths " + tiny_path.string() + " -o " + (dir.path / "d.csv").string());
    INFO(r.err);
    CHECK(r.exit_code == 1);
    CHECK(r.err.rfind("smoketrace depths: " + tiny_path.string() +
                          ": /camera/fov_deg: too small for a usable camera (got 1e-20)",
                      0) == 0);
    CHECK(!std::filesystem::exists(dir.path / "d.csv"));

    json far = json::parse(R"({ "light": { "direction": [0, 1, 0] },
        "smoke": { "particles": [ { "center": [0, 0, 0], "radius": 1e15 } ] }, "camera": { "fov_deg": 1 } })");
    const auto far_path = dir.write("far.json", far.dump());
    const auto f = smoketrace::test::run_cli("render " + far_path.string() + " -o " + (dir.path / "f.png").string());
    INFO(f.err);
    CHECK(f.exit_code == 1);
    CHECK(f.err.rfind("smoketrace render: " + far_path.string() +
                          ": /camera/fov_deg: pushes the default camera beyond the coordinate limit of 1e+17",
                      0) == 0);
    CHECK(!std::filesystem::exists(dir.path / "f.png"));
}
