#pragma once
// Contract: textbook::optical_depths's statuses and hit counts (textbook/optical_depth.hpp); lengths within one
// float ulp (the resolver's eight running double sums against one, hit_resolver.hpp; a smooth kernel's shares
// summed in another order), plus one ulp of the farthest crossing per crossing where a particle is tested as a
// world sphere (its t rounds apart from the textbook's object-space root). tests/test_textbook_optical_depth.cpp.
// The optical-depth pass (thesis 4.3.2): for each particle, a ray from its centre toward the light
// collects the particle surfaces it crosses, through the trace API and its any-hit callback. The rays all
// go the same way, so they are traced in bundles of thirty-two neighbours (trace_bundle(),
// ray_bundle.hpp), each ray getting what trace() would give it alone; the rare follow-ups below use
// trace().
//
//   ray:    origin = particle centre, direction = toward the light, tmin = optical_depth_tmin(radius)
//           (2^-22 of the particle's radius; the thesis's fixed 1e-7 would lose every particle smaller
//           than that), tmax = 1e38, inclusion mask ~2 (everything but billboards), no closest-hit data needed;
//   any-hit (particle stand-ins, non-opaque): store (t, +1) for a front face (entering a particle) or
//           (t, −1) for a back face (leaving one), IgnoreHit() so the search goes on;
//   ground (opaque): commits without any-hit and shrinks tmax — the particle is occluded.
//
// Statuses are defined so that they do not depend on the order the traversal finds things in (and so
// match any other correct tracer, Embree included):
//   occluded — opaque geometry lies on the ray; `hits` counts the surfaces in front of it;
//   cutoff   — not occluded, and the ray meets more than K particle surfaces (K = cutoff > 0): the
//              search ends at the (K+1)-th, `hits` = K + 1 (thesis 4.4.3, "fully dark");
//   ok       — all surfaces stored, `hits` = their number.
// A crossing of a shared edge or vertex counts once (ray_triangle.hpp). Hits go into variable-length
// per-ray lists, kept in the buffer of the thread that traced the ray: no fixed K-slot arrays (the thesis's
// limitation 6.1). resolve() turns them into optical path lengths where they lie; gather() copies them
// into one flat buffer for callers that want the hits themselves.
//
// With a smooth density kernel (settings.kernel, density_kernel.hpp) the rays, the any-hit calls, the
// statuses and the counts are the same, but no hit is kept: each exit (−1) adds its particle's closed-form
// share to the ray's sum, l = Σ ∫ρ dt (the density-weighted length; τ = l·σt as before), integrated over
// lanes for the whole bundle's ok rays' exits at once after its walk (kernel_bundle_sums.hpp, as the ground's
// shadow rays are), and summed per ray in double in the order the walk met them (fixed for a bundle, so the same for any thread count). The sum needs no sort: the
// exits name each particle met once. The shares are taken along the rays' own direction (to_light normalised
// in float), normalised once more in double. resolve() then hands out those sums; gather() gives no hits;
// a ray's hits cost no memory past its bundle.
#include <smoketrace/core/aligned_allocator.hpp>
#include <smoketrace/core/simd/level.hpp>
#include <smoketrace/core/work_progress.hpp>
#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/hit_resolver.hpp>
#include <smoketrace/smoke/light_ray.hpp>
#include <smoketrace/smoke/kernel_bundle_sums.hpp>
#include <smoketrace/geometry/ray_bundle.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/accel/trace_types.hpp>

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <vector>

