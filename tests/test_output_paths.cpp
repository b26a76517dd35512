// Output paths (output_path.hpp): an output never destroys what its path names. A regular file is replaced
// whole or not at all, a symbolic link is followed and stays a link, a FIFO or a socket is opened as it is
// (never renamed over or removed), "-" is standard output, and a folder or an input is refused before any
// work. The library functions first, then the command line (depths, render, bake-sixway).
//
// Everything happens in the tests' own temporary folders: a FIFO made here stands in for a device, and no
// test writes to /dev or any other system path.
#include "support/cli_runner.hpp"
#include "support/fixtures.hpp"

#include <smoketrace/io/output_path.hpp>
#include <smoketrace/io/png_io.hpp>
#include <smoketrace/io/temporary_file.hpp>
#include <smoketrace/render/sixway_texture.hpp>

#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <functional>
#include <fstream>
#include <memory>
#include <poll.h>
#include <stdexcept>
#include <string>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <vector>

namespace fs = std::filesystem;
using namespace smoketrace;
using smoketrace::test::CliRun;
using smoketrace::test::file_bytes;
using smoketrace::test::message_of;
using smoketrace::test::run_cli;
using smoketrace::test::run_cli_stdout;
using smoketrace::test::TempDir;

namespace {

const std::string kScene = std::string(SMOKETRACE_ASSET_DIR) + "/scenes/minimal.json";
const std::string kCsvHeader = "particle,optical_path_length,hits,status\n";
const std::string kPngSignature("\x89PNG\r\n\x1a\n", 8);

// A FIFO read or a CLI run that takes longer than this has hung: minimal.json renders in milliseconds.
constexpr auto kDeadline = std::chrono::seconds(60);

// The names in a folder, sorted: what a write left behind (a temporary file would show here).
std::vector<std::string> names_in(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

std::function<void(std::ostream&)> writes(const std::string& text) {
    return [text](std::ostream& out) { out << text; };
}

void make_fifo(const fs::path& p) { REQUIRE(::mkfifo(p.c_str(), 0600) == 0); }

// The read end of a FIFO, opened without waiting for a writer, so that a writer's open() never waits
// either and nothing here can block for good.
struct FifoReader {
    int fd;
    explicit FifoReader(const fs::path& fifo) : fd(::open(fifo.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)) {
        REQUIRE(fd >= 0);
    }
    FifoReader(const FifoReader&) = delete;
    FifoReader& operator=(const FifoReader&) = delete;
    ~FifoReader() { ::close(fd); }
    // Whatever is in the pipe now; false once no writer holds it open and it is empty (or on an error).
    bool read_some(std::string& into) {
        std::array<char, 1 << 16> buf;
        for (;;) {
            const ssize_t n = ::read(fd, buf.data(), buf.size());
            if (n > 0) {
                into.append(buf.data(), std::size_t(n));
                continue;
            }
            if (n < 0 && (errno == EAGAIN || errno == EINTR)) return true;
            return false;  // 0: no writer (yet or any more)
        }
    }
    void wait(int ms) {
        pollfd p{fd, POLLIN, 0};
        (void)::poll(&p, 1, ms);
    }
};

// SIGPIPE ignored for a scope: should a reader give up at its deadline, the writer in this process gets
// EPIPE (an exception) instead of killing the test program. No process is started while it is held.
struct IgnoreSigpipe {
    struct sigaction old{};
    IgnoreSigpipe() {
        struct sigaction ignore{};
        ignore.sa_handler = SIG_IGN;
        ::sigaction(SIGPIPE, &ignore, &old);
    }
    ~IgnoreSigpipe() { ::sigaction(SIGPIPE, &old, nullptr); }
};

// write_output(fifo, write) in this thread while a second thread drains the FIFO, bounded by kDeadline.
std::string write_into_fifo(const fs::path& fifo, const std::function<void(std::ostream&)>& write) {
    IgnoreSigpipe guard;
    auto reader = std::make_unique<FifoReader>(fifo);
    std::atomic<bool> done{false};
    std::string bytes;
    bool timed_out = false;
    std::thread drain([&] {
        const auto start = std::chrono::steady_clock::now();
        // Reads until the writer has finished and the pipe is empty. Before the writer opens the FIFO a read
        // also finds no writer, hence the flag.
        while (reader->read_some(bytes) || !done) {
            if (std::chrono::steady_clock::now() - start > kDeadline) {
                timed_out = true;
                break;
            }
            reader->wait(20);
        }
        reader.reset();  // a writer still writing now gets EPIPE
    });
    std::string error;
    try {
        write_output(fifo, write);
    } catch (const std::exception& e) {
        error = e.what();
    }
    done = true;
    drain.join();
    INFO(error);
    REQUIRE_FALSE(timed_out);
    REQUIRE(error.empty());
    return bytes;
}

struct FifoRun {
    int exit_code;  // -1: killed by a signal, or by this test at the deadline
    std::string err, bytes;
};

// Runs `smoketrace ARGS` in a child process while this thread drains `fifo`; the child is killed at
// kDeadline (a hang fails the test instead of stopping it).
FifoRun run_cli_into_fifo(const std::string& args, const fs::path& fifo, const fs::path& scratch) {
    const fs::path out = scratch / "fifo_run.out", err = scratch / "fifo_run.err";
    const std::string cmd = std::string(SMOKETRACE_CLI) + " " + args + " >" + out.string() + " 2>" + err.string();
    FifoReader reader(fifo);
    const pid_t pid = ::fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
        ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
        ::_exit(127);
    }
    FifoRun run{-1, {}, {}};
    const auto start = std::chrono::steady_clock::now();
    int status = 0;
    for (;;) {
        reader.read_some(run.bytes);
        const pid_t done = ::waitpid(pid, &status, WNOHANG);
        if (done == pid) {
            reader.read_some(run.bytes);  // what the child wrote last
            run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
            break;
        }
        if (std::chrono::steady_clock::now() - start > kDeadline) {
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &status, 0);
            FAIL("smoketrace " << args << " did not finish within the deadline");
        }
        reader.wait(20);
    }
    run.err = file_bytes(err);
    fs::remove(out);
    fs::remove(err);
    return run;
}

