#pragma once
// A smooth density kernel's sums for the rays of one trace_bundle() call (density_kernel.hpp): the rule of the
// optical-depth pass (optical_depth_pass.hpp) for any bundle of rays toward the light, the ground's shadow
// rays included. During the walk the any-hit callback notes each EXIT (a back face: the ray leaves a
// particle's stand-in) with its lane, its ray's origin and the particle; entries add nothing. After the walk
// every exit is integrated at once, over lanes (integrate_stretches()), and each ray's shares are summed in
// double in the order its walk met them: l = Σ ∫ρ dt, the density-weighted length (τ = σt·l).
//
// No sort: a ray leaves every convex stand-in it meets exactly once, so its exits name each particle once.
// A ray's order is fixed by the walk (trace_bundle() meets a ray's candidates in trace<TlasWalk::all_hits>'s
// order when nothing is committed, bundle_traversal.hpp), so a lone ray that adds
// particle_stretch_integral() for each exit in its walk's order gets the same bits.
#include <smoketrace/geometry/ray_bundle.hpp>
#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/particle_system.hpp>

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace smoketrace {

// Reused from bundle to bundle (one per thread): once its lists have grown, a bundle allocates nothing.
class BundleKernelSums {
public:
    // Before a bundle's walk.
    void clear() {
        exits_.clear();
        lanes_.clear();
    }
    // From the any-hit callback, for an exit of lane `lane`'s ray (from `origin`) out of particle `p`'s stand-in.
    void add_exit(unsigned lane, const glm::vec3& origin, const Particle& p) {
        exits_.add(origin, p.center, p.radius);
        lanes_.push_back(std::uint8_t(lane));
    }
    // After the walk: sums[lane] = the lane's shares summed in its walk's order (0 for a lane with no exit).
    // `unit_direction`: the rays' direction, unit length in double.
    void integrate(const DensityKernel& kernel, const glm::dvec3& unit_direction,
                   std::array<double, kBundleWidth>& sums);

private:
    KernelStretches exits_;
    std::vector<std::uint8_t> lanes_;  // [e]: exit e's lane
    std::vector<double> shares_;       // [e]: its share
};

}  // namespace smoketrace