namespace smoketrace {

// Hits per block of a thread's kept hits (OpticalDepthPass): 1 MiB of packed hits, so that the slack of a
// thread's last block is small next to the hits of a large pass, and a block holds tens of thousands of rays.
inline constexpr std::size_t kKeptHitsPerBlock = (std::size_t{1} << 20) / sizeof(PackedSurfaceHit);

struct OpticalDepthSettings {
    std::uint32_t cutoff = 0;  // K: more than K surfaces → cutoff (0 = no cutoff)
    // Most hits one trace() (or run()) may keep, over all its particles; 0 = default_max_total_hits(). Without a cutoff
    // the hits grow with the square of the particle density (n particles in a fixed volume: each ray
    // crosses ~n of them), so a dense scene can ask for more memory than the machine has.
    std::uint64_t max_total_hits = 0;
    // Where the pass counts the particles it has traced, for a progress display; null: nowhere.
    WorkProgress* progress = nullptr;
    // The stand-ins' density: uniform (eq. 3.1, the union of the balls through the hit resolver) or a smooth
    // kernel whose closed-form shares the pass sums per ray (the top of this file).
    DensityKernel kernel{};
};

// Thrown by OpticalDepthPass::run when the hits would exceed the budget: the message says how many, how
// much memory that is, and what to do (a cutoff, or fewer or smaller particles).
class OpticalDepthBudgetError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Half of this machine's memory at kPeakBytesPerStoredHit per hit (memory_budget.hpp), and at most
// 2^32 − 1 (HitLists offsets are 32-bit).
[[nodiscard]] std::uint64_t default_max_total_hits();

// The pass's output for the particles it traced (in the order given to run()).
struct OpticalDepthHits {
    std::vector<std::uint32_t> particles;  // which particle each entry belongs to
    HitLists lists;                        // ok particles' hits (other particles own an empty list)
    std::vector<DepthStatus> status;
    std::vector<std::uint32_t> hit_counts;
};

// A particle's status and hit count (see the top of this file) from its ray's search `r`, which stored
// `hits`. A search that did not see the whole ray, because it was cut off or met the ground, is completed
// here with more trace() calls. The pass's, and explain_optical_depth()'s (optical_depth_story.hpp).
struct RayOutcome {
    DepthStatus status = DepthStatus::ok;
    std::uint32_t hits = 0;
};
[[nodiscard]] RayOutcome optical_depth_outcome(const AccelScene& scene, const Ray& ray, const TraceResult& r,
                                               std::span<const SurfaceHit> hits, std::uint32_t cutoff);

class OpticalDepthPass {
public:
    OpticalDepthPass();
    ~OpticalDepthPass();
    // Movable, not copyable: the rays of the last trace() point into this pass's per-thread buffers.
    OpticalDepthPass(OpticalDepthPass&&) noexcept;
    OpticalDepthPass& operator=(OpticalDepthPass&&) noexcept;

    // Traces the rays of `which` (particle indices) toward `to_light` (need not be unit length) in
    // parallel over bundles (TBB). The result does not depend on the number of threads. Throws
    // OpticalDepthBudgetError (leaving `out` unspecified) when the hits exceed settings.max_total_hits,
    // std::invalid_argument when settings.kernel is not valid (density_kernel.hpp's validate()).
    // trace() followed by gather().
    void run(const SmokeScene& scene, std::span<const Particle> particles, std::span<const std::uint32_t> which,
             const glm::vec3& to_light, const OpticalDepthSettings& settings, OpticalDepthHits& out);

    // The two halves of run(). trace() traces the rays and keeps each ok ray's hits where the thread
    // that traced it stored them, until the next trace(); gather() copies them into out, one flat buffer
    // in the order of `which`, with the statuses and counts. A trace() that throws leaves no rays: then
    // gather() gives an empty output and resolve() wants no lengths. With a smooth kernel trace() sums each
    // ray's shares instead of keeping its hits (the budget then has nothing to count), and gather() gives
    // every particle an empty list.
    void trace(const SmokeScene& scene, std::span<const Particle> particles, std::span<const std::uint32_t> which,
               const glm::vec3& to_light, const OpticalDepthSettings& settings);
    void gather(OpticalDepthHits& out) const;

    // After trace(): resolve_optical_path_lengths() on the kept hits where they lie, without gathering
    // them first (each packed list sorted and walked by a ListResolver, eq. 3.1). lengths[i] for which[i]
    // (std::invalid_argument unless lengths.size() == which.size()); the same bits as gather() and then
    // resolve_optical_path_lengths(), without the copy. With a smooth kernel: the sums trace() computed
    // (kFullyDarkPathLength unless ok), whatever `method`.
    void resolve(HitSort method, std::span<float> lengths);

