// The optical-depth pass (thesis 4.3.2), see optical_depth_pass.hpp.
#include <smoketrace/optical_depth_pass.hpp>
#include <smoketrace/trace.hpp>

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

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
    if (cutoff > 0) limits.max_any_hit_invocations = cutoff + 1;
    const TraceResult r = trace(scene, ray, ray_flag_none, kLightRayMask, collect, limits);

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
        trace(scene, front, ray_flag_force_non_opaque, kStandInMask, [&](const TraceHit&) {
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

}  // namespace

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
