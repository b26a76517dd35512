// The command line's own documentation and where it finds its assets: --version, --help listing every
// option of every command with its default (checked against the options each command really reads, which an
// unknown option's message lists), and the asset search of apps/cli/assets.hpp from a binary copied to a
// folder of its own (the installed layout, the build tree's, neither).
#include "support/cli_runner.hpp"

#include <smoketrace/render/pixel_samples.hpp>
#include <smoketrace/render/sixway_baker.hpp>
#include <smoketrace/render/sixway_texture.hpp>

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <vector>

namespace fs = std::filesystem;
using smoketrace::test::TempDir;

namespace {

struct Run {
    int exit_code;  // -1: killed by a signal
    std::string out, err;
};

std::string read_text(const fs::path& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// Runs a shell command line with SMOKETRACE_ASSETS unset unless `env` sets it; captures stdout and stderr.
Run run(const std::string& command, const std::string& env = "env -u SMOKETRACE_ASSETS") {
    const TempDir capture;
    const fs::path out = capture.path / "out", err = capture.path / "err";
    const int status = std::system((env + " " + command + " >" + out.string() + " 2>" + err.string()).c_str());
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_text(out), read_text(err)};
}

Run cli(const std::string& args) { return run(std::string(SMOKETRACE_CLI) + " " + args); }

const std::string kScene = std::string(SMOKETRACE_ASSET_DIR) + "/scenes/minimal.json";

// The flags a command reads, from the message of an unknown option: "… (the options: -o, --mode, …)".
std::vector<std::string> options_read_by(const std::string& command) {
    // The unknown flag first, then positional arguments for the commands that want them (they are only read;
    // diff wants two).
    const Run r = cli(command + " --no-such-option scene.json other.json");
    REQUIRE(r.exit_code == 2);
    const std::string key = "(the options: ";
    const auto from = r.err.find(key);
    REQUIRE(from != std::string::npos);
    const auto to = r.err.find(')', from);
    REQUIRE(to != std::string::npos);
    std::vector<std::string> flags;
    std::stringstream list(r.err.substr(from + key.size(), to - from - key.size()));
    for (std::string f; std::getline(list, f, ',');) flags.push_back(f.substr(f.find_first_not_of(' ')));
    return flags;
}

// The entry of `flag` in a command's help: from "  FLAG" to the next option or the end, without the last newline.
std::string entry_of(const std::string& help, const std::string& flag) {
    for (std::size_t at = help.find("\n  " + flag); at != std::string::npos; at = help.find("\n  " + flag, at + 1)) {
        const char after = help[at + 3 + flag.size()];
        if (after != ' ' && after != '\n') continue;  // "--frames" is not "--frame"
        auto next = help.find("\n  -", at + 1);
        if (next == std::string::npos) next = help.size() - (help.ends_with('\n') ? 1 : 0);
        return help.substr(at + 1, next - at - 1);
    }
    return {};
}

// The commands --help lists: "usage: smoketrace NAME …" lines.
std::vector<std::string> listed_commands(const std::string& help) {
    std::vector<std::string> names;
    const std::string key = "\nusage: smoketrace ";
    for (auto at = help.find(key); at != std::string::npos; at = help.find(key, at + 1)) {
        const auto start = at + key.size();
        names.push_back(help.substr(start, help.find_first_of(" \n", start) - start));
    }
    return names;
}

}  // namespace

TEST_CASE("cli help: --version prints the project's version and its kernel level", "[cli]") {
    const Run r = cli("--version");
    CHECK(r.exit_code == 0);
    const std::string first = std::string("smoketrace ") + SMOKETRACE_VERSION + "\n";
    CHECK(r.out.substr(0, first.size()) == first);
    // The second line: the level this process would run, then the binary's levels (test_kernel_levels.cpp).
    CHECK(r.out.substr(first.size()).rfind("kernels: ", 0) == 0);
    CHECK(std::count(r.out.begin(), r.out.end(), '\n') == 2);
}