    // The traced rays' statuses and surface counts, in the order of `which`.
    [[nodiscard]] std::span<const DepthStatus> status() const { return status_; }
    [[nodiscard]] std::span<const std::uint32_t> hit_counts() const { return hit_counts_; }

private:
    // trace() and resolve() at one kernel level (core/simd/dispatch.hpp): optical_depth_pass.cpp, compiled
    // once per level, instantiates each for the level it is compiled for.
    template <simd::Level L>
    void trace_at_level(const SmokeScene& scene, std::span<const Particle> particles,
                        std::span<const std::uint32_t> which, const glm::vec3& to_light,
                        const OpticalDepthSettings& settings);
    template <simd::Level L>
    void resolve_at_level(HitSort method, std::span<float> lengths);

    struct Scratch {
        std::array<std::vector<SurfaceHit>, kBundleWidth> lane_hits;  // the bundle in flight's, per ray
        BundleKernelSums kernel_sums;  // a smooth kernel's: the bundle in flight's exits and their sums
        ListResolver resolver;  // resolve()'s, kept with its memory for lists past the sorting network
        // The hits of this thread's ok rays, packed (PackedSurfaceHit: 18 per ray at 10^6 particles without a
        // cutoff, most of the pass's memory), ray after ray, in blocks of fixed capacity (a ray with more
        // hits than a block gets a block of its own size): a ray's hits stay contiguous and never move, and
        // the memory is what the hits need, where one growing vector would hold up to twice that and copy
        // it at every doubling. The blocks are kept, emptied, for the next trace().
        // Grown unwritten (UnwrittenAllocator): keep() writes each hit, so zeroing it first would be a second
        // pass over the pass's largest memory.
        std::vector<std::vector<PackedSurfaceHit, UnwrittenAllocator<PackedSurfaceHit>>> blocks;
        std::size_t block = 0;  // the block being filled
        std::uint64_t kept = 0;  // hits kept in this trace()
        std::uint64_t warmed_in_trace = 0;  // the last trace() in which this thread prefetched the top level

        PackedSurfaceHit* keep(std::span<const SurfaceHit> hits);
        void clear();
    };
    // A ray's outcome, stored in trace order (index k of ray_order_) so that each task writes a
    // contiguous stretch: in particle order the rays of a task land all over the output arrays, and two
    // threads' writes share cache lines. Scattered to particle order after the parallel part.
    struct RayRecord {
        PackedSurfaceHit* hits;  // where the ray's hits are kept (ok rays), until the next trace()
        std::uint32_t count;
        DepthStatus status;
    };
    // Every thread's Scratch: a tbb::enumerable_thread_specific, defined in the .cpp so that no public header
    // needs TBB. Reached once per task (its local()), never per ray; moving the pass keeps it where it is.
    struct ThreadScratch;
    std::unique_ptr<ThreadScratch> scratch_;
    // The arrays per ray below grow unwritten: trace() writes every element (at 10^7 particles zeroing
    // them would be a serial pass over fresh pages).
    std::vector<glm::vec3, UnwrittenAllocator<glm::vec3>> origins_;  // the rays' origins, in the order of `which`
    std::vector<std::uint32_t> ray_order_;  // bundle_order() of origins_
    BundleOrderScratch order_scratch_;
    struct RayStart {
        glm::vec3 origin;
        float tmin;  // optical_depth_tmin() of the particle's radius
    };
    std::vector<RayStart, UnwrittenAllocator<RayStart>> starts_;    // [k]: the k-th ray traced's
    std::vector<RayRecord, UnwrittenAllocator<RayRecord>> rays_;    // [k]: the k-th ray traced
    std::vector<float, UnwrittenAllocator<float>> sums_;            // [k]: its kernel sum (smooth kernels)
    bool smooth_ = false;                   // the last trace()'s kernel was smooth: sums_, no kept hits
    std::vector<std::uint32_t> which_;      // the particles of the last trace()
    std::vector<DepthStatus> status_;       // [i]: the ray of which_[i]
    std::vector<std::uint32_t> hit_counts_;
    std::uint64_t traces_ = 0;              // trace() calls so far
};

}  // namespace smoketrace
