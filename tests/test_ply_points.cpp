// Particles from a PLY point cloud (ply_points.hpp, "particles": "cloud.ply" in a scene file): both byte
// orders, float and double, ascii, extra properties and elements, velocity; the same particles and the same
// depths as the same values in a JSON list; every error names the PLY file and what is wrong.
#include "support/cli_runner.hpp"

#include <smoketrace/io/ply_points.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/smoke/tube_generator.hpp>

#include <catch2/catch.hpp>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iterator>
#include <limits>
#include <string>
#include <tuple>
#include <vector>

using namespace smoketrace;
using test::TempDir;

namespace {

struct Layout {
    std::string format = "binary_little_endian";
    bool doubles = false;
    bool extra = false;     // an extra property before x, one between, and an element before the vertices
    bool velocity = false;
};

template <class T>
void put(std::string& out, T v, bool big_endian) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &v, sizeof(T));
    if (big_endian) std::reverse(bytes, bytes + sizeof(T));
    out.append(bytes, sizeof(T));
}

std::string shortest(double v) {
    char buffer[64];
    return std::string(buffer, std::to_chars(buffer, buffer + sizeof buffer, v).ptr);
}

// A PLY file of `particles` (centre, radius, velocity) in `layout`.
std::string ply_file(const std::vector<Particle>& particles, const Layout& layout) {
    const std::string type = layout.doubles ? "double" : "float";
    std::string out = "ply\r\nformat " + layout.format + " 1.0\ncomment written by test_ply_points\n";
    if (layout.extra) out += "element camera 2\nproperty uchar view\nproperty int id\n";
    out += "element vertex " + std::to_string(particles.size()) + "\n";
    if (layout.extra) out += "property uchar red\n";
    out += "property " + type + " x\nproperty " + type + " y\nproperty " + type + " z\n";
    if (layout.extra) out += "property ushort age\n";
    out += "property " + type + " radius\n";
    if (layout.velocity) out += "property " + type + " vx\nproperty " + type + " vy\nproperty " + type + " vz\n";
    if (layout.extra) out += "element face 0\nproperty list uchar int vertex_indices\n";
    out += "end_header\n";
    const bool ascii = layout.format == "ascii", big = layout.format == "binary_big_endian";
    if (layout.extra) {
        for (int c = 0; c < 2; ++c) {
            if (ascii) out += std::to_string(c) + " " + std::to_string(1000 + c) + "\n";
            else {
                put<std::uint8_t>(out, std::uint8_t(c), big);
                put<std::int32_t>(out, 1000 + c, big);
            }
        }
    }
    for (const Particle& p : particles) {
        std::vector<float> values = {p.center.x, p.center.y, p.center.z, p.radius};
        if (layout.velocity) values.insert(values.end(), {p.velocity.x, p.velocity.y, p.velocity.z});
        if (ascii) {
            if (layout.extra) out += "255 ";
            for (std::size_t i = 0; i < values.size(); ++i) {
                if (layout.extra && i == 3) out += "7 ";
                out += shortest(double(values[i])) + " ";
            }
            out += "\n";
            continue;
        }
        if (layout.extra) put<std::uint8_t>(out, 200, big);
        for (std::size_t i = 0; i < values.size(); ++i) {
            if (layout.extra && i == 3) put<std::uint16_t>(out, 9, big);
            if (layout.doubles) put<double>(out, double(values[i]), big);
            else put<float>(out, values[i], big);
        }
    }
    return out;
}

const char* const kSceneHead = R"({ "light": { "direction": [0.3, 1, 0.2] }, "smoke": { "particles": )";
const char* const kSceneTail = R"( }, "ground": { "corners": [[-5,-3,-5], [-5,-3,5], [5,-3,5], [5,-3,-5]] } })";

// The same particles as a JSON list: each float as the shortest decimal of its double, which reads back as
// exactly that float, so the default origin (near the first particle) keeps them as the PLY file does.
std::string json_list(const std::vector<Particle>& particles, bool velocity) {
    std::string out = "[";
    for (std::size_t i = 0; i < particles.size(); ++i) {
        const Particle& p = particles[i];
        out += std::string(i ? "," : "") + "{\"center\": [" + shortest(double(p.center.x)) + "," +
               shortest(double(p.center.y)) + "," + shortest(double(p.center.z)) + "], \"radius\": " +
               shortest(double(p.radius));
        if (velocity)
            out += ", \"velocity\": [" + shortest(double(p.velocity.x)) + "," + shortest(double(p.velocity.y)) + "," +
                   shortest(double(p.velocity.z)) + "]";
        out += "}";
    }
    return out + "]";
}

