#pragma once
// The benchmark program is one executable; each bench_*.cpp registers its sections here.
#include <smoketrace/core/simd/level.hpp>

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace smoketrace::bench {

struct BenchOptions {
    bool quick = false;          // --quick: the CI-sized run (< 3 minutes on 2 cores in total)
    int repeats = 5;             // medians over this many repeats
    std::string results_dir;     // CSV output folder
    // The assets folder (bench_assets.hpp), found before the first section that reads it; empty when no
    // section run needs one.
    std::filesystem::path assets;
    std::vector<int> thread_counts;  // --thread-counts: section threads' counts (empty: 1, 2, 4, … the cores)
};

using SectionFn = void (*)(const BenchOptions&);

struct Section {
    std::string_view name;
    std::string_view summary;
    SectionFn run;
    bool needs_assets = false;  // reads BenchOptions::assets (the scene files, the six-way texture)
};

std::vector<Section>& section_registry();

struct RegisterSection {
    explicit RegisterSection(Section s) { section_registry().push_back(s); }
};

// "name=value" summary lines collected from every section and printed at the end.
void report(const std::string& name, double value);

// The benchmark's main() at one kernel level (bench_main.cpp; dispatching_main.cpp chooses the level).
template <simd::Level L>
int bench_main_at_level(int argc, char** argv);

}  // namespace smoketrace::bench
