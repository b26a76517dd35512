#pragma once
// The W child boxes of a wide node against one ray, for both wide trees (the top level's 4-wide one,
// wide_bvh.hpp, and a mesh BLAS's 8-wide one, blas_wide_bvh.hpp): bit i of the result is set when the ray
// meets child i's box in [tmin, tmax], with its entry distance in t_enter[i]. Lane by lane exactly the
// scalar intersect() of aabb.hpp (same operations and roundings, and a NaN slab distance, 0·∞, ignored the
// same way: max / min return their second operand, the accumulator, when the first is NaN). Over W lanes
// of floats (core/simd/lanes.hpp): W = 4 is one SSE2 operation per step on every x86-64 build, W = 8 one
// AVX2 operation; without AVX2 the 8-wide test is its scalar twin.
#include <smoketrace/core/simd/lanes.hpp>
#include <smoketrace/geometry/aabb.hpp>

namespace smoketrace {

template <unsigned W>
class WideBoxTest {
    using Floats = simd::Floats<W>;

public:
    explicit WideBoxTest(const BoxRay& r) {
        for (int a = 0; a < 3; ++a) {
            origin_[a] = Floats::broadcast(r.origin[a]);
            inv_dir_[a] = Floats::broadcast(r.inv_dir[a]);
            inv_far_[a] = Floats::broadcast(r.inv_far[a]);
            near_[a] = r.near[a];
            far_[a] = r.far[a];
        }
        tmin_ = Floats::broadcast(r.tmin);
    }

    // A node whose child boxes are stored per plane: bounds[p][i], plane p of child i in the order of
    // planes() (lo.x, lo.y, lo.z, hi.x, hi.y, hi.z). t_enter: W floats aligned to 4·W bytes.
    template <class Node>
    [[gnu::always_inline]] unsigned test(const Node& n, float tmax, float* t_enter) const {
        Floats t0 = tmin_, t1 = Floats::broadcast(tmax * kSlabFarScale);
#pragma GCC unroll 3
        for (int a = 0; a < 3; ++a) {
            const Floats t_near = (Floats::load(n.bounds[near_[a]]) - origin_[a]) * inv_dir_[a];
            const Floats t_far = (Floats::load(n.bounds[far_[a]]) - origin_[a]) * inv_far_[a];
            t0 = max(t_near, t0);
            t1 = min(t_far, t1);
        }
        store(t_enter, t0);
        return bits(t0 <= t1);
    }

private:
    Floats origin_[3], inv_dir_[3], inv_far_[3], tmin_;
    int near_[3], far_[3];
};

}  // namespace smoketrace