std::vector<Particle> some_particles(std::uint32_t count) {
    TubeSettings t;
    t.particles = count;
    t.particle_radius = 0.2f;
    t.center = {3.0f, 2.5f, -1.0f};  // not at 0: the default origin moves
    t.jitter_speed = 0.01f;
    return generate_tubes(t);
}

void require_same_particles(const SceneDescription& a, const SceneDescription& b, bool velocity) {
    REQUIRE(a.smoke.particles.size() == b.smoke.particles.size());
    CHECK(std::memcmp(&a.origin, &b.origin, sizeof a.origin) == 0);
    for (std::size_t i = 0; i < a.smoke.particles.size(); ++i) {
        const Particle &p = a.smoke.particles[i], &q = b.smoke.particles[i];
        INFO("particle " << i);
        REQUIRE(std::memcmp(&p.center, &q.center, sizeof p.center) == 0);
        REQUIRE(std::bit_cast<std::uint32_t>(p.radius) == std::bit_cast<std::uint32_t>(q.radius));
        if (velocity) REQUIRE(std::memcmp(&p.velocity, &q.velocity, sizeof p.velocity) == 0);
        else REQUIRE(p.velocity == glm::vec3(0.0f));
    }
}

std::string scene_error(const TempDir& dir, const std::string& ply_text, const std::string& ply_name = "c.ply") {
    dir.write(ply_name, ply_text);
    const auto scene = dir.write("s.json", kSceneHead + ("\"" + ply_name + "\"") + kSceneTail);
    try {
        (void)load_scene_file(scene);
    } catch (const SceneFileError& e) {
        return e.what();
    }
    return "(no error)";
}

}  // namespace

TEST_CASE("PLY particles: both byte orders, float and double, ascii, extra properties, velocity", "[ply]") {
    const std::vector<Particle> particles = some_particles(301);
    TempDir dir;
    for (const char* format : {"binary_little_endian", "binary_big_endian", "ascii"}) {
        for (bool doubles : {false, true}) {
            for (bool extra : {false, true}) {
                for (bool velocity : {false, true}) {
                    INFO(format << (doubles ? " double" : " float") << (extra ? " extra" : "")
                                << (velocity ? " velocity" : ""));
                    dir.write("cloud.ply", ply_file(particles, {format, doubles, extra, velocity}));
                    const auto ply_scene =
                        dir.write("ply.json", kSceneHead + std::string("\"cloud.ply\"") + kSceneTail);
                    const auto json_scene =
                        dir.write("list.json", kSceneHead + json_list(particles, velocity) + kSceneTail);
                    require_same_particles(load_scene_file(ply_scene), load_scene_file(json_scene), velocity);
                }
            }
        }
    }
}

TEST_CASE("PLY particles: the path is relative to the scene file's folder", "[ply]") {
    TempDir dir;
    std::filesystem::create_directories(dir.path / "frames" / "clouds");
    std::ofstream(dir.path / "frames" / "clouds" / "f1.ply", std::ios::binary) << ply_file(some_particles(5), {});
    const auto scene = dir.write("frames/s.json", kSceneHead + std::string("\"clouds/f1.ply\"") + kSceneTail);
    CHECK(load_scene_file(scene).smoke.particles.size() == 5);
    // From another working directory, and with a relative scene path.
    const auto cwd = std::filesystem::current_path();
    std::filesystem::current_path(dir.path);
    CHECK(load_scene_file("frames/s.json").smoke.particles.size() == 5);
    std::filesystem::current_path(cwd);
}

