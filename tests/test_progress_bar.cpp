// Progress on a terminal (apps/cli/progress_bar.hpp): the bar draws the stage the work is in, how far it has
// come and the time left when asked to (a terminal), and nothing otherwise; through the command line, on a
// pseudo-terminal (what a user's terminal is) and into a file (a log).
#include "../apps/cli/progress_bar.hpp"
#include "support/cli_runner.hpp"

#include <catch2/catch.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <pty.h>
#include <string>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

using smoketrace::WorkProgress;
using smoketrace::cli::ProgressBar;
using smoketrace::test::TempDir;

namespace {

const std::string kScene = std::string(SMOKETRACE_ASSET_DIR) + "/scenes/minimal.json";

std::string file_text(std::FILE* f) {
    std::fflush(f);
    std::string text;
    std::rewind(f);
    for (int c; (c = std::fgetc(f)) != EOF;) text += char(c);
    std::fseek(f, 0, SEEK_END);
    return text;
}

// What a run of `smoketrace ARGS` writes to a terminal on standard error: the command runs with its standard
// error on a pseudo-terminal (its standard output to /dev/null) and everything the terminal receives is read.
struct TerminalRun {
    int exit_code = -1;
    std::string terminal;
};
// `columns`: the terminal's width (0: unknown).
TerminalRun run_on_terminal(const std::string& args, unsigned short columns = 0) {
    int master = -1;
    struct winsize size{};
    size.ws_col = columns;
    size.ws_row = columns ? 24 : 0;
    const pid_t child = ::forkpty(&master, nullptr, nullptr, &size);
    REQUIRE(child >= 0);
    if (child == 0) {
        const std::string command = "exec " + std::string(SMOKETRACE_CLI) + " " + args + " >/dev/null";
        ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
        ::_exit(127);
    }
    TerminalRun run;
    char buffer[4096];
    for (ssize_t n; (n = ::read(master, buffer, sizeof buffer)) > 0;) run.terminal.append(buffer, std::size_t(n));
    ::close(master);  // read() ends with EIO once the child has closed its side
    int status = 0;
    ::waitpid(child, &status, 0);
    run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return run;
}

}  // namespace

TEST_CASE("progress bar: a stage's percentage and the time it has left, redrawn while the work goes on",
          "[progress]") {
    std::FILE* out = std::tmpfile();
    REQUIRE(out);
    {
        ProgressBar bar(1, "frame", /*on_terminal=*/true, out);
        WorkProgress* work = bar.work();
        REQUIRE(work != nullptr);
        work->begin("view", 1000);
        work->add(250);
        // The bar redraws on its own: wait (at most 5 s, on a loaded machine) for a line with the count.
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
        while (file_text(out).find("view 25%") == std::string::npos && std::chrono::steady_clock::now() < deadline)
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        const std::string text = file_text(out);
        INFO(text);
        CHECK_THAT(text, Catch::Contains("view 25%, ~"));
        CHECK_THAT(text, Catch::Contains(" left in view"));
    }
    // finish() (here: the destructor) clears the line for what the command prints next.
    CHECK_THAT(file_text(out), Catch::EndsWith("\r\033[K"));
    std::fclose(out);
}

TEST_CASE("progress bar: steps done, and the time left from them", "[progress]") {
    std::FILE* out = std::tmpfile();
    REQUIRE(out);
    ProgressBar bar(4, "frame", true, out);
    bar.step();
    const std::string text = file_text(out);
    INFO(text);
    CHECK_THAT(text, Catch::Contains("] 1/4 frames, "));
    CHECK_THAT(text, Catch::Contains(" left, "));
    CHECK_THAT(text, Catch::Contains("so far\033[K"));
    bar.finish();
    std::fclose(out);
}

TEST_CASE("progress bar: nothing is drawn and nothing counted when not on a terminal", "[progress]") {
    std::FILE* out = std::tmpfile();
    REQUIRE(out);
    {
        ProgressBar bar(3, "frame", /*on_terminal=*/false, out);
        CHECK(bar.work() == nullptr);
        bar.step();
        bar.finish();
    }
    CHECK(file_text(out).empty());
    std::fclose(out);
}

TEST_CASE("progress: render and depths show progress on a terminal and nothing in a log", "[progress][cli]") {
    const TempDir dir;
    const std::string render = "render " + kScene + " --size 16x16 --frames 3 --assets " SMOKETRACE_ASSET_DIR " -o " +
                               (dir.path / "f.png").string();
    const std::string depths = "depths " + kScene + " --repeat 2 -o " + (dir.path / "d.csv").string();
    const TerminalRun r = run_on_terminal(render);
    INFO(r.terminal);
    CHECK(r.exit_code == 0);
    CHECK_THAT(r.terminal, Catch::Contains("] 1/3 frames, "));
    CHECK_THAT(r.terminal, Catch::Contains("] 2/3 frames, "));
    CHECK_THAT(r.terminal, Catch::Contains(" left, "));
    CHECK_THAT(r.terminal, Catch::Contains("\r\033[Kwrote "));  // the bar cleared before the last word
    const TerminalRun d = run_on_terminal(depths);
    INFO(d.terminal);
    CHECK(d.exit_code == 0);
    CHECK_THAT(d.terminal, Catch::Contains("] 1/2 repeats, "));
    CHECK_THAT(d.terminal, Catch::Contains("\r\033[Kwrote "));
    // The same runs into a file: the words, no bar.
    for (const std::string& args : {render, depths}) {
        const smoketrace::test::CliRun logged = smoketrace::test::run_cli(args);
        INFO(logged.err);
        CHECK(logged.exit_code == 0);
        CHECK(logged.err.find('\r') == std::string::npos);
        CHECK(logged.err.find('\033') == std::string::npos);
        CHECK_THAT(logged.err, Catch::StartsWith("wrote "));
    }
}

TEST_CASE("progress: a line never wraps on a narrow terminal", "[progress][cli]") {
    const TempDir dir;
    constexpr unsigned short kColumns = 40;
    const TerminalRun r = run_on_terminal("render " + kScene + " --size 16x16 --frames 3 --assets " SMOKETRACE_ASSET_DIR
                                          " -o " + (dir.path / "f.png").string(), kColumns);
    INFO(r.terminal);
    CHECK(r.exit_code == 0);
    REQUIRE(r.terminal.find("] 1/3 frames") != std::string::npos);  // the bar narrowed to leave room for words
    // Each redraw: "\r", at most kColumns - 1 characters, then "\033[K" (erase the rest of the row).
    std::size_t drawn = 0;
    for (std::size_t at = r.terminal.find('\r'); at != std::string::npos; at = r.terminal.find('\r', at + 1)) {
        const std::size_t end = r.terminal.find("\033[K", at);
        if (end == std::string::npos || r.terminal.find('\r', at + 1) < end) continue;  // not a bar's line
        CHECK(end - at - 1 <= kColumns - 1u);
        ++drawn;
    }
    CHECK(drawn >= 3);
}
