#pragma once
// Strict command-line parsing: every value is checked, and an error names the flag and the problem.
#include <smoketrace/core/shown_text.hpp>

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace smoketrace::cli {

// Bad input on the command line: main() prints "smoketrace: <message>" and exits with code 2.
struct CliError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// Walks argv of one subcommand. Flags take their value as the next argument ("--threads 4") or
// after '=' ("--threads=4"). Unknown flags are errors (see finish()).
class ArgReader {
public:
    explicit ArgReader(std::vector<std::string> args);

    // Next positional argument, or an error naming `what` when there is none.
    std::string positional(const std::string& what);
    // True when `flag` is present (flags without a value), consuming it.
    bool flag(const std::string& flag);
    // Value of `flag` if given (consumed), checked and converted.
    std::optional<std::string> string(const std::string& flag);
    std::optional<long long> integer(const std::string& flag, long long min, long long max);
    std::optional<double> number(const std::string& flag, double min, double max);  // finite only
    // "WxH" with both in [1, max_side].
    std::optional<std::pair<int, int>> size(const std::string& flag, int max_side);
    // Errors out on anything not consumed: an unknown flag (the message lists the flags asked for) or a
    // stray positional argument.
    void finish() const;

private:
    std::optional<std::string> take_value(const std::string& flag);
    std::vector<std::string> args_;
    std::vector<bool> used_;
    std::vector<std::string> asked_;  // every flag looked for, in order: the known options
};

// A command-line argument or a path in a message: 'TEXT', shown as shown_text.hpp says (escaped, capped).
inline std::string quoted_arg(std::string_view text) {
    std::string quoted(1, '\'');  // appended, not "'" + …: GCC 12 warns falsely (-Wrestrict) on that
    quoted += shown_text(text, kMaxShownPathBytes);
    quoted += '\'';
    return quoted;
}

// Parses a whole string as a number; throws CliError naming `what` otherwise.
long long parse_integer(const std::string& text, const std::string& what, long long min, long long max);
double parse_number(const std::string& text, const std::string& what, double min, double max);

}  // namespace smoketrace::cli