// The bytes `smoketrace ARGS -o FILE` writes into a regular file: what any other kind of output must
// receive too.
std::string reference_output(const std::string& command, const std::string& args, const std::string& file_name) {
    TempDir dir;
    const fs::path file = dir.path / file_name;
    const CliRun r = run_cli(command + " -o " + file.string() + " " + args);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    return file_bytes(file);
}

}  // namespace

// ---- The library -------------------------------------------------------------------------------------------

TEST_CASE("output: a new file and a regular file are written whole, a replaced file keeps its mode", "[output]") {
    TempDir dir;
    const fs::path file = dir.path / "a.csv";
    const OutputTarget fresh = resolve_output(file);
    CHECK(fresh.kind == OutputKind::replace);
    CHECK(fresh.file == file);
    write_output(file, writes("first\n"));
    CHECK(file_bytes(file) == "first\n");

    // A private file stays private: the replacement gets its mode bits, not the default ones.
    fs::permissions(file, fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace);
    write_output(file, writes("second\n"));
    CHECK(file_bytes(file) == "second\n");
    CHECK(fs::status(file).permissions() == (fs::perms::owner_read | fs::perms::owner_write));
    CHECK(names_in(dir.path) == std::vector<std::string>{"a.csv"});
}

TEST_CASE("output: a failing write leaves the old file as it was and no temporary file", "[output]") {
    TempDir dir;
    TempDir elsewhere;
    const fs::path file = dir.path / "keep.csv";
    const fs::path far = elsewhere.path / "far.csv";
    std::ofstream(file) << "old contents\n";
    std::ofstream(far) << "far contents\n";
    fs::create_symlink(far, dir.path / "link.csv");
    // A writer that throws half way (after more than the writer's 64 KiB buffer, so bytes did reach the
    // temporary file), and one that leaves the stream failed.
    const std::function<void(std::ostream&)> throws = [](std::ostream& out) {
        out << std::string(200'000, 'x');
        throw std::runtime_error("the writer gave up");
    };
    const std::function<void(std::ostream&)> fails = [](std::ostream& out) {
        out << "partial";
        out.setstate(std::ios::badbit);
    };
    CHECK(message_of([&] { write_output(file, throws); }) == "the writer gave up");
    CHECK(message_of([&] { write_output(file, fails); }).find("keep.csv: write failed") != std::string::npos);
    // Through a link: the temporary file lives (and is removed) in the target's folder.
    CHECK(message_of([&] { write_output(dir.path / "link.csv", throws); }) == "the writer gave up");
    CHECK(message_of([&] { write_output(dir.path / "link.csv", fails); }).find("far.csv") != std::string::npos);
    CHECK(file_bytes(file) == "old contents\n");
    CHECK(file_bytes(far) == "far contents\n");
    CHECK(names_in(dir.path) == std::vector<std::string>{"keep.csv", "link.csv"});
    CHECK(names_in(elsewhere.path) == std::vector<std::string>{"far.csv"});
    CHECK(fs::is_symlink(dir.path / "link.csv"));
}

TEST_CASE("output: a symbolic link, and a chain of two, is followed: the target is replaced, the links stay",
          "[output]") {
    TempDir dir;
    TempDir other;
    const fs::path target = other.path / "target.csv";
    std::ofstream(target) << "old\n";
    // link2 -> link1 (relative) -> target (absolute, in another folder)
    fs::create_symlink(target, dir.path / "link1.csv");
    fs::create_symlink("link1.csv", dir.path / "link2.csv");
    for (const char* name : {"link1.csv", "link2.csv"}) {
        INFO(name);
        const OutputTarget t = resolve_output(dir.path / name);
        CHECK(t.kind == OutputKind::replace);
        CHECK(t.file == target);
        write_output(dir.path / name, writes(std::string("via ") + name + "\n"));
        CHECK(file_bytes(target) == std::string("via ") + name + "\n");
        CHECK(fs::is_symlink(dir.path / "link1.csv"));
        CHECK(fs::read_symlink(dir.path / "link1.csv") == target);
        CHECK(fs::read_symlink(dir.path / "link2.csv") == "link1.csv");
    }
    CHECK(names_in(dir.path) == std::vector<std::string>{"link1.csv", "link2.csv"});
    CHECK(names_in(other.path) == std::vector<std::string>{"target.csv"});

    // A link whose target does not exist yet creates the target, in the link's folder's sub-folder here.
    fs::create_directories(dir.path / "sub");
    fs::create_symlink("sub/new.csv", dir.path / "dangling.csv");
    write_output(dir.path / "dangling.csv", writes("new\n"));
    CHECK(fs::is_symlink(dir.path / "dangling.csv"));
    CHECK(file_bytes(dir.path / "sub" / "new.csv") == "new\n");
    CHECK(names_in(dir.path / "sub") == std::vector<std::string>{"new.csv"});
}

TEST_CASE("output: links to a folder, into a missing folder, and in a loop are refused", "[output]") {
    TempDir dir;
    fs::create_directories(dir.path / "folder");
    fs::create_symlink("folder", dir.path / "to_folder.csv");
    fs::create_symlink("missing/x.csv", dir.path / "to_missing.csv");
    fs::create_symlink("loop_b", dir.path / "loop_a");
    fs::create_symlink("loop_a", dir.path / "loop_b");
    auto refusal = [](const fs::path& p) {
        try {
            (void)resolve_output(p);
        } catch (const OutputPathError& e) {
            return std::string(e.what());
        }
        return std::string("(no OutputPathError)");
    };
    const std::string folder = refusal(dir.path / "to_folder.csv");
    CHECK(folder.find("to_folder.csv: is a directory") != std::string::npos);
    const std::string missing = refusal(dir.path / "to_missing.csv");
    CHECK(missing.find("to_missing.csv (a link to '") != std::string::npos);
    CHECK(missing.find("folder '" + (dir.path / "missing").string() + "' does not exist") != std::string::npos);
    CHECK(refusal(dir.path / "loop_a").find("loop_a") != std::string::npos);
    // Writing is refused the same way, and nothing is created.
    CHECK(message_of([&] { write_output(dir.path / "to_folder.csv", writes("x")); }).find("is a directory") !=
          std::string::npos);
    CHECK(fs::is_empty(dir.path / "folder"));
    CHECK(names_in(dir.path) ==
          std::vector<std::string>{"folder", "loop_a", "loop_b", "to_folder.csv", "to_missing.csv"});
}

TEST_CASE("output: folders, missing folders and files used as folders are refused", "[output]") {
    TempDir dir;
    const fs::path plain = dir.path / "plain.txt";
    std::ofstream(plain) << "x";
    struct Case {
        fs::path path;
        std::string expect;
    };
    const Case cases[] = {
        {dir.path, "is a directory"},
        {dir.path / "no" / "such" / "x.csv", "folder '" + (dir.path / "no" / "such").string() + "' does not exist"},
        {plain / "x.csv", "'" + plain.string() + "' is not a folder"},
        {fs::path(), "empty"},
    };
    for (const Case& c : cases) {
        INFO(c.path);
        std::string message = "(no OutputPathError)";
        try {
            (void)resolve_output(c.path);
        } catch (const OutputPathError& e) {
            message = e.what();
        }
        CHECK(message.find(c.expect) != std::string::npos);
        if (!c.path.empty()) CHECK(message.find(c.path.string()) != std::string::npos);
    }
    CHECK(names_in(dir.path) == std::vector<std::string>{"plain.txt"});
}

TEST_CASE("output: a FIFO is streamed into, never replaced", "[output]") {
    TempDir dir;
    const fs::path fifo = dir.path / "fifo";
    make_fifo(fifo);
    const OutputTarget t = resolve_output(fifo);
    CHECK(t.kind == OutputKind::stream);
    CHECK(t.file == fifo);
    // More than a pipe holds (64 KiB), so the writer must wait for the reader: a stream, not a file.
    std::string text;
    for (int i = 0; text.size() < 1'000'000; ++i) text += std::to_string(i) + "\n";
    CHECK(write_into_fifo(fifo, writes(text)) == text);
    CHECK(fs::is_fifo(fifo));
    // Through a link too; the link stays.
    fs::create_symlink("fifo", dir.path / "link");
    CHECK(resolve_output(dir.path / "link").kind == OutputKind::stream);
    CHECK(write_into_fifo(dir.path / "link", writes("via link\n")) == "via link\n");
    CHECK(fs::is_symlink(dir.path / "link"));
    CHECK(fs::is_fifo(fifo));
    CHECK(names_in(dir.path) == std::vector<std::string>{"fifo", "link"});
}

TEST_CASE("output: a socket is opened, not replaced: the error names it and the socket stays", "[output]") {
    TempDir dir;
    const fs::path path = dir.path / "sock";
    const int s = ::socket(AF_UNIX, SOCK_STREAM, 0);
    REQUIRE(s >= 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    REQUIRE(path.string().size() < sizeof addr.sun_path);
    std::strcpy(addr.sun_path, path.c_str());
    REQUIRE(::bind(s, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0);
    CHECK(resolve_output(path).kind == OutputKind::stream);
    // open() of a socket fails (ENXIO): an error naming it, where a rename would have replaced it.
    const std::string message = message_of([&] { write_output(path, writes("x")); });
    CHECK(message.find(path.string() + ": cannot open for writing") != std::string::npos);
    CHECK(fs::is_socket(path));
    CHECK(names_in(dir.path) == std::vector<std::string>{"sock"});
    ::close(s);
}

TEST_CASE("output: the same file as an input, by any spelling, link or hard link, is refused", "[output]") {
    TempDir dir;
    const fs::path scene = dir.write("scene.json", "{}");
    const fs::path twin = dir.write("twin.json", "{}");  // same bytes, another file
    fs::create_directories(dir.path / "sub");
    fs::create_hard_link(scene, dir.path / "hard.csv");
    fs::create_symlink("scene.json", dir.path / "soft.csv");
    const std::vector<fs::path> inputs{dir.path / "unrelated.json", scene};
    const fs::path same[] = {scene, dir.path / "." / "scene.json", dir.path / "sub" / ".." / "scene.json",
                             dir.path / "hard.csv", dir.path / "soft.csv"};
    for (const fs::path& out : same) {
        INFO(out);
        std::string message = "(no OutputPathError)";
        try {
            check_not_an_input(resolve_output(out), inputs);
        } catch (const OutputPathError& e) {
            message = e.what();
        }
        CHECK(message.find(out.string() + ": is the same file as the input '" + scene.string() + "'") !=
              std::string::npos);
    }
    CHECK_NOTHROW(check_not_an_input(resolve_output(twin), inputs));
    CHECK_NOTHROW(check_not_an_input(resolve_output(dir.path / "new.csv"), inputs));
    CHECK_NOTHROW(check_not_an_input(resolve_output("-"), inputs));
    CHECK(resolve_output("-").kind == OutputKind::standard_output);
    CHECK(file_bytes(scene) == "{}");
}

// ---- Temporary files, signals and groups --------------------------------------------------------------------

namespace {

// The wait status of a child process that runs `body` with the command line's signal handling. Catch2
// catches SIGINT and SIGTERM itself, so the child first puts back the default that a program starts with.
int status_of_child(const std::function<void()>& body) {
    const pid_t pid = ::fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
        for (const int s : {SIGHUP, SIGINT, SIGTERM, SIGABRT}) ::signal(s, SIG_DFL);
        remove_temporary_files_on_signals();
        try {
            body();
        } catch (...) {
            ::_exit(3);
        }
        ::_exit(0);
    }
    int status = 0;
    REQUIRE(::waitpid(pid, &status, 0) == pid);
    return status;
}

// A writer that writes more than the 64 KiB buffer (so that the temporary file holds bytes), then gets `sig`.
std::function<void(std::ostream&)> signalled_while_writing(int sig) {
    return [sig](std::ostream& out) {
        out << std::string(200'000, 'x');
        out.flush();
        ::raise(sig);
    };
}

}  // namespace

TEST_CASE("output: a signal that ends the program while a file is written removes its temporary file",
          "[output][signal]") {
    // SIGABRT: what std::terminate and a failed assertion end in.
    for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGABRT}) {
        INFO("signal " << sig);
        TempDir dir;
        const fs::path file = dir.write("frame_0007.png", "old frame");
        const int status = status_of_child([&] { write_output(file, signalled_while_writing(sig)); });
        // Ended by the signal itself, as a shell reports it (128 + N), not by an exit status of our own.
        CHECK(WIFSIGNALED(status));
        CHECK((WIFSIGNALED(status) ? WTERMSIG(status) : 0) == sig);
        CHECK(names_in(dir.path) == std::vector<std::string>{"frame_0007.png"});
        CHECK(file_bytes(file) == "old frame");
    }
}

TEST_CASE("output: files written together are replaced together or not at all", "[output][group]") {
    TempDir dir;
    const fs::path a = dir.write("a.png", "old a"), b = dir.path / "b.png", c = dir.write("c.json", "old c");
    const std::vector<std::string> before{"a.png", "c.json"};
    auto group = [&](const std::function<void(std::ostream&)>& last) {
        return std::vector<GroupOutput>{
            {resolve_output(a), writes("new a")}, {resolve_output(b), writes("new b")}, {resolve_output(c), last}};
    };

    // The last writer fails: nothing is replaced, and no temporary file remains.
    const std::vector<GroupOutput> failing = group([](std::ostream&) { throw std::runtime_error("bake failed"); });
    CHECK(message_of([&] { write_outputs_together(failing); }) == "bake failed");
    CHECK(names_in(dir.path) == before);
    CHECK(file_bytes(a) == "old a");
    CHECK(file_bytes(c) == "old c");

    // The last rename fails (its target is a folder that is not empty: the rename itself refuses it, for root
    // too): the first two are put back, a.png with its old bytes and b.png, new, removed again.
    fs::create_directories(dir.path / "d.json" / "inside");
    std::vector<GroupOutput> renames = group(writes("new c"));
    renames[2].target = OutputTarget{OutputKind::replace, dir.path / "d.json", dir.path / "d.json"};
    const std::string message = message_of([&] { write_outputs_together(renames); });
    CHECK(message.find((dir.path / "d.json").string() + ": cannot rename into place") != std::string::npos);
    CHECK(message.find("left as they were") != std::string::npos);
    CHECK(names_in(dir.path) == std::vector<std::string>{"a.png", "c.json", "d.json"});
    CHECK(file_bytes(a) == "old a");
    fs::remove_all(dir.path / "d.json");

    // A stream cannot be taken back: refused before anything is written.
    make_fifo(dir.path / "fifo");
    std::vector<GroupOutput> with_stream = group(writes("new c"));
    with_stream[1].target = resolve_output(dir.path / "fifo");
    CHECK(message_of([&] { write_outputs_together(with_stream); }).find("fifo: is not a regular file") !=
          std::string::npos);
    CHECK(file_bytes(a) == "old a");
    fs::remove(dir.path / "fifo");

    // A signal while the last file is written: the program ends, the old files are whole, nothing is left.
    const std::vector<GroupOutput> signalled = group(signalled_while_writing(SIGTERM));
    const int status = status_of_child([&] { write_outputs_together(signalled); });
    CHECK((WIFSIGNALED(status) ? WTERMSIG(status) : 0) == SIGTERM);
    CHECK(names_in(dir.path) == before);
    CHECK(file_bytes(a) == "old a");
    CHECK(file_bytes(c) == "old c");

    // And when all goes well, all three are new.
    write_outputs_together(group(writes("new c")));
    CHECK(names_in(dir.path) == std::vector<std::string>{"a.png", "b.png", "c.json"});
    CHECK(file_bytes(a) + file_bytes(b) + file_bytes(c) == "new anew bnew c");
}

// ---- The command line ----------------------------------------------------------------------------------------

TEST_CASE("output cli: -o - puts the CSV of depths and the PNG of render on standard output", "[output][cli]") {
    const std::string csv = reference_output("depths " + kScene, "", "d.csv");
    REQUIRE(csv.rfind(kCsvHeader, 0) == 0);
    const std::string png = reference_output("render " + kScene, "--size 16x16", "r.png");
    REQUIRE(png.rfind(kPngSignature, 0) == 0);

    CliRun r = run_cli_stdout("depths " + kScene + " -o -");
    INFO(r.err);
    CHECK(r.exit_code == 0);
    CHECK(r.out == csv);
    // --timings goes to standard error then: standard output holds the CSV or the PNG alone.
    r = run_cli_stdout("depths " + kScene + " -o - --timings");
    CHECK(r.exit_code == 0);
    CHECK(r.out == csv);
    CHECK(r.err.find("tlas_update=") != std::string::npos);
    r = run_cli_stdout("render " + kScene + " -o - --size 16x16 --timings");
    CHECK(r.exit_code == 0);
    CHECK(r.out == png);
    CHECK(r.err.find("total=") != std::string::npos);
    // Without -o -, the timings stay on standard output.
    TempDir dir;
    r = run_cli_stdout("render " + kScene + " -o " + (dir.path / "t.png").string() + " --size 16x16 --timings");
    CHECK(r.exit_code == 0);
    CHECK(r.out.find("total=") != std::string::npos);
}

TEST_CASE("output cli: -o - takes one frame: a sequence to standard output is a usage error", "[output][cli]") {
    for (const char* frames : {"2", "24"}) {
        const CliRun r = run_cli_stdout("render " + kScene + " -o - --size 8x8 --frames " + std::string(frames));
        INFO(r.err);
        CHECK(r.exit_code == 2);
        CHECK(r.err.find("-o -: standard output takes one frame, not " + std::string(frames)) != std::string::npos);
        CHECK(r.out.empty());
    }
}

TEST_CASE("output cli: a symbolic link and a chain of two are followed, the links stay", "[output][cli]") {
    const std::string csv = reference_output("depths " + kScene, "", "d.csv");
    const std::string png = reference_output("render " + kScene, "--size 8x8", "r.png");
    TempDir dir;
    TempDir other;
    std::ofstream(other.path / "t.csv") << "old\n";
    std::ofstream(other.path / "t.png") << "old\n";
    fs::create_symlink(other.path / "t.csv", dir.path / "one.csv");
    fs::create_symlink("one.csv", dir.path / "two.csv");
    fs::create_symlink(other.path / "t.png", dir.path / "one.png");
    fs::create_symlink("one.png", dir.path / "two.png");
    for (const char* link : {"one", "two"}) {
        INFO(link);
        std::ofstream(other.path / "t.csv") << "old\n";
        CliRun r = run_cli("depths " + kScene + " -o " + (dir.path / (std::string(link) + ".csv")).string());
        CHECK(r.exit_code == 0);
        CHECK(file_bytes(other.path / "t.csv") == csv);
        std::ofstream(other.path / "t.png") << "old\n";
        r = run_cli("render " + kScene + " --size 8x8 -o " + (dir.path / (std::string(link) + ".png")).string());
        CHECK(r.exit_code == 0);
        CHECK(file_bytes(other.path / "t.png") == png);
    }
    for (const char* link : {"one.csv", "two.csv", "one.png", "two.png"}) CHECK(fs::is_symlink(dir.path / link));
    CHECK(fs::read_symlink(dir.path / "two.png") == "one.png");
    CHECK(names_in(dir.path) == std::vector<std::string>{"one.csv", "one.png", "two.csv", "two.png"});
    CHECK(names_in(other.path) == std::vector<std::string>{"t.csv", "t.png"});
}

TEST_CASE("output cli: a FIFO receives the CSV or the PNG as a stream and stays a FIFO", "[output][cli]") {
    const std::string csv = reference_output("depths " + kScene, "", "d.csv");
    const std::string png = reference_output("render " + kScene, "--size 16x16", "r.png");
    TempDir dir;
    const fs::path fifo = dir.path / "pipe";  // no .png: a single frame into a FIFO may have any name
    make_fifo(fifo);
    FifoRun r = run_cli_into_fifo("depths " + kScene + " -o " + fifo.string(), fifo, dir.path);
    INFO(r.err);
    CHECK(r.exit_code == 0);
    CHECK(r.bytes == csv);
    r = run_cli_into_fifo("render " + kScene + " --size 16x16 -o " + fifo.string(), fifo, dir.path);
    INFO(r.err);
    CHECK(r.exit_code == 0);
    CHECK(r.bytes == png);
    CHECK(fs::is_fifo(fifo));
    CHECK(names_in(dir.path) == std::vector<std::string>{"pipe"});
}

TEST_CASE("output cli: an output that is an input is refused before any work, the input unchanged",
          "[output][cli]") {
    TempDir dir;
    const fs::path scene = dir.path / "scene.json";
    fs::copy_file(kScene, scene);
    const std::string before = file_bytes(scene);
    fs::create_directories(dir.path / "sub");
    fs::create_hard_link(scene, dir.path / "hard.csv");
    fs::create_symlink("scene.json", dir.path / "soft.csv");
    const fs::path spellings[] = {scene, dir.path / "sub" / ".." / "scene.json", dir.path / "hard.csv",
                                  dir.path / "soft.csv"};
    for (const fs::path& out : spellings) {
        INFO(out);
        const CliRun r = run_cli_stdout("depths " + scene.string() + " -o " + out.string() + " --timings");
        INFO(r.err);
        CHECK(r.exit_code == 2);
        CHECK(r.err.find("-o: " + out.string() + ": is the same file as the input '" + scene.string() + "'") !=
              std::string::npos);
        CHECK(r.out.empty());  // no timings: nothing was traced
        CHECK(file_bytes(scene) == before);
    }
    // depths checks before it even reads the scene: a broken scene gets the refusal, not a JSON error.
    const fs::path broken = dir.write("broken.json", "{ not json");
    CliRun r = run_cli("depths " + broken.string() + " -o " + broken.string());
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("is the same file as the input") != std::string::npos);
    CHECK(file_bytes(broken) == "{ not json");

    // render: every frame of a sequence is checked before the first is traced. Frame 1's path is the
    // scene (a hard link): frame 0 is not written and no timings are printed.
    fs::create_hard_link(scene, dir.path / "seq_0001.png");
    r = run_cli_stdout("render " + scene.string() + " -o " + (dir.path / "seq.png").string() +
                       " --size 8x8 --frames 2 --timings");
    INFO(r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("seq_0001.png: is the same file as the input '" + scene.string() + "'") != std::string::npos);
    CHECK(r.out.empty());
    CHECK_FALSE(fs::exists(dir.path / "seq_0000.png"));
    CHECK(file_bytes(scene) == before);

    // render: the six-way textures it reads are inputs too.
    const fs::path textures = dir.path / "textures";
    fs::create_directories(textures);
    for (const std::string_view f : {kSixwayPositiveFile, kSixwayNegativeFile, kSixwayLayoutFile})
        fs::copy_file(fs::path(SMOKETRACE_ASSET_DIR) / f, textures / f);
    for (const std::string_view f : {kSixwayPositiveFile, kSixwayNegativeFile}) {
        const std::string atlas = file_bytes(textures / f);
        r = run_cli("render " + scene.string() + " --size 8x8 --textures " + textures.string() + " -o " +
                    (textures / f).string());
        INFO(r.err);
        CHECK(r.exit_code == 2);
        CHECK(r.err.find("is the same file as the input '" + (textures / f).string() + "'") != std::string::npos);
        CHECK(file_bytes(textures / f) == atlas);
    }
    CHECK(names_in(dir.path) ==
          std::vector<std::string>{"broken.json", "hard.csv", "scene.json", "seq_0001.png", "soft.csv", "sub",
                                   "textures"});
}

