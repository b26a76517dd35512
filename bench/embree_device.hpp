#pragma once
// The Embree device of every bench section that compares with Embree, made in this one place so that the
// environment variable SMOKETRACE_EMBREE_CONFIG (an Embree device string: "isa=avx2", "hugepages=1",
// "threads=1", ...) reaches each of them, and "ours vs Embree at AVX2" is one command.
#include "support/embree_reference.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <string_view>

namespace smoketrace::bench {

inline constexpr const char* kEmbreeConfigVariable = "SMOKETRACE_EMBREE_CONFIG";

// The kernel levels Embree 3 knows by name in isa= and max_isa= (it ignores case). It takes any other
// value too, and silently runs SSE2 kernels for it; a typo would quietly make the comparison one with
// Embree at SSE2, so the bench refuses such a value itself.
inline constexpr std::string_view kEmbreeIsaNames[] = {"sse",   "sse2",   "sse3", "ssse3", "sse41", "sse4.1",
                                                       "sse42", "sse4.2", "avx",  "avxi",  "avx2",  "avx512"};

// What is wrong with `config` as the bench's Embree device string, or "" when nothing is that the bench can
// see: each isa= or max_isa= value must be one of kEmbreeIsaNames. (Embree's own errors come from
// embree_reference::Device.) Embree's syntax: key=value pairs, separated by commas or spaces.
inline std::string embree_config_problem(std::string_view config) {
    const auto is_name_char = [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '.';
    };
    const auto is_space = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
    for (std::size_t at = 0; at < config.size();) {
        if (!is_name_char(config[at])) {
            ++at;
            continue;
        }
        std::size_t end = at;
        while (end < config.size() && is_name_char(config[end])) ++end;
        const std::string_view key = config.substr(at, end - at);  // keys are case-sensitive, values not
        at = end;
        if (key != "isa" && key != "max_isa") continue;
        while (at < config.size() && is_space(config[at])) ++at;
        if (at == config.size() || config[at] != '=') continue;  // Embree then ignores the key too
        ++at;
        while (at < config.size() && is_space(config[at])) ++at;
        end = at;
        while (end < config.size() && is_name_char(config[end])) ++end;
        std::string value(config.substr(at, end - at));
        std::transform(value.begin(), value.end(), value.begin(),
                       [](unsigned char c) { return char(std::tolower(c)); });
        if (std::find(std::begin(kEmbreeIsaNames), std::end(kEmbreeIsaNames), value) == std::end(kEmbreeIsaNames)) {
            std::string names;
            for (const std::string_view n : kEmbreeIsaNames) names += (names.empty() ? "" : ", ") + std::string(n);
            return std::string(key) + "=" + std::string(config.substr(at, end - at)) +
                   " is not a kernel level Embree 3 knows (it would run SSE2 kernels); give one of " + names;
        }
        at = end;
    }
    return "";
}

// A device from SMOKETRACE_EMBREE_CONFIG; unset or empty: Embree's defaults (all threads, the best kernels
// this CPU runs). Throws std::runtime_error naming the variable when the bench or Embree refuses the string.
inline embree_reference::Device bench_embree_device() {
    const char* config = std::getenv(kEmbreeConfigVariable);
    if (!config || !*config) return embree_reference::Device();
    const std::string where = std::string(kEmbreeConfigVariable) + "=\"" + config + "\": ";
    if (const std::string problem = embree_config_problem(config); !problem.empty())
        throw std::runtime_error(where + problem);
    try {
        return embree_reference::Device(config);
    } catch (const std::runtime_error& e) {
        throw std::runtime_error(where + e.what());
    }
}

}  // namespace smoketrace::bench