TEST_CASE("PLY particles: every problem names the file and what is wrong", "[ply]") {
    TempDir dir;
    const std::vector<Particle> three = some_particles(3);
    const std::string good = ply_file(three, {});
    const std::string ply = (dir.path / "c.ply").string();
    auto with_header_line = [&](const std::string& from, const std::string& to) {
        std::string text = good;
        return text.replace(text.find(from), from.size(), to);
    };
    struct Case {
        std::string text, expected;
    };
    std::vector<Case> cases = {
        {"PLY\n", ply + ": not a PLY file"},
        {with_header_line("binary_little_endian", "binary_middle_endian"),
         ply + ": unsupported format \"binary_middle_endian\""},
        {with_header_line("property float radius\n", ""), ply + ": element vertex has no property radius"},
        {with_header_line("property float radius\n", "property float radius\nproperty float vx\n"),
         ply + ": element vertex has only part of a velocity"},
        {with_header_line("element vertex 3", "element points 3"), ply + ": no element vertex"},
        {with_header_line("property float radius\n", "property float radius\nproperty list uchar int n\n"),
         ply + ": element vertex: list properties are not supported"},
        {with_header_line("property float radius\n", "property quad radius\n"),
         ply + ": element vertex, property radius: unknown type \"quad\""},
        {good.substr(0, good.size() - 5),
         ply + ": truncated: the header declares 3 vertices, the data ends in vertex 2"},
        {good.substr(0, good.find("end_header")), ply + ": truncated header"},
        {with_header_line("element vertex 3", "element vertex 60000000"),
         "/smoke/particles: " + ply + ": element vertex: too many particles"},
    };
    // Values: through the scene file's checks, naming the vertex and the property.
    std::vector<Particle> bad = three;
    bad[1].radius = -1.0f;
    cases.push_back(
        {ply_file(bad, {}), "/smoke/particles: " + ply + ": vertex 1, property radius: must be > 0 (got -1)"});
    bad = three;
    bad[2].center.y = std::numeric_limits<float>::quiet_NaN();
    cases.push_back({ply_file(bad, {}), ": vertex 2, property y: must be finite (got nan)"});
    bad = three;
    bad[0].velocity.z = -std::numeric_limits<float>::infinity();
    cases.push_back({ply_file(bad, {"binary_big_endian", false, false, true}),
                     ": vertex 0, property vz: must be finite (got -inf)"});
    bad = three;
    bad[1].radius = 1e-40f;
    cases.push_back({ply_file(bad, {}), ": vertex 1, property radius: must be at least 1.1754944e-38"});
    bad = three;
    bad[0].center.x = 3e15f;
    cases.push_back({ply_file(bad, {"ascii"}), ": vertex 0, property x: must be in [-1e+15, 1e+15]"});
    cases.push_back(
        {with_header_line("format binary_little_endian", "format ascii"), ": vertex 0, property x: not a number"});
    for (const Case& c : cases) {
        const std::string message = scene_error(dir, c.text);
        INFO("message: " << message);
        CHECK(message.rfind((dir.path / "s.json").string() + ": /smoke/particles: ", 0) == 0);
        CHECK(message.find(c.expected) != std::string::npos);
    }
    // Motion beyond the coordinate range within render.frames: the vertex, not a JSON index it never had.
    bad = three;
    bad[1].center.x = 9e14f;
    bad[1].velocity.x = 1e14f;
    dir.write("c.ply", ply_file(bad, {"binary_little_endian", false, false, true}));
    const auto moving = dir.write("m.json", R"({ "light": { "direction": [0.3, 1, 0.2] }, "render": { "frames": 3 },
        "smoke": { "particles": "c.ply" } })");
    CHECK_THROWS_WITH(load_scene_file(moving),
                      Catch::StartsWith(moving.string() + ": /smoke/particles: " + ply +
                                        ": vertex 1: moves beyond the coordinate range +-1e+15 within 3 frames"));
    // A file that is not there, and one that is not a regular file.
    const auto scene = dir.write("s.json", kSceneHead + std::string("\"missing.ply\"") + kSceneTail);
    CHECK_THROWS_WITH(load_scene_file(scene), Catch::Contains("missing.ply: cannot open the file for reading"));
    const auto folder = dir.write("f.json", kSceneHead + std::string("\".\"") + kSceneTail);
    CHECK_THROWS_WITH(load_scene_file(folder), Catch::Contains(": is not a regular file"));
}

// A reader whose constructor refuses the header (it throws) must close the file it opened: a program that
// reads many clouds, or a fuzzer, would otherwise run out of descriptors (the fuzzer found this one).
TEST_CASE("PLY particles: a refused header leaves no file open", "[ply]") {
    TempDir dir;
    const auto open_descriptors = [] {
        return std::distance(std::filesystem::directory_iterator("/proc/self/fd"), {});
    };
    const std::string bad = (dir.path / "bad.ply").string();
    std::FILE* f = std::fopen(bad.c_str(), "wb");
    REQUIRE(f);
    std::fputs("ply\nformat binary_middle_endian 1.0\nend_header\n", f);
    std::fclose(f);
    const auto before = open_descriptors();
    for (int i = 0; i < 64; ++i) CHECK_THROWS_AS(PlyPointReader(bad, "bad.ply"), PlyError);
    CHECK(open_descriptors() == before);
}