TEST_CASE("output cli: the PLY point cloud a scene reads is an input too: -o onto it is refused, it is unchanged",
          "[output][cli]") {
    TempDir dir;
    const std::string ply_text = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                                 "property float z\nproperty float radius\nend_header\n0 0 0 0.5\n0.6 0.1 0 0.4\n";
    const fs::path ply = dir.write("cloud.ply", ply_text);
    const fs::path scene = dir.write("s.json", R"({ "light": { "direction": [0.3, 1, 0.2] },
        "smoke": { "particles": "cloud.ply" } })");
    // Other names of the same file, as the other commands' extensions want them.
    fs::create_hard_link(ply, dir.path / "frame.png");
    fs::create_hard_link(ply, dir.path / "seq_0001.png");
    fs::create_hard_link(ply, dir.path / "story.svg");
    fs::create_symlink("cloud.ply", dir.path / "link.csv");
    struct Case {
        std::string args;
        fs::path out;
    };
    const Case cases[] = {
        {"depths " + scene.string() + " --timings", ply},  // the issue's case: the CSV replaced the cloud
        {"depths " + scene.string() + " --timings", dir.path / "link.csv"},
        {"render " + scene.string() + " --size 8x8 --timings", dir.path / "frame.png"},
        {"render " + scene.string() + " --size 8x8 --frames 2 --timings", dir.path / "seq.png"},
        {"explain " + scene.string() + " --particle 0", dir.path / "story.svg"},
    };
    for (const Case& c : cases) {
        INFO(c.args << " -o " << c.out);
        const CliRun r = run_cli_stdout(c.args + " -o " + c.out.string());
        INFO(r.err);
        CHECK(r.exit_code == 2);
        // Both paths named: the output as given, and the input as the scene names it.
        CHECK(r.err.find("is the same file as the input '" + ply.string() + "'") != std::string::npos);
        CHECK(r.err.find("-o: " + (c.out == dir.path / "seq.png" ? dir.path / "seq_0001.png" : c.out).string()) !=
              std::string::npos);
        CHECK(r.out.empty());  // nothing traced: no timings, no story
        CHECK(file_bytes(ply) == ply_text);
    }
    CHECK(names_in(dir.path) ==
          std::vector<std::string>{"cloud.ply", "frame.png", "link.csv", "s.json", "seq_0001.png", "story.svg"});
    // The scene itself still renders: the refusal is about the output, not the cloud.
    const CliRun ok = run_cli("depths " + scene.string() + " -o " + (dir.path / "d.csv").string());
    INFO(ok.err);
    CHECK(ok.exit_code == 0);
    CHECK(file_bytes(dir.path / "d.csv").rfind(kCsvHeader, 0) == 0);
}

