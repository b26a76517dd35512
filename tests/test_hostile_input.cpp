// Hostile input (issue 7): what tests/test_scene_file.cpp, test_cli.cpp, test_png_io.cpp and test_sixway.cpp
// did not already cover. Every case: a message naming the file, the flag or the JSON path and the problem, a
// non-zero exit code, no output file left behind (no temporary file either), no crash.
//  * scene files: absurd nesting, particle counts beyond what this machine's memory holds (generator
//    counts and long particle lists, refused before anything that large is built), coordinates and
//    colours whose derived values would overflow float, motion that leaves the coordinate range, files
//    that are empty, binary or a folder, and the valid extreme: no particles at all;
//  * reads with a bound: /dev/zero, sparse files of gigabytes, FIFOs that stream without end, files that
//    cannot be a JSON object (refused at their first read), a scene file over kMaxSceneFileBytes;
//  * the optical-depth pass's hit budget (dense scenes without a cutoff need memory quadratic in density);
//  * six-way textures given with --textures: missing, truncated, wrong-size and corrupt files, a sidecar of
//    gigabytes or over its limit, atlases whose header claims more pixels than a texture may have;
//  * the command line: bad numbers for every numeric flag, --threads 0 and --size 0x0 for each command that
//    takes them, output paths in read-only or unwritable folders and onto an existing folder.
#include "support/cli_runner.hpp"

#include <smoketrace/render/camera.hpp>
#include <smoketrace/core/memory_budget.hpp>
#include <smoketrace/core/shown_text.hpp>
#include <smoketrace/smoke/optical_depth_pass.hpp>
#include <smoketrace/io/json_text_file.hpp>
#include <smoketrace/io/png_io.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>
#include <smoketrace/render/sixway_texture.hpp>
#include <smoketrace/smoke/tube_generator.hpp>

#include <catch2/catch.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <numeric>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <csignal>
#include <fcntl.h>
#include <pthread.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;
using namespace smoketrace;
using smoketrace::test::CliRun;
using smoketrace::test::run_cli;
using smoketrace::test::TempDir;

namespace {

const std::string kScene = std::string(SMOKETRACE_ASSET_DIR) + "/scenes/minimal.json";

// The files in `dir` whose names are not in `inputs`: outputs or temporary files left behind.
std::vector<std::string> leftovers(const fs::path& dir, const std::vector<std::string>& inputs) {
    std::vector<std::string> extra;
    for (const auto& e : fs::directory_iterator(dir)) {
        const std::string name = e.path().filename().string();
        if (std::find(inputs.begin(), inputs.end(), name) == inputs.end()) extra.push_back(name);
    }
    return extra;
}

struct Case {
    std::string args;    // shell words after "smoketrace"
    std::string expect;  // must appear in the message
};

// Each case fails cleanly: exit code > 0 (not a signal), message containing `expect`, nothing new in `dir`.
void require_clean_failures(const std::vector<Case>& cases, const TempDir& dir, const std::vector<std::string>& inputs) {
    for (const Case& c : cases) {
        INFO("smoketrace " << c.args);
        const CliRun r = run_cli(c.args);
        INFO("stderr: " << r.err);
        CHECK(r.exit_code > 0);
        CHECK(r.err.find(c.expect) != std::string::npos);
        CHECK(r.err.find("terminate called") == std::string::npos);  // no uncaught exception
        CHECK(leftovers(dir.path, inputs).empty());
    }
}

std::string error_of(const std::string& text, const std::string& source = "bad.json") {
    try {
        (void)parse_scene(text, source);
    } catch (const SceneFileError& e) {
        return e.what();
    }
    return "(no error)";
}

const char* const kLight = R"("light": { "direction": [0, 1, 0] })";

// A PNG file's bytes with the size in its header (IHDR) changed, and the chunk's CRC made to match: a file
// that passes every check of its structure and claims pixels its data does not have.
std::string with_png_size(std::string png, std::uint32_t width, std::uint32_t height) {
    REQUIRE(png.substr(12, 4) == "IHDR");
    for (int i = 0; i < 4; ++i) {
        png[std::size_t(16 + i)] = char(width >> (24 - 8 * i));
        png[std::size_t(20 + i)] = char(height >> (24 - 8 * i));
    }
    std::uint32_t crc = 0xFFFFFFFFu;  // the PNG specification's CRC-32 over the chunk's type and data
    for (std::size_t i = 12; i < 12 + 4 + 13; ++i) {
        crc ^= std::uint8_t(png[i]);
        for (int k = 0; k < 8; ++k) crc = (crc & 1u) ? 0xEDB88320u ^ (crc >> 1) : crc >> 1;
    }
    crc ^= 0xFFFFFFFFu;
    for (int i = 0; i < 4; ++i) png[std::size_t(29 + i)] = char(crc >> (24 - 8 * i));
    return png;
}

}  // namespace

// ---- Scene files -----------------------------------------------------------------------------------------

TEST_CASE("hostile scene: nesting deeper than 64 levels is refused before anything recursive meets it", "[hostile]") {
    // 10^6 nested arrays: nlohmann parses them iteratively, but dumping one for a message recursed and
    // overflowed the stack (a segfault, before the scan).
    const std::string deep = std::string(R"({"light": )") + std::string(1'000'000, '[') + std::string(1'000'000, ']') + "}";
    const std::string message = error_of(deep);
    INFO(message.substr(0, 200));
    CHECK(message.rfind("bad.json: /light/0/0/0/", 0) == 0);
    CHECK(message.find("nested deeper than 64 levels") != std::string::npos);
    // 64 levels are fine for the scanner; the reader then says what is wrong with the value.
    const std::string ok_depth = std::string(R"({"light": )") + std::string(63, '[') + std::string(63, ']') + "}";
    CHECK(error_of(ok_depth).find("/light: must be an object") != std::string::npos);
}

