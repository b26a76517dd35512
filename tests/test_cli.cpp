// The command line as a user meets it: bad input gets a clear message, a non-zero exit, and no output.
#include "support/apng_reader.hpp"
#include "support/cli_runner.hpp"
#include "support/fixtures.hpp"

#include <smoketrace/core/process_usage.hpp>
#include <smoketrace/io/pfm_io.hpp>
#include <smoketrace/io/png_io.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>
#include <smoketrace/truth/ground_truth.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/textbook/optical_depth.hpp>

#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;
using namespace smoketrace;
using smoketrace::test::CliRun;
using smoketrace::test::file_bytes;
using smoketrace::test::run_cli;
using smoketrace::test::run_cli_stdout;
using smoketrace::test::TempDir;

namespace {

const std::string kScene = std::string(SMOKETRACE_ASSET_DIR) + "/scenes/minimal.json";

// The CSV rows of a depths run: index, length as printed, hits, status word.
struct CsvRow {
    std::string index, length, hits, status;
};

std::vector<CsvRow> read_depths_csv(const fs::path& path, std::string& header) {
    std::ifstream in(path);
    std::getline(in, header);
    std::vector<CsvRow> rows;
    for (std::string line; std::getline(in, line);) {
        std::vector<std::string> f;
        std::stringstream ss(line);
        for (std::string field; std::getline(ss, field, ',');) f.push_back(field);
        INFO("row '" << line << "'");
        REQUIRE(f.size() == 4);
        rows.push_back({f[0], f[1], f[2], f[3]});
    }
    return rows;
}

// The library's answer for the same scene and cutoff: OpticalPathLengths over every particle, as the CLI does.
struct Depths {
    std::vector<float> lengths;
    std::vector<DepthStatus> status;
    std::vector<std::uint32_t> hit_counts;
};

Depths library_depths(const SceneDescription& desc, std::uint32_t cutoff, const DensityKernel& kernel = {}) {
    std::optional<GroundQuad> ground;
    if (desc.ground) ground = GroundQuad{desc.ground->corners};
    SmokeScene smoke(desc.smoke.particles, desc.smoke.shape, ground, /*billboards=*/false);
    smoke.update(desc.smoke.particles, desc.camera.position);
    OpticalPathLengths depths(desc.smoke.particles.size());
    FrameTimings t;
    OpticalDepthSettings settings{cutoff};
    settings.kernel = kernel;
    depths.update(smoke, desc.smoke.particles, smoketrace::test::all_of(desc.smoke.particles.size()),
                  desc.light.direction, settings, HitSort::adaptive, t);
    return {depths.lengths(), depths.status(), depths.hit_counts()};
}

const char* status_word(DepthStatus s) {
    return s == DepthStatus::ok ? "ok" : s == DepthStatus::occluded ? "occluded" : "cutoff";
}

// The "name=value" lines of a --timings report, from its start to the line `until` (exclusive; "" for the end),
// as numbers. A value that is not a whole number (the faults) or a decimal fails the test.
std::map<std::string, double> timing_fields(const std::string& report, const std::string& until = "") {
    std::map<std::string, double> fields;
    std::istringstream in(report);
    for (std::string line; std::getline(in, line);) {
        if (!until.empty() && line.rfind(until, 0) == 0) break;
        const std::size_t eq = line.find('=');
        if (eq == std::string::npos || line.find(' ') != std::string::npos) continue;  // "frame=0 tlas=rebuild"
        const std::string name = line.substr(0, eq), value = line.substr(eq + 1);
        INFO(line);
        char* end = nullptr;
        const double v = std::strtod(value.c_str(), &end);
        REQUIRE((!value.empty() && *end == '\0'));
        if (name.find("_faults") != std::string::npos)
            REQUIRE(value.find_first_not_of("0123456789") == std::string::npos);
        fields[name] = v;
    }
    return fields;
}

// What the children this process has waited for have spent so far (RUSAGE_CHILDREN).
ProcessUsage children_usage() {
    rusage u{};
    REQUIRE(::getrusage(RUSAGE_CHILDREN, &u) == 0);
    const auto ms = [](const timeval& t) { return double(t.tv_sec) * 1e3 + double(t.tv_usec) * 1e-3; };
    return {ms(u.ru_utime), ms(u.ru_stime), std::int64_t(u.ru_minflt), std::int64_t(u.ru_majflt)};
}

}  // namespace