TEST_CASE("output cli: a sequence killed at random moments leaves no temporary file and ends by the signal",
          "[output][cli][signal]") {
    // Each run is killed by SIGINT or SIGTERM at a drawn moment (below); whatever it was doing, the folder then
    // holds only whole frames, and the run ends by the signal (a shell's 128 + N). 40 runs of this small
    // sequence take a few seconds.
    constexpr int kKills = 40;
    constexpr int kFrames = 64;
    const std::string args = "render " + kScene + " --size 24x24 --mode basic --frames " + std::to_string(kFrames) +
                             " --threads 1";
    TempDir dir;
    // Starts the command writing into `out`; the signals it is sent arrive with the defaults a program started
    // from a shell has (Catch2 catches SIGINT and SIGTERM, and a forked copy of it must not).
    auto start = [&](const fs::path& out) {
        sigset_t signals, old;
        sigemptyset(&signals);
        sigaddset(&signals, SIGINT);
        sigaddset(&signals, SIGTERM);
        ::sigprocmask(SIG_BLOCK, &signals, &old);
        const pid_t pid = ::fork();
        if (pid == 0) {
            ::signal(SIGINT, SIG_DFL);
            ::signal(SIGTERM, SIG_DFL);
            ::sigprocmask(SIG_SETMASK, &old, nullptr);
            const int null = ::open("/dev/null", O_WRONLY);
            ::dup2(null, STDOUT_FILENO);
            ::dup2(null, STDERR_FILENO);
            const std::string cmd =
                "exec " + std::string(SMOKETRACE_CLI) + " " + args + " -o " + (out / "frame.png").string();
            ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
            ::_exit(127);
        }
        ::sigprocmask(SIG_SETMASK, &old, nullptr);
        REQUIRE(pid > 0);
        return pid;
    };
    // Polls until `out` holds a whole frame (true), or until the run has ended without one (false: it is then
    // reaped into `status`). A run that does neither within a minute has hung: it is killed and the test fails.
    auto await_first_frame = [&](const fs::path& out, pid_t pid, int& status) {
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(1);
        for (;;) {
            for (const std::string& name : names_in(out))
                if (name.rfind("frame_", 0) == 0) return true;
            if (::waitpid(pid, &status, WNOHANG) == pid) return false;
            if (std::chrono::steady_clock::now() > deadline) {
                ::kill(pid, SIGKILL);
                ::waitpid(pid, &status, 0);
                FAIL("the sequence wrote no frame and did not end within a minute");
            }
            std::this_thread::sleep_for(std::chrono::microseconds(100));
        }
    };
    // Whole runs, timed: how long a run takes, and how long it spends writing frames after its first (most of a
    // run is start-up: loading the textures, building the scene). The fastest of three sets both windows, so
    // that a run slowed by other work on the machine (or a sanitizer build, many times slower) still sees
    // kills spread over its length.
    using us = std::chrono::microseconds;
    auto run_us = us::max(), writing_us = us::max();
    int status = 0;
    for (int i = 0; i < 3; ++i) {
        const fs::path out = dir.path / ("whole" + std::to_string(i));
        fs::create_directories(out);
        const auto t0 = std::chrono::steady_clock::now();
        const pid_t whole = start(out);
        const bool framed = await_first_frame(out, whole, status);
        const auto t1 = std::chrono::steady_clock::now();
        if (framed) REQUIRE(::waitpid(whole, &status, 0) == whole);
        const auto t2 = std::chrono::steady_clock::now();
        run_us = std::min(run_us, std::chrono::duration_cast<us>(t2 - t0));
        writing_us = std::min(writing_us, std::chrono::duration_cast<us>(t2 - t1));
        REQUIRE((WIFEXITED(status) ? WEXITSTATUS(status) : -1) == 0);
        REQUIRE(names_in(out).size() == std::size_t(kFrames));
    }
    // Half the kills come at a moment drawn from the whole run: before, between, during and after frame writes.
    // The other half wait for the first frame and then come at a moment drawn from the writing window, so
    // that the case under test, a run stopped with some frames written and some not, is met however long the
    // start-up took this time.
    std::uint64_t seed = 0x9E3779B97F4A7C15ull;
    auto draw_us = [&](us window) {
        seed = seed * 6364136223846793005ull + 1442695040888963407ull;  // an LCG step: the moments are fixed
        return us((seed >> 33) % std::uint64_t(window.count() + 1));
    };
    int mid_sequence = 0;  // kills that found some frames written and some not
    for (int k = 0; k < kKills; ++k) {
        const fs::path out = dir.path / ("run" + std::to_string(k));
        fs::create_directories(out);
        const int sig = k % 2 ? SIGTERM : SIGINT;
        const bool after_first_frame = (k / 2) % 2 == 1;  // both signals meet both kinds of moment
        const pid_t pid = start(out);
        bool running = true;
        if (after_first_frame) running = await_first_frame(out, pid, status);
        if (running) {
            std::this_thread::sleep_for(draw_us(after_first_frame ? writing_us : run_us));
            ::kill(pid, sig);
            REQUIRE(::waitpid(pid, &status, 0) == pid);
        }
        const std::vector<std::string> names = names_in(out);
        INFO("kill " << k << " (signal " << sig << (after_first_frame ? ", after the first frame" : "")
                     << "): " << names.size() << " files");
        // A run that finished before the kill exits 0; every other ends by the signal it was sent.
        if (WIFEXITED(status)) CHECK(WEXITSTATUS(status) == 0);
        else CHECK((WIFSIGNALED(status) ? WTERMSIG(status) : 0) == sig);
        for (const std::string& name : names) {
            INFO(name);
            CHECK(name.size() == std::string("frame_0000.png").size());
            CHECK(name.rfind("frame_", 0) == 0);
            CHECK(read_png_rgba8(out / name).width == 24);
        }
        if (!names.empty() && names.size() < std::size_t(kFrames)) ++mid_sequence;
    }
    // The test means something only if kills came while frames were being written. Nearly every kill that
    // waited for the first frame does (it misses only when the rest of the run was faster than the fastest
    // reference run's writing); a quarter of all kills leaves room for that.
    INFO("kills that came mid-sequence: " << mid_sequence << "; a whole run took " << run_us.count()
                                          << " us, writing its frames " << writing_us.count() << " us");
    CHECK(mid_sequence >= kKills / 4);
}

