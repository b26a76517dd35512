// smoketrace: command-line entry. Subcommands register themselves (command.hpp).
#include "arguments.hpp"
#include "command.hpp"

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
void print_usage(std::ostream& out) {
    out << "usage: smoketrace <command> [arguments]\n\ncommands:\n";
    for (const auto& c : smoketrace::cli::command_registry())
        out << "  " << c.usage << "\n      " << c.summary << "\n";
}
}  // namespace

int main(int argc, char** argv) {
    using namespace smoketrace::cli;
    if (argc < 2) {
        print_usage(std::cerr);
        return 2;
    }
    const std::string name = argv[1];
    if (name == "--help" || name == "-h" || name == "help") {
        print_usage(std::cout);
        return 0;
    }
    for (const auto& c : command_registry()) {
        if (c.name != name) continue;
        for (int i = 2; i < argc; ++i)
            if (std::string_view(argv[i]) == "--help" || std::string_view(argv[i]) == "-h") {
                std::cout << "usage: smoketrace " << c.usage << "\n  " << c.summary << "\n";
                return 0;
            }
        try {
            return c.run(Args(argv + 2, argv + argc));
        } catch (const CliError& e) {
            std::cerr << "smoketrace " << name << ": " << e.what() << "\n";
            return 2;
        } catch (const std::exception& e) {
            std::cerr << "smoketrace " << name << ": " << e.what() << "\n";
            return 1;
        }
    }
    std::cerr << "smoketrace: unknown command '" << name << "'\n";
    print_usage(std::cerr);
    return 2;
}
