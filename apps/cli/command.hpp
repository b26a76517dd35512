#pragma once
// The smoketrace command line: each subcommand lives in its own cmd_*.cpp and registers itself here,
// so main.cpp never changes when a command is added.
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace smoketrace::cli {

using Args = std::vector<std::string>;
// A command returns the process exit code; it throws CliError (see arguments.hpp) for bad input.
using CommandFn = int (*)(const Args& args);

struct Command {
    std::string_view name;
    std::string_view usage;    // one line: "depths SCENE.json -o OUT.csv [options]"
    std::string_view summary;  // one sentence
    CommandFn run;
};

std::vector<Command>& command_registry();

struct RegisterCommand {
    explicit RegisterCommand(Command c) { command_registry().push_back(c); }
};

}  // namespace smoketrace::cli
