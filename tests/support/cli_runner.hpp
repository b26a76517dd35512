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
};

// Runs `smoketrace ARGS` (shell words), stdout discarded, stderr captured. Each call has its own
// stderr file, so tests running in parallel (ctest -j) never read each other's messages.
inline CliRun run_cli(const std::string& args) {
    static std::atomic<unsigned> serial{0};
    namespace fs = std::filesystem;
    const fs::path err_file =
        fs::temp_directory_path() / ("smoketrace_err_" + std::to_string(::getpid()) + "_" + std::to_string(serial++));
    const std::string cmd = std::string(SMOKETRACE_CLI) + " " + args + " >/dev/null 2>" + err_file.string();
    const int status = std::system(cmd.c_str());
    std::ifstream in(err_file);
    std::stringstream ss;
    ss << in.rdbuf();
    in.close();
    fs::remove(err_file);
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ss.str()};
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
