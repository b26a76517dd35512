#pragma once
// The smoketrace command line: each subcommand lives in its own cmd_*.cpp and registers itself here,
// so main.cpp never changes when a command is added.
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace smoketrace::cli {

using Args = std::vector<std::string>;
// A command returns the process exit code; it throws CliError (see arguments.hpp) for bad input.
using CommandFn = int (*)(const Args& args);

// One option of a command, as --help lists it: "--size WxH", what it does, and what holds without it.
struct OptionHelp {
    std::string_view flag;           // "--size"
    std::string_view value;          // "WxH"; empty for a flag that takes no value
    std::string_view default_value;  // what holds when the option is not given; empty: the option is required
    std::string_view meaning;        // one sentence
};

struct Command {
    std::string_view name;
    std::string_view usage;    // one line: "depths SCENE.json -o OUT.csv [options]"
    std::string_view summary;  // one sentence
    CommandFn run;
    std::span<const OptionHelp> options = {};  // every option the command reads (tests/test_cli_help.cpp checks)
};

std::vector<Command>& command_registry();

struct RegisterCommand {
    explicit RegisterCommand(Command c) { command_registry().push_back(c); }
};

}  // namespace smoketrace::cli