TEST_CASE("hostile scene: particle counts beyond this machine's memory are refused before being built", "[hostile]") {
    const std::uint64_t limit = scene_particle_limit();
    INFO("limit " << limit << " particles (" << format_bytes(machine_memory_bytes()) << " of memory)");
    REQUIRE(limit >= 1);
    REQUIRE(limit <= kMaxSceneParticles);

    // The generator: the count is checked before generate_tubes() allocates anything.
    const std::string tubes =
        std::string("{") + kLight + R"(, "smoke": { "tubes": { "count": )" + std::to_string(limit + 1) + " } } }";
    const std::string m = error_of(tubes);
    INFO(m);
    CHECK(m.rfind("bad.json: /smoke/tubes/count: too many particles", 0) == 0);
    if (limit < kMaxSceneParticles) CHECK(m.find("this machine's memory") != std::string::npos);

    // A list: the scan stops counting at the limit, before nlohmann builds a document of that size (about
    // 400 bytes per particle object); each element here is a 2-byte "0," so the text stays small.
    std::string list = std::string("{") + kLight + R"(, "smoke": { "particles": [)";
    list.reserve(list.size() + 2 * (limit + 1) + 8);
    for (std::uint64_t i = 0; i <= limit; ++i) list += "0,";
    list.back() = ']';
    list += "} }";
    const std::string l = error_of(list);
    INFO(l);
    CHECK(l.rfind("bad.json: /smoke/particles: too many particles", 0) == 0);
    CHECK(l.find("more than " + std::to_string(limit)) != std::string::npos);
}

TEST_CASE("hostile scene: coordinates, radii and colours whose float arithmetic would overflow", "[hostile]") {
    // Each value fits a float; before the bounds the first ended in "Scene: instance 0 has a non-finite or empty
    // world box", the colours in infinite pixels that the PNG writer refused, with no file or JSON path.
    const std::string p = R"("smoke": { "particles": [ { "center": [0, 0, 0], "radius": 1 } ] })";
    const struct {
        std::string text, path, problem;
    } cases[] = {
        {std::string("{") + kLight + R"(, "smoke": { "particles": [ { "center": [1e38, 0, 0], "radius": 1 } ] } })",
         "/smoke/particles/0/center/0", "must be in [-1e+15, 1e+15] (got 1e+38)"},
        {std::string("{") + kLight + R"(, "smoke": { "particles": [ { "center": [0, 0, 0], "radius": 3e38 } ] } })",
         "/smoke/particles/0/radius", "must be <= 1e+15 (got 3e+38)"},
        {std::string("{") + kLight + ", " + p + R"(, "ground": { "corners": [[-3e38, 0, 3e38], [3e38, 0, 3e38], [3e38, 0, -3e38], [-3e38, 0, -3e38]] } })",
         "/ground/corners/0/0", "must be in [-1e+15, 1e+15]"},
        {std::string("{") + kLight + ", " + p + R"(, "camera": { "position": [0, 0, 2e16] } })", "/camera/position/2",
         "must be in [-1e+15, 1e+15]"},
        {std::string(R"({ "light": { "direction": [0, 1, 0], "color": [3e38, 1, 1] }, )") + p + " }", "/light/color/0",
         "must be <= 1e+06 (got 3e+38)"},
        {std::string("{") + kLight + ", " + p + R"(, "ambient": [1, 1e7, 1] })", "/ambient/1", "must be <= 1e+06"},
        {std::string("{") + kLight + ", " + p + R"(, "background": [0, 0, 2e6] })", "/background/2", "must be <= 1e+06"},
        {std::string("{") + kLight + ", " + p + R"(, "ground": { "corners": [[-4, -1, 4], [4, -1, 4], [4, -1, -4], [-4, -1, -4]], "color": [1e30, 0, 0] } })",
         "/ground/color/0", "must be <= 1e+06"},
        // Generated particles beyond the range.
        {std::string("{") + kLight + R"(, "smoke": { "tubes": { "count": 10, "separation": 3e38 } } })", "/smoke/tubes",
         "generated particle 0 lies beyond the coordinate range"},
        // Motion: the file's frames carry a particle out of range, or grow it beyond it.
        {std::string("{") + kLight + R"(, "smoke": { "particles": [ { "center": [0, 0, 0], "radius": 1, "velocity": [0, 3e38, 0] } ] }, "render": { "frames": 3 } })",
         "/smoke/particles/0", "moves beyond the coordinate range +-1e+15 within 3 frames (y reaches"},
        {std::string("{") + kLight + R"(, "smoke": { "particles": [ { "center": [0, 0, 0], "radius": 1, "growth": 1e30 } ] }, "render": { "frames": 2 } })",
         "/smoke/particles/0", "grows beyond a radius of 1e+15 within 2 frames"},
        {std::string("{") + kLight + R"(, "smoke": { "tubes": { "count": 4, "drift": [1e12, 0, 0] } }, "render": { "frames": 5000 } })",
         "/smoke/tubes", "generated particle 0 moves beyond the coordinate range"},
    };
    for (const auto& c : cases) {
        const std::string message = error_of(c.text);
        INFO(message);
        CHECK(message.rfind("bad.json: " + c.path + ": ", 0) == 0);
        CHECK(message.find(c.problem) != std::string::npos);
    }
    // At the bounds: accepted, and a single frame of a fast particle is fine (it never moves).
    CHECK(error_of(std::string("{") + kLight + R"(, "smoke": { "particles": [ { "center": [1e15, -1e15, 1e15], "radius": 1e15 } ] },
        "ambient": [1e6, 1e6, 1e6] })") == "(no error)");
    CHECK(error_of(std::string("{") + kLight + R"(, "smoke": { "particles": [ { "center": [0, 0, 0], "radius": 1, "velocity": [3e38, 0, 0] } ] } })") ==
          "(no error)");
}