TEST_CASE("cli help: --help lists every option of every command, each with its default", "[cli]") {
    const Run all = cli("--help");
    REQUIRE(all.exit_code == 0);
    const std::vector<std::string> commands = listed_commands(all.out);
    REQUIRE(commands == std::vector<std::string>{"bake-sixway", "depths", "diff", "explain", "render", "truth"});
    for (const std::string& command : commands) {
        INFO(command);
        const Run one = cli("help " + command);
        REQUIRE(one.exit_code == 0);
        // `help CMD` and `CMD --help` print the same, and --help prints it too.
        CHECK(cli(command + " --help").out == one.out);
        CHECK(all.out.find(one.out) != std::string::npos);
        const std::vector<std::string> flags = options_read_by(command);
        REQUIRE(flags.size() >= 2);  // the fewest: diff's -o and --scale
        for (const std::string& flag : flags) {
            INFO(flag);
            const std::string entry = entry_of(one.out, flag);
            REQUIRE_FALSE(entry.empty());
            CHECK((entry.find("\n      default: ") != std::string::npos ||
                   entry.find("\n      required") != std::string::npos));
        }
        // And nothing more: every option listed is one the command reads.
        std::size_t listed = 0;
        for (auto at = one.out.find("\n  -"); at != std::string::npos; at = one.out.find("\n  -", at + 1)) ++listed;
        CHECK(listed == flags.size());
    }
    // One command's help is that command's only.
    CHECK(entry_of(cli("help depths").out, "--mode").empty());
    CHECK_FALSE(entry_of(cli("help render").out, "--mode").empty());
}

TEST_CASE("cli help: the defaults shown for bake-sixway are the baker's", "[cli]") {
    const smoketrace::SixwayBakeSettings defaults;
    const std::string help = cli("help bake-sixway").out;
    CHECK_THAT(entry_of(help, "--frames"), Catch::EndsWith("default: " + std::to_string(defaults.frames)));
    CHECK_THAT(entry_of(help, "--tile"), Catch::EndsWith("default: " + std::to_string(defaults.tile)));
    CHECK_THAT(entry_of(help, "--seed"), Catch::EndsWith("default: " + std::to_string(defaults.seed)));
}

TEST_CASE("cli help: --spp names the range the renderer takes", "[cli][spp]") {
    const std::string entry = entry_of(cli("help render").out, "--spp");
    CHECK_THAT(entry, Catch::Contains("1…" + std::to_string(smoketrace::kMaxSpp)));
    CHECK_THAT(entry, Catch::EndsWith("default: the scene's render.spp (1)"));
}

TEST_CASE("cli help: help for an unknown command is an error", "[cli]") {
    const Run r = cli("help frobnicate");
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Contains("unknown command 'frobnicate'"));
    CHECK(cli("help render depths").exit_code == 2);
}

TEST_CASE("cli assets: beside the binary, from SMOKETRACE_ASSETS or --assets, else an error naming where it looked",
          "[cli]") {
    // The binary copied into <tmp>/bin: nothing beside it at first.
    const TempDir root;
    fs::create_directories(root.path / "bin");
    const fs::path binary = root.path / "bin" / "smoketrace";
    fs::copy_file(SMOKETRACE_CLI, binary);
    const fs::path png = root.path / "out.png";
    const std::string render = binary.string() + " render " + kScene + " -o " + png.string() + " --size 16x16";

    Run r = run(render);
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Contains("no assets folder"));
    CHECK_THAT(r.err, Catch::Contains((root.path / "share" / "smoketrace").string()));
    CHECK_THAT(r.err, Catch::Contains((root.path / "bin" / "assets").string()));
    CHECK_THAT(r.err, Catch::Contains("SMOKETRACE_ASSETS"));
    CHECK_FALSE(fs::exists(png));

    // Named on the command line or in the environment.
    CHECK(run(render + " --assets " + SMOKETRACE_ASSET_DIR).exit_code == 0);
    CHECK(fs::exists(png));
    fs::remove(png);
    CHECK(run(render, std::string("env SMOKETRACE_ASSETS=") + SMOKETRACE_ASSET_DIR).exit_code == 0);
    CHECK(fs::exists(png));
    fs::remove(png);
    r = run(render, "env SMOKETRACE_ASSETS=" + (root.path / "nowhere").string());
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err,
               Catch::Contains("SMOKETRACE_ASSETS: '" + (root.path / "nowhere").string() + "' is not a folder"));
    r = run(render + " --assets " + SMOKETRACE_ASSET_DIR + " --textures " + SMOKETRACE_ASSET_DIR);
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Contains("give one"));
    CHECK_FALSE(fs::exists(png));

    // The installed layout: <prefix>/share/smoketrace beside <prefix>/bin.
    const fs::path share = root.path / "share" / "smoketrace";
    fs::create_directories(share);
    using smoketrace::kSixwayLayoutFile, smoketrace::kSixwayPositiveFile, smoketrace::kSixwayNegativeFile;
    for (std::string_view f : {kSixwayLayoutFile, kSixwayPositiveFile, kSixwayNegativeFile})
        fs::copy_file(fs::path(SMOKETRACE_ASSET_DIR) / f, share / f);
    CHECK(run(render).exit_code == 0);
    CHECK(fs::exists(png));
}

