// Kernel levels (core/simd/level.hpp): the level a process runs, SMOKETRACE_SIMD, and the same bytes from
// every level this binary holds and this CPU runs, through the command line as a user meets it. The
// kernels' lanes and traversals at each level are tested against their scalar twins by the kernel test
// programs compiled for each level (tests/CMakeLists.txt: smoketrace_kernel_tests_<level>).
#include <smoketrace/core/simd/level.hpp>

#include "support/cli_runner.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <string>
#include <vector>

using namespace smoketrace;
using smoketrace::test::file_bytes;
using smoketrace::test::run_cli_with;
using smoketrace::test::TempDir;

namespace {

const std::string kAssets = std::string(SMOKETRACE_ASSET_DIR);

// The levels of this binary that this CPU runs: each is tried below.
std::vector<simd::Level> runnable_levels() {
    std::vector<simd::Level> levels;
    for (simd::Level l : simd::levels_in_binary())
        if (simd::cpu_runs(l)) levels.push_back(l);
    return levels;
}

std::string forced(simd::Level level) { return "SMOKETRACE_SIMD=" + std::string(simd::level_name(level)); }

}  // namespace

TEST_CASE("kernel levels: each name reads back, and the binary's levels run in order", "[simd][levels]") {
    for (simd::Level l : {simd::Level::scalar, simd::Level::sse2, simd::Level::avx2, simd::Level::avx512,
                          simd::Level::neon}) {
        CHECK(simd::parse_level(simd::level_name(l)) == l);
    }
    CHECK_FALSE(simd::parse_level("AVX2").has_value());  // the names are lower case, as documented
    CHECK_FALSE(simd::parse_level("").has_value());
    const auto built = simd::levels_in_binary();
    REQUIRE_FALSE(built.empty());
    CHECK(std::is_sorted(built.begin(), built.end()));
    // Unless forced (the ctest entries of the kernel tests force each level), the process runs the highest
    // level of the binary that the CPU runs.
    const simd::Level active = simd::active_level();
    CHECK(std::find(built.begin(), built.end(), active) != built.end());
    CHECK(simd::cpu_runs(active));
    if (std::getenv("SMOKETRACE_SIMD") == nullptr) CHECK(active == runnable_levels().back());
    // A CPU runs every x86 level below one it runs.
    if (simd::cpu_runs(simd::Level::avx512)) CHECK(simd::cpu_runs(simd::Level::avx2));
    if (simd::cpu_runs(simd::Level::avx2)) CHECK(simd::cpu_runs(simd::Level::sse2));
}

TEST_CASE("kernel levels: every level this CPU runs writes the same frame and depths, bit for bit",
          "[simd][levels][cli]") {
    const std::vector<simd::Level> levels = runnable_levels();
    INFO("levels tried: " << levels.size());
    TempDir dir;
    const std::string scene = kAssets + "/scenes/two_tubes_right.json";
    const std::string smooth = kAssets + "/scenes/two_tubes_above.json";
    std::vector<std::string> frames, tiled_frames, depths, kernel_depths;
    for (simd::Level l : levels) {
        const std::string name(simd::level_name(l));
        const std::string png = (dir.path / (name + ".png")).string();
        const std::string one = (dir.path / (name + "_one.png")).string();
        const std::string csv = (dir.path / (name + ".csv")).string();
        const std::string kcsv = (dir.path / (name + "_gauss.csv")).string();
        // The tiled compositor (ray tiles, triangle sieve) and the per-ray one (wide-tree walk), four
        // samples a pixel; the optical depths of stand-ins (bundles, resolver) and of a smooth kernel.
        REQUIRE(run_cli_with(forced(l), "render " + scene + " -o " + png + " --size 160x120 --spp 4").exit_code == 0);
        REQUIRE(run_cli_with(forced(l), "render " + smooth + " -o " + one +
                                            " --size 96x64 --compositor one-traversal --kernel gaussian")
                    .exit_code == 0);
        REQUIRE(run_cli_with(forced(l), "depths " + scene + " -o " + csv + " --shape icosahedron").exit_code == 0);
        REQUIRE(run_cli_with(forced(l), "depths " + smooth + " -o " + kcsv + " --kernel gaussian").exit_code == 0);
        frames.push_back(file_bytes(png));
        tiled_frames.push_back(file_bytes(one));
        depths.push_back(file_bytes(csv));
        kernel_depths.push_back(file_bytes(kcsv));
        REQUIRE_FALSE(frames.back().empty());
        REQUIRE_FALSE(depths.back().empty());
    }
    for (std::size_t i = 1; i < levels.size(); ++i) {
        INFO(simd::level_name(levels[i]) << " against " << simd::level_name(levels[0]));
        CHECK(frames[i] == frames[0]);
        CHECK(tiled_frames[i] == tiled_frames[0]);
        CHECK(depths[i] == depths[0]);
        CHECK(kernel_depths[i] == kernel_depths[0]);
    }
}