TEST_CASE("hostile scene: camera up vectors of any length and a scene too small to frame", "[hostile]") {
    // Each used to read fine and then fail (or render one flat colour) in the renderer's float camera: up =
    // [0, 1e-30, 0] underflowed |forward x up| to 0 ("camera: up is parallel to the view direction", no file
    // named), up = [3e38, 3e38, 0] overflowed it to a zero right vector, and a lone particle of radius 1e-38
    // at (1, 1, 1) put the default camera on the point it looks at (radius 2e-38 here: 1e-38 is not a normal float).
    const std::string p = R"("smoke": { "particles": [ { "center": [0, 0, 0], "radius": 1 } ] })";
    for (const std::string up : {"[0, 1e-30, 0]", "[3e38, 3e38, 0]", "[0, 1e-7, 1e-12]"}) {
        INFO("up " << up);
        const SceneDescription s =
            parse_scene(std::string("{") + kLight + ", " + p + R"(, "camera": { "position": [0, 0, 5], "up": )" + up + " } }", "up.json");
        CHECK(std::abs(glm::length(glm::dvec3(s.camera.up)) - 1.0) < 1e-6);
        CHECK_NOTHROW(Camera(s.camera.position, s.camera.look_at, s.camera.up, s.camera.fov_deg, 8, 8));
    }
    const SceneDescription tiny = parse_scene(std::string("{") + kLight +
                                                  R"(, "smoke": { "particles": [ { "center": [1, 1, 1], "radius": 2e-38 } ] } })",
                                              "tiny.json");
    CHECK(tiny.camera.position != tiny.camera.look_at);
    CHECK_NOTHROW(Camera(tiny.camera.position, tiny.camera.look_at, tiny.camera.up, tiny.camera.fov_deg, 8, 8));
    // Parallel after all: still the reader's error, with the path.
    const std::string parallel = error_of(std::string("{") + kLight + ", " + p +
                                          R"(, "camera": { "position": [0, 0, 5], "up": [0, 0, 1e-30] } })");
    CHECK(parallel.rfind("bad.json: /camera/up: is parallel to the view direction", 0) == 0);
}

// ---- The optical-depth pass's hit budget -----------------------------------------------------------------

TEST_CASE("hostile scene: a dense scene without a cutoff is refused by the hit budget, not the OOM killer", "[hostile]") {
    // The two tubes with 750 particles meet ~1e5 surfaces in all. A tubes scene of 10^6 particles (a valid file)
    // would meet ~4·10^10 (each ray crosses ~4·10^4 of the denser particles): before the budget `smoketrace
    // depths` on it grew past 14 GiB and kept going. A budget below the scene's need stands in for that here.
    TubeSettings t;
    const std::vector<Particle> ps = generate_tubes(t);
    SmokeScene scene(ps, StandInShape{}, std::nullopt, false);
    scene.update(ps, glm::vec3(0.0f, 0.0f, 10.0f));
    std::vector<std::uint32_t> all(ps.size());
    std::iota(all.begin(), all.end(), 0u);
    OpticalDepthPass pass;
    OpticalDepthHits hits;
    pass.run(scene, ps, all, {0.0f, 1.0f, 0.0f}, OpticalDepthSettings{}, hits);
    const std::uint64_t need = hits.lists.hit_count();
    REQUIRE(need > 1000);

    OpticalDepthSettings tight;
    tight.max_total_hits = need / 2;
    try {
        pass.run(scene, ps, all, {0.0f, 1.0f, 0.0f}, tight, hits);
        FAIL("no error");
    } catch (const OpticalDepthBudgetError& e) {
        const std::string m = e.what();
        INFO(m);
        CHECK(m.find("more than " + std::to_string(need / 2) + " particle surfaces") != std::string::npos);
        CHECK(m.find("cutoff") != std::string::npos);
    }
    // The failed pass holds no rays: nothing stale to gather or resolve.
    CHECK(pass.status().empty());
    std::vector<float> none, all_lengths(ps.size());
    CHECK_NOTHROW(pass.resolve(HitSort::adaptive, none));
    CHECK_THROWS_AS(pass.resolve(HitSort::adaptive, all_lengths), std::invalid_argument);
    OpticalDepthHits empty;
    pass.gather(empty);
    CHECK(empty.lists.particle_count() == 0);
    // Exactly enough: the same result as without a budget; a cutoff keeps any density within budget.
    OpticalDepthSettings exact;
    exact.max_total_hits = need;
    OpticalDepthHits again;
    pass.run(scene, ps, all, {0.0f, 1.0f, 0.0f}, exact, again);
    CHECK(again.lists.hits.size() == need);
    OpticalDepthSettings cut = tight;
    cut.cutoff = 8;
    CHECK_NOTHROW(pass.run(scene, ps, all, {0.0f, 1.0f, 0.0f}, cut, again));
    CHECK(default_max_total_hits() <= std::numeric_limits<std::uint32_t>::max());
    CHECK(default_max_total_hits() * kPeakBytesPerStoredHit <= machine_memory_bytes() / 2);
}

// ---- Scene files through the command line ----------------------------------------------------------------

