// Bench section "resolver": the thesis's table B.4 (compute pass time against the optical depth cutoff, 750
// particles) for the thesis's bubble sort, std::sort and the radix sort, plus the measurements behind the
// resolver's design choices: segmented vs per-particle sorting (hit_resolver.cpp), the rank/radix
// crossover kRadixSortMinItems and the digit width rule kRadixBucketsPerItem (radix_sort.hpp).
#include "bench_registry.hpp"
#include "bench_util.hpp"
#include "timing.hpp"

#include <smoketrace/core/prng.hpp>
#include <smoketrace/smoke/hit_resolver.hpp>
#include <smoketrace/core/radix_sort.hpp>

#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <ctime>
#include <cstdint>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

namespace smoketrace::bench {
namespace {

constexpr std::size_t kParticles = 750;  // table B.4
// Hits per list: the thesis's cutoffs (table B.4) and an "unlimited" list as long as a ray through both tubes.
constexpr std::size_t kHitCounts[] = {20, 40, 60, 80, 100, 120, 300};

// The thesis's compute pass time at each cutoff (table B.4, RTX 2080 Ti, bubble sort), for comparison.
double thesis_b4_ms(std::size_t cutoff) {
    switch (cutoff) {
        case 20: return 0.018;
        case 40: return 0.063;
        case 60: return 0.183;
        case 80: return 0.376;
        case 100: return 0.833;
        case 120: return 1.374;
        default: return 0.0;  // the thesis had no unlimited lists
    }
}


// Exactly k hits of one optical-depth ray through a dense tube of unit-size particles, in the shuffled order
// any-hit delivers them: 1-3 particles cover the origin (the ray's own particle among them: exits only), the
// others are chords entered and left along the ray, overlapping their neighbours.
std::vector<SurfaceHit> synthetic_ray_hits(Pcg32& rng, std::size_t k) {
    std::vector<SurfaceHit> hits;
    const std::size_t covering = k % 2 == 1 ? (rng.below(2) ? 1 : 3) : 2;
    for (std::size_t i = 0; i < covering; ++i) hits.push_back({rng.uniform(0.2f, 1.0f), -1});
    const std::size_t chords = (k - covering) / 2;
    const float tube_length = 0.5f + 0.35f * static_cast<float>(chords);  // ~3 chords overlap at any t
    for (std::size_t i = 0; i < chords; ++i) {
        const float half = rng.uniform(0.1f, 0.9f);
        const float centre = rng.uniform(half + 0.01f, half + 0.01f + tube_length);
        hits.push_back({centre - half, +1});
        hits.push_back({centre + half, -1});
    }
    for (std::size_t i = hits.size(); i > 1; --i) {
        std::swap(hits[i - 1], hits[rng.below(static_cast<std::uint32_t>(i))]);
    }
    return hits;
}

HitLists synthetic_lists(std::size_t k, std::uint64_t seed) {
    Pcg32 rng(seed);
    HitLists lists;
    for (std::size_t p = 0; p < kParticles; ++p) lists.add_particle(synthetic_ray_hits(rng, k));
    return lists;
}

// Which clock a measurement reads. Single-threaded rows read the calling thread's CPU time: on a shared,
// overloaded machine a long run (bubble sort, 10-200 ms) is preempted many times and its wall time inflates
// far more than a short one's, which would flatter every ratio against it. The single-threaded work runs in
// the calling thread (a task_arena of concurrency 1 has no worker threads). Multi-threaded rows: wall time.
enum class Clock { wall, thread_cpu };

double now_ms(Clock clock) {
    if (clock == Clock::wall) {
        return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
    }
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

// Median times of several variants of one measurement, sampled round-robin (sample s of every variant before
// sample s + 1), so that the shared machine's slow spells hit every variant alike and the ratios between
// them stay fair. Before each timed run restore() puts back the shuffled input, untimed: every sort must
// start from any-hit order, not from the previous run's output. run(v) runs variant v; clocks[v] times it.
template <class Restore, class Run>
std::vector<double> median_ms(int samples, const std::vector<Clock>& clocks, Restore&& restore, Run&& run) {
    std::vector<std::vector<double>> ms(clocks.size());
    for (int s = 0; s < samples; ++s) {
        for (std::size_t v = 0; v < clocks.size(); ++v) {
            restore();
            const double t0 = now_ms(clocks[v]);
            run(v);
            ms[v].push_back(now_ms(clocks[v]) - t0);
        }
    }
    std::vector<double> medians;
    for (const std::vector<double>& m : ms) medians.push_back(stats_of(m).median);
    return medians;
}

struct CsvRow {
    std::string table, method;
    std::size_t size;  // hits per list (k) or items per list
    int threads;
    double median_ms, ns_per_item;
};

// The batched alternative: one radix sort of every particle's hits keyed by (particle, t) as two stable LSD
// sorts (t, then particle), the sorted hits copied back into the lists, then the walks.
struct TaggedHit {
    std::uint32_t particle;
    SurfaceHit hit;
};
void resolve_segmented(std::vector<TaggedHit>& tagged, std::vector<TaggedHit>& scratch, HitLists& lists,
                       std::span<float> lengths) {
    radix_sort(std::span{tagged}, std::span{scratch}, [](const TaggedHit& h) { return float_sort_key(h.hit.t); });
    radix_sort(std::span{tagged}, std::span{scratch}, [](const TaggedHit& h) { return h.particle; });
    for (std::size_t i = 0; i < tagged.size(); ++i) lists.hits[i] = tagged[i].hit;
    for (std::size_t p = 0; p < lists.particle_count(); ++p) {
        lengths[p] = static_cast<float>(optical_path_length(lists.of(p)));
    }
}

const char* name_of(HitSort m) {
    switch (m) {
        case HitSort::adaptive: return "adaptive";
        case HitSort::std_sort: return "std_sort";
        case HitSort::bubble: return "bubble";
    }
    return "?";
}

void run_resolver(const BenchOptions& options) {
    // Each run is short (0.05-60 ms) and the machine is shared: many samples, medians. Quick mode: a few.
    const int samples = options.quick ? options.repeats : options.repeats * 5;
    const int all_threads = tbb::info::default_concurrency();
    tbb::task_arena one_thread(1);
    tbb::task_arena every_thread(all_threads);
    std::vector<CsvRow> csv;
    const std::vector<DepthStatus> status(kParticles, DepthStatus::ok);
    std::vector<float> lengths(kParticles);
    auto ns_per = [](double ms, double items) { return ms * 1e6 / items; };

    // Table B.4: every list exactly k hits, all resolvable (a real frame at cutoff k has shorter lists
    // too and skips lists over the cutoff; full lists are the worst case and show the growth with k).
    std::cout << "Table B.4 shape: " << kParticles << " particles, k hits each, median of " << samples
              << " runs (ms, ns per hit)\n";
    std::cout << std::setw(6) << "k" << std::setw(10) << "method" << std::setw(14) << "1 thread cpu" << std::setw(10)
              << "ns/hit" << std::setw(10) << all_threads << " threads wall" << std::setw(10) << "ns/hit"
              << "   thesis B.4 (GPU, bubble)\n";
    const HitSort methods[] = {HitSort::bubble, HitSort::std_sort, HitSort::adaptive};
    double radix_ns[2] = {0, 0}, bubble_over_radix_120 = 0;
    for (const std::size_t k : kHitCounts) {
        const HitLists shuffled = synthetic_lists(k, 1000 + k);
        HitLists work = shuffled;
        const double hits = static_cast<double>(shuffled.hit_count());
        // Variant 2m: method m on one thread (CPU time); 2m + 1: on every thread (wall time).
        std::vector<Clock> clocks;
        for (std::size_t m = 0; m < std::size(methods); ++m) {
            clocks.insert(clocks.end(), {Clock::thread_cpu, Clock::wall});
        }
        const std::vector<double> ms = median_ms(
            samples, clocks, [&] { work.hits = shuffled.hits; },
            [&](std::size_t v) {
                auto resolve = [&] { resolve_optical_path_lengths(work, status, lengths, methods[v / 2]); };
                (v % 2 == 0 ? one_thread : every_thread).execute(resolve);
            });
        for (std::size_t m = 0; m < std::size(methods); ++m) {
            const double ms1 = ms[2 * m], msn = ms[2 * m + 1];
            std::cout << std::setw(6) << k << std::setw(10) << name_of(methods[m]) << std::fixed
                      << std::setprecision(4) << std::setw(14) << ms1 << std::setprecision(2) << std::setw(10)
                      << ns_per(ms1, hits) << std::setprecision(4) << std::setw(23) << msn << std::setprecision(2)
                      << std::setw(10) << ns_per(msn, hits);
            if (methods[m] == HitSort::bubble && thesis_b4_ms(k) > 0) {
                std::cout << std::setprecision(3) << std::setw(12) << thesis_b4_ms(k) << " ms";
            }
            std::cout << "\n";
            csv.push_back({"b4", name_of(methods[m]), k, 1, ms1, ns_per(ms1, hits)});
            csv.push_back({"b4", name_of(methods[m]), k, all_threads, msn, ns_per(msn, hits)});
        }
        const double radix_ms = ms[4], bubble_ms = ms[0];
        if (k == 20) radix_ns[0] = ns_per(radix_ms, hits);
        if (k == 120) {
            radix_ns[1] = ns_per(radix_ms, hits);
            bubble_over_radix_120 = bubble_ms / radix_ms;
        }
    }

    // Segmented (one sort over all hits keyed by particle, then t) vs per-particle (HitSort::adaptive), one thread.
    std::cout << "Segmented vs per-particle sorting, 1 thread (ns per hit, CPU time)\n";
    for (const std::size_t k : kHitCounts) {
        const HitLists shuffled = synthetic_lists(k, 2000 + k);
        HitLists work = shuffled;
        std::vector<TaggedHit> tagged_shuffled, tagged, scratch(shuffled.hit_count());
        for (std::size_t p = 0; p < kParticles; ++p) {
            for (const SurfaceHit& h : shuffled.of(p)) tagged_shuffled.push_back({static_cast<std::uint32_t>(p), h});
        }
        const double hits = static_cast<double>(shuffled.hit_count());
        const std::vector<double> ms = median_ms(
            samples, {Clock::thread_cpu, Clock::thread_cpu},
            [&] {
                work.hits = shuffled.hits;
                tagged = tagged_shuffled;
            },
            [&](std::size_t v) {
                if (v == 0) {
                    one_thread.execute([&] { resolve_optical_path_lengths(work, status, lengths, HitSort::adaptive); });
                } else {
                    resolve_segmented(tagged, scratch, work, lengths);
                }
            });
        std::cout << "  k=" << std::setw(4) << k << std::fixed << std::setprecision(2) << "  per-particle "
                  << std::setw(6) << ns_per(ms[0], hits) << "  segmented " << std::setw(6) << ns_per(ms[1], hits)
                  << "  (segmented / per-particle " << ms[1] / ms[0] << ")\n";
        csv.push_back({"segmented", "per_particle", k, 1, ms[0], ns_per(ms[0], hits)});
        csv.push_back({"segmented", "segmented", k, 1, ms[1], ns_per(ms[1], hits)});
    }

    // Sort alone, by list length, on the t values of one ray (~96k items per run): insertion sort, rank sort,
    // the radix sort with its automatic digit width (the library's kRadixBucketsPerItem and alternatives),
    // fixed 8- and 11-bit digits, std::sort, and what the resolver runs (HitSort::adaptive: with AVX-512 the
    // sorting network up to 64 items). Justifies kRadixSortMinItems, kRadixBucketsPerItem and the network.
    struct Variant {
        std::string name;
        unsigned fixed_bits;           // radix variants: fixed digit width, 0 = automatic
        std::size_t buckets_per_item;  // radix variants with automatic width
    };
    std::vector<Variant> variants = {{"insertion", 0, 0}, {"rank", 0, 0}};
    for (const std::size_t b : {std::size_t{1}, std::size_t{2}, std::size_t{4}, std::size_t{16}}) {
        variants.push_back({"auto/" + std::to_string(b) + (b == kRadixBucketsPerItem ? "*" : ""), 0, b});
    }
    variants.push_back({"fixed8", 8, 0});
    variants.push_back({"fixed11", 11, 0});
    variants.push_back({"std_sort", 0, 0});
    variants.push_back({"resolver", 0, 0});  // sort_hits_by_t(HitSort::adaptive): the network up to 64 items (AVX-512)
    const std::size_t kInsertion = 0, kRank = 1, kStdSort = variants.size() - 2, kResolver = variants.size() - 1;
    const std::size_t library_radix = 2 + static_cast<std::size_t>(std::countr_zero(kRadixBucketsPerItem));
    std::cout << "Sort crossover: ns per item, sort only, 1 thread CPU time (auto/B: radix sort, digits with at most "
                 "B buckets per item; * = the library's; resolver: sort_hits_by_t, HitSort::adaptive)\n";
    std::cout << std::setw(8) << "items";
    for (const Variant& v : variants) std::cout << std::setw(10) << v.name;
    std::cout << "\n";
    const std::vector<std::size_t> sizes =
        options.quick ? std::vector<std::size_t>{16, 64, 128, 192, 256, 320, 384, 512, 2048}
                      : std::vector<std::size_t>{8, 16, 24, 32, 48, 64, 80, 96, 112, 128, 144, 160, 176, 192, 224, 256,
                                                 512, 2048, 16384, 131072};
    std::size_t radix_first_wins = 0;
    for (const std::size_t n : sizes) {
        Pcg32 rng(3000 + n);
        const std::size_t lists_per_run = std::max<std::size_t>(1, 98304 / n);
        std::vector<SurfaceHit> shuffled;
        for (std::size_t l = 0; l < lists_per_run; ++l) {
            const std::vector<SurfaceHit> ray = synthetic_ray_hits(rng, n);  // exactly n hits of one ray
            shuffled.insert(shuffled.end(), ray.begin(), ray.end());
        }
        std::vector<SurfaceHit> items, scratch(n);
        auto key = [](const SurfaceHit& h) { return float_sort_key(h.t); };
        auto applies = [&](std::size_t v) {
            if (v == kInsertion) return n <= 2048;  // quadratic: too slow beyond
            if (v == kRank) return n <= kRankSortMaxItems;
            return true;
        };
        std::vector<std::size_t> measured;  // the variants that apply, in order
        for (std::size_t v = 0; v < variants.size(); ++v) {
            if (applies(v)) measured.push_back(v);
        }
        const std::vector<double> ms = median_ms(
            samples, std::vector<Clock>(measured.size(), Clock::thread_cpu), [&] { items = shuffled; },
            [&](std::size_t i) {
                const std::size_t v = measured[i];
                for (std::size_t l = 0; l < lists_per_run; ++l) {
                    const std::span<SurfaceHit> list = std::span{items}.subspan(l * n, n);
                    if (v == kInsertion) {
                        insertion_sort(list, key);
                    } else if (v == kRank) {
                        rank_sort(list, std::span{scratch}, key);
                    } else if (v == kResolver) {
                        sort_hits_by_t(list, std::span{scratch}, HitSort::adaptive);
                    } else if (v == kStdSort) {
                        std::sort(list.begin(), list.end(),
                                  [](const SurfaceHit& a, const SurfaceHit& b) { return a.t < b.t; });
                    } else {
                        detail::radix_sort_impl(list, std::span{scratch}, key, variants[v].fixed_bits,
                                                variants[v].buckets_per_item);
                    }
                }
            });
        std::vector<double> ms_of(variants.size(), 0.0);
        for (std::size_t i = 0; i < measured.size(); ++i) ms_of[measured[i]] = ms[i];
        const double items_per_run = static_cast<double>(shuffled.size());
        std::cout << std::setw(8) << n << std::fixed << std::setprecision(2);
        for (std::size_t v = 0; v < variants.size(); ++v) {
            if (!applies(v)) {
                std::cout << std::setw(10) << "-";
                continue;
            }
            std::cout << std::setw(10) << ns_per(ms_of[v], items_per_run);
            csv.push_back({"crossover", variants[v].name, n, 1, ms_of[v], ns_per(ms_of[v], items_per_run)});
        }
        std::cout << "\n";
        if (radix_first_wins == 0 && applies(kRank) && ms_of[library_radix] < ms_of[kRank]) radix_first_wins = n;
    }
    std::cout << "  the radix sort first beats the rank sort at " << radix_first_wins
              << " items (kRadixSortMinItems = " << kRadixSortMinItems << ")\n";

    CsvFile file("table,method,items_per_list,threads,median_ms,ns_per_item");
    for (const CsvRow& r : csv) file.row(r.table, r.method, r.size, r.threads, r.median_ms, r.ns_per_item);
    file.write(std::filesystem::path(options.results_dir) / "resolver.csv");

    // Single-threaded figures: per-hit cost is a property of the sort, not of the core count.
    report("resolver_ns_per_hit_cutoff20", radix_ns[0]);
    report("resolver_ns_per_hit_cutoff120", radix_ns[1]);
    report("radix_vs_bubble_speedup_cutoff120", bubble_over_radix_120);
    report("resolver_per_hit_ratio_120_vs_20", radix_ns[1] / radix_ns[0]);
}

const RegisterSection kResolverSection{{"resolver",
                                        "hit resolver (thesis 4.3.3, table B.4): bubble vs std::sort vs the adaptive "
                                        "sort, segmented vs per-particle, sort crossover",
                                        &run_resolver}};

}  // namespace
}  // namespace smoketrace::bench
