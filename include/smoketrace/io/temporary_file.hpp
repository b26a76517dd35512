#pragma once
// Temporary files: the hidden file beside an output that write_output() (output_path.hpp) fills and then
// renames into place. While one exists it is listed where a signal handler can find it, so that a signal
// that ends the program (^C, a batch scheduler's SIGTERM at its time limit) removes it too, instead of
// leaving a `.frame_0007.png.tmp…` behind for good.
//
// The list is a fixed table of path strings, each slot guarded by one lock-free atomic: the handler reads
// memory and calls unlink(), both async-signal-safe, and never allocates or takes a lock. A thread holds the
// signals off (pthread_sigmask) while it creates and lists a file, or renames a group, and the handler waits
// for such a slot to settle, so that no file is created unlisted and no group is half renamed when it runs.
#include <filesystem>
#include <span>
#include <string_view>

namespace smoketrace {

class TemporaryFile;
void rename_together(std::span<TemporaryFile* const> files, std::span<const std::filesystem::path> targets);

// One temporary file, created new and removed by the destructor unless it was renamed into place.
class TemporaryFile {
public:
    TemporaryFile() = default;
    TemporaryFile(const TemporaryFile&) = delete;
    TemporaryFile& operator=(const TemporaryFile&) = delete;
    ~TemporaryFile();

    // Creates `path` and opens it for writing; never through anything already lying there (O_EXCL,
    // O_NOFOLLOW). False, with errno set, when it cannot. Call once.
    bool create(const std::filesystem::path& path);
    [[nodiscard]] int fd() const { return fd_; }
    [[nodiscard]] const std::filesystem::path& path() const { return path_; }
    // Closes the descriptor; close()'s result (some file systems report late write errors only there).
    int close();
    // Renames the file onto `target`, which it then no longer removes. False, with errno set, on failure.
    bool rename_to(const std::filesystem::path& target);

private:
    friend void rename_together(std::span<TemporaryFile* const>, std::span<const std::filesystem::path>);
    std::filesystem::path path_;
    int fd_ = -1;
    int slot_ = -1;  // its place in the table; -1 when the table was full (never with this program's writers)
    bool renamed_ = false;
};

// Renames files[i] onto targets[i] for every i, together or not at all: if a rename fails, the targets
// already replaced get their old files back (kept as hard links until then; a target that did not exist
// is removed again) and std::runtime_error names the target and the reason. A signal that arrives
// meanwhile takes effect only once the group is complete or rolled back.
void rename_together(std::span<TemporaryFile* const> files, std::span<const std::filesystem::path> targets);

// A hidden name beside `file` for a temporary file or a backup: ".NAME" + kind + "PID-N", unique per process
// and per call, so two threads (or two processes) writing the same target never share one; NAME is cut so
// that the whole stays within the 255 bytes a file name may have.
[[nodiscard]] std::filesystem::path hidden_name_beside(const std::filesystem::path& file, std::string_view kind);

// Removes every listed temporary file. Async-signal-safe: for a signal handler.
void remove_temporary_files() noexcept;

// For a program (the command line calls it first; the library never does): for each of SIGHUP, SIGINT,
// SIGQUIT, SIGTERM, SIGPIPE, SIGXCPU, SIGXFSZ and the signals of a crash or an abort() (SIGABRT, SIGBUS,
// SIGFPE, SIGILL, SIGSEGV) whose disposition is the default, a handler that removes the temporary files,
// restores the default and raises the signal again, so that the program ends as the signal would have
// ended it (a shell sees status 128 + N). A signal the parent ignores stays ignored; one a sanitizer
// catches stays the sanitizer's.
void remove_temporary_files_on_signals();

}  // namespace smoketrace
