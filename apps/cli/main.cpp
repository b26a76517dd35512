// smoketrace: command-line entry. Subcommands register themselves (command.hpp).
#include "arguments.hpp"
#include "assets.hpp"
#include "command.hpp"

#include <smoketrace/io/temporary_file.hpp>

#include <cstdio>
#include <exception>
#include <iostream>
#include <string>
#include <string_view>

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

int unknown_command(std::string_view name) {
    std::cerr << "smoketrace: unknown command '" << name << "'\n";
    print_usage(std::cerr);
    return 2;
}

}  // namespace

int main(int argc, char** argv) {
    using namespace smoketrace::cli;
    // ^C or a scheduler's SIGTERM while a file is being written must not leave its temporary file behind.
    smoketrace::remove_temporary_files_on_signals();
    if (argc < 2) {
        print_usage(std::cerr);
        return 2;
    }
    const std::string name = argv[1];
    if (name == "--version" || name == "-V") {
        std::cout << "smoketrace " << SMOKETRACE_VERSION << "\n";
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
        const Command* c = find_command(argv[2]);
        if (!c) return unknown_command(argv[2]);
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
    try {
        return c->run(Args(argv + 2, argv + argc));
    } catch (const CliError& e) {
        std::cerr << "smoketrace " << name << ": " << e.what() << "\n";
        return 2;
    } catch (const std::exception& e) {
        std::cerr << "smoketrace " << name << ": " << e.what() << "\n";
        return 1;
    }
}