TEST_CASE("hostile cli: bad scene files of every kind, through depths and render", "[hostile][cli]") {
    TempDir dir;
    std::vector<std::string> inputs;
    auto input = [&](const std::string& name, const std::string& text) {
        inputs.push_back(name);
        return dir.write(name, text).string();
    };
    const std::string empty = input("empty.json", "");
    const std::string binary = input("binary.json", std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR\xff\xfe", 18));
    const std::string nan = input("nan.json", std::string("{") + kLight + R"(, "smoke": { "particles": [ { "center": [NaN, 0, 0], "radius": 1 } ] } })");
    const std::string deep = input("deep.json", std::string(R"({"light": )") + std::string(100000, '[') + std::string(100000, ']') + "}");
    const std::string count = input("count.json", std::string("{") + kLight + R"(, "smoke": { "tubes": { "count": )" +
                                                      std::to_string(scene_particle_limit() + 1) + " } } }");
    const std::string far = input("far.json", std::string("{") + kLight + R"(, "smoke": { "particles": [ { "center": [0, 3e38, 0], "radius": 1 } ] } })");
    const std::string bright = input("bright.json", std::string(R"({ "light": { "direction": [0, 1, 0] }, "ambient": [3e38, 0, 0],
        "smoke": { "particles": [] } })"));
    const std::string fast = input("fast.json", std::string("{") + kLight + R"(, "smoke": { "particles": [ { "center": [0, 0, 0], "radius": 1, "velocity": [1e14, 0, 0] } ] } })");
    // A narrow camera, fine at the file's 512 rows (0.028° would do), too narrow at 16384 (0.9° needed).
    const std::string narrow = input("narrow.json", std::string("{") + kLight + R"(, "smoke": { "particles": [] },
        "camera": { "position": [0, 0, 10], "look_at": [0, 0, 0], "fov_deg": 0.05 } })");
    inputs.push_back("folder.json");
    fs::create_directories(dir.path / "folder.json");
    const fs::path csv = dir.path / "out.csv", png = dir.path / "out.png";
    std::vector<Case> cases;
    for (const std::string command : {"depths", "render"}) {
        const std::string out = " -o " + (command == std::string("depths") ? csv : png).string();
        cases.push_back({command + " " + empty + out, "empty.json: malformed JSON at the end of the input (byte 1)"});
        cases.push_back({command + " " + binary + out,
                         "binary.json: not a JSON object: its first non-blank byte, byte 1, is 0x89"});
        // An endless device: refused at its first byte, not read until memory runs out.
        cases.push_back({command + " /dev/zero" + out, "/dev/zero: byte 1 is a NUL byte"});
        cases.push_back({command + " " + nan + out, "nan.json: malformed JSON"});
        cases.push_back({command + " " + deep + out, "deep.json: /light/0/0"});
        cases.push_back({command + " " + count + out, "count.json: /smoke/tubes/count: too many particles"});
        cases.push_back({command + " " + far + out, "far.json: /smoke/particles/0/center/1"});
        cases.push_back({command + " " + bright + out, "bright.json: /ambient/0"});
        cases.push_back({command + " " + (dir.path / "folder.json").string() + out, "folder.json: is a directory"});
    }
    // --frames beyond the file's: the motion is checked again for the frames asked for.
    cases.push_back({"render " + fast + " -o " + png.string() + " --size 8x8 --frames 20", "fast.json: /smoke/particles/0: moves beyond"});
    // --size taller than the file's image: the camera's pixel angle is checked again for the height asked for.
    cases.push_back({"render " + narrow + " -o " + png.string() + " --size 16x16384",
                     "--size: 16x16384: the scene's camera.fov_deg (0.05) is too small for this size: at 16384 pixels "
                     "high, neighbouring pixels' rays would be less than 2^-20 radians apart"});
    require_clean_failures(cases, dir, inputs);
    CHECK(run_cli("render " + narrow + " -o " + png.string() + " --size 16x512").exit_code == 0);
    // The same file is fine for as many frames as keep it in range.
    const CliRun ok = run_cli("render " + fast + " -o " + png.string() + " --size 8x8 --frames 3");
    CHECK(ok.exit_code == 0);
    for (int f = 0; f < 3; ++f) CHECK(fs::exists(dir.path / ("out_000" + std::to_string(f) + ".png")));
}

// ---- Reads with a bound ------------------------------------------------------------------------------------

namespace {

// Writes `total` bytes of `fill` (after `head`) into the FIFO `path` from another thread, until the reader
// closes its end; returns how many bytes went in. SIGPIPE is blocked in that thread only, so that a closed
// reader shows as EPIPE there and nothing else in the test process changes.
class FifoWriter {
public:
    FifoWriter(fs::path path, std::string head, char fill, std::size_t total)
        : thread_([this, path = std::move(path), head = std::move(head), fill, total] {
              sigset_t pipe_signal;
              sigemptyset(&pipe_signal);
              sigaddset(&pipe_signal, SIGPIPE);
              pthread_sigmask(SIG_BLOCK, &pipe_signal, nullptr);
              const int fd = ::open(path.c_str(), O_WRONLY);  // waits for the reader to open its end
              if (fd < 0) return;
              std::string chunk = head + std::string(std::size_t(1) << 16, fill);
              while (written_ < total) {
                  const std::size_t n = std::min(chunk.size(), total - written_);
                  const ssize_t done = ::write(fd, chunk.data(), n);
                  if (done <= 0) break;  // EPIPE: the reader stopped reading
                  written_ += std::size_t(done);
                  if (written_ >= head.size()) chunk.assign(std::size_t(1) << 16, fill);
              }
              ::close(fd);
          }) {}
    std::size_t written() {
        thread_.join();
        return written_;
    }

private:
    std::size_t written_ = 0;
    std::thread thread_;
};

}  // namespace

TEST_CASE("hostile scene: files that cannot be a JSON object are refused at their first bytes, however large",
          "[hostile]") {
    TempDir dir;
    auto message_of = [](const fs::path& path) {
        try {
            (void)load_scene_file(path);
        } catch (const SceneFileError& e) {
            return std::string(e.what());
        }
        return std::string("(no error)");
    };
    // A sparse file of 1 GiB of zeros: read whole, it took 1 GiB of memory and many seconds before
    // "malformed JSON at byte 1".
    const fs::path sparse = dir.path / "sparse.json";
    std::ofstream(sparse).close();
    fs::resize_file(sparse, std::uintmax_t(1) << 30);
    CHECK(message_of(sparse) ==
          sparse.string() + ": byte 1 is a NUL byte, which JSON text never holds (is it a binary file?)");
    // A NUL further in: named by its byte.
    const fs::path late = dir.write("late.json", "{" + std::string(99999, ' ') + std::string(1, '\0') + "}");
    CHECK_THAT(message_of(late), Catch::StartsWith(late.string() + ": byte 100001 is a NUL byte"));
    // Valid JSON, but not an object: refused without parsing what follows.
    const fs::path list = dir.write("list.json", " \r\n\t[1, 2, 3]");
    CHECK(message_of(list) ==
          list.string() +
              ": not a JSON object: its first non-blank byte, byte 5, is '[' (a JSON object begins with '{')");
    // A FIFO that would go on for 64 MiB of zeros: the reader stops after its first read.
    const fs::path fifo = dir.path / "zeros.json";
    REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
    constexpr std::size_t kStreamBytes = std::size_t(64) << 20;
    FifoWriter zeros(fifo, "", '\0', kStreamBytes);
    CHECK_THAT(message_of(fifo), Catch::StartsWith(fifo.string() + ": byte 1 is a NUL byte"));
    CHECK(zeros.written() < kStreamBytes);
    // A byte-order mark before the object is still read, as JSON readers do.
    const fs::path bom =
        dir.write("bom.json", std::string("\xEF\xBB\xBF\n{") + kLight + R"(, "smoke": { "particles": [] } })");
    CHECK(message_of(bom) == "(no error)");
}