// Each row: its index in order, the length as a finite number >= 0 (ok) or "inf" (occluded, cutoff), the hit
// count and the status word, all equal to the library's answer for the same scene. "%.9g" prints a float so
// that it reads back as the same float, so the lengths are compared bit for bit.
TEST_CASE("cli: depths writes one CSV row per particle", "[cli]") {
    TempDir dir;
    // minimal.json (every particle ok), and a scene with every status: a roof over x < 0 occludes the
    // particles under it, a column of four overlapping particles crosses more than --cutoff 3 surfaces.
    const fs::path statuses = dir.write("statuses.json", R"({
        "light": { "direction": [0, 1, 0] },
        "smoke": { "particles": [
            { "center": [-2, 0, 0], "radius": 0.5 }, { "center": [-1, 0.5, 0.5], "radius": 0.4 },
            { "center": [2, 0, 0], "radius": 0.5 }, { "center": [2, 0.6, 0], "radius": 0.5 },
            { "center": [2, 1.2, 0], "radius": 0.5 }, { "center": [2, 1.8, 0], "radius": 0.5 },
            { "center": [4, 0, 0], "radius": 0.5 }, { "center": [4.3, 0.7, 0.2], "radius": 0.6 } ] },
        "ground": { "corners": [[-8, 3, 8], [0, 3, 8], [0, 3, -8], [-8, 3, -8]] } })");
    struct Run {
        fs::path scene;
        std::uint32_t cutoff;
    };
    std::size_t seen[3] = {0, 0, 0};  // rows per status, over both runs
    for (const Run& run : {Run{kScene, 0}, Run{statuses, 3}}) {
        INFO("scene " << run.scene << ", cutoff " << run.cutoff);
        const fs::path out = dir.path / "d.csv";
        const CliRun r = run_cli("depths " + run.scene.string() + " -o " + out.string() +
                                 (run.cutoff ? " --cutoff " + std::to_string(run.cutoff) : std::string()));
        INFO(r.err);
        REQUIRE(r.exit_code == 0);
        std::string header;
        const std::vector<CsvRow> rows = read_depths_csv(out, header);
        REQUIRE(header == "particle,optical_path_length,hits,status");

        const SceneDescription desc = load_scene_file(run.scene);
        const Depths want = library_depths(desc, run.cutoff, desc.smoke.kernel);  // the scene's: the default
        REQUIRE(rows.size() == desc.smoke.particles.size());
        for (std::size_t i = 0; i < rows.size(); ++i) {
            const CsvRow& row = rows[i];
            INFO("row " << i << ": " << row.index << "," << row.length << "," << row.hits << "," << row.status);
            CHECK(row.index == std::to_string(i));
            CHECK(row.status == status_word(want.status[i]));
            CHECK(row.hits == std::to_string(want.hit_counts[i]));
            if (want.status[i] == DepthStatus::ok) {
                char* end = nullptr;
                const float l = std::strtof(row.length.c_str(), &end);
                REQUIRE(end == row.length.c_str() + row.length.size());  // the whole field is one number
                CHECK(std::isfinite(l));
                CHECK(l >= 0.0f);
                CHECK(std::bit_cast<std::uint32_t>(l) == std::bit_cast<std::uint32_t>(want.lengths[i]));
            } else {
                CHECK(row.length == "inf");  // "fully dark" (kFullyDarkPathLength)
            }
            ++seen[int(want.status[i])];
        }
        fs::remove(out);
    }
    CHECK(seen[int(DepthStatus::ok)] >= 5);
    CHECK(seen[int(DepthStatus::occluded)] == 2);
    CHECK(seen[int(DepthStatus::cutoff)] >= 1);
}

// FNV-1a 64 of a file's bytes.
std::uint64_t fnv1a(const std::string& bytes) {
    std::uint64_t hash = 1469598103934665603ull;
    for (const char c : bytes) {
        hash ^= std::uint8_t(c);
        hash *= 1099511628211ull;
    }
    return hash;
}

TEST_CASE("cli: depths --kernel uniform writes the CSV of before the kernels, byte for byte", "[cli]") {
    // FNV-1a 64 of `depths two_tubes_above.json` (the scene's cutoff 60) and of the same with --shape
    // icosahedron, written by the commit before density kernels existed. --kernel uniform and a scene file
    // saying "kernel": "uniform" must still write those bytes (the default is now poly1: other bytes).
    TempDir dir;
    const std::string above = std::string(SMOKETRACE_ASSET_DIR) + "/scenes/two_tubes_above.json";
    std::string text = file_bytes(above);
    const auto at = text.find("\"shape\": \"sphere\"");
    REQUIRE(at != std::string::npos);
    text.insert(at, "\"kernel\": \"uniform\", ");
    const fs::path with_kernel = dir.write("uniform.json", text);
    struct Run {
        std::string args;
        std::uint64_t hash;
    };
    for (const Run& run : {Run{above + " --kernel uniform", 13216367947350250666ull},
                           Run{with_kernel.string(), 13216367947350250666ull},
                           Run{above + " --kernel uniform --shape icosahedron", 13359516651570021001ull}}) {
        const fs::path out = dir.path / "d.csv";
        const CliRun r = run_cli("depths " + run.args + " -o " + out.string());
        INFO(run.args << ": " << r.err);
        REQUIRE(r.exit_code == 0);
        CHECK(fnv1a(file_bytes(out)) == run.hash);
    }
}

TEST_CASE("cli: depths --kernel gaussian writes the library's sums, with the uniform run's statuses and hits",
          "[cli]") {
    TempDir dir;
    const std::string above = std::string(SMOKETRACE_ASSET_DIR) + "/scenes/two_tubes_above.json";
    const SceneDescription desc = load_scene_file(above);
    const Depths uniform = library_depths(desc, desc.render.cutoff);
    for (const DensityKernel& kernel : {kGaussianKernel, kPoly1Kernel, kPoly2Kernel}) {
        const fs::path out = dir.path / (kernel.name() + ".csv");
        const CliRun r = run_cli("depths " + above + " --kernel " + kernel.name() + " -o " + out.string());
        INFO(kernel.name() << ": " << r.err);
        REQUIRE(r.exit_code == 0);
        std::string header;
        const std::vector<CsvRow> rows = read_depths_csv(out, header);
        const Depths want = library_depths(desc, desc.render.cutoff, kernel);
        REQUIRE(rows.size() == desc.smoke.particles.size());
        std::size_t ok = 0;
        double sum = 0, uniform_sum = 0;
        for (std::size_t i = 0; i < rows.size(); ++i) {
            INFO("row " << i);
            CHECK(want.status[i] == uniform.status[i]);
            CHECK(want.hit_counts[i] == uniform.hit_counts[i]);
            CHECK(rows[i].status == status_word(want.status[i]));
            CHECK(rows[i].hits == std::to_string(want.hit_counts[i]));
            if (want.status[i] != DepthStatus::ok) {
                CHECK(rows[i].length == "inf");
                continue;
            }
            ++ok;
            const float l = std::strtof(rows[i].length.c_str(), nullptr);
            CHECK(std::bit_cast<std::uint32_t>(l) == std::bit_cast<std::uint32_t>(want.lengths[i]));
            sum += l;
            uniform_sum += uniform.lengths[i];
        }
        CHECK(ok > 700);
        // The puff fills about a third of its ball: on the whole the rays see far less smoke (one by one they
        // need not: a kernel's peak exceeds 1, and overlaps add).
        CHECK(sum < 0.6 * uniform_sum);
    }
}