TEST_CASE("PLY particles: the same depths as the same particles in JSON (smoketrace depths)", "[ply][cli]") {
    const std::vector<Particle> particles = some_particles(400);
    TempDir dir;
    dir.write("cloud.ply", ply_file(particles, {"binary_big_endian", true, true, false}));
    const auto ply_scene = dir.write("ply.json", kSceneHead + std::string("\"cloud.ply\"") + kSceneTail);
    const auto json_scene = dir.write("list.json", kSceneHead + json_list(particles, false) + kSceneTail);
    REQUIRE(test::run_cli("depths " + ply_scene.string() + " -o " + (dir.path / "ply.csv").string()).exit_code == 0);
    REQUIRE(test::run_cli("depths " + json_scene.string() + " -o " + (dir.path / "list.csv").string()).exit_code == 0);
    const std::string csv = test::file_bytes(dir.path / "ply.csv");
    CHECK(std::count(csv.begin(), csv.end(), '\n') == 401);
    CHECK(csv.find(",ok\n") != std::string::npos);
    CHECK(csv == test::file_bytes(dir.path / "list.csv"));
}

TEST_CASE("PLY particles: header values that overflow, a second vertex element, trailing data and ascii values "
          "out of their type's range are refused", "[ply][hostile]") {
    TempDir dir;
    const std::vector<Particle> three = some_particles(3);
    const std::string good = ply_file(three, {});
    const std::string ascii = ply_file(three, {"ascii"});
    const std::string ply = (dir.path / "c.ply").string();
    auto replaced = [](std::string text, const std::string& from, const std::string& to) {
        REQUIRE(text.find(from) != std::string::npos);
        return text.replace(text.find(from), from.size(), to);
    };
    // An ascii cloud of two particles, the first one's x and radius as given, of the types given.
    auto hand_made = [](const std::string& x_type, const std::string& x, const std::string& radius_type,
                        const std::string& radius) {
        return "ply\nformat ascii 1.0\nelement vertex 2\nproperty " + x_type + " x\nproperty float y\n"
               "property float z\nproperty " + radius_type + " radius\nend_header\n" + x + " 0 0 " + radius +
               "\n1 0 0 1\n";
    };
    struct Case {
        std::string name, text, expected;
    };
    const std::vector<Case> cases = {
        // 2^62 elements of 4 bytes before the vertices: 2^64 bytes, which wrapped to a skip of 0, so the
        // vertices were read as if the element were not there.
        {"a skip that wraps to 0",
         replaced(good, "element vertex", "element junk 4611686018427387904\nproperty float a\nelement vertex"),
         ply + ": the elements before vertex end, by the header's counts, beyond byte 2^64, past the end of the file"},
        // (2^61 - 1) elements of 8 bytes: 2^64 - 8, a seek of -8 bytes, back into "end_header\n", whose text
        // was read as vertex 0.
        {"a skip that seeks backwards",
         replaced(good, "element vertex",
                  "element junk 2305843009213693951\nproperty float a\nproperty float b\nelement vertex"),
         ply + ": the elements before vertex end, by the header's counts, beyond byte 2^64"},
        {"a skipped element whose data is not there",
         replaced(good, "element vertex", "element junk 1000\nproperty float a\nelement vertex"),
         ply + ": the elements before vertex end, by the header's counts, at byte "},
        {"a second vertex element", replaced(good, "end_header", "element vertex 1\nproperty float x\nend_header"),
         ply + ": element vertex appears twice in the header"},
        {"trailing bytes (binary)", good + "garbage",
         ply + ": the header's elements end at byte " + std::to_string(good.size()) + ", but the file has " +
             std::to_string(good.size() + 7) + " bytes: 7 bytes of trailing data"},
        {"a vertex count one short (binary)", replaced(good, "element vertex 3", "element vertex 2"),
         ": 16 bytes of trailing data"},
        {"a fixed-size element after vertex that is missing",
         replaced(good, "end_header", "element extra 5\nproperty float q\nend_header"),
         ply + ": truncated: the elements after vertex end, by the header's counts, at byte"},
        {"a vertex count one short (ascii)", replaced(ascii, "element vertex 3", "element vertex 2"),
         ply + ": after the last vertex the file has 1 more non-blank lines, where the header's elements after "
               "vertex give 0"},
        {"trailing text (ascii)", ascii + "42\n", "after the last vertex the file has 1 more non-blank lines"},
        // Refused at the first read, before the scene file reserves memory for the count.
        {"a vertex count the text cannot hold (ascii)", hand_made("float", "0", "float", "1").replace(
                                                            std::strlen("ply\nformat ascii 1.0\nelement vertex "), 1, "9"),
         ply + ": truncated: the header declares 9 vertices of 4 values, more than the 16 bytes after it can hold as "
               "text"},
        {"a uchar radius of 300 (ascii)", hand_made("float", "0", "uchar", "300"),
         ply + ": vertex 0, property radius: out of range for uchar (0 to 255) (got \"300\")"},
        {"a uchar radius of 0.5 (ascii)", hand_made("float", "0", "uchar", "0.5"),
         ply + ": vertex 0, property radius: not a whole number, as its integer type needs (got \"0.5\")"},
        {"a short x of -40000 (ascii)", hand_made("short", "-40000", "float", "1"),
         ply + ": vertex 0, property x: out of range for short (-32768 to 32767) (got \"-40000\")"},
        {"a float x beyond FLT_MAX (ascii)", hand_made("float", "1e39", "float", "1"),
         ply + ": vertex 0, property x: out of range for float (got \"1e39\")"},
    };
    for (const Case& c : cases) {
        INFO(c.name);
        const std::string message = scene_error(dir, c.text);
        INFO("message: " << message);
        CHECK(message.rfind((dir.path / "s.json").string() + ": /smoke/particles: ", 0) == 0);
        CHECK(message.find(c.expected) != std::string::npos);
    }
    // A header of endless comment lines ends at the limit, not at the end of the file.
    std::string comments;
    while (comments.size() <= kMaxPlyHeaderBytes) comments += "comment " + std::string(1000, 'x') + "\n";
    CHECK_THAT(scene_error(dir, replaced(good, "end_header", comments + "end_header")),
               Catch::Contains(ply + ": the header is longer than 1048576 bytes"));
    // The valid neighbours of those files still load: an ascii uchar radius of 255, a short x of -32768, an
    // element after vertex whose data is there, a header just under the limit.
    const auto scene = dir.write("s.json", kSceneHead + std::string("\"c.ply\"") + kSceneTail);
    dir.write("c.ply", hand_made("short", "-32768", "uchar", "255"));
    const SceneDescription extremes = load_scene_file(scene);
    REQUIRE(extremes.smoke.particles.size() == 2);
    CHECK(extremes.smoke.particles[0].radius == 255.0f);
    CHECK(double(extremes.smoke.particles[0].center.x) + extremes.origin.x == -32768.0);
    dir.write("c.ply",
              replaced(good, "end_header", "element extra 2\nproperty float q\nend_header") + std::string(8, '\0'));
    CHECK(load_scene_file(scene).smoke.particles.size() == 3);
    std::string filler;
    while (good.size() + filler.size() + 1000 < kMaxPlyHeaderBytes) filler += "comment " + std::string(990, 'y') + "\n";
    dir.write("c.ply", replaced(good, "end_header", filler + "end_header"));
    CHECK(load_scene_file(scene).smoke.particles.size() == 3);
}