TEST_CASE("kernel levels: every level this CPU runs writes the same ground truth and ladder rung, bit for bit",
          "[simd][levels][cli]") {
    // The truth's passes (truth/ground_truth.cpp: the camera march, the light volume, the exact light rays,
    // check()) and a ladder rung's (own light volumes, axis depths); small and coarse, so that each level's
    // run takes seconds: the bytes, not the convergence, are what is compared.
    const std::vector<simd::Level> levels = runnable_levels();
    INFO("levels tried: " << levels.size());
    TempDir dir;
    const std::string scene = kAssets + "/scenes/two_tubes_right.json";
    std::vector<std::string> truths, rungs;
    for (simd::Level l : levels) {
        const std::string name(simd::level_name(l));
        const std::string truth = (dir.path / (name + "_truth.pfm")).string();
        const std::string rung = (dir.path / (name + "_rung.pfm")).string();
        const auto t = smoketrace::test::detail::run_cli(
            "truth " + scene + " -o " + truth + " --size 40x30 --spp 1 --light-spacing 8 --check 5", true, forced(l));
        REQUIRE(t.exit_code == 0);
        const std::size_t found = t.out.find("largest difference");  // check()'s findings, after its time
        REQUIRE(found != std::string::npos);
        REQUIRE(run_cli_with(forced(l), "truth " + scene + " -o " + rung + " --size 24x16 --spp 1 --rung six-axis")
                    .exit_code == 0);
        truths.push_back(file_bytes(truth) + t.out.substr(found, t.out.find('\n', found) - found));
        rungs.push_back(file_bytes(rung));
        REQUIRE_FALSE(rungs.back().empty());
    }
    for (std::size_t i = 1; i < levels.size(); ++i) {
        INFO(simd::level_name(levels[i]) << " against " << simd::level_name(levels[0]));
        CHECK(truths[i] == truths[0]);
        CHECK(rungs[i] == rungs[0]);
    }
}

TEST_CASE("kernel levels: --version names the level the process runs, SMOKETRACE_SIMD's where set",
          "[simd][levels][cli]") {
    for (simd::Level l : runnable_levels()) {
        const auto r = smoketrace::test::detail::run_cli("--version", true, forced(l));
        CHECK(r.exit_code == 0);
        CHECK(r.out.find("kernels: " + std::string(simd::level_name(l)) + " (this binary: ") != std::string::npos);
    }
}

TEST_CASE("kernel levels: SMOKETRACE_SIMD naming no level, or one the binary lacks, stops before any work",
          "[simd][levels][cli]") {
    TempDir dir;
    const std::string out = (dir.path / "x.png").string();
    const std::string scene = kAssets + "/scenes/minimal.json";
    const auto bogus = run_cli_with("SMOKETRACE_SIMD=avx3", "render " + scene + " -o " + out);
    CHECK(bogus.exit_code == 2);
    CHECK(bogus.err.find("SMOKETRACE_SIMD=avx3: no such kernel level (this binary has ") != std::string::npos);
    for (simd::Level l : {simd::Level::scalar, simd::Level::sse2, simd::Level::avx2, simd::Level::avx512,
                          simd::Level::neon}) {
        const auto built = simd::levels_in_binary();
        if (std::find(built.begin(), built.end(), l) != built.end() && simd::cpu_runs(l)) continue;
        const auto r = run_cli_with(forced(l), "render " + scene + " -o " + out);
        INFO(simd::level_name(l));
        CHECK(r.exit_code == 2);
        CHECK(r.err.find(forced(l) + ": ") != std::string::npos);
    }
    CHECK_FALSE(std::filesystem::exists(out));
}