TEST_CASE("hostile scene: a scene file longer than kMaxSceneFileBytes is refused by its size, a stream at the "
          "bound", "[hostile]") {
    TempDir dir;
    // A sparse file one byte over the limit, beginning like a scene: refused before a byte of it is read.
    const fs::path big = dir.write("big.json", std::string("{") + kLight + R"(, "smoke": { "particles": [)");
    fs::resize_file(big, kMaxSceneFileBytes + 1);
    const CliRun r = run_cli("depths " + big.string() + " -o " + (dir.path / "out.csv").string());
    CHECK(r.exit_code == 1);
    CHECK(r.err.find(big.string() + ": the file is 4294967297 bytes, more than the limit of 4294967296 bytes") !=
          std::string::npos);
    CHECK(!fs::exists(dir.path / "out.csv"));
    // A stream has no size: it is read up to the bound and no further (a bound of 1 MiB here, for a 16 MiB
    // stream, so that the test moves little data; load_scene_file() gives kMaxSceneFileBytes).
    const fs::path fifo = dir.path / "spaces.json";
    REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
    constexpr std::size_t kBound = std::size_t(1) << 20, kStreamBytes = std::size_t(16) << 20;
    FifoWriter spaces(fifo, "{", ' ', kStreamBytes);
    CHECK_THROWS_WITH(read_json_object_text(fifo, kBound), "it is longer than the limit of 1048576 bytes");
    CHECK(spaces.written() < kStreamBytes);
    // Up to the bound, a stream is read whole, with the padding asked for.
    const fs::path fifo2 = dir.path / "small.json";
    REQUIRE(::mkfifo(fifo2.c_str(), 0600) == 0);
    FifoWriter small(fifo2, "{", ' ', kBound);
    const JsonText text = read_json_object_text(fifo2, kBound, 64);
    CHECK(small.written() == kBound);
    CHECK(text.size() == kBound);
    CHECK(text.capacity() >= kBound + 64);
    // A regular file is read whole too (past the first chunk, straight into the text), then zero bytes.
    std::string scene = std::string("{") + kLight + R"(, "smoke": { "particles": [)";
    while (scene.size() < 3 * kBound) scene += R"({ "center": [1, 2, 3], "radius": 0.5 }, )";
    scene += R"({ "center": [1, 2, 3], "radius": 0.5 }] } })";
    const JsonText file_text = read_json_object_text(dir.write("long.json", scene), kMaxSceneFileBytes, 64);
    CHECK(file_text.view() == scene);
    REQUIRE(file_text.capacity() >= scene.size() + 64);
    CHECK(std::string_view(file_text.data() + scene.size(), 64) == std::string(64, '\0'));
}

TEST_CASE("hostile cli: an empty particle list is valid: render draws the ground and sky, depths writes a header", "[hostile][cli]") {
    TempDir dir;
    const fs::path scene = dir.write("empty.json", std::string("{") + kLight + R"(, "smoke": { "particles": [] },
        "ground": { "corners": [[-2, -1, 2], [2, -1, 2], [2, -1, -2], [-2, -1, -2]] } })");
    const fs::path sky_only = dir.write("sky.json", std::string("{") + kLight + R"(, "smoke": { "particles": [] } })");
    for (const fs::path& s : {scene, sky_only}) {
        INFO(s);
        // Which pixels see the ground: the pixel's camera ray (the renderer's Camera, the file's default
        // camera at 16x16) against the quad y = -1, |x|, |z| < 2, in double; rays within 1e-3 of its border
        // are left out (a float ray may fall either side).
        const SceneDescription desc = load_scene_file(s);
        const Camera camera(desc.camera.position, desc.camera.look_at, desc.camera.up, desc.camera.fov_deg, 16, 16);
        // Expected codes. Sky: the background, encoded exactly as the PNG writer does. Ground, eq. 4.4 with
        // nothing to cast a shadow, the light straight above (N·L = 1): c_base·(c_light + c_amb), computed here
        // in double; the renderer's float product may differ by an ulp, which can cross an 8-bit decision
        // threshold, so the ground may be one code off.
        std::array<int, 3> sky_code{}, ground_code{};
        for (int k = 0; k < 3; ++k) {
            sky_code[k] = linear_to_srgb8(desc.background[k]);
            if (desc.ground) {
                const double lit = double(desc.light.color[k]) + double(desc.ambient[k]);
                ground_code[k] = linear_to_srgb8(float(double(desc.ground->color[k]) * lit));
            }
        }
        for (const char* mode : {"basic", "simple-shadow", "full"}) {
            INFO("mode " << mode);
            const fs::path png = dir.path / (s.stem().string() + "_" + mode + ".png");
            const CliRun r = run_cli("render " + s.string() + " -o " + png.string() + " --size 16x16 --mode " + mode);
            INFO(r.err);
            REQUIRE(r.exit_code == 0);
            const Rgba8Image img = read_png_rgba8(png, 16, 16);
            int sky = 0, ground = 0;
            for (int y = 0; y < 16; ++y)
                for (int x = 0; x < 16; ++x) {
                    const Ray ray = camera.ray(x, y, 0.0f);
                    const glm::dvec3 o(ray.origin), d(ray.direction);
                    bool on_ground = false;
                    if (desc.ground && d.y < 0.0) {
                        const glm::dvec3 g = o + ((-1.0 - o.y) / d.y) * d;
                        const double out = std::max(std::abs(g.x), std::abs(g.z)) - 2.0;
                        if (std::abs(out) < 1e-3) continue;
                        on_ground = out < 0.0;
                    }
                    const std::uint8_t* px = img.texel(x, y);
                    INFO("pixel (" << x << ", " << y << ") = " << int(px[0]) << " " << int(px[1]) << " " << int(px[2])
                                   << (on_ground ? ", ground" : ", sky"));
                    for (int k = 0; k < 3; ++k) {
                        if (on_ground) CHECK(std::abs(int(px[k]) - ground_code[k]) <= 1);
                        else CHECK(int(px[k]) == sky_code[k]);
                    }
                    (on_ground ? ground : sky) += 1;
                }
            CHECK(sky >= 16);  // the sky all round the ground
            if (desc.ground) CHECK(ground >= 16);
        }
        const fs::path csv = dir.path / (s.stem().string() + ".csv");
        REQUIRE(run_cli("depths " + s.string() + " -o " + csv.string()).exit_code == 0);
        std::ifstream in(csv);
        std::stringstream text;
        text << in.rdbuf();
        CHECK(text.str() == "particle,optical_path_length,hits,status\n");
    }
}

