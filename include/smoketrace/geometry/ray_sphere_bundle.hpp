#pragma once
// sphere_roots() (ray_sphere.hpp) for the rays of a bundle (ray_bundle.hpp) against one sphere: its
// origins, one direction, in lanes of doubles (core/simd/lanes.hpp: eight per AVX-512 operation, four per
// AVX2 one, one at a time without; a group with no ray entering the sphere's box is skipped); and which
// of the crossings found lie in each ray's [tmin, tmax], the candidates trace_bundle() hands to the rays'
// searches.
//
// Same answers, bit for bit: each lane performs sphere_roots()'s operations in its order and precision
// (the build disables FMA contraction, CMakeLists.txt), copysign and negation are exact bit operations,
// "swap if t0 > t1" is a select on the same comparison, and the conversion to float rounds to nearest like
// static_cast<float>. So a sphere hit has the same t whether its ray was traced alone or in a bundle; a
// test (test_trace_bundle.cpp) holds the two against each other, in each of the three builds CI makes
// (AVX-512 natively, AVX2 and plain x86-64, where this is the lanes' scalar twin, under the sanitizers).
#include <smoketrace/core/simd/lanes.hpp>
#include <smoketrace/geometry/ray_bundle.hpp>
#include <smoketrace/geometry/ray_sphere.hpp>

#include <glm/vec3.hpp>

#include <bit>
#include <limits>

namespace smoketrace {

// What a sphere shows the rays of a bundle: per lane, the roots as sphere_roots() gives them, and the
// lanes whose entry / exit, rounded to float as trace() reports it, lies in their [tmin, tmax].
struct BundleSphereCrossings {
    alignas(64) double t_enter[kBundleWidth];
    alignas(64) double t_exit[kBundleWidth];
    unsigned enter = 0;  // bit i: lane i's ray crosses the sphere and enters it inside [tmin_i, tmax_i]
    unsigned exit = 0;   // the same for leaving it
};

// For each lane of `lanes` (a bit set over the bundle's lanes): the roots of the lane's ray, its origin
// taken relative to `translation` first (o − T, as trace()'s world-sphere path does), against the sphere
// (center, radius) in that frame; `tmax`: the lanes' current tmax (kBundleWidth floats, 64-byte
// aligned). A lane for which sphere_roots() returns false has neither bit set; t_enter / t_exit are
// meaningful only where a bit is set, and then equal sphere_roots()'s roots bit for bit.
inline void sphere_crossings_bundle(const RayBundle& b, unsigned lanes, const float* tmax,
                                    const glm::dvec3& translation, const glm::dvec3& center, double radius,
                                    BundleSphereCrossings& out) {
    const glm::dvec3 d(b.direction);
    out.enter = out.exit = 0;
    using simd::kDoubleLanes;
    using Doubles = simd::Doubles<kDoubleLanes>;
    using Floats = simd::Floats<kDoubleLanes>;
    const double a_scalar = d.x * d.x + d.y * d.y + d.z * d.z;
    if (!(a_scalar > 0.0)) return;
    const Doubles dx = Doubles::broadcast(d.x), dy = Doubles::broadcast(d.y), dz = Doubles::broadcast(d.z);
    const Doubles a = Doubles::broadcast(a_scalar);
    const Doubles inv_a = Doubles::broadcast(1.0 / a_scalar);  // as sphere_roots() divides, once per ray
    const Doubles r2 = Doubles::broadcast(radius * radius);
    const Doubles tx = Doubles::broadcast(translation.x), ty = Doubles::broadcast(translation.y),
                  tz = Doubles::broadcast(translation.z);
    const Doubles cx = Doubles::broadcast(center.x), cy = Doubles::broadcast(center.y),
                  cz = Doubles::broadcast(center.z);
    const Doubles zero = Doubles::broadcast(0.0);
    const Doubles infinity = Doubles::broadcast(std::numeric_limits<double>::infinity());
    // The groups of kDoubleLanes lanes with a ray to test, as a bit set walked in one loop: a test per
    // group whether to skip it is a branch on data, mispredicted often enough to cost more than it saves.
    constexpr unsigned kGroupBits = (1u << kDoubleLanes) - 1u;
    unsigned groups = 0;
    for (unsigned g = 0; g < kBundleWidth / kDoubleLanes; ++g)
        groups |= unsigned(((lanes >> (kDoubleLanes * g)) & kGroupBits) != 0) << g;
    for (; groups != 0; groups &= groups - 1) {
        const unsigned first = kDoubleLanes * unsigned(std::countr_zero(groups));  // the group's first lane
        // f = (o − T) − c, each lane's origin widened exactly to double.
        const Doubles fx = Doubles::widen(b.x + first) - tx - cx;
        const Doubles fy = Doubles::widen(b.y + first) - ty - cy;
        const Doubles fz = Doubles::widen(b.z + first) - tz - cz;
        // b = f·d, perp = f − (b·(1/a))·d, h² = r² − |perp|²: sphere_roots()'s lines, term by term.
        const Doubles bq = fx * dx + fy * dy + fz * dz;
        const Doubles b_over_a = bq * inv_a;
        const Doubles px = fx - b_over_a * dx, py = fy - b_over_a * dy, pz = fz - b_over_a * dz;
        const Doubles h2 = r2 - (px * px + py * py + pz * pz);
        // No early exit when no lane has h² > 0: as a branch on data it cost more than the roots it saved.
        const auto positive = h2 > zero;
        const Doubles c = (fx * fx + fy * fy + fz * fz) - r2;
        // q = −(b + copysign(√(a·h²), b)); lanes with h² ≤ 0 compute a NaN that is masked out below.
        const Doubles q = -(bq + copysign(sqrt(a * h2), bq));
        const Doubles t0 = c / q;
        const Doubles t1 = q * inv_a;
        // std::isfinite of both roots (|t| < ∞, false for NaN), then "swap if t0 > t1".
        const auto finite = (abs(t0) < infinity) & (abs(t1) < infinity);
        const auto swap = t0 > t1;
        const Doubles near = select(swap, t1, t0), far = select(swap, t0, t1);
        store(out.t_enter + first, near);
        store(out.t_exit + first, far);
        // The lanes whose root t, rounded to float (to nearest, as static_cast<float>), lies in [lo, hi].
        auto in_float_range = [](Doubles t, const float* lo, const float* hi) {
            const Floats tf = narrow(t);
            return bits((tf >= Floats::load(lo)) & (tf <= Floats::load(hi)));
        };
        const unsigned crosses = bits(positive & finite);
        out.enter |= (crosses & in_float_range(near, b.tmin + first, tmax + first)) << first;
        out.exit |= (crosses & in_float_range(far, b.tmin + first, tmax + first)) << first;
    }
    out.enter &= lanes;
    out.exit &= lanes;
}

}  // namespace smoketrace