TEST_CASE("cli help: a mistyped or missing command gets one line and the list of commands, not every option", "[cli]") {
    for (const std::string& args : {std::string("rendr"), std::string("")}) {
        INFO("smoketrace " << args);
        const Run r = cli(args);
        INFO(r.err);
        CHECK(r.exit_code == 2);
        CHECK(r.out.empty());
        CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 2);
        CHECK_THAT(r.err, Catch::Contains("\ncommands: bake-sixway, depths, diff, explain, render, truth ("));
        CHECK_THAT(r.err, !Catch::Contains("--size"));
    }
    CHECK_THAT(cli("rendr").err, Catch::StartsWith("smoketrace: unknown command 'rendr' (did you mean render?)\n"));
    CHECK_THAT(cli("").err, Catch::StartsWith("smoketrace: missing command"));
    CHECK_THAT(cli("frobnicate").err, !Catch::Contains("did you mean"));  // nothing is two edits from it
}

TEST_CASE("cli help: help help says what help does", "[cli]") {
    for (const char* args : {"help help", "help --help"}) {
        const Run r = cli(args);
        CHECK(r.exit_code == 0);
        CHECK_THAT(r.out, Catch::StartsWith("usage: smoketrace help [command]"));
        CHECK(r.err.empty());
    }
}

TEST_CASE("cli: standard output that cannot be written is an error for every command, not exit 0", "[cli]") {
    if (!fs::exists("/dev/full")) {
        WARN("no /dev/full here: skipped");
        return;
    }
    const TempDir dir;
    const fs::path err = dir.path / "err";
    for (const std::string& args :
         {std::string("--help"), std::string("--version"), std::string("help render"), std::string("render --help"),
          std::string("help help"), "explain " + kScene + " --particle 0", "depths " + kScene + " -o -"}) {
        INFO("smoketrace " << args);
        const int status =
            std::system((std::string(SMOKETRACE_CLI) + " " + args + " >/dev/full 2>" + err.string()).c_str());
        const std::string message = read_text(err);
        INFO(message);
        CHECK(WIFEXITED(status));
        CHECK(WEXITSTATUS(status) != 0);
        CHECK_THAT(message, Catch::Contains("standard output"));
    }
}

TEST_CASE("cli: every command says what it wrote, on standard error", "[cli]") {
    const TempDir dir;
    struct Writes {
        std::string args, wrote;
    };
    const std::string csv = (dir.path / "d.csv").string(), png = (dir.path / "r.png").string();
    for (const Writes& w : {Writes{"depths " + kScene + " -o " + csv, "wrote " + csv + " (5 particles)\n"},
                            Writes{"depths " + kScene + " -o -", "wrote the CSV to standard output (5 particles)\n"},
                            Writes{"render " + kScene + " --size 8x8 -o " + png, "wrote " + png + "\n"},
                            Writes{"bake-sixway --frames 1 --tile 4 -o " + dir.path.string(),
                                   "wrote " + (dir.path / "sixway_pos.png").string()}}) {
        INFO("smoketrace " << w.args);
        const Run r = run(std::string(SMOKETRACE_CLI) + " " + w.args, "env SMOKETRACE_ASSETS=" SMOKETRACE_ASSET_DIR);
        CHECK(r.exit_code == 0);
        CHECK_THAT(r.err, Catch::Contains(w.wrote));
        if (w.args.find("-o -") == std::string::npos) CHECK(r.out.empty());
    }
}
