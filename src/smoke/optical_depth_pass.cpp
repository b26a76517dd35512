// The optical-depth pass (thesis 4.3.2), see optical_depth_pass.hpp: a kernel source, compiled once per
// kernel level (core/simd/dispatch.hpp); trace() and resolve() choose the level in
// optical_depth_pass_dispatch.cpp.
#include <smoketrace/core/memory_budget.hpp>
#include <smoketrace/smoke/optical_depth_pass.hpp>
#include <smoketrace/geometry/ray_bundle.hpp>
#include <smoketrace/trace/trace.hpp>
#include <smoketrace/trace/trace_bundle.hpp>

#include <glm/geometric.hpp>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <string>

namespace smoketrace {
namespace {

// Particles per parallel task: one bundle. The rays come in bundle order, so neighbouring particles
// share a task and tasks differ in work as much as the smoke is uneven (a ray rising through both tubes
// crosses twice the surfaces of one rising through the upper tube only); small tasks keep the threads
// balanced (at 750 particles, 24 tasks for two threads).
// Fixed task boundaries (simple_partitioner) make the bundles, and so every hit, independent of the
// thread count.
constexpr std::size_t kParticlesPerChunk = 32;
static_assert(kParticlesPerChunk % kBundleWidth == 0);

[[noreturn]] void over_budget(std::uint64_t budget) {
    throw OpticalDepthBudgetError(
        "optical-depth pass: the particles' light rays cross more than " + std::to_string(budget) +
        " particle surfaces in all, more than the hit lists may hold (" + std::to_string(budget) + " hits need " +
        format_bytes(budget * kPeakBytesPerStoredHit) + "; by default they may use half of this machine's " +
        format_bytes(machine_memory_bytes()) + "); set a cutoff (\"render\": {\"cutoff\": K} in the scene file, "
        "--cutoff K on the command line), or use fewer or smaller particles");
}

}  // namespace

RayOutcome optical_depth_outcome(const AccelScene& scene, const Ray& ray, const TraceResult& r,
                                 std::span<const SurfaceHit> hits, std::uint32_t cutoff) {
    if (r.cut_off) {
        // Cut off before the whole ray was seen: only a ground-only ray can tell whether it is occluded.
        const TraceResult g =
            trace(scene, ray, ray_flag_accept_first_hit_and_end_search | ray_flag_force_opaque, kGroundMask);
        if (!g.hit) return {DepthStatus::cutoff, cutoff + 1};
        // Occluded: count the surfaces in front of the opaque hit, with no cutoff.
        // tmax just below the ground: the same "t < t_ground" count as the uncut path below.
        const Ray front{ray.origin, ray.tmin, ray.direction, std::nextafter(g.committed.t, 0.0f)};
        std::uint32_t n = 0;
        trace<TlasWalk::all_hits>(scene, front, ray_flag_force_non_opaque, kStandInMask, [&](const TraceHit&) {
            ++n;
            return AnyHitDecision::ignore;
        });
        return {DepthStatus::occluded, n};
    }
    if (r.hit) {
        // Occluded: hits found before the opaque commit may lie behind it; keep the count in front.
        const float t_opaque = r.committed.t;
        const auto n = std::count_if(hits.begin(), hits.end(), [&](const SurfaceHit& h) { return h.t < t_opaque; });
        return {DepthStatus::occluded, static_cast<std::uint32_t>(n)};
    }
    return {DepthStatus::ok, static_cast<std::uint32_t>(hits.size())};
}

PackedSurfaceHit* OpticalDepthPass::Scratch::keep(std::span<const SurfaceHit> hits) {
    if (blocks.empty() || blocks[block].capacity() - blocks[block].size() < hits.size()) {
        if (!blocks.empty()) ++block;
        if (block == blocks.size()) blocks.emplace_back();
        blocks[block].reserve(std::max(kKeptHitsPerBlock, hits.size()));  // empty here: nothing moves
    }
    auto& b = blocks[block];
    const std::size_t first = b.size();
    b.resize(first + hits.size());  // within the capacity: earlier rays' hits stay put
    PackedSurfaceHit* at = b.data() + first;
    for (std::size_t k = 0; k < hits.size(); ++k) at[k] = pack_surface_hit(hits[k]);
    kept += hits.size();
    return at;
}

void OpticalDepthPass::Scratch::clear() {
    for (auto& b : blocks) b.clear();
    block = 0;
    kept = 0;
}

struct OpticalDepthPass::ThreadScratch {
    tbb::enumerable_thread_specific<Scratch> threads;
};

OpticalDepthPass::OpticalDepthPass() : scratch_(std::make_unique<ThreadScratch>()) {}
OpticalDepthPass::~OpticalDepthPass() = default;
OpticalDepthPass::OpticalDepthPass(OpticalDepthPass&&) noexcept = default;
OpticalDepthPass& OpticalDepthPass::operator=(OpticalDepthPass&&) noexcept = default;

template <simd::Level L>
void OpticalDepthPass::trace_at_level(const SmokeScene& smoke, std::span<const Particle> particles,
                                      std::span<const std::uint32_t> which, const glm::vec3& to_light,
                                      const OpticalDepthSettings& settings) {
    static_assert(L == simd::kCompiledLevel);
    const AccelScene& scene = smoke.scene();
    const glm::vec3 dir = glm::normalize(to_light);
    const std::size_t n = which.size();
    // Set once every ray is traced: after a throw the pass holds no rays.
    which_.clear();
    status_.clear();
    hit_counts_.clear();
    validate(settings.kernel);
    // The rays in bundles of neighbours (ray_bundle.hpp): ray_order_[k] is the k-th ray traced, an index
    // into `which`.
    origins_.resize(n);
    for (std::size_t i = 0; i < n; ++i) origins_[i] = particles[which[i]].center;
    bundle_order(origins_, dir, ray_order_, order_scratch_);
    // The rays' starts in trace order, gathered in one sweep of independent loads: filled into each bundle
    // from the order of `which`, every start would be a cache miss that the bundle waits for (at 10^7 particles).
    starts_.resize(n);
    const std::size_t chunk_count = (n + kParticlesPerChunk - 1) / kParticlesPerChunk;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t k = r.begin(); k < r.end(); ++k) {
            const std::uint32_t i = ray_order_[k];
            starts_[k] = {origins_[i], optical_depth_tmin(particles[which[i]].radius)};
        }
    });
    rays_.resize(n);
    const bool smooth = settings.kernel.smooth();
    // The shares' geometry in double along the direction the rays are traced with.
    const glm::dvec3 unit_dir = glm::normalize(glm::dvec3(dir));
    sums_.resize(smooth ? n : 0);

    // Hits kept so far, over all chunks; the budget also keeps the 32-bit offsets below from wrapping.
    const std::uint64_t budget = std::min<std::uint64_t>(
        settings.max_total_hits > 0 ? settings.max_total_hits : default_max_total_hits(),
        std::numeric_limits<std::uint32_t>::max());
    std::atomic<std::uint64_t> kept{0};
    TraceLimits limits;
    if (settings.cutoff > 0) limits.max_any_hit_invocations = settings.cutoff;  // a (K+1)-th surface cuts off

    if (!scratch_) scratch_ = std::make_unique<ThreadScratch>();  // a moved-from pass starts over
    tbb::enumerable_thread_specific<Scratch>& threads = scratch_->threads;
    for (Scratch& sc : threads) sc.clear();
    const std::uint64_t trace_id = ++traces_;
    if (settings.progress) settings.progress->begin("optical depths", n);

    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, chunk_count, 1),
        [&](const tbb::blocked_range<std::size_t>& r) {
            Scratch& sc = threads.local();
            // The rays of one pass reach every particle: each thread first asks its caches for the whole
            // top level at once (AccelScene::prefetch_top_level), once per pass. Between two passes a frame's
            // other work evicts it, and a walk from L3 waits at every node, pointer chase by pointer chase.
            if (sc.warmed_in_trace != trace_id) {
                sc.warmed_in_trace = trace_id;
                scene.prefetch_top_level();
            }
            std::uint64_t kept_before = sc.kept;
            for (std::size_t c = r.begin(); c < r.end(); ++c) {
                const std::size_t end = std::min(n, (c + 1) * kParticlesPerChunk);
                for (std::size_t k = c * kParticlesPerChunk; k < end; k += kBundleWidth) {
                    RayBundle bundle(dir);
                    for (std::size_t j = k; j < std::min(end, k + kBundleWidth); ++j)
                        bundle.add(starts_[j].origin, starts_[j].tmin, kOpticalDepthTmax);
                    for (std::vector<SurfaceHit>& lane : sc.lane_hits) lane.clear();
                    if (!smooth) {
                        // Thesis 4.3.2's any-hit shader: store (t, +1) entering a stand-in, (t, −1) leaving one,
                        // and IgnoreHit() so that the search goes on.
                        auto collect = [&](unsigned lane, const TraceHit& h) {
                            sc.lane_hits[lane].push_back(SurfaceHit{h.t, h.front_face() ? +1 : -1});
                            return AnyHitDecision::ignore;
                        };
                        const BundleResults results =
                            trace_bundle(scene, bundle, ray_flag_none, kLightRayMask, collect, limits);
                        for (unsigned lane = 0; lane < bundle.count; ++lane) {
                            const std::vector<SurfaceHit>& hits = sc.lane_hits[lane];
                            const RayOutcome o =
                                optical_depth_outcome(scene, bundle.ray(lane), results[lane], hits, settings.cutoff);
                            rays_[k + lane] = {o.status == DepthStatus::ok ? sc.keep(hits) : nullptr, o.hits, o.status};
                        }
                        continue;
                    }
                    // The same shader, which also notes each exit's particle (its user id) for its share
                    // (kernel_bundle_sums.hpp); after the walk, the ok rays' shares, summed.
                    sc.kernel_sums.clear();
                    auto collect_exits = [&](unsigned lane, const TraceHit& h) {
                        const bool front = h.front_face();
                        sc.lane_hits[lane].push_back(SurfaceHit{h.t, front ? +1 : -1});
                        if (!front) sc.kernel_sums.add_exit(lane, h.instance_id, particles);
                        return AnyHitDecision::ignore;
                    };
                    const BundleResults results =
                        trace_bundle(scene, bundle, ray_flag_none, kLightRayMask, collect_exits, limits);
                    unsigned ok = 0;
                    for (unsigned lane = 0; lane < bundle.count; ++lane) {
                        const RayOutcome o = optical_depth_outcome(scene, bundle.ray(lane), results[lane],
                                                                   sc.lane_hits[lane], settings.cutoff);
                        rays_[k + lane] = {nullptr, o.hits, o.status};
                        ok |= unsigned(o.status == DepthStatus::ok) << lane;
                    }
                    std::array<double, kBundleWidth> sums;
                    sc.kernel_sums.integrate(settings.kernel, unit_dir, bundle, particles, ok, sums);
                    for (unsigned lane = 0; lane < bundle.count; ++lane) sums_[k + lane] = float(sums[lane]);
                }
                // The budget, checked once per task: the hits over it are at most one task's.
                const std::uint64_t task_hits = sc.kept - kept_before;
                kept_before = sc.kept;
                if (kept.fetch_add(task_hits, std::memory_order_relaxed) + task_hits > budget)
                    over_budget(budget);  // TBB cancels the other tasks and rethrows in trace()'s caller
                // Counted where the budget is, once per task of kParticlesPerChunk particles.
                if (settings.progress) settings.progress->add(end - c * kParticlesPerChunk);
            }
        },
        tbb::simple_partitioner());

    // Statuses and counts to the order of `which`, in parallel: at 10^7 particles each store is a cache miss.
    smooth_ = smooth;
    which_.assign(which.begin(), which.end());
    status_.resize(n);
    hit_counts_.resize(n);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t k = r.begin(); k < r.end(); ++k) {
            const std::size_t i = ray_order_[k];
            status_[i] = rays_[k].status;
            hit_counts_[i] = rays_[k].count;
        }
    });
}