// ---- Textures ----------------------------------------------------------------------------------------------

TEST_CASE("hostile cli: missing, truncated, wrong-size and corrupt six-way textures", "[hostile][cli]") {
    TempDir out;
    const fs::path png = out.path / "out.png";
    const fs::path assets(SMOKETRACE_ASSET_DIR);
    // A fresh copy of the committed textures per case, then one thing broken.
    struct Broken {
        std::string name, expect;
        std::function<void(const fs::path&)> breakit;
    };
    auto bytes_of = [](const fs::path& p) {
        std::ifstream in(p, std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(in), {});
    };
    auto put = [](const fs::path& p, const std::string& bytes) { std::ofstream(p, std::ios::binary | std::ios::trunc) << bytes; };
    const std::string pos = std::string(kSixwayPositiveFile), neg = std::string(kSixwayNegativeFile), layout = std::string(kSixwayLayoutFile);
    const std::vector<Broken> broken{
        {"missing positive atlas", pos, [&](const fs::path& d) { fs::remove(d / pos); }},
        {"missing sidecar", layout, [&](const fs::path& d) { fs::remove(d / layout); }},
        {"truncated positive atlas", pos, [&](const fs::path& d) { put(d / pos, bytes_of(d / pos).substr(0, 1000)); }},
        {"truncated negative atlas (last byte)", neg, [&](const fs::path& d) {
             const std::string b = bytes_of(d / neg);
             put(d / neg, b.substr(0, b.size() - 1));
         }},
        {"negative atlas of another size", "expected", [&](const fs::path& d) { write_png_rgba8(d / neg, Rgba8Image(64, 64)); }},
        {"atlas not divisible by the grid", "does not divide", [&](const fs::path& d) {
             write_png_rgba8(d / pos, Rgba8Image(30, 30));
             write_png_rgba8(d / neg, Rgba8Image(30, 30));
         }},
        {"an empty file as the atlas", pos, [&](const fs::path& d) { put(d / pos, ""); }},
        {"a JPEG-ish file as the atlas", pos, [&](const fs::path& d) { put(d / pos, std::string("\xff\xd8\xff\xe0garbage", 11)); }},
        {"truncated sidecar", layout, [&](const fs::path& d) { put(d / layout, bytes_of(d / layout).substr(0, 40)); }},
        {"sidecar frames beyond the limit", "/frames", [&](const fs::path& d) {
             std::string j = bytes_of(d / layout);
             j.replace(j.find("\"frames\": 16"), 12, "\"frames\": 99999");
             put(d / layout, j);
         }},
        // Reads with a bound: a sidecar of gigabytes, or longer than its limit; an atlas whose header gives a size
        // that decodes to a gigabyte (its data is a few bytes: decoding first failed with "not enough pixels").
        {"a sidecar of 1 GiB of zeros (sparse)", layout + "': the file is 1073741824 bytes, more than the limit of "
                                                          "1048576 bytes", [&](const fs::path& d) {
             put(d / layout, "");
             fs::resize_file(d / layout, std::uintmax_t(1) << 30);
         }},
        {"a sidecar of zeros", layout + "': byte 1 is a NUL byte", [&](const fs::path& d) {
             put(d / layout, std::string(1000, '\0'));
         }},
        {"a sidecar longer than kMaxSixwayLayoutBytes", "more than the limit of 1048576 bytes", [&](const fs::path& d) {
             std::string text(1, '{');  // appended, not "{" + …: GCC 12 warns falsely (-Wrestrict) on that
             text.append(kMaxSixwayLayoutBytes, ' ');
             put(d / layout, text + bytes_of(d / layout).substr(1));
         }},
        {"a positive atlas whose header says 16384x16384", pos + "': PNG size 16384x16384 is larger than the limit "
                                                                 "of 8192x8192 for a texture",
         [&](const fs::path& d) { put(d / pos, with_png_size(bytes_of(d / pos), 16384, 16384)); }},
        {"a negative atlas whose header says 16384x16384", neg + "': expected 512x512 pixels, the file has 16384x16384",
         [&](const fs::path& d) { put(d / neg, with_png_size(bytes_of(d / neg), 16384, 16384)); }},
        {"sidecar pointing outside with a missing file", "nowhere.png", [&](const fs::path& d) {
             std::string j = bytes_of(d / layout);
             j.replace(j.find("\"sixway_pos.png\""), 16, "\"../nowhere.png\"");
             put(d / layout, j);
         }},
    };
    for (const Broken& b : broken) {
        TempDir textures;
        for (const std::string& f : {pos, neg, layout}) fs::copy_file(assets / f, textures.path / f);
        b.breakit(textures.path);
        INFO(b.name);
        const CliRun r = run_cli("render " + kScene + " -o " + png.string() + " --size 8x8 --textures " + textures.path.string());
        INFO("stderr: " << r.err);
        CHECK(r.exit_code > 0);
        CHECK(r.err.find(b.expect) != std::string::npos);
        CHECK(fs::is_empty(out.path));
    }
}

