#pragma once
// One particle's optical-depth ray told step by step, for people learning the method (smoketrace explain
// --particle, docs/explain.md): the ray of the optical-depth pass (4.3.2) traced once more with trace() and
// an any-hit callback that stores what the pass's callback stores and also records who it came from, then
// the pass's own outcome (optical_depth_outcome) and the resolver's own sort and walk (ListResolver, eq.
// 3.1). Nothing of the method is done a second time: l is the resolver's, bit for bit what the pass gives
// the same particle (tests/test_explain.cpp). The counter after each hit and the in-smoke stretches are
// the walk written out for reading; the length that counts is `length`.
#include <smoketrace/geometry/ray.hpp>
#include <smoketrace/smoke/hit_resolver.hpp>
#include <smoketrace/smoke/optical_depth_pass.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/trace/trace_types.hpp>

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace smoketrace {

// One surface the ray crossed: the stand-in's particle, entry (+1) or exit (−1), and where.
struct StoryHit {
    float t = 0.0f;
    std::uint32_t particle = 0;
    std::int32_t value = 0;  // +1 entering (front face), −1 leaving (back face), as stored by the pass
};

// A stretch [t0, t1) of the ray inside smoke: the counter was > 0 all along it.
struct SmokeStretch {
    float t0 = 0.0f, t1 = 0.0f;
};

struct OpticalDepthStory {
    std::uint32_t particle = 0;
    Ray ray;  // the pass's ray: from the centre toward the light, tmin = optical_depth_tmin(radius)
    // Every candidate the any-hit callback was called with, in the order trace() met them (any-hit order
    // is free: the pass, tracing 32 rays together, may meet them in another order; the set is the same).
    std::vector<StoryHit> seen;
    std::optional<float> ground_t;  // the opaque ground committed on the ray at this t (the particle is occluded)
    bool cut_off = false;           // a (cutoff+1)-th candidate ended the search (TraceResult::cut_off)
    std::uint32_t cutoff = 0;       // the settings' K (0: none)
    TraceCounters counters;         // of the trace() call above
    RayOutcome outcome;             // status and hit count, as the pass reports them (depths' CSV)
    // Status ok only: the stored hits after the resolver's sort (its order, ties included), the eq. 3.1
    // counter's start −Σ values and its value after each sorted hit, and the stretches where it was > 0.
    std::vector<StoryHit> sorted;
    std::int64_t counter_start = 0;
    std::vector<std::int64_t> counter_after;  // [i]: after sorted[i]
    std::vector<SmokeStretch> stretches;
    float length = 0.0f;         // l: the resolver's; kFullyDarkPathLength unless ok
    float sigma_t = 0.0f;
    float optical_depth = 0.0f;  // τ = l·σt (eq. 2.12)
    float transmittance = 1.0f;  // T = exp(−τ) (eq. 2.10); σt = 0 gives 1, even for l = ∞
};

// The story of particle `particle`'s optical-depth ray, as OpticalDepthPass::trace() and resolve() with
// these arguments would compute it. Throws std::out_of_range naming the index and the count when there
// is no such particle.
[[nodiscard]] OpticalDepthStory explain_optical_depth(const SmokeScene& scene, std::span<const Particle> particles,
                                                      std::uint32_t particle, const glm::vec3& to_light,
                                                      const OpticalDepthSettings& settings, HitSort sort,
                                                      float sigma_t);

}  // namespace smoketrace