namespace {

// The scene read with `threads` threads at most (a TBB arena of that size), up to kMostThreads whatever the
// machine's core count: TBB's limit is raised to it for the read, where fewer cores would have it lower.
constexpr int kMostThreads = 4;
SceneDescription load_with_threads(const std::filesystem::path& scene, int threads) {
    const tbb::global_control most(tbb::global_control::max_allowed_parallelism, kMostThreads);
    SceneDescription loaded;
    tbb::task_arena(threads).execute([&] { loaded = load_scene_file(scene); });
    return loaded;
}

std::string error_with_threads(const std::filesystem::path& scene, int threads) {
    try {
        (void)load_with_threads(scene, threads);
    } catch (const SceneFileError& e) {
        return e.what();
    }
    return "(no error)";
}

std::size_t piece_count(const std::filesystem::path& ply) {
    PlyPointReader reader(ply, "cloud.ply");
    return reader.pieces().size();
}

// An ascii PLY of `particles` (x y z radius) whose values are separated by every kind of white space in
// turn, so that vertices begin and end anywhere in a line, and a vertex's values span lines.
std::string ragged_ascii(const std::vector<Particle>& particles) {
    std::string out = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(particles.size()) +
                      "\nproperty float x\nproperty float y\nproperty float z\nproperty float radius\nend_header\n";
    constexpr const char* kSeparators[] = {" ", "\t", "\n", "  ", "\r\n", " \n\t", "\v", "\f", " "};
    std::size_t n = 0;
    for (const Particle& p : particles)
        for (float v : {p.center.x, p.center.y, p.center.z, p.radius})
            out += shortest(double(v)) + kSeparators[n++ % std::size(kSeparators)];
    return out + "\n";
}

}  // namespace