TEST_CASE("output cli: an output that is a folder is refused before any work", "[output][cli]") {
    TempDir dir;
    fs::create_directories(dir.path / "taken.csv");
    fs::create_directories(dir.path / "taken.png");
    fs::create_directories(dir.path / "seq_0001.png");
    struct Case {
        std::string args, expect;
    };
    const Case cases[] = {
        {"depths " + kScene + " -o " + (dir.path / "taken.csv").string(), "taken.csv: is a directory"},
        {"render " + kScene + " --size 8x8 -o " + (dir.path / "taken.png").string(), "taken.png: is a directory"},
        {"render " + kScene + " --size 8x8 --frames 2 -o " + (dir.path / "seq.png").string(),
         "seq_0001.png: is a directory"},
    };
    for (const Case& c : cases) {
        INFO(c.args);
        const CliRun r = run_cli(c.args);
        INFO(r.err);
        CHECK(r.exit_code == 2);
        CHECK(r.err.find("-o: ") != std::string::npos);
        CHECK(r.err.find(c.expect) != std::string::npos);
    }
    CHECK(names_in(dir.path) == std::vector<std::string>{"seq_0001.png", "taken.csv", "taken.png"});
    for (const auto& e : fs::directory_iterator(dir.path)) CHECK(fs::is_empty(e.path()));
}

