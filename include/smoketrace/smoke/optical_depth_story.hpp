#pragma once
// One particle's optical-depth ray told step by step, for people learning the method (smoketrace explain
// --particle, docs/explain.md): the ray of the optical-depth pass (4.3.2) traced once more with trace() and
// an any-hit callback that stores what the pass's callback stores and also records who it came from, then
// the pass's own outcome (optical_depth_outcome), the resolver's own sort (sort_hits_by_t) and its own walk
// (detail::walk_sorted_hits, eq. 3.1, hit_walk.hpp), which reports each step to the story. Nothing of the
// method is done a second time: l is the resolver's, bit for bit what the pass gives the same particle
// (tests/test_explain.cpp); the counter after each hit and the in-smoke stretches are the walk's steps.
//
// Under a smooth density kernel (settings.kernel, density_kernel.hpp) the pass sorts nothing: each exit adds
// its particle's closed-form share, in the order the walk met them, and the story records each candidate's
// share and the sum after it, the pass's own sum (the story's trace<TlasWalk::all_hits>() meets a ray's
// candidates in the order the pass's trace_bundle() does, kernel_bundle_sums.hpp), so l is again the
// pass's, bit for bit.
#include <smoketrace/geometry/ray.hpp>
#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/hit_resolver.hpp>
#include <smoketrace/smoke/optical_depth_pass.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/accel/trace_types.hpp>

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
    DensityKernel kernel{};  // the settings': uniform tells eq. 3.1's sort and walk, a smooth one the sum
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
    // A smooth kernel, status ok (then `sorted`, the counter and the stretches stay empty): [i] the share of
    // seen[i] (an exit's: particle_stretch_integral() from the ray's origin; an entry's: 0) and the sum of the
    // shares up to and including it, in double, in the order trace() met them.
    std::vector<double> shares;
    std::vector<double> sum_after;
    float length = 0.0f;         // l: the resolver's, or a smooth kernel's sum rounded; kFullyDarkPathLength unless ok
    float sigma_t = 0.0f;
    float optical_depth = 0.0f;  // τ = l·σt (eq. 2.12)
    float transmittance = 1.0f;  // T = exp(−τ) (eq. 2.10); σt = 0 gives 1, even for l = ∞
};

// The story of particle `particle`'s optical-depth ray, as OpticalDepthPass::trace() and resolve() with
// these arguments would compute it (`sort` only for the uniform kernel). Throws std::out_of_range naming the
// index and the count when there is no such particle, std::invalid_argument when settings.kernel is not valid.
[[nodiscard]] OpticalDepthStory explain_optical_depth(const SmokeScene& scene, std::span<const Particle> particles,
                                                      std::uint32_t particle, const glm::vec3& to_light,
                                                      const OpticalDepthSettings& settings, HitSort sort,
                                                      float sigma_t);

}  // namespace smoketrace