TEST_CASE("cli: depths --path textbook writes textbook::optical_depths, with the fast pass's statuses and hits",
          "[cli][textbook]") {
    // The lengths bit for bit as the library's textbook path gives them ("%.9g" reads back as the same float);
    // the fast pass's within float rounding (tests/test_textbook_optical_depth.cpp), here only its rows' words.
    TempDir dir;
    const std::string above = std::string(SMOKETRACE_ASSET_DIR) + "/scenes/two_tubes_above.json";
    const SceneDescription desc = load_scene_file(above);
    std::optional<GroundQuad> ground;
    if (desc.ground) ground = GroundQuad{desc.ground->corners};
    SmokeScene smoke(desc.smoke.particles, desc.smoke.shape, ground, /*billboards=*/false);
    smoke.update(desc.smoke.particles, desc.camera.position);
    for (const DensityKernel& kernel : {kUniformKernel, kPoly1Kernel}) {
        std::string header;
        const fs::path book_csv = dir.path / "textbook.csv", fast_csv = dir.path / "fast.csv";
        for (const auto& [out, path] : {std::pair{book_csv, " --path textbook"}, std::pair{fast_csv, " --path fast"}}) {
            const CliRun r = run_cli("depths " + above + " --kernel " + kernel.name() + path + " -o " + out.string());
            INFO(kernel.name() << path << ": " << r.err);
            REQUIRE(r.exit_code == 0);
        }
        const std::vector<CsvRow> book = read_depths_csv(book_csv, header), fast = read_depths_csv(fast_csv, header);
        const textbook::OpticalDepths want =
            textbook::optical_depths(smoke, desc.smoke.particles, smoketrace::test::all_of(desc.smoke.particles.size()),
                                     desc.light.direction, desc.render.cutoff, kernel);
        REQUIRE(book.size() == desc.smoke.particles.size());
        REQUIRE(fast.size() == book.size());
        for (std::size_t i = 0; i < book.size(); ++i) {
            INFO(kernel.name() << " row " << i);
            CHECK(book[i].status == status_word(want.status[i]));
            CHECK(book[i].hits == std::to_string(want.hit_counts[i]));
            CHECK(book[i].status == fast[i].status);
            CHECK(book[i].hits == fast[i].hits);
            if (want.status[i] != DepthStatus::ok) continue;
            const float l = std::strtof(book[i].length.c_str(), nullptr);
            CHECK(std::bit_cast<std::uint32_t>(l) == std::bit_cast<std::uint32_t>(want.lengths[i]));
        }
    }
    // A value that is no path, and the fast pass's own knobs, are refused before any work.
    for (const auto& [bad, expect] : {std::pair{" --path slow", "--path: 'slow' is not one of textbook, fast"},
                                      std::pair{" --path textbook --sort std", "--sort"},
                                      std::pair{" --path textbook --timings", "--timings"}}) {
        const fs::path out = dir.path / "refused.csv";
        const CliRun r = run_cli("depths " + above + bad + " -o " + out.string());
        INFO(bad << ": " << r.err);
        CHECK(r.exit_code == 2);
        CHECK_THAT(r.err, Catch::Contains(expect));
        CHECK_FALSE(fs::exists(out));
    }
}

// --timings: beside each stage's wall time, what the process spent in it, as lines a script can read. The
// counts are checked against what they must be: a stage that allocates fresh memory faults, no stage uses more
// CPU than its threads had, the stages together fault no more than the whole process did (getrusage() of the
// child), and render's total covers its stages.
TEST_CASE("cli: --timings gives each stage's CPU time and page faults", "[cli][timings]") {
    TempDir dir;
    // 50000 particles (the tubes' generator: no list to write), uniform kernel: the hits are kept, in memory.
    const fs::path scene = dir.write("tubes.json", R"({ "light": { "direction": [0, 1, 0] },
        "smoke": { "tubes": { "count": 50000, "particle_radius": 0.043 }, "kernel": "uniform" },
        "ground": { "corners": [[-5, -3, -5], [-5, -3, 5], [5, -3, 5], [5, -3, -5]] } })");
    const fs::path csv = dir.path / "depths.csv";
    const ProcessUsage before = children_usage();
    const CliRun r = run_cli_stdout("depths " + scene.string() + " -o " + csv.string() + " --threads 2 --timings");
    const ProcessUsage child = children_usage() - before;
    INFO(r.out << r.err);
    REQUIRE(r.exit_code == 0);
    const std::map<std::string, double> f = timing_fields(r.out);
    double stage_faults = 0.0;
    for (const char* stage : {"read_scene", "tlas_update", "od_pass", "resolve", "write_csv"}) {
        INFO(stage);
        const std::string s = stage;
        for (const char* field : {"", ".user_ms", ".system_ms", ".minor_faults", ".major_faults"}) {
            INFO(field);
            REQUIRE(f.count(s + (*field ? field : "")) == 1);
            CHECK(f.at(s + (*field ? field : "")) >= 0.0);
        }
        // Two worker threads, and a millisecond for the clock and the counters read at slightly other instants.
        CHECK(f.at(s + ".user_ms") + f.at(s + ".system_ms") <= 2.0 * f.at(s) + 1.0);
        stage_faults += f.at(s + ".minor_faults");
    }
    // 50000 particles of 40 bytes and the scene's instances and TLAS: fresh pages in both stages.
    CHECK(f.at("read_scene.minor_faults") > 0.0);
    CHECK(f.at("tlas_update.minor_faults") > 0.0);
    CHECK(stage_faults <= double(child.minor_faults));

    const fs::path png = dir.path / "frame.png";
    const CliRun v = run_cli_stdout("render " + kScene + " -o " + png.string() + " --size 32x32 --frames 2 --timings");
    INFO(v.out << v.err);
    REQUIRE(v.exit_code == 0);
    const std::map<std::string, double> frame0 = timing_fields(v.out, "frame=1");
    REQUIRE(frame0.count("total.minor_faults") == 1);
    for (const char* field : {".user_ms", ".system_ms", ".minor_faults", ".major_faults"}) {
        INFO(field);
        double sum = 0.0;
        for (const char* stage : {"tlas_update", "od_pass", "resolve", "view"})
            sum += frame0.at(stage + std::string(field));
        // Each printed with 3 decimals: four roundings of at most 0.0005 each.
        CHECK(frame0.at("total" + std::string(field)) + 0.002 >= sum);
    }
    CHECK(timing_fields(v.out.substr(v.out.find("\nmedian\n") + 1)).count("view.minor_faults") == 1);
}