void OpticalDepthPass::gather(OpticalDepthHits& out) const {
    // The kept hits gathered into one flat buffer in the order of `which`: the same buffer whichever
    // thread kept them.
    const std::size_t n = which_.size();
    out.particles = which_;
    out.status = status_;
    out.hit_counts = hit_counts_;
    HitLists& lists = out.lists;
    lists.offsets.resize(n + 1);
    lists.offsets[0] = 0;
    for (std::size_t i = 0; i < n; ++i)
        lists.offsets[i + 1] = lists.offsets[i] + (status_[i] == DepthStatus::ok && !smooth_ ? hit_counts_[i] : 0);
    lists.hits.resize(lists.offsets[n]);
    if (smooth_) return;  // a smooth kernel's trace() kept no hits
    const std::size_t chunk_count = (n + kParticlesPerChunk - 1) / kParticlesPerChunk;
    tbb::parallel_for(std::size_t(0), chunk_count, [&](std::size_t c) {
        for (std::size_t k = c * kParticlesPerChunk; k < std::min(n, (c + 1) * kParticlesPerChunk); ++k) {
            const RayRecord& r = rays_[k];
            if (r.status != DepthStatus::ok) continue;
            std::transform(r.hits, r.hits + r.count, lists.hits.begin() + lists.offsets[ray_order_[k]],
                           unpack_surface_hit);
        }
    });
}