// ---- The command line --------------------------------------------------------------------------------------

TEST_CASE("hostile cli: bad numbers and sizes for every numeric flag", "[hostile][cli]") {
    TempDir dir;
    const std::string csv = " -o " + (dir.path / "out.csv").string();
    const std::string png = " -o " + (dir.path / "out.png").string();
    const std::string depths = "depths " + kScene + csv, render = "render " + kScene + png;
    const std::vector<Case> cases{
        {render + " --threads 0", "--threads: 0 is out of range [1, 4096]"},
        {depths + " --threads 0", "--threads: 0 is out of range [1, 4096]"},
        {render + " --threads -2", "--threads"},
        {depths + " --threads 99999999999999999999", "--threads: '99999999999999999999' is not a whole number"},
        {depths + " --threads 2.5", "--threads: '2.5' is not a whole number"},
        {depths + " --threads ''", "--threads: '' is not a whole number"},
        {depths + " --threads", "--threads: missing value"},
        {depths + " --threads 1 --threads 2", "--threads: given more than once"},
        {depths + " --cutoff 1e3", "--cutoff: '1e3' is not a whole number"},
        {depths + " --cutoff -1", "--cutoff"},
        {depths + " --repeat 0", "--repeat"},
        {depths + " --sort quick", "--sort"},
        {depths + " --size 8x8", "unknown option '--size'"},
        {render + " --size 0x0", "--size width: 0 is out of range"},
        {render + " --size 16x0", "--size height: 0 is out of range"},
        {render + " --size 0x16", "--size width"},
        {render + " --size -4x4", "--size width"},
        {render + " --size 16x", "--size height: '' is not a whole number"},
        {render + " --size x16", "--size width"},
        {render + " --size 16X16", "not of the form WxH"},
        {render + " --size 16384x16384", "has more than 67108864 pixels"},
        {render + " --size 16385x1", "--size width: 16385 is out of range"},
        {render + " --frames 0", "--frames"},
        {render + " --frames 1.5", "--frames"},
        {render + " --groups 0", "--groups"},
        {render + " --groups 99999999", "--groups"},
        {render + " --cutoff nan", "--cutoff"},
        {render + " --compositing under", "--compositing"},
        {render + " --compositor fast", "--compositor"},
        {"render " + kScene + " -o " + (dir.path / "out.jpg").string(), "must end in .png"},
        {"render " + kScene, "missing -o"},
        {"render", "missing scene file"},
        {"depths " + kScene + " " + kScene + csv, "unexpected argument"},
        {"bake-sixway -o " + dir.path.string() + " --tile 0", "--tile"},
        {"bake-sixway -o " + dir.path.string() + " --frames 99999", "--frames"},
    };
    require_clean_failures(cases, dir, {});
}

TEST_CASE("hostile cli: output paths that cannot be written", "[hostile][cli]") {
    TempDir dir;
    // A target that is an existing folder: the rename onto it fails for every user, root included.
    fs::create_directories(dir.path / "taken.png");
    fs::create_directories(dir.path / "taken.csv");
    std::vector<Case> cases{
        {"render " + kScene + " -o " + (dir.path / "taken.png").string() + " --size 8x8", "taken.png"},
        {"depths " + kScene + " -o " + (dir.path / "taken.csv").string(), "taken.csv"},
        {"render " + kScene + " -o " + (dir.path / "no" / "such" / "x.png").string(), "does not exist"},
        {"bake-sixway -o " + (dir.path / "no" / "such").string(), "is not an existing folder"},
    };
    // A "folder" that is a regular file: no user, root included, can create a file in it. (No test writes to
    // /proc, /dev or any other system path, even to check that it is refused.)
    { std::ofstream(dir.path / "plain_file") << "not a folder\n"; }
    const fs::path in_file = dir.path / "plain_file";
    cases.push_back({"render " + kScene + " -o " + (in_file / "x.png").string() + " --size 8x8", "plain_file"});
    cases.push_back({"depths " + kScene + " -o " + (in_file / "x.csv").string(), "plain_file"});
    cases.push_back({"bake-sixway -o " + in_file.string() + " --frames 1 --tile 4", "plain_file"});
    fs::create_directories(dir.path / "ro");
    require_clean_failures(cases, dir, {"ro", "taken.png", "taken.csv", "plain_file"});
    CHECK(fs::is_regular_file(in_file));
    CHECK(fs::file_size(in_file) == std::string("not a folder\n").size());

    // A read-only folder: meaningful only where permissions apply, i.e. not for root, which CI may run as.
    const fs::path ro = dir.path / "ro";
    fs::permissions(ro, fs::perms::owner_read | fs::perms::owner_exec, fs::perm_options::replace);
    const bool writable_anyway = ::access(ro.c_str(), W_OK) == 0;  // root (or CAP_DAC_OVERRIDE)
    if (writable_anyway) {
        WARN("running with permission to write into read-only folders (root?): the read-only-folder checks "
             "are skipped; the file-as-folder and existing-folder checks above fail for root too");
    } else {
        for (const Case& c : std::vector<Case>{
                 {"render " + kScene + " -o " + (ro / "x.png").string() + " --size 8x8", (ro / "x.png").string()},
                 {"depths " + kScene + " -o " + (ro / "x.csv").string(), (ro / "x.csv").string()},
                 {"bake-sixway -o " + ro.string() + " --frames 1 --tile 4", ro.string()},
             }) {
            INFO("smoketrace " << c.args);
            const CliRun r = run_cli(c.args);
            INFO("stderr: " << r.err);
            CHECK(r.exit_code > 0);
            CHECK(r.err.find(c.expect) != std::string::npos);
            CHECK(fs::is_empty(ro));
        }
    }
    fs::permissions(ro, fs::perms::owner_all, fs::perm_options::replace);
}