TEST_CASE("cli: bad arguments and files name the problem and leave no output", "[cli]") {
    TempDir dir;
    const fs::path csv = dir.path / "out.csv";
    const fs::path png = dir.path / "out.png";
    struct Case {
        std::string args, expect;
    };
    const fs::path broken = dir.write("broken.json", "{ \"light\": { \"direction\": [0, 1, ");
    const fs::path bad_radius = dir.write("radius.json",
        R"({"light":{"direction":[0,1,0]},"smoke":{"particles":[{"center":[0,0,0],"radius":-1}]}})");
    const fs::path zero_light = dir.write("light.json",
        R"({"light":{"direction":[0,0,0]},"smoke":{"particles":[]}})");
    const Case cases[] = {
        {"depths " + kScene + " -o " + csv.string() + " --bogus", "unknown option '--bogus'"},
        {"depths " + kScene + " -o " + csv.string() + " --threads 0", "--threads"},
        {"depths " + kScene + " -o " + csv.string() + " --cutoff abc", "--cutoff"},
        {"depths " + kScene + " -o " + csv.string() + " --shape cube", "--shape"},
        {"depths " + kScene + " -o " + csv.string() + " --kernel cubic",
         "--kernel: 'cubic' is not one of uniform, gaussian, poly1, poly2"},
        {"render " + kScene + " -o " + png.string() + " --kernel Gaussian", "--kernel"},
        {"depths " + kScene, "missing -o"},
        {"depths -o " + csv.string(), "missing scene file"},
        {"render -o " + png.string(), "missing scene file"},
        {"render -o " + png.string() + " --frames 2", "missing scene file"},
        {"depths " + (dir.path / "missing.json").string() + " -o " + csv.string(), "missing.json"},
        {"depths " + broken.string() + " -o " + csv.string(), "broken.json"},
        {"depths " + bad_radius.string() + " -o " + csv.string(), "/smoke/particles/0/radius"},
        {"depths " + zero_light.string() + " -o " + csv.string(), "/light/direction"},
        {"depths " + kScene + " -o " + (dir.path / "no" / "such" / "dir.csv").string(), "does not exist"},
        {"render " + kScene + " -o " + png.string() + " --size 0x0", "--size"},
        {"render " + kScene + " -o " + png.string() + " --size 12", "WxH"},
        {"render " + kScene + " -o " + png.string() + " --mode fancy", "--mode"},
        {"render " + kScene + " -o " + png.string() + " --frames -3", "--frames"},
        {"render " + kScene + " -o " + png.string() + " --frames 5:2", "--frames 5:2: A must be less than B"},
        {"render " + kScene + " -o " + png.string() + " --frames 3:3", "--frames 3:3: A must be less than B"},
        {"render " + kScene + " -o " + png.string() + " --frames 0:2",
         "--frames 0:2: B is beyond the 1 frames of the sequence (the scene's render.frames)"},
        {"render " + kScene + " -o " + png.string() + " --frames x:2", "--frames A:B: A: 'x' is not a whole number"},
        {"render " + kScene + " -o " + png.string() + " --frames 1:", "--frames A:B: B: '' is not a whole number"},
        {"render " + kScene + " -o " + png.string() + " --frames -1:2", "--frames A:B: A: -1 is out of range"},
        {"render " + kScene + " -o " + png.string() + " --spp 0", "--spp: 0 is out of range [1, 64]"},
        {"render " + kScene + " -o " + png.string() + " --spp 65", "--spp: 65 is out of range [1, 64]"},
        {"render " + kScene + " -o " + png.string() + " --spp 1.5", "--spp: '1.5' is not a whole number"},
        {"render " + kScene + " -o " + png.string() + " --spp four", "--spp: 'four' is not a whole number"},
        {"render " + kScene + " -o " + png.string() + " --spp", "--spp"},
        {"render " + kScene + " -o " + (dir.path / "nowhere" / "x.png").string(), "does not exist"},
        {"render " + kScene + " -o " + png.string() + " --textures " + (dir.path / "none").string(), "sixway"},
        {"frobnicate", "unknown command"},
    };
    for (const Case& c : cases) {
        INFO(c.args);
        const CliRun r = run_cli(c.args);
        CHECK(r.exit_code != 0);
        CHECK(r.err.find(c.expect) != std::string::npos);
        CHECK_FALSE(fs::exists(csv));
        CHECK_FALSE(fs::exists(png));
    }
    // Nothing at all is left in the folder but the inputs (no temporary files either).
    for (const auto& e : fs::directory_iterator(dir.path)) CHECK(e.path().extension() == ".json");
}