TEST_CASE("PLY particles: a cloud of many pieces gives the same particles at any thread count", "[ply]") {
    const std::vector<Particle> particles = some_particles(80000);
    TempDir dir;
    const auto ply_scene = dir.write("ply.json", kSceneHead + std::string("\"cloud.ply\"") + kSceneTail);
    struct Cloud {
        const char* name;
        std::string text;
        bool velocity;
    };
    const Cloud clouds[] = {
        {"binary little-endian floats, velocity", ply_file(particles, {"binary_little_endian", false, false, true}),
         true},
        {"binary big-endian doubles, extra properties and elements",
         ply_file(particles, {"binary_big_endian", true, true, false}), false},
        {"ascii, extra properties and elements, velocity", ply_file(particles, {"ascii", false, true, true}), true},
        {"ascii, vertices across lines", ragged_ascii(particles), false},
    };
    for (const Cloud& cloud : clouds) {
        INFO(cloud.name);
        dir.write("cloud.ply", cloud.text);
        REQUIRE(piece_count(dir.path / "cloud.ply") >= 8);
        const SceneDescription one = load_with_threads(ply_scene, 1);
        // The reference: the same particles as a JSON list.
        const auto json_scene = dir.write("list.json", kSceneHead + json_list(particles, cloud.velocity) + kSceneTail);
        require_same_particles(one, load_scene_file(json_scene), cloud.velocity);
        for (int threads : {2, kMostThreads}) {
            INFO(threads << " threads");
            const SceneDescription more = load_with_threads(ply_scene, threads);
            require_same_particles(one, more, cloud.velocity);
            // The default camera, which frames every particle, too.
            CHECK(std::memcmp(&one.camera, &more.camera, sizeof one.camera) == 0);
        }
    }
}

