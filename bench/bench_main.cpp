// smoketrace_bench: [--quick] [--section NAME]... [--repeats N] [--results DIR] [--assets DIR]
//                   [--thread-counts LIST] [--dry-run] [--list]
// The whole benchmark at one kernel level: compiled once per level with the sections that call the trace
// headers, like the library's passes (core/simd/dispatch.hpp); main() in dispatching_main.cpp.
#include "bench_assets.hpp"
#include "bench_registry.hpp"
#include "embree_device.hpp"

#include <smoketrace/core/simd/level.hpp>
#include <smoketrace/io/output_path.hpp>

#include <tbb/info.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <utility>

namespace smoketrace::bench {
std::vector<Section>& section_registry() {
    static std::vector<Section> sections;
    return sections;
}
namespace {
std::vector<std::pair<std::string, double>>& summary() {
    static std::vector<std::pair<std::string, double>> lines;
    return lines;
}

constexpr int kMaxThreadCount = 1024;
constexpr int kMaxRepeats = 1000;

// --repeats N: a whole number from 1 to kMaxRepeats ("3x" or "-2" is an error, not 3 or 1).
int parse_repeats(std::string_view text) {
    int n = 0;
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), n);
    if (text.empty() || ec != std::errc() || ptr != text.data() + text.size() || n < 1 || n > kMaxRepeats)
        throw std::runtime_error("--repeats: '" + std::string(text) + "' is not a whole number from 1 to " +
                                 std::to_string(kMaxRepeats));
    return n;
}

// --thread-counts LIST: positive integers separated by commas ("1,2,4,16"), sorted and without repeats,
// with 1 added where missing (the sweep's speedups are over one thread).
std::vector<int> parse_thread_counts(std::string_view list) {
    std::vector<int> counts;
    for (std::size_t at = 0; at <= list.size();) {
        const std::size_t end = std::min(list.find(',', at), list.size());
        const std::string_view item = list.substr(at, end - at);
        int n = 0;
        const auto [ptr, ec] = std::from_chars(item.data(), item.data() + item.size(), n);
        if (item.empty() || ec != std::errc() || ptr != item.data() + item.size() || n < 1 || n > kMaxThreadCount)
            throw std::runtime_error("--thread-counts: '" + std::string(item) + "' in '" + std::string(list) +
                                     "' is not a thread count (give positive integers up to " +
                                     std::to_string(kMaxThreadCount) + " separated by commas, e.g. 1,2,4,16)");
        counts.push_back(n);
        at = end + 1;
    }
    counts.push_back(1);
    std::sort(counts.begin(), counts.end());
    counts.erase(std::unique(counts.begin(), counts.end()), counts.end());
    return counts;
}

// Without --thread-counts: 1, 2, 4, … up to the threads this process may run on, and that count itself.
std::vector<int> default_thread_counts() {
    const int cores = tbb::info::default_concurrency();
    std::vector<int> counts;
    for (int n = 1; n < cores; n *= 2) counts.push_back(n);
    counts.push_back(cores);
    return counts;
}

}  // namespace
// Formats through a local stream: a section that leaves std::cout in fixed notation must not change how
// the summary looks.
std::string summary_line(const std::string& name, double value) {
    std::ostringstream line;
    line.precision(6);
    line << name << "=" << value;
    return line.str();
}
void report(const std::string& name, double value) {
    summary().emplace_back(name, value);
    std::cout << "  " << summary_line(name, value) << "\n";
}
}  // namespace smoketrace::bench

