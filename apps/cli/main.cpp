// smoketrace: command-line entry. Subcommands register themselves (command.hpp).
#include "arguments.hpp"
#include "assets.hpp"
#include "command.hpp"

#include <smoketrace/core/simd/level.hpp>
#include <smoketrace/io/temporary_file.hpp>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <string>
#include <string_view>
#include <vector>

namespace smoketrace::cli {
std::vector<Command>& command_registry() {
    static std::vector<Command> commands;
    return commands;
}
}  // namespace smoketrace::cli

namespace {

using smoketrace::cli::Command;

// One command's usage line, summary and every option with its default.
void print_command_help(std::ostream& out, const Command& c) {
    out << "usage: smoketrace " << c.usage << "\n  " << c.summary << "\n";
    if (c.options.empty()) return;
    out << "options:\n";
    for (const auto& o : c.options) {
        out << "  " << o.flag;
        if (!o.value.empty()) out << " " << o.value;
        out << "\n      " << o.meaning << "\n      ";
        if (o.default_value.empty()) out << "required\n";
        else out << "default: " << o.default_value << "\n";
    }
}

void print_usage(std::ostream& out) {
    out << "usage: smoketrace <command> [arguments]\n"
           "       smoketrace help [command] | <command> --help   this help, or one command's\n"
           "       smoketrace --version                         the version\n"
           "The assets (six-way textures) come from --assets DIR, else the folder in "
        << smoketrace::cli::kAssetsEnvironment
        << ", else share/smoketrace beside an installed binary or assets/ beside a built one.\n\ncommands:\n";
    for (const auto& c : smoketrace::cli::command_registry()) {
        out << "\n";
        print_command_help(out, c);
    }
}

const Command* find_command(std::string_view name) {
    for (const auto& c : smoketrace::cli::command_registry())
        if (c.name == name) return &c;
    return nullptr;
}

// Edits (insertions, deletions, substitutions) that turn `a` into `b`: for "did you mean".
std::size_t edit_distance(std::string_view a, std::string_view b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diagonal = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t above = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diagonal = above;
        }
    }
    return row[b.size()];
}

// A wrong or missing command gets one line saying so and one listing the commands, not every option of every
// command: the user needs the name, and `help` is one word away.
int command_error(const std::string& problem) {
    std::string names;
    for (const auto& c : smoketrace::cli::command_registry())
        names += (names.empty() ? "" : ", ") + std::string(c.name);
    std::cerr << "smoketrace: " << problem << "\ncommands: " << names
              << " (smoketrace help COMMAND: its options; smoketrace help: all of them)\n";
    return 2;
}

int unknown_command(std::string_view name) {
    // Two edits reach every slip of one key or two swapped letters, and no other command's name.
    constexpr std::size_t kMaxSuggestionEdits = 2;
    std::string problem = "unknown command " + smoketrace::cli::quoted_arg(name);
    for (const auto& c : smoketrace::cli::command_registry())
        if (edit_distance(name, c.name) <= kMaxSuggestionEdits) {
            problem += " (did you mean " + std::string(c.name) + "?)";
            break;
        }
    return command_error(problem);
}

constexpr std::string_view kHelpForHelp =
    "usage: smoketrace help [command]  (also: smoketrace --help, smoketrace <command> --help)\n"
    "  every command with its options and their defaults, or one command's\n";

// What a command wrote to standard output must have reached it: `explain ... > /dev/full` or a closed pipe
// fails here (at the flush of stdio's buffer) instead of exiting 0 with the output lost.
int checked_standard_output(std::string_view name, int code) {
    errno = 0;
    std::cout.flush();  // (std::cout writes through stdout: this flushes stdio's buffer)
    const bool flushed = std::fflush(stdout) == 0 && !std::cout.fail();
    const int error = errno;  // the flush's, when it failed; a write that failed earlier left no errno to trust
    if (flushed && !std::ferror(stdout)) return code;
    std::cerr << "smoketrace" << (name.empty() ? "" : " ") << name << ": cannot write to standard output"
              << (!flushed && error != 0 ? std::string(" (") + std::strerror(error) + ")" : std::string()) << "\n";
    return code == 0 ? 1 : code;
}

// "kernels: avx512 (this binary: sse2, avx2, avx512)": what --version says of the kernel levels.
std::string kernel_levels_line() {
    namespace simd = smoketrace::simd;
    std::string built;
    for (simd::Level l : simd::levels_in_binary()) built += (built.empty() ? "" : ", ") + std::string(simd::level_name(l));
    try {
        return "kernels: " + std::string(simd::level_name(simd::active_level())) + " (this binary: " + built + ")\n";
    } catch (const std::exception& e) {
        return "kernels: none usable (this binary: " + built + "): " + e.what() + "\n";
    }
}

int run(int argc, char** argv) {
    using namespace smoketrace::cli;
    // ^C or a scheduler's SIGTERM while a file is being written must not leave its temporary file behind.
    smoketrace::remove_temporary_files_on_signals();
    if (argc < 2) return command_error("missing command (usage: smoketrace <command> [arguments])");
    const std::string name = argv[1];
    if (name == "--version" || name == "-V") {
        std::cout << "smoketrace " << SMOKETRACE_VERSION << "\n" << kernel_levels_line();
        return 0;
    }
    if (name == "--help" || name == "-h" || name == "help") {
        if (argc == 2) {
            print_usage(std::cout);
            return 0;
        }
        if (argc > 3) {
            std::cerr << "smoketrace help: give one command name\n";
            return 2;
        }
        const std::string_view topic = argv[2];
        if (topic == "help" || topic == "--help" || topic == "-h") {
            std::cout << kHelpForHelp;
            return 0;
        }
        const Command* c = find_command(topic);
        if (!c) return unknown_command(topic);
        print_command_help(std::cout, *c);
        return 0;
    }
    const Command* c = find_command(name);
    if (!c) return unknown_command(name);
    for (int i = 2; i < argc; ++i)
        if (std::string_view(argv[i]) == "--help" || std::string_view(argv[i]) == "-h") {
            print_command_help(std::cout, *c);
            return 0;
        }
    // A message repeats paths and values the user gave: shown (shown_text.hpp) where it was put together,
    // and the whole once more here, for any part that came from elsewhere (a library's text, a PLY header).
    try {
        // SMOKETRACE_SIMD's errors before any work, not at the first pass after a long read.
        (void)smoketrace::simd::active_level();
    } catch (const std::exception& e) {
        std::cerr << "smoketrace " << name << ": " << smoketrace::shown_text(e.what(), smoketrace::kShownUncapped)
                  << "\n";
        return 2;
    }
    try {
        return c->run(Args(argv + 2, argv + argc));
    } catch (const CliError& e) {
        std::cerr << "smoketrace " << name << ": " << smoketrace::shown_text(e.what(), smoketrace::kShownUncapped)
                  << "\n";
        return 2;
    } catch (const std::exception& e) {
        std::cerr << "smoketrace " << name << ": " << smoketrace::shown_text(e.what(), smoketrace::kShownUncapped)
                  << "\n";
        return 1;
    }
}

}  // namespace

int main(int argc, char** argv) {
    smoketrace::cli::remember_argv0(argc > 0 ? argv[0] : nullptr);
    const int code = run(argc, argv);
    const bool known = argc >= 2 && find_command(argv[1]) != nullptr;
    return checked_standard_output(known ? std::string_view(argv[1]) : std::string_view(), code);
}