TEST_CASE("PLY particles: in a cloud of many pieces the first problem in the file is reported, at any thread "
          "count", "[ply]") {
    TempDir dir;
    // Binary: 200000 vertices of 16 bytes, 13 pieces; ascii: 60000 lines of some 45 bytes, 10 pieces.
    const std::vector<Particle> particles = some_particles(200000);
    const std::vector<Particle> ascii_particles(particles.begin(), particles.begin() + 60000);
    const std::string ply = (dir.path / "c.ply").string();
    const auto scene = dir.write("s.json", kSceneHead + std::string("\"c.ply\"") + kSceneTail);
    // An ascii cloud of `ascii_particles` with the values `changes` gives (vertex, value index, text) in place.
    auto ascii_with = [&](const std::vector<std::tuple<std::size_t, int, std::string>>& changes) {
        std::string out = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(ascii_particles.size()) +
                          "\nproperty float x\nproperty float y\nproperty float z\nproperty uchar id\n"
                          "property float radius\nend_header\n";
        for (std::size_t i = 0; i < ascii_particles.size(); ++i) {
            const Particle& p = ascii_particles[i];
            std::string values[5] = {shortest(double(p.center.x)), shortest(double(p.center.y)),
                                     shortest(double(p.center.z)), "7", shortest(double(p.radius))};
            for (const auto& [vertex, index, text] : changes)
                if (vertex == i) values[index] = text;
            out += values[0] + " " + values[1] + " " + values[2] + " " + values[3] + " " + values[4] + "\n";
        }
        return out;
    };
    std::vector<Particle> late = particles, two = particles;
    late[190000].radius = -1.0f;
    two[30000].center.y = std::numeric_limits<float>::quiet_NaN();
    two[170000].radius = -1.0f;
    const std::string ascii = ascii_with({});
    struct Case {
        std::string name, text, expected;
    };
    const std::vector<Case> cases = {
        {"a value in a late piece", ply_file(late, {}), ply + ": vertex 190000, property radius: must be > 0 (got -1)"},
        {"values in two pieces", ply_file(two, {}), ply + ": vertex 30000, property y: must be finite (got nan)"},
        {"a value the reader refuses after one the scene refuses", ascii_with({{20000, 4, "-1"}, {50000, 0, "abc"}}),
         ply + ": vertex 20000, property radius: must be > 0 (got -1)"},
        {"a value the scene refuses after one the reader refuses", ascii_with({{20000, 0, "abc"}, {50000, 4, "-1"}}),
         ply + ": vertex 20000, property x: not a number (got \"abc\")"},
        // In one piece, and one batch of the reader: the vertex first in the file, not the kind of problem.
        {"a value the reader refuses just after one the scene refuses", ascii_with({{5, 4, "-1"}, {8, 1, "abc"}}),
         ply + ": vertex 5, property radius: must be > 0 (got -1)"},
        {"the data ends in a late piece", ascii.substr(0, ascii.size() - 1000),
         ply + ": truncated: the header declares 60000 vertices, the data ends in vertex "},
        {"the data ends after a value the reader refuses",
         ascii_with({{30000, 2, "1e99"}}).substr(0, ascii.size() * 3 / 4),
         ply + ": vertex 30000, property z: out of range for float (got \"1e99\")"},
        {"trailing data after a late piece", ascii + "1 2 3\n",
         ply + ": after the last vertex the file has 1 more non-blank lines, where the header's elements after "
               "vertex give 0"},
    };
    for (const Case& c : cases) {
        INFO(c.name);
        dir.write("c.ply", c.text);
        REQUIRE(piece_count(dir.path / "c.ply") >= 8);
        const std::string serial = error_with_threads(scene, 1);
        INFO("message: " << serial);
        CHECK(serial.rfind(scene.string() + ": /smoke/particles: " + ply, 0) == 0);
        CHECK(serial.find(c.expected) != std::string::npos);
        for (int threads : {2, kMostThreads}) CHECK(error_with_threads(scene, threads) == serial);
    }
}

TEST_CASE("PLY particles: a piece ends a batch before a vertex it cannot read, and refuses it at the next read",
          "[ply]") {
    TempDir dir;
    std::string text = ply_file(some_particles(20), {"ascii"});
    // Vertex 5's y: the sixth line of the vertices.
    std::size_t at = text.find("end_header\n") + 11;
    for (int line = 0; line < 5; ++line) at = text.find('\n', at) + 1;
    at = text.find(' ', at) + 1;
    text.replace(at, text.find(' ', at) - at, "0x1p3");
    const auto path = dir.write("c.ply", text);
    PlyPointReader reader(path, "c.ply");
    const std::vector<PlyPiece> pieces = reader.pieces();
    REQUIRE(pieces.size() == 1);
    PlyPointReader::PieceReader piece(reader);
    piece.start(pieces[0]);
    std::vector<PlyPoint> batch(7);
    CHECK(piece.read(batch) == 5);
    CHECK_THROWS_WITH(piece.read(batch), "c.ply: vertex 5, property y: not a number (got \"0x1p3\")");
}

TEST_CASE("PLY particles: an ascii value longer than the reader's buffer", "[ply]") {
    TempDir dir;
    // 1.000…0 with more zeros than a piece or a read holds: a valid float, so the value must be read whole.
    const std::string long_one = "1." + std::string(2 * kPlyPieceBytes, '0');
    const auto path = dir.write("c.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                         "property float z\nproperty float radius\nend_header\n0 0 0 " + long_one +
                                         "\n" + long_one + " 2 3 0.5\n4 " + long_one + " 6 0.25\n");
    const auto scene = dir.write("s.json", kSceneHead + std::string("\"c.ply\"") + kSceneTail);
    REQUIRE(piece_count(path) == 3);
    for (int threads : {1, 2}) {
        const SceneDescription s = load_with_threads(scene, threads);
        REQUIRE(s.smoke.particles.size() == 3);
        CHECK(s.smoke.particles[0].radius == 1.0f);
        CHECK(double(s.smoke.particles[1].center.x) + s.origin.x == 1.0);
        CHECK(double(s.smoke.particles[2].center.y) + s.origin.y == 1.0);
        CHECK(s.smoke.particles[2].radius == 0.25f);
    }
}