TEST_CASE("cli: an output folder that cannot be written is an error, not a crash", "[cli]") {
    TempDir dir;
    // A "folder" that is a regular file fails for every user, root included.
    const fs::path file = dir.write("plain.txt", "x");
    CliRun r = run_cli("depths " + kScene + " -o " + (file / "d.csv").string());
    CHECK(r.exit_code != 0);
    CHECK(r.err.find("d.csv") != std::string::npos);
    // A read-only folder: only meaningful for a user that permissions apply to (CI runs as root).
    if (::geteuid() != 0) {
        const fs::path ro = dir.path / "ro";
        fs::create_directories(ro);
        fs::permissions(ro, fs::perms::owner_read | fs::perms::owner_exec);
        r = run_cli("depths " + kScene + " -o " + (ro / "d.csv").string());
        fs::permissions(ro, fs::perms::owner_all);
        CHECK(r.exit_code != 0);
        CHECK(r.err.find("d.csv") != std::string::npos);
    }
}

TEST_CASE("cli: --spp overrides the scene's render.spp", "[cli][spp]") {
    // minimal.json says nothing about spp (1); a copy of it says 4. The option wins over the file both ways, and
    // 4 samples give another image than 1 (the particles' and the ground's edges), so the setting is used.
    TempDir dir;
    std::string text = file_bytes(kScene);
    const auto brace = text.rfind('}');
    REQUIRE(brace != std::string::npos);
    text.insert(brace, ", \"render\": { \"spp\": 4 } ");
    const fs::path four = dir.write("four.json", text);
    REQUIRE(load_scene_file(four).render.spp == 4u);
    const auto render = [&](const fs::path& scene, const std::string& name, const std::string& options) {
        const fs::path out = dir.path / name;
        const CliRun r = run_cli("render " + scene.string() + " -o " + out.string() + " --size 24x24" + options);
        INFO(r.err);
        REQUIRE(r.exit_code == 0);
        return file_bytes(out);
    };
    const std::string file_one = render(kScene, "a.png", "");
    const std::string file_four = render(four, "b.png", "");
    CHECK(render(kScene, "c.png", " --spp 4") == file_four);
    CHECK(render(four, "d.png", " --spp 1") == file_one);
    CHECK(file_one != file_four);
}

// render --frames A:B writes frames A … B-1 of the sequence: the same files, byte for byte, as a full run.
// The sequence has every kind of state a frame inherits: particles that move, spin and grow (jitter,
// spin_speed), a light that turns, and 3 particle groups whose optical depths are each from a different
// frame. 2:5 starts where frame 0's full update is still in use; 5:8 where it is not (frames 0 and 1 trace
// nothing when skipped). The still minimal scene (no motion, a light that stays) keeps frame 0's depths for
// ever: 2:4 must trace it.
TEST_CASE("cli: render --frames A:B writes the full run's frames A to B-1", "[cli][frames]") {
    TempDir dir;
    const auto with_render = [&](const std::string& scene, const std::string& name, const std::string& render) {
        std::string text = file_bytes(scene);
        const auto brace = text.rfind('}');
        REQUIRE(brace != std::string::npos);
        const auto at = text.find("\"render\"");
        if (at != std::string::npos) {
            // Replace the scene's render object (no nested objects in it).
            const auto end = text.find('}', at);
            text.replace(at, end + 1 - at, "\"render\": " + render);
        } else {
            text.insert(brace, ", \"render\": " + render + " ");
        }
        const fs::path path = dir.write(name, text);
        REQUIRE_NOTHROW(load_scene_file(path));
        return path;
    };
    const fs::path tubes = with_render(std::string(SMOKETRACE_ASSET_DIR) + "/scenes/two_tubes_sequence.json",
                                       "tubes.json", R"({ "mode": "full", "groups": 3, "frames": 8 })");
    const fs::path still = with_render(kScene, "still.json", R"({ "frames": 4 })");
    const auto render = [&](const fs::path& scene, const std::string& folder, const std::string& options) {
        fs::create_directories(dir.path / folder);
        const CliRun r = run_cli("render " + scene.string() + " -o " + (dir.path / folder / "f.png").string() +
                                 " --size 20x20 --threads 2" + options);
        INFO(r.err);
        REQUIRE(r.exit_code == 0);
    };
    const auto name = [](std::uint32_t f) {
        char buffer[32];
        std::snprintf(buffer, sizeof buffer, "f_%04u.png", f);
        return std::string(buffer);
    };
    const auto check_range = [&](const fs::path& scene, const std::string& full, std::uint32_t a, std::uint32_t b,
                                 std::uint32_t count) {
        const std::string folder = full + "_" + std::to_string(a);
        render(scene, folder, " --frames " + std::to_string(a) + ":" + std::to_string(b));
        std::size_t files = 0;
        for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir.path / folder)) ++files;
        CHECK(files == b - a);  // only the frames asked for
        for (std::uint32_t f = 0; f < count; ++f) {
            INFO("frame " << f << " of --frames " << a << ":" << b);
            const bool in_range = f >= a && f < b;
            REQUIRE(fs::exists(dir.path / folder / name(f)) == in_range);
            if (in_range) CHECK(file_bytes(dir.path / folder / name(f)) == file_bytes(dir.path / full / name(f)));
        }
    };
    render(tubes, "tubes", "");
    check_range(tubes, "tubes", 2, 5, 8);
    check_range(tubes, "tubes", 5, 8, 8);
    // Frames differ from one another (the check above could not pass with a constant image).
    CHECK(file_bytes(dir.path / "tubes" / name(4)) != file_bytes(dir.path / "tubes" / name(5)));
    render(still, "still", "");
    check_range(still, "still", 2, 4, 4);
}