template <smoketrace::simd::Level L>
int smoketrace::bench::bench_main_at_level(int argc, char** argv) {
    static_assert(L == simd::kCompiledLevel);
    BenchOptions options;
    options.results_dir = "bench-results";
    std::vector<std::string> only;
    std::optional<std::string> assets;
    bool dry_run = false;
    try {
        for (int i = 1; i < argc; ++i) {
            const std::string a = argv[i];
            if (a == "--quick") options.quick = true;
            else if (a == "--section" && i + 1 < argc) only.push_back(argv[++i]);
            else if (a == "--repeats" && i + 1 < argc) options.repeats = parse_repeats(argv[++i]);
            else if (a == "--results" && i + 1 < argc) options.results_dir = argv[++i];
            else if (a == "--assets" && i + 1 < argc) assets = argv[++i];
            else if (a == "--thread-counts" && i + 1 < argc) options.thread_counts = parse_thread_counts(argv[++i]);
            else if (a == "--dry-run") dry_run = true;
            else if (a == "--list") {
                for (const auto& s : section_registry()) std::cout << s.name << "  " << s.summary << "\n";
                return 0;
            } else {
                std::cerr << "usage: smoketrace_bench [--quick] [--section NAME]... [--repeats N] [--results DIR] "
                             "[--assets DIR] [--thread-counts LIST] [--dry-run] [--list]\n";
                return 2;
            }
        }
    } catch (const std::exception& e) {
        std::cerr << "smoketrace_bench: " << e.what() << "\n";
        return 2;
    }
    if (options.thread_counts.empty()) options.thread_counts = default_thread_counts();
    if (options.quick && options.repeats > 3) options.repeats = 3;
    for (const auto& o : only) {
        bool known = false;
        for (const auto& s : section_registry()) known = known || o == s.name;
        if (!known) {
            std::cerr << "smoketrace_bench: no section '" << o << "' (see --list)\n";
            return 2;
        }
    }
    std::vector<const Section*> chosen;
    for (const auto& s : section_registry())
        if (only.empty() || std::find(only.begin(), only.end(), s.name) != only.end()) chosen.push_back(&s);
    // The assets folder is looked for when a section run reads it, or when one is named (a wrong one is an
    // error either way), before any section starts.
    std::string assets_line = "(not needed)";
    if (assets || std::any_of(chosen.begin(), chosen.end(), [](const Section* s) { return s->needs_assets; })) {
        try {
            const BenchAssets found = find_bench_assets(assets, argc > 0 ? argv[0] : nullptr);
            options.assets = found.folder;
            assets_line = found.folder.string() + " (" + found.found_by + ")";
        } catch (const std::exception& e) {
            std::cerr << "smoketrace_bench: " << e.what() << "\n";
            return 2;
        }
    }
    // A device string that the bench or Embree refuses stops the run now, not at the first section using it.
    try {
        if (std::getenv(kEmbreeConfigVariable)) (void)bench_embree_device();
    } catch (const std::exception& e) {
        std::cerr << "smoketrace_bench: " << e.what() << "\n";
        return 2;
    }
    // Which kernels every figure below comes from: ours (SMOKETRACE_SIMD forces a lower level), and what
    // Embree was asked for (its own choice unless SMOKETRACE_EMBREE_CONFIG says, e.g. isa=avx2).
    const char* embree_config = std::getenv("SMOKETRACE_EMBREE_CONFIG");
    // Without SMOKETRACE_BENCH_LEVELS the sections' own loops run at the baseline, the library's passes at
    // the process's level: then both are said.
    std::string kernels(simd::level_name(L));
    if (simd::active_level() != L)
        kernels += std::string(" (the sections' own loops; the library's passes: ") +
                   std::string(simd::level_name(simd::active_level())) + ")";
    std::cout << "kernels: " << kernels << "; Embree's device config: "
              << (embree_config && *embree_config ? embree_config : "(Embree's default: the best ISA it has)") << "\n"
              << "assets: " << assets_line << "\n";
    if (dry_run) {
        std::cout << "sections:";
        for (const Section* s : chosen) std::cout << " " << s->name;
        std::cout << "\nthread counts of section threads:";
        for (const int n : options.thread_counts) std::cout << " " << n;
        std::cout << "\nresults: " << options.results_dir << (options.quick ? " (quick)" : "") << "\n";
        std::cout << "repeats: " << options.repeats << "\n";
        return 0;
    }
    std::filesystem::create_directories(options.results_dir);
    const auto start = std::chrono::steady_clock::now();
    auto seconds_since = [](std::chrono::steady_clock::time_point t) {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    };
    std::ostringstream durations;
    durations.precision(3);
    for (const Section* section : chosen) {
        const Section& s = *section;
        std::cout << "== " << s.name << ": " << s.summary << "\n" << std::flush;
        const auto t0 = std::chrono::steady_clock::now();
        s.run(options);
        const double sec = seconds_since(t0);
        std::cout << "   (" << s.name << ": " << std::fixed << std::setprecision(1) << sec << " s)\n"
                  << std::defaultfloat << std::setprecision(6) << std::flush;
        durations << "section_seconds_" << s.name << "=" << sec << "\n";
    }
    // The summary, on stdout and as summary.txt in the results folder (with each section's wall time).
    std::ostringstream text;
    for (const auto& [name, value] : summary()) text << summary_line(name, value) << "\n";
    std::cout << "== summary\n" << text.str() << std::flush;
    smoketrace::write_output(std::filesystem::path(options.results_dir) / "summary.txt", [&](std::ostream& out) {
        out << text.str() << durations.str() << "bench_seconds=" << seconds_since(start) << "\n"
            << "quick=" << (options.quick ? 1 : 0) << "\n"
            << "kernels=" << kernels << "\n";
    });
    return 0;
}

template int smoketrace::bench::bench_main_at_level<smoketrace::simd::kCompiledLevel>(int, char**);
