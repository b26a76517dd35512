// The optical-depth pass (thesis 4.3.2), see optical_depth_pass.hpp.
#include <smoketrace/memory_budget.hpp>
#include <smoketrace/optical_depth_pass.hpp>
#include <smoketrace/trace.hpp>

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <string>

namespace smoketrace {
namespace {

// Particles per parallel chunk: large enough to amortise the task, small enough to balance 2–64 cores.
// Fixed chunk boundaries (simple_partitioner) make the layout of the hit buffer thread-count independent.
constexpr std::size_t kParticlesPerChunk = 64;

struct ParticleRayResult {
    DepthStatus status = DepthStatus::ok;
    std::uint32_t hits = 0;
};

// One particle's ray. Appends its hits to `hits` and returns status and count.
ParticleRayResult trace_particle(const SmokeScene& smoke, const Particle& p, const glm::vec3& dir, std::uint32_t cutoff,
                                 std::vector<SurfaceHit>& hits) {
    const Scene& scene = smoke.scene();
    const Ray ray{p.center, kOpticalDepthTmin, dir, kOpticalDepthTmax};
    const std::size_t start = hits.size();
    auto collect = [&](const TraceHit& h) {
        hits.push_back(SurfaceHit{h.t, h.front_face() ? +1 : -1});
        return AnyHitDecision::ignore;
    };
    TraceLimits limits;
    if (cutoff > 0) limits.max_any_hit_invocations = cutoff;  // a (K+1)-th surface cuts the ray off
    // Every surface is collected: the 4-wide TLAS walk (trace.hpp).
    const TraceResult r = trace<TlasWalk::all_hits>(scene, ray, ray_flag_none, kLightRayMask, collect, limits);

    ParticleRayResult out;
    if (r.cut_off) {
        hits.resize(start);
        // Cut off before the whole ray was seen: only a ground-only ray can tell whether it is occluded.
        const Ray ground_ray{p.center, kOpticalDepthTmin, dir, kOpticalDepthTmax};
        const TraceResult g = trace(scene, ground_ray, ray_flag_accept_first_hit_and_end_search | ray_flag_force_opaque,
                                    kGroundMask);
        if (!g.hit) return {DepthStatus::cutoff, cutoff + 1};
        // Occluded: count the surfaces in front of the opaque hit, with no cutoff.
        // tmax just below the ground: the same "t < t_ground" count as the uncut path below.
        const Ray front{p.center, kOpticalDepthTmin, dir, std::nextafter(g.committed.t, 0.0f)};
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
        const auto n = std::count_if(hits.begin() + std::ptrdiff_t(start), hits.end(),
                                     [&](const SurfaceHit& h) { return h.t < t_opaque; });
        hits.resize(start);
        return {DepthStatus::occluded, static_cast<std::uint32_t>(n)};
    }
    out.hits = static_cast<std::uint32_t>(hits.size() - start);
    return out;
}

[[noreturn]] void over_budget(std::uint64_t budget) {
    throw OpticalDepthBudgetError(
        "optical-depth pass: the particles' light rays cross more than " + std::to_string(budget) +
        " particle surfaces in all, more than the hit lists may hold (" + std::to_string(budget) + " hits need " +
        format_bytes(budget * kPeakBytesPerStoredHit) + "; by default they may use half of this machine's " +
        format_bytes(machine_memory_bytes()) + "); set a cutoff (\"render\": {\"cutoff\": K} in the scene file, "
        "--cutoff K on the command line), or use fewer or smaller particles");
}

}  // namespace

std::uint64_t default_max_total_hits() {
    return std::min<std::uint64_t>(std::numeric_limits<std::uint32_t>::max(),
                                   machine_memory_bytes() / 2 / kPeakBytesPerStoredHit);
}

void OpticalDepthPass::run(const SmokeScene& smoke, std::span<const Particle> particles,
                           std::span<const std::uint32_t> which, const glm::vec3& to_light,
                           const OpticalDepthSettings& settings, OpticalDepthHits& out) {
    const glm::vec3 dir = glm::normalize(to_light);
    const std::size_t n = which.size();
    out.particles.assign(which.begin(), which.end());
    out.status.assign(n, DepthStatus::ok);
    out.hit_counts.assign(n, 0);
    const std::size_t chunk_count = (n + kParticlesPerChunk - 1) / kParticlesPerChunk;
    if (chunks_.size() < chunk_count) chunks_.resize(chunk_count);
    // Hits kept so far, over all chunks; the budget also keeps the 32-bit offsets below from wrapping.
    const std::uint64_t budget = std::min<std::uint64_t>(
        settings.max_total_hits > 0 ? settings.max_total_hits : default_max_total_hits(),
        std::numeric_limits<std::uint32_t>::max());
    std::atomic<std::uint64_t> kept{0};

    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, chunk_count, 1),
        [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t c = r.begin(); c < r.end(); ++c) {
                std::vector<SurfaceHit>& hits = chunks_[c].hits;
                hits.clear();
                const std::size_t end = std::min(n, (c + 1) * kParticlesPerChunk);
                for (std::size_t i = c * kParticlesPerChunk; i < end; ++i) {
                    const ParticleRayResult res = trace_particle(smoke, particles[which[i]], dir, settings.cutoff, hits);
                    out.status[i] = res.status;
                    out.hit_counts[i] = res.hits;
                    if (res.status == DepthStatus::ok && kept.fetch_add(res.hits, std::memory_order_relaxed) + res.hits > budget)
                        over_budget(budget);  // TBB cancels the other chunks and rethrows in run()'s caller
                }
            }
        },
        tbb::simple_partitioner());

    // Gather the chunks into one flat buffer in particle order.
    HitLists& lists = out.lists;
    lists.offsets.resize(n + 1);
    lists.offsets[0] = 0;
    for (std::size_t i = 0; i < n; ++i)
        lists.offsets[i + 1] = lists.offsets[i] + (out.status[i] == DepthStatus::ok ? out.hit_counts[i] : 0);
    lists.hits.resize(lists.offsets[n]);
    tbb::parallel_for(std::size_t(0), chunk_count, [&](std::size_t c) {
        const std::size_t first = c * kParticlesPerChunk;
        std::copy(chunks_[c].hits.begin(), chunks_[c].hits.end(), lists.hits.begin() + lists.offsets[first]);
    });
}

}  // namespace smoketrace