// ---- Messages a terminal can trust (issue 31) --------------------------------------------------------------

namespace {

// Bytes a terminal acts on: C0 controls but the newline that ends a message, DEL, and C1's CSI (0x9B).
bool has_terminal_control(const std::string& message) {
    for (std::size_t i = 0; i < message.size(); ++i) {
        const auto c = static_cast<unsigned char>(message[i]);
        if ((c < 0x20 && c != '\n') || c == 0x7F || c == 0x9B) return true;
        if (c == 0xC2 && i + 1 < message.size() && static_cast<unsigned char>(message[i + 1]) == 0x9B) return true;
    }
    return false;
}

// A scene with a light and `rest`.
std::string lit(const std::string& rest) {
    return std::string("{").append(kLight).append(", ").append(rest).append("}");
}

}  // namespace

TEST_CASE("hostile scene: keys and values are shown escaped and capped, never raw", "[hostile]") {
    // An escape sequence that would clear the screen, and a NUL that cut the message short.
    const std::string key = error_of(lit(R"("smoke": {"particles": [], "\u001b[2J\u0000after": 1})"));
    INFO(key);
    CHECK_FALSE(has_terminal_control(key));
    CHECK(key.find(R"(/smoke/\u001b[2J\u0000after: unknown key)") != std::string::npos);
    // A C1 CSI in a string value (valid UTF-8, which nlohmann's dump() passes through) and a tab.
    const std::string value = error_of(lit(R"("smoke": {"particles": [], "shape": "\u009b31m\tx"})"));
    INFO(value);
    CHECK_FALSE(has_terminal_control(value));
    CHECK(value.find(R"(unknown shape "\u009b31m\tx")") != std::string::npos);
    // A key of 100 000 characters is shown by its first kMaxShownValueBytes, not whole; a value too.
    const std::string long_key =
        error_of(lit(R"("smoke": {"particles": [], ")" + std::string(100000, 'k') + R"(": 1})"));
    CHECK(long_key.size() < 300);
    CHECK(long_key.find(std::string(kMaxShownValueBytes - 3, 'k') + "...") != std::string::npos);
    const std::string long_value =
        error_of(lit(R"("smoke": {"particles": [], "shape": ")" + std::string(100000, 'v') + R"("})"));
    CHECK(long_value.size() < 400);
    // The file's own name is shown too: it came from the user.
    const std::string named = error_of(lit(R"("smoke": 1)"), "a\x1b]0;title\x07.json");
    CHECK_FALSE(has_terminal_control(named));
    CHECK(named.rfind(R"(a\u001b]0;title\u0007.json: /smoke: )", 0) == 0);
}

TEST_CASE("hostile cli: arguments and paths are shown escaped and capped, never raw", "[hostile][cli]") {
    const TempDir dir;
    // sh's printf makes the bytes: ESC, BEL, an invalid UTF-8 byte.
    const std::vector<Case> cases = {
        {"render " + kScene + " -o x.png --mode \"$(printf 'a\\033[2Jb')\"", R"(--mode: 'a\u001b[2Jb')"},
        {"depths \"$(printf 'no\\033]0;t\\007such\\377.json')\" -o " + (dir.path / "x.csv").string(),
         R"(no\u001b]0;t\u0007such\xff.json)"},
        {"depths " + kScene + " -o x.csv \"--$(printf '\\033[31m')\"", R"(unknown option '--\u001b[31m')"},
        {"\"$(printf 'rend\\033[2Jer')\"", R"(unknown command 'rend\u001b[2Jer')"},
    };
    require_clean_failures(cases, dir, {});
    for (const Case& c : cases) CHECK_FALSE(has_terminal_control(run_cli(c.args).err));
    // An argument of 100 000 bytes is shown by its start.
    const CliRun r = run_cli("render " + kScene + " -o x.png --mode " + std::string(100000, 'm'));
    CHECK(r.exit_code == 2);
    CHECK(r.err.size() < kMaxShownPathBytes + 200);
}

TEST_CASE("hostile scene: a value of the wrong type is named in JSON's words", "[hostile]") {
    const std::string null_direction = error_of(R"({"light": {"direction": null}})");
    INFO(null_direction);
    CHECK(null_direction.find("/light/direction: must be an array of 3 numbers (got null)") != std::string::npos);
    const auto alpha_error = [](const std::string& value) {
        return error_of(lit(R"("smoke": {"particles": [], "alpha": )" + value + "}"));
    };
    CHECK_THAT(alpha_error("[1, 2]"),
               Catch::Contains("/smoke/alpha: must be a number (got an array of 2 elements, [1,2])"));
    CHECK_THAT(alpha_error(R"({"a": 1})"), Catch::Contains(R"((got an object, {"a":1}))"));
    CHECK_THAT(alpha_error("[]"), Catch::Contains("(got an empty array)"));
    CHECK_THAT(alpha_error("false"), Catch::Contains("(got false)"));
    // 1e-400 is below the smallest double: it reads as 0, which the message must not show as the file's "0.0".
    for (const char* list : {R"([{"center": [0, 0, 0], "radius": 1e-400}])",                  // the fast reader's list
                             R"([{"center": [0, 0, 0], "radius": 1e-400, "spin": "x"}])"}) {  // the reference reader
        const std::string tiny = error_of(lit(R"("smoke": {"particles": )" + std::string(list) + "}"));
        INFO(tiny);
        CHECK(tiny.find("/smoke/particles/0/radius: ") != std::string::npos);
        CHECK(tiny.find("(got 1e-400, a number too close to 0 for a double, which reads as 0)") != std::string::npos);
    }
    const std::string huge = error_of(lit(R"("smoke": {"particles": [], "sigma_t": 1e999})"));
    CHECK(huge.find("/smoke/sigma_t: must be finite (got 1e999, a number out of range for a double)") !=
          std::string::npos);
}