template <simd::Level L>
void OpticalDepthPass::resolve_at_level(HitSort method, std::span<float> lengths) {
    static_assert(L == simd::kCompiledLevel);
    const std::size_t n = which_.size();
    if (lengths.size() != n) {
        throw std::invalid_argument("OpticalDepthPass::resolve: " + std::to_string(n) + " particles traced but " +
                                    std::to_string(lengths.size()) + " lengths");
    }
    // Ray by ray in trace order, chunk by chunk as they were traced: each task reads the stretch of a
    // thread's kept hits that one trace task wrote, packed as they are (ListResolver). Each ray sorts only
    // its own hits: deterministic.
    const std::size_t chunk_count = (n + kParticlesPerChunk - 1) / kParticlesPerChunk;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunk_count, 1),
                      [&](const tbb::blocked_range<std::size_t>& r) {
        ListResolver& resolve_list = scratch_->threads.local().resolver;
        for (std::size_t k = r.begin() * kParticlesPerChunk; k < std::min(n, r.end() * kParticlesPerChunk); ++k) {
            const RayRecord& ray = rays_[k];
            if (smooth_) {
                lengths[ray_order_[k]] = ray.status == DepthStatus::ok ? sums_[k] : kFullyDarkPathLength;
                continue;
            }
            const std::span<const PackedSurfaceHit> hits(ray.hits, ray.count);
            lengths[ray_order_[k]] =
                ray.status == DepthStatus::ok ? resolve_list.at_level<L>(hits, method) : kFullyDarkPathLength;
        }
    });
}

// This copy's kernels (core/simd/dispatch.hpp); the entry points are in optical_depth_pass_dispatch.cpp.
template void OpticalDepthPass::trace_at_level<simd::kCompiledLevel>(const SmokeScene&, std::span<const Particle>,
                                                                     std::span<const std::uint32_t>, const glm::vec3&,
                                                                     const OpticalDepthSettings&);
template void OpticalDepthPass::resolve_at_level<simd::kCompiledLevel>(HitSort, std::span<float>);

}  // namespace smoketrace
