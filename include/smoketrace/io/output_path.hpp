#pragma once
// Output paths: what writing to the path an -o names means, done so that it never destroys what the path
// is. Every output of the library, the command line and the bench goes through write_output().
//
//   "-"                                  standard output, streamed.
//   an existing file that is not a       opened and written directly, streamed (no temporary file, never
//   regular file (a character device,    renamed over or removed), as `cp` or a shell redirection does.
//   a FIFO, a socket, /dev/stdout on a
//   terminal or a pipe)
//   a regular file, or a new name in an  written whole to a temporary file beside the file, then renamed
//   existing folder                      over it: the file appears whole or not at all, the temporary file
//                                        is removed on every failure, an existing file keeps its mode bits.
//   a symbolic link (or a chain)         followed: its final target is what is written or replaced (in the
//                                        target's folder), the link stays a link; a link whose target
//                                        does not exist yet creates it.
//   a folder                             refused (OutputPathError).
//
// A symbolic link that names this process's standard output (/dev/stdout, /dev/fd/1 when standard output
// is a redirected file) is written as "-": through the shell's own descriptor, so `>>` appends and a
// redirection shared with other commands keeps its order. Other links whose text does not name the file
// they open (the kernel's /proc/self/fd/N entries for pipes, sockets or deleted files) are streamed.
//
// An output that is the same file as an input (another spelling, a link or a hard link of it) is refused
// by check_not_an_input(), which compares device and inode numbers. A temporary file is removed on every
// failure, and also by a signal that ends the program where the program asked for that
// (remove_temporary_files_on_signals(), temporary_file.hpp). Files that belong together (a six-way bake's
// atlases and sidecar) are replaced together or not at all by write_outputs_together().
#include <filesystem>
#include <functional>
#include <ostream>
#include <span>
#include <stdexcept>
#include <string_view>
#include <vector>

namespace smoketrace {

// The output path that means standard output.
inline constexpr std::string_view kStandardOutputPath = "-";

// A path that cannot be an output at all, found before anything is written: a folder, a missing folder, a
// folder that cannot be written in, the same file as an input. The message names the path and the problem.
struct OutputPathError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

enum class OutputKind {
    standard_output,  // "-", or a link naming this process's standard output
    stream,           // an existing file that is not a regular file: opened and written as it is
    replace,          // a regular file or a new one: temporary file beside `file`, renamed over it
};

struct OutputTarget {
    OutputKind kind = OutputKind::replace;
    std::filesystem::path given;  // as the caller spelled it, for messages
    std::filesystem::path file;   // what is opened (stream) or replaced (replace: symbolic links followed)
};

// What writing to `path` means now (see above). Throws OutputPathError naming the path and the problem:
// empty, a folder (also behind a link), its folder (or its link target's folder) missing, not a folder or
// not writable, a loop of symbolic links, or a path the system refuses to look at.
[[nodiscard]] OutputTarget resolve_output(const std::filesystem::path& path);

// Throws OutputPathError naming both paths when `output` is the same file as one of `inputs` (same device
// and inode: another spelling, a symbolic link or a hard link of it). Inputs that do not exist, and
// standard output, are never the same.
void check_not_an_input(const OutputTarget& output, const std::vector<std::filesystem::path>& inputs);

// Calls write(stream) and puts the bytes where `target` says. Throws std::runtime_error naming the path
// and the reason (cannot open, write failed, disk full, cannot rename…); a replaced file is then left as
// it was and no temporary file remains. Output streamed to standard output or a device may have been
// written in part: there is nothing to roll back.
void write_output(const OutputTarget& target, const std::function<void(std::ostream&)>& write);
// resolve_output(path), then the above.
void write_output(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write);

// One file of a group that write_outputs_together() replaces.
struct GroupOutput {
    OutputTarget target;
    std::function<void(std::ostream&)> write;
};

// Writes every output to a temporary file beside its file, then renames them into place together
// (rename_together(), temporary_file.hpp): on any failure, and on a signal meanwhile, every file is left as
// it was and no temporary file remains. Each target must be OutputKind::replace (a stream written in part
// cannot be taken back): OutputPathError names one that is not. Other failures throw std::runtime_error
// naming the file and the reason.
void write_outputs_together(std::span<const GroupOutput> outputs);

}  // namespace smoketrace
