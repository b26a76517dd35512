// smoketrace_bench: [--quick] [--section NAME]... [--repeats N] [--results DIR]
#include "bench_registry.hpp"

#include <cstdlib>
#include <filesystem>
#include <iostream>
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
}  // namespace
void report(const std::string& name, double value) {
    summary().emplace_back(name, value);
    std::cout << "  " << name << "=" << value << "\n";
}
}  // namespace smoketrace::bench

int main(int argc, char** argv) {
    using namespace smoketrace::bench;
    BenchOptions options;
    options.results_dir = "bench-results";
    std::vector<std::string> only;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--quick") options.quick = true;
        else if (a == "--section" && i + 1 < argc) only.push_back(argv[++i]);
        else if (a == "--repeats" && i + 1 < argc) options.repeats = std::max(1, std::atoi(argv[++i]));
        else if (a == "--results" && i + 1 < argc) options.results_dir = argv[++i];
        else if (a == "--list") {
            for (const auto& s : section_registry()) std::cout << s.name << "  " << s.summary << "\n";
            return 0;
        } else {
            std::cerr << "usage: smoketrace_bench [--quick] [--section NAME]... [--repeats N] [--results DIR] [--list]\n";
            return 2;
        }
    }
    if (options.quick && options.repeats > 3) options.repeats = 3;
    std::filesystem::create_directories(options.results_dir);
    for (const auto& s : section_registry()) {
        bool wanted = only.empty();
        for (const auto& o : only) wanted = wanted || o == s.name;
        if (!wanted) continue;
        std::cout << "== " << s.name << ": " << s.summary << "\n" << std::flush;
        s.run(options);
    }
    std::cout << "== summary\n";
    for (const auto& [name, value] : summary()) std::cout << name << "=" << value << "\n";
    return 0;
}