TEST_CASE("output cli: bake-sixway checks its three files before baking and follows links", "[output][cli]") {
    TempDir dir;
    // sixway_pos.png a folder: refused before baking, nothing written.
    fs::create_directories(dir.path / std::string(kSixwayPositiveFile));
    CliRun r = run_cli("bake-sixway -o " + dir.path.string() + " --frames 1 --tile 4");
    INFO(r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find(std::string(kSixwayPositiveFile) + ": is a directory") != std::string::npos);
    CHECK(names_in(dir.path) == std::vector<std::string>{std::string(kSixwayPositiveFile)});
    fs::remove(dir.path / std::string(kSixwayPositiveFile));

    // sixway.json a link into another folder: the target is written, the link stays.
    TempDir other;
    fs::create_symlink(other.path / "layout.json", dir.path / std::string(kSixwayLayoutFile));
    r = run_cli("bake-sixway -o " + dir.path.string() + " --frames 1 --tile 4");
    INFO(r.err);
    CHECK(r.exit_code == 0);
    CHECK(fs::is_symlink(dir.path / std::string(kSixwayLayoutFile)));
    CHECK(file_bytes(other.path / "layout.json").find("\"format\": \"smoketrace-sixway\"") != std::string::npos);
    CHECK(read_png_rgba8(dir.path / std::string(kSixwayPositiveFile)).width == 4);
    CHECK(names_in(other.path) == std::vector<std::string>{"layout.json"});
}