// One limit for --frames N, --frames A:B and render.frames (kMaxSceneFrames), and frame names with the digits of
// the last frame's number (at least 4), so that `ls` and a glob list them in frame order for any length.
TEST_CASE("cli: --frames has one limit, and frame names sort in frame order", "[cli][frames]") {
    TempDir dir;
    const std::string most = std::to_string(kMaxSceneFrames);
    // Accepted up to the limit: the check after it (standard output takes one frame) is what refuses this run.
    CliRun r = run_cli("render " + kScene + " -o - --frames " + most);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("-o -: standard output takes one frame, not " + most) != std::string::npos);
    r = run_cli("render " + kScene + " -o " + (dir.path / "x.png").string() + " --frames " +
                std::to_string(kMaxSceneFrames + 1));
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("--frames: " + std::to_string(kMaxSceneFrames + 1) + " is out of range [1, " + most + "]") !=
          std::string::npos);

    // The still minimal scene with a sequence of `frames`; the last two frames written (cheap: nothing moves).
    const auto names = [&](std::uint32_t frames, const std::string& range) {
        std::string text = file_bytes(kScene);
        text.insert(text.rfind('}'), ", \"render\": { \"frames\": " + std::to_string(frames) + " } ");
        const fs::path folder = dir.path / std::to_string(frames);
        fs::create_directories(folder);
        const fs::path scene = dir.write("s" + std::to_string(frames) + ".json", text);
        const CliRun run = run_cli("render " + scene.string() + " -o " + (folder / "f.png").string() +
                                   " --size 4x4 --frames " + range);
        INFO(run.err);
        REQUIRE(run.exit_code == 0);
        std::vector<std::string> found;
        for (const auto& e : fs::directory_iterator(folder)) found.push_back(e.path().filename().string());
        std::sort(found.begin(), found.end());
        return found;
    };
    CHECK(names(10000, "9998:10000") == std::vector<std::string>{"f_9998.png", "f_9999.png"});  // 4 digits, as before
    CHECK(names(10001, "9999:10001") == std::vector<std::string>{"f_09999.png", "f_10000.png"});
    CHECK(names(100001, "99999:100001") == std::vector<std::string>{"f_099999.png", "f_100000.png"});
    // --frames N names the same way: N frames numbered 0 … N-1.
    CHECK(names(1, "3") == std::vector<std::string>{"f_0000.png", "f_0001.png", "f_0002.png"});
}

// An extension in any case names the same kind of file: out.PNG is a PNG, a sequence keeps the case.
TEST_CASE("cli: -o takes .png and .svg in any case", "[cli][output]") {
    TempDir dir;
    const fs::path png = dir.path / "out.PNG";
    CliRun r = run_cli("render " + kScene + " -o " + png.string() + " --size 8x8");
    INFO(r.err);
    CHECK(r.exit_code == 0);
    CHECK(file_bytes(png).rfind("\x89PNG\r\n\x1a\n", 0) == 0);
    r = run_cli("render " + kScene + " -o " + (dir.path / "seq.Png").string() + " --size 8x8 --frames 2");
    CHECK(r.exit_code == 0);
    CHECK(fs::exists(dir.path / "seq_0000.Png"));
    CHECK(fs::exists(dir.path / "seq_0001.Png"));
    r = run_cli("explain " + kScene + " --particle 0 -o " + (dir.path / "story.SVG").string());
    CHECK(r.exit_code == 0);
    CHECK(file_bytes(dir.path / "story.SVG").find("<svg") != std::string::npos);
    // Still refused: another extension, and none.
    CHECK(run_cli("render " + kScene + " -o " + (dir.path / "out.jpg").string()).exit_code == 2);
    CHECK(run_cli("render " + kScene + " -o " + (dir.path / "png").string()).exit_code == 2);
    CHECK_FALSE(fs::exists(dir.path / "out.jpg"));
    CHECK_FALSE(fs::exists(dir.path / "png"));
}

// A ground quad is lit on the face the camera sees, whichever way its corners are wound: the same quad wound
// the other way gives the same image, byte for byte (it used to show its unlit back: ambient only). Seen from
// below, with the light above, it is the back that the camera sees: dark in either winding.
TEST_CASE("cli: a ground wound either way is lit on the side the camera sees", "[cli][ground]") {
    TempDir dir;
    const auto scene = [&](const std::string& name, const std::string& corners, const std::string& camera_y) {
        return dir.write(name, R"({ "light": { "direction": [0.3, 1, 0.2] },
            "smoke": { "particles": [ { "center": [0, 0, 0], "radius": 0.5 } ] },
            "ground": { "corners": )" + corners + R"( },
            "camera": { "position": [0, )" + camera_y + R"(, 8], "look_at": [0, -3, 0], "width": 24, "height": 24 } })");
    };
    const std::string ccw = "[[-5,-3,-5], [-5,-3,5], [5,-3,5], [5,-3,-5]]";  // counter-clockwise from above
    const std::string cw = "[[-5,-3,-5], [5,-3,-5], [5,-3,5], [-5,-3,5]]";
    const auto render = [&](const fs::path& s) {
        const fs::path out = dir.path / (s.stem().string() + ".png");
        const CliRun r = run_cli("render " + s.string() + " -o " + out.string());
        INFO(r.err);
        REQUIRE(r.exit_code == 0);
        return file_bytes(out);
    };
    const std::string above_ccw = render(scene("above_ccw.json", ccw, "4"));
    CHECK(render(scene("above_cw.json", cw, "4")) == above_ccw);
    const std::string below_ccw = render(scene("below_ccw.json", ccw, "-9"));
    CHECK(render(scene("below_cw.json", cw, "-9")) == below_ccw);
    // The lit face and the unlit one differ (the checks above could not pass with a ground that is never lit).
    CHECK(load_scene_file(dir.path / "above_cw.json").ground->normal == glm::vec3(0.0f, 1.0f, 0.0f));
    CHECK(load_scene_file(dir.path / "below_ccw.json").ground->normal == glm::vec3(0.0f, -1.0f, 0.0f));
    const Rgba8Image lit = read_png_rgba8(dir.path / "above_cw.png");
    const Rgba8Image back = read_png_rgba8(dir.path / "below_cw.png");
    const auto red = [](const Rgba8Image& image) {  // the red channel at the centre: the ground's centre
        return image.pixels[(std::size_t(image.height / 2) * std::size_t(image.width) + std::size_t(image.width / 2)) * 4];
    };
    CHECK(int(red(lit)) > int(red(back)) + 50);
}

