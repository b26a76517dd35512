#include "arguments.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace smoketrace::cli {

ArgReader::ArgReader(std::vector<std::string> args) : args_(std::move(args)), used_(args_.size(), false) {}

std::string ArgReader::positional(const std::string& what) {
    for (std::size_t i = 0; i < args_.size(); ++i) {
        if (used_[i]) continue;
        if (args_[i].size() > 1 && args_[i][0] == '-') continue;  // a flag, seen later by finish()
        used_[i] = true;
        return args_[i];
    }
    throw CliError("missing " + what);
}

bool ArgReader::flag(const std::string& flag) {
    asked_.push_back(flag);
    bool found = false;
    for (std::size_t i = 0; i < args_.size(); ++i)
        if (!used_[i] && args_[i] == flag) used_[i] = found = true;
    return found;
}

std::optional<std::string> ArgReader::take_value(const std::string& flag) {
    asked_.push_back(flag);
    std::optional<std::string> value;
    for (std::size_t i = 0; i < args_.size(); ++i) {
        if (used_[i]) continue;
        if (args_[i] == flag) {
            if (i + 1 >= args_.size()) throw CliError(flag + ": missing value");
            if (value) throw CliError(flag + ": given more than once");
            used_[i] = used_[i + 1] = true;
            value = args_[i + 1];
            ++i;
        } else if (args_[i].rfind(flag + "=", 0) == 0) {
            if (value) throw CliError(flag + ": given more than once");
            used_[i] = true;
            value = args_[i].substr(flag.size() + 1);
        }
    }
    return value;
}

std::optional<std::string> ArgReader::string(const std::string& flag) {
    auto v = take_value(flag);
    if (v && v->empty()) throw CliError(flag + ": empty value");
    return v;
}

long long parse_integer(const std::string& text, const std::string& what, long long min, long long max) {
    errno = 0;
    char* end = nullptr;
    const long long v = std::strtoll(text.c_str(), &end, 10);
    if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE)
        throw CliError(what + ": " + quoted_arg(text) + " is not a whole number");
    if (v < min || v > max)
        throw CliError(what + ": " + shown_text(text, kMaxShownPathBytes) + " is out of range [" + std::to_string(min) +
                       ", " + std::to_string(max) + "]");
    return v;
}

double parse_number(const std::string& text, const std::string& what, double min, double max) {
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size())
        throw CliError(what + ": " + quoted_arg(text) + " is not a number");
    if (!std::isfinite(v)) throw CliError(what + ": " + quoted_arg(text) + " is not finite");
    if (v < min || v > max)
        throw CliError(what + ": " + shown_text(text, kMaxShownPathBytes) + " is out of range [" + std::to_string(min) +
                       ", " + std::to_string(max) + "]");
    return v;
}

std::optional<long long> ArgReader::integer(const std::string& flag, long long min, long long max) {
    auto v = take_value(flag);
    if (!v) return std::nullopt;
    return parse_integer(*v, flag, min, max);
}

std::optional<double> ArgReader::number(const std::string& flag, double min, double max) {
    auto v = take_value(flag);
    if (!v) return std::nullopt;
    return parse_number(*v, flag, min, max);
}

std::optional<std::pair<int, int>> ArgReader::size(const std::string& flag, int max_side) {
    auto v = take_value(flag);
    if (!v) return std::nullopt;
    const auto x = v->find('x');
    if (x == std::string::npos) throw CliError(flag + ": " + quoted_arg(*v) + " is not of the form WxH");
    const auto w = parse_integer(v->substr(0, x), flag + " width", 1, max_side);
    const auto h = parse_integer(v->substr(x + 1), flag + " height", 1, max_side);
    return std::pair<int, int>{int(w), int(h)};
}

void ArgReader::finish() const {
    for (std::size_t i = 0; i < args_.size(); ++i) {
        if (used_[i]) continue;
        if (args_[i].size() > 1 && args_[i][0] == '-') {
            std::string known;
            for (const std::string& f : asked_) known += (known.empty() ? "" : ", ") + f;
            throw CliError("unknown option " + quoted_arg(args_[i]) + " (the options: " + known + ")");
        }
        throw CliError("unexpected argument " + quoted_arg(args_[i]));
    }
}

}  // namespace smoketrace::cli
