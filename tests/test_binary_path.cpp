// Finding the running binary (apps/cli/binary_path.hpp) where the system does not say: argv[0] resolved as
// execvp() resolves it, against a folder and a PATH made up for the test.
#include "../apps/cli/binary_path.hpp"
#include "support/cli_runner.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;
using smoketrace::cli::binary_from_argv0;
using smoketrace::test::TempDir;

namespace {

// An empty file at `path` with the given permissions (folders above it created).
fs::path make_file(const fs::path& path, fs::perms perms) {
    fs::create_directories(path.parent_path());
    std::ofstream(path) << "";
    fs::permissions(path, perms);
    return path;
}

constexpr fs::perms kExecutable = fs::perms::owner_read | fs::perms::owner_write | fs::perms::owner_exec;
constexpr fs::perms kNotExecutable = fs::perms::owner_read | fs::perms::owner_write;

}  // namespace

TEST_CASE("binary path: a bare argv[0] is the first executable file of that name on PATH", "[cli][binary_path]") {
    const TempDir root;
    const fs::path base = fs::canonical(root.path);
    make_file(base / "a" / "tool", kNotExecutable);  // first on PATH, but execvp() would skip it
    make_file(base / "b" / "tool", kExecutable);
    make_file(base / "c" / "tool", kExecutable);
    const std::string path = (base / "missing").string() + ":" + (base / "a").string() + ":" +
                             (base / "b").string() + ":" + (base / "c").string();

    CHECK(binary_from_argv0("tool", "/", path.c_str()) == base / "b" / "tool");
    CHECK_FALSE(binary_from_argv0("other", "/", path.c_str()));
    CHECK_FALSE(binary_from_argv0("tool", "/", (base / "a").c_str()));
    CHECK_FALSE(binary_from_argv0("tool", base / "c", nullptr));  // PATH not set: a bare name is not a path
    CHECK_FALSE(binary_from_argv0("", base / "c", path.c_str()));
}

TEST_CASE("binary path: an empty PATH entry is the current folder", "[cli][binary_path]") {
    const TempDir root;
    const fs::path base = fs::canonical(root.path);
    make_file(base / "tool", kExecutable);
    for (const char* path : {"", ":/nonexistent", "/nonexistent:", "/nonexistent::/x"}) {
        INFO("PATH=" << path);
        CHECK(binary_from_argv0("tool", base, path) == base / "tool");
    }
    CHECK_FALSE(binary_from_argv0("tool", base, "/nonexistent"));
}

TEST_CASE("binary path: an argv[0] with a '/' is a path, relative ones from the current folder, never searched",
          "[cli][binary_path]") {
    const TempDir root;
    const fs::path base = fs::canonical(root.path);
    make_file(base / "bin" / "tool", kExecutable);
    make_file(base / "elsewhere" / "tool", kExecutable);
    const std::string path = (base / "elsewhere").string();

    CHECK(binary_from_argv0("bin/tool", base, path.c_str()) == base / "bin" / "tool");
    CHECK(binary_from_argv0("./tool", base / "bin", path.c_str()) == base / "bin" / "tool");
    CHECK(binary_from_argv0("../bin/tool", base / "elsewhere", path.c_str()) == base / "bin" / "tool");
    CHECK(binary_from_argv0((base / "bin" / "tool").string(), "/", path.c_str()) == base / "bin" / "tool");
    CHECK_FALSE(binary_from_argv0("./tool", base, path.c_str()));  // not in `base`, and PATH is not searched
    CHECK_FALSE(binary_from_argv0("bin", base, path.c_str()));     // a folder, not a file
}

TEST_CASE("binary path: symbolic links are resolved, so an installed binary reached through one finds its prefix",
          "[cli][binary_path]") {
    const TempDir root;
    const fs::path base = fs::canonical(root.path);
    const fs::path real = make_file(base / "prefix" / "bin" / "smoketrace", kExecutable);
    fs::create_directories(base / "links");
    fs::create_symlink(real, base / "links" / "smoketrace");

    CHECK(binary_from_argv0("smoketrace", "/", (base / "links").c_str()) == real);
    CHECK(binary_from_argv0("links/smoketrace", base, nullptr) == real);
}

TEST_CASE("binary path: the running binary is found without argv[0] where the system says", "[cli][binary_path]") {
    // This test's own binary, through /proc/self/exe on Linux, _NSGetExecutablePath on macOS.
    std::string why;
    const std::optional<fs::path> self = smoketrace::cli::running_binary(nullptr, why);
    INFO(why);
    REQUIRE(self);
    CHECK(fs::is_regular_file(*self));
    CHECK(self->is_absolute());
}