// render -o OUT.apng writes the sequence as one animated PNG: every frame the numbered PNGs hold, in order,
// shown for 1/render.fps s; the same bytes for any thread count; --frames A:B takes those frames alone.
TEST_CASE("cli: render -o OUT.apng writes the sequence as one animated PNG", "[cli][apng]") {
    TempDir dir;
    std::string text = file_bytes(std::string(SMOKETRACE_ASSET_DIR) + "/scenes/two_tubes_sequence.json");
    const auto at = text.find("\"render\"");
    REQUIRE(at != std::string::npos);
    text.replace(at, text.find('}', at) + 1 - at, R"("render": { "mode": "full", "groups": 2, "frames": 4, "fps": 12 })");
    const fs::path scene = dir.write("seq.json", text);
    const auto render = [&](const std::string& out, const std::string& options) {
        const CliRun r = run_cli("render " + scene.string() + " -o " + (dir.path / out).string() + " --size 24x16" +
                                 options);
        INFO(r.err);
        REQUIRE(r.exit_code == 0);
        return r;
    };
    fs::create_directories(dir.path / "frames");
    render("frames/f.png", " --threads 2");
    const CliRun r = render("one.apng", " --threads 1");
    CHECK_THAT(r.err, Catch::Contains("one.apng (4 frames at 12 per second)"));
    render("three.apng", " --threads 3");
    render("part.apng", " --threads 2 --frames 1:3");
    CHECK(file_bytes(dir.path / "one.apng") == file_bytes(dir.path / "three.apng"));

    const auto check_frames = [&](const std::string& file, std::uint32_t first, std::uint32_t count) {
        INFO(file);
        const test::Apng apng = test::read_apng(file_bytes(dir.path / file));  // throws on a broken chunk rule
        REQUIRE(apng.frames.size() == count);
        for (std::uint32_t k = 0; k < count; ++k) {
            char name[32];
            std::snprintf(name, sizeof name, "frames/f_%04u.png", first + k);
            INFO(name);
            const Rgba8Image png = read_png_rgba8(dir.path / name, 24, 16);
            std::vector<std::uint8_t> rgb;
            for (std::size_t i = 0; i < png.pixels.size(); i += 4) rgb.insert(rgb.end(), &png.pixels[i], &png.pixels[i + 3]);
            CHECK(apng.frames[k].rgb == rgb);
            CHECK((apng.frames[k].delay_num == 1 && apng.frames[k].delay_den == 12));
        }
    };
    check_frames("one.apng", 0, 4);
    check_frames("part.apng", 1, 2);
    CHECK(file_bytes(dir.path / "frames/f_0000.png") != file_bytes(dir.path / "frames/f_0003.png"));

    // A bad frame rate is the scene's error: nothing written.
    text.replace(text.find("\"fps\": 12"), 9, "\"fps\": 0");
    const fs::path bad = dir.write("bad.json", text);
    const CliRun e = run_cli("render " + bad.string() + " -o " + (dir.path / "bad.apng").string() + " --size 24x16");
    CHECK(e.exit_code != 0);
    CHECK_THAT(e.err, Catch::Contains("/render/fps"));
    CHECK_FALSE(fs::exists(dir.path / "bad.apng"));
    std::size_t entries = 0;  // the files above and no temporary file
    for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir.path)) ++entries;
    CHECK(entries == 6);  // seq.json, bad.json, frames/, one, three, part
}

