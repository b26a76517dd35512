#pragma once
// Running the smoketrace binary from a test, and a scratch folder for its inputs and outputs: the command
// line as a user meets it (tests/test_cli.cpp, test_hostile_input.cpp, test_sixway.cpp).
// SMOKETRACE_CLI is the binary's path, defined by tests/CMakeLists.txt.
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <system_error>
#include <unistd.h>

namespace smoketrace::test {

struct CliRun {
    int exit_code;  // -1: killed by a signal (a crash)
    std::string err;
    std::string out = {};  // standard output's bytes (run_cli_stdout only)
};

// A file's bytes, "" when it cannot be read.
inline std::string file_bytes(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

namespace detail {
// Runs `smoketrace ARGS` with stderr, and stdout when `capture_out`, in files of their own, so that tests
// running in parallel (ctest -j) never read each other's output. `environment`: shell assignments put
// before the command ("NAME=value ...").
inline CliRun run_cli(const std::string& args, bool capture_out, const std::string& environment = "") {
    static std::atomic<unsigned> serial{0};
    namespace fs = std::filesystem;
    const std::string stem = "smoketrace_" + std::to_string(::getpid()) + "_" + std::to_string(serial++);
    const fs::path err_file = fs::temp_directory_path() / (stem + ".err");
    const fs::path out_file = fs::temp_directory_path() / (stem + ".out");
    const std::string cmd = environment + (environment.empty() ? "" : " ") + std::string(SMOKETRACE_CLI) + " " + args + " >" +
                            (capture_out ? out_file.string() : std::string("/dev/null")) + " 2>" + err_file.string();
    const int status = std::system(cmd.c_str());
    CliRun run{WIFEXITED(status) ? WEXITSTATUS(status) : -1, file_bytes(err_file)};
    if (capture_out) run.out = file_bytes(out_file);
    std::error_code ec;
    fs::remove(err_file, ec);
    fs::remove(out_file, ec);
    return run;
}
}  // namespace detail

// Runs `smoketrace ARGS` (shell words), stdout discarded, stderr captured.
inline CliRun run_cli(const std::string& args) { return detail::run_cli(args, false); }
// The same, standard output captured too (byte for byte: a PNG written to -o -).
inline CliRun run_cli_stdout(const std::string& args) { return detail::run_cli(args, true); }
// run_cli() with environment variables set for the one run ("NAME=value ...", shell words).
inline CliRun run_cli_with(const std::string& environment, const std::string& args) {
    return detail::run_cli(args, false, environment);
}

// A fresh, empty folder, removed with everything in it (even when a test made it read-only).
struct TempDir {
    std::filesystem::path path;
    TempDir() {
        static std::atomic<unsigned> serial{0};
        path = std::filesystem::temp_directory_path() /
               ("smoketrace_test_" + std::to_string(::getpid()) + "_" + std::to_string(serial++));
        std::filesystem::remove_all(path);
        std::filesystem::create_directories(path);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    ~TempDir() {
        std::error_code ec;
        std::filesystem::permissions(path, std::filesystem::perms::owner_all, std::filesystem::perm_options::add, ec);
        std::filesystem::remove_all(path, ec);
    }
    std::filesystem::path write(const std::string& name, const std::string& text) const {
        std::ofstream(path / name, std::ios::binary) << text;
        return path / name;
    }
};

}  // namespace smoketrace::test
