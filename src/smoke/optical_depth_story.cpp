// One particle's optical-depth ray told step by step, see optical_depth_story.hpp.
#include <smoketrace/smoke/optical_depth_story.hpp>
#include <smoketrace/smoke/hit_resolver_avx512.hpp>
#include <smoketrace/smoke/hit_walk.hpp>
#include <smoketrace/trace/trace.hpp>

#include <glm/geometric.hpp>

#include <bit>
#include <cmath>
#include <stdexcept>
#include <string>

namespace smoketrace {

OpticalDepthStory explain_optical_depth(const SmokeScene& smoke, std::span<const Particle> particles,
                                        std::uint32_t particle, const glm::vec3& to_light,
                                        const OpticalDepthSettings& settings, HitSort sort, float sigma_t) {
    if (particle >= particles.size()) {
        throw std::out_of_range("particle " + std::to_string(particle) + " does not exist (the scene has " +
                                std::to_string(particles.size()) + " particles, 0…" +
                                std::to_string(particles.size() == 0 ? 0 : particles.size() - 1) + ")");
    }
    validate(settings.kernel);
    const AccelScene& scene = smoke.scene();
    OpticalDepthStory story;
    story.particle = particle;
    story.kernel = settings.kernel;
    story.cutoff = settings.cutoff;
    story.sigma_t = sigma_t;
    // The pass's ray (OpticalDepthPass::trace: normalised direction, the particle's tmin, kOpticalDepthTmax).
    const Particle& p = particles[particle];
    story.ray = Ray{p.center, optical_depth_tmin(p.radius), glm::normalize(to_light), kOpticalDepthTmax};

    // The pass's any-hit shader (thesis 4.3.2): store (t, ±1) and ignore, so that the search goes on; here
    // it also notes the particle (the stand-in's user id) and keeps the order the candidates came in.
    std::vector<SurfaceHit> stored;
    TraceLimits limits;
    if (settings.cutoff > 0) limits.max_any_hit_invocations = settings.cutoff;
    const TraceResult r = trace<TlasWalk::all_hits>(
        scene, story.ray, ray_flag_none, kLightRayMask,
        [&](const TraceHit& h) {
            const std::int32_t value = h.front_face() ? +1 : -1;
            stored.push_back(SurfaceHit{h.t, value});
            story.seen.push_back(StoryHit{h.t, h.instance_id, value});
            return AnyHitDecision::ignore;
        },
        limits);
    story.counters = r.counters;
    story.cut_off = r.cut_off;
    if (r.hit) story.ground_t = r.committed.t;
    story.outcome = optical_depth_outcome(scene, story.ray, r, stored, settings.cutoff);

    story.length = kFullyDarkPathLength;
    if (story.outcome.status == DepthStatus::ok && settings.kernel.smooth()) {
        // The pass's sum (optical_depth_pass.hpp): each exit's share from the ray's origin along the direction
        // in double, added in the order the walk met them.
        const glm::dvec3 unit_dir = glm::normalize(glm::dvec3(story.ray.direction));
        double sum = 0.0;
        for (const StoryHit& h : story.seen) {
            double share = 0.0;
            if (h.value < 0) {
                const Particle& q = particles[h.particle];
                share = particle_stretch_integral(settings.kernel, story.ray.origin, unit_dir, q.center, q.radius);
                sum += share;
            }
            story.shares.push_back(share);
            story.sum_after.push_back(sum);
        }
        story.length = float(sum);
    } else if (story.outcome.status == DepthStatus::ok) {
        // The resolver's sort, then its walk (hit_walk.hpp) on the lanes the resolver uses, told step by step:
        // the bits OpticalDepthPass::resolve() gives the pass's stored hits.
        std::vector<SurfaceHit> scratch(stored.size());
        sort_hits_by_t(stored, scratch, sort);
        // Who each sorted hit came from: the first unclaimed candidate with the same t and value (equal
        // twins are interchangeable, their order within a tie changes nothing).
        std::vector<bool> claimed(story.seen.size(), false);
        for (const SurfaceHit& h : stored) {
            for (std::size_t k = 0; k < story.seen.size(); ++k) {
                const StoryHit& s = story.seen[k];
                if (claimed[k] || s.value != h.value ||
                    std::bit_cast<std::uint32_t>(s.t) != std::bit_cast<std::uint32_t>(h.t))
                    continue;
                claimed[k] = true;
                story.sorted.push_back(s);
                break;
            }
        }
        // The in-smoke gaps the walk adds, merged into stretches; a stretch open at the origin starts at t = 0.
        struct TellSteps {
            OpticalDepthStory& story;
            std::span<const SurfaceHit> hits;
            bool open = false;
            float opened = 0.0f;
            void start(std::int64_t counter_start) {
                story.counter_start = counter_start;
                open = counter_start > 0;
            }
            void block(std::size_t first, const detail::ScalarWalkLanes::Ints& after, std::uint32_t in_smoke) {
                for (std::size_t i = 0; i < detail::kWalkLanes && first + i < hits.size(); ++i) {
                    const float t = hits[first + i].t;
                    story.counter_after.push_back(after[i]);
                    const bool gap_in_smoke = (in_smoke >> i & 1u) != 0;
                    if (gap_in_smoke && !open) opened = t;
                    if (!gap_in_smoke && open && t > opened) story.stretches.push_back({opened, t});
                    open = gap_in_smoke;
                }
            }
        };
        using L = detail::FastWalkLanes;
        story.length = static_cast<float>(
            detail::walk_sorted_hits<L>(L::SortedHits{stored}, TellSteps{story, stored}));
    }
    story.optical_depth = story.length * sigma_t;
    story.transmittance = sigma_t == 0.0f ? 1.0f : std::exp(-story.length * sigma_t);
    return story;
}

}  // namespace smoketrace