// truth and depths --truth read the puff from the textures' sidecar: a small bake keeps them fast.
TEST_CASE("cli: truth writes the image and its bound, depths --truth adds the true optical depths", "[cli][truth]") {
    TempDir dir;
    const fs::path textures = dir.path / "textures";
    fs::create_directories(textures);
    REQUIRE(run_cli("bake-sixway -o " + textures.string() + " --frames 2 --tile 16").exit_code == 0);
    const fs::path scene = dir.write("two.json", R"({
        "light": { "direction": [0.3, 1, 0.2] },
        "smoke": { "particles": [ { "center": [0, 0, 0], "radius": 0.6 }, { "center": [0.2, 0.7, 0], "radius": 0.5 } ],
                   "sigma_t": 3 },
        "ground": { "corners": [[-3, -1, 3], [3, -1, 3], [3, -1, -3], [-3, -1, -3]] },
        "camera": { "position": [0, 1, 6], "look_at": [0, 0, 0], "fov_deg": 40 } })");
    const fs::path image = dir.path / "t.png";
    const CliRun r = run_cli_stdout("truth " + scene.string() + " -o " + image.string() + " --size 8x8 --spp 1 --assets " +
                             textures.string());
    INFO(r.out << r.err);
    REQUIRE(r.exit_code == 0);
    CHECK(fs::file_size(image) > 0);
    CHECK_THAT(r.out, Catch::Contains("unconverged pixels: "));
    CHECK_THAT(r.out, Catch::Contains("error bound"));
    const CliRun checked = run_cli_stdout("truth " + scene.string() + " -o " + image.string() +
                                          " --size 8x8 --spp 1 --check 4 --assets " + textures.string());
    INFO(checked.out << checked.err);
    CHECK(checked.exit_code == 0);
    CHECK_THAT(checked.out, Catch::Contains("checked 4 pixels (every 4th)") && Catch::Contains("0 above the tolerance"));
    const CliRun both = run_cli("truth " + scene.string() + " -o " + image.string() + " --check 4 --rung six-axis");
    CHECK(both.exit_code == 2);
    CHECK_THAT(both.err, Catch::Contains("--check"));

    const fs::path csv = dir.path / "d.csv";
    const CliRun d = run_cli("depths " + scene.string() + " -o " + csv.string() + " --truth --assets " + textures.string());
    INFO(d.err);
    REQUIRE(d.exit_code == 0);
    std::ifstream in(csv);
    std::string header, line;
    std::getline(in, header);
    CHECK(header == "particle,optical_path_length,hits,status,true_optical_depth");
    const GroundTruth truth(load_scene_file(scene), read_sixway_bake_settings(textures / "sixway.json"), 0, 1, 1);
    const std::vector<double> want = truth.particle_optical_depths();
    for (std::size_t i = 0; std::getline(in, line); ++i) {
        REQUIRE(i < want.size());
        const std::string field = line.substr(line.rfind(',') + 1);
        CHECK(std::strtod(field.c_str(), nullptr) == want[i]);  // shortest round-trip text: the same double
        CHECK(want[i] > 0.0);
    }

    // --rung NAME writes that rung of the ladder instead of the truth: the library's render_ladder() image, bit
    // for bit (PFM holds the float radiance); an unknown rung is a usage error naming the rungs, nothing written.
    const fs::path rung_image = dir.path / "rung.pfm";
    const CliRun rung = run_cli_stdout("truth " + scene.string() + " -o " + rung_image.string() +
                                       " --size 8x8 --spp 1 --rung six-axis --assets " + textures.string());
    INFO(rung.out << rung.err);
    REQUIRE(rung.exit_code == 0);
    CHECK_THAT(rung.out, Catch::Contains("rung six-axis"));
    {
        TruthSettings settings;
        settings.spp = 1;
        const GroundTruth t(load_scene_file(scene), read_sixway_bake_settings(textures / "sixway.json"), 0, 8, 8, settings);
        std::array<ImageRgba, kTruthRungs> rungs;
        (void)t.render_ladder(rungs);
        const ImageRgba written = read_pfm(rung_image);
        const ImageRgba& want_rung = rungs[std::size_t(TruthRung::six_axis)];
        REQUIRE(written.pixels.size() == want_rung.pixels.size());
        for (std::size_t k = 0; k < written.pixels.size(); ++k) {
            CHECK(written.pixels[k].x == want_rung.pixels[k].x);
            CHECK(written.pixels[k].y == want_rung.pixels[k].y);
            CHECK(written.pixels[k].z == want_rung.pixels[k].z);
        }
    }
    const fs::path no_rung = dir.path / "none.png";
    const CliRun unknown = run_cli("truth " + scene.string() + " -o " + no_rung.string() + " --rung nope --assets " +
                                   textures.string());
    CHECK(unknown.exit_code == 2);
    CHECK_THAT(unknown.err, Catch::Contains("--rung") && Catch::Contains("one-transmittance") &&
                                Catch::Contains("bake-extinction"));
    CHECK_FALSE(fs::exists(no_rung));

    // A sidecar without the bake settings: the file and the field are named, nothing is written.
    std::string sidecar = file_bytes(textures / "sixway.json");
    sidecar = sidecar.substr(0, sidecar.find(",\n  \"bake\"")) + "\n}\n";
    dir.write("textures/sixway.json", sidecar);
    fs::remove(image);
    const CliRun bad = run_cli("truth " + scene.string() + " -o " + image.string() + " --size 8x8 --assets " +
                               textures.string());
    CHECK(bad.exit_code == 1);
    CHECK_THAT(bad.err, Catch::Contains("sixway.json") && Catch::Contains("/bake"));
    CHECK_FALSE(fs::exists(image));
}

TEST_CASE("cli: render --path textbook draws the fast path's frames and refuses its options", "[cli][textbook]") {
    // The textbook path is held to the fast one in linear colour (tests/test_textbook_frame.cpp); the 8-bit
    // sRGB images may then differ where a value lies at a rounding boundary, by one step at most.
    constexpr int kMaxStepDifference = 1;
    TempDir dir;
    const std::string sequence = std::string(SMOKETRACE_ASSET_DIR) + "/scenes/two_tubes_sequence.json";
    for (const auto& entry : {std::pair{kScene, std::string(" --mode simple-shadow --spp 4")},
                              std::pair{sequence, std::string(" --frames 3:4 --kernel uniform")}}) {
        const std::string &scene = entry.first, &options = entry.second;  // Clang 14 captures no binding
        INFO(scene << options);
        const auto render = [&](const std::string& name, const std::string& path) {
            const fs::path out = dir.path / name;
            const CliRun r = run_cli("render " + scene + " -o " + out.string() + " --size 32x32" + options + path);
            INFO(r.err);
            REQUIRE(r.exit_code == 0);
            const bool one_frame = options.find("--frames") == std::string::npos;
            return read_png_rgba8(one_frame ? out : dir.path / (out.stem().string() + "_0003.png"), 32, 32);
        };
        const Rgba8Image fast = render("fast.png", ""), textbook = render("textbook.png", " --path textbook");
        int worst = 0;
        for (std::size_t i = 0; i < fast.pixels.size(); ++i)
            worst = std::max(worst, std::abs(int(fast.pixels[i]) - int(textbook.pixels[i])));
        CHECK(worst <= kMaxStepDifference);
        CHECK(render("explicit_fast.png", " --path fast").pixels == fast.pixels);
    }
    for (const std::string& bad : {std::string(" --path textbook --compositor tiled"),
                                   std::string(" --path textbook --timings"), std::string(" --path slow")}) {
        const fs::path out = dir.path / "refused.png";
        const CliRun r = run_cli("render " + kScene + " -o " + out.string() + bad);
        INFO(bad << ": " << r.err);
        CHECK(r.exit_code == 2);
        CHECK(r.err.find(bad.find("slow") != std::string::npos ? "--path" : "textbook") != std::string::npos);
        CHECK(!fs::exists(out));
    }
}
