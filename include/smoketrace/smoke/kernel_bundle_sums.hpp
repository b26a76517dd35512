#pragma once
// A smooth density kernel's sums for the rays of one trace_bundle() call (density_kernel.hpp): the rule of the
// optical-depth pass (optical_depth_pass.hpp) for any bundle of rays toward the light, the ground's shadow
// rays included. During the walk the any-hit callback notes each EXIT (a back face: the ray leaves a
// particle's stand-in) with its lane and the particle; entries add nothing. After the walk the exits of the
// lanes asked for are integrated at once, over lanes (integrate_stretches()), and each ray's shares are summed
// in double in the order its walk met them: l = Σ ∫ρ dt, the density-weighted length (τ = σt·l).
//
// No sort: a ray leaves every convex stand-in it meets exactly once, so its exits name each particle once.
// A ray's order is fixed by the walk (trace_bundle() meets a ray's candidates in trace<TlasWalk::all_hits>'s
// order when nothing is committed, bundle_traversal.hpp), so a lone ray that adds
// particle_stretch_integral() for each exit in its walk's order gets the same bits.
//
// The particles are read after the walk, each asked for from memory when its exit is noted: at 10^5 particles
// and more their array is far beyond L2, and a read in the callback stalled the walk at every exit.
#include <smoketrace/geometry/ray_bundle.hpp>
#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/particle_system.hpp>

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace smoketrace {

// Reused from bundle to bundle (one per thread): once its lists have grown, a bundle allocates nothing.
class BundleKernelSums {
public:
    // Before a bundle's walk.
    void clear() {
        for (std::vector<std::uint32_t>& lane : exits_) lane.clear();
    }
    // From the any-hit callback, for an exit of lane `lane`'s ray out of the stand-in of `particles[particle]`.
    void add_exit(unsigned lane, std::uint32_t particle, std::span<const Particle> particles) {
        exits_[lane].push_back(particle);
        __builtin_prefetch(&particles[particle]);  // read in integrate(), after the walk
    }
    // After the walk: sums[lane] = the lane's shares summed in its walk's order, for the lanes set in `lanes`
    // (bit per lane; the others' exits are not integrated, and their sums are 0). The rays start at
    // bundle.origin(lane); `unit_direction` is their direction, unit length in double.
    void integrate(const DensityKernel& kernel, const glm::dvec3& unit_direction, const RayBundle& bundle,
                   std::span<const Particle> particles, unsigned lanes, std::array<double, kBundleWidth>& sums);

private:
    std::array<std::vector<std::uint32_t>, kBundleWidth> exits_;  // [lane]: its exits' particles, in walk order
    KernelStretches stretches_;  // the lanes' exits, lane after lane
    std::vector<double> shares_;
};

}  // namespace smoketrace
