// The command line as a user meets it: bad input gets a clear message, a non-zero exit, and no output.
#include "support/cli_runner.hpp"

#include <catch2/catch.hpp>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;
using smoketrace::test::CliRun;
using smoketrace::test::run_cli;
using smoketrace::test::TempDir;

namespace {

const std::string kScene = std::string(SMOKETRACE_ASSET_DIR) + "/scenes/minimal.json";

}  // namespace

TEST_CASE("cli: depths writes one CSV row per particle", "[cli]") {
    TempDir dir;
    const fs::path out = dir.path / "d.csv";
    const CliRun r = run_cli("depths " + kScene + " -o " + out.string());
    REQUIRE(r.exit_code == 0);
    std::ifstream in(out);
    std::string header;
    std::getline(in, header);
    REQUIRE(header == "particle,optical_path_length,hits,status");
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
