#pragma once
// The exact answer for sphere stand-ins, in double: the optical path length of a ray through a union of
// spheres (thesis eq. 3.1's "in-smoke stretches", computed without a tracer), the surfaces it crosses, and
// the tolerance a float tracer must meet. The reference of tests/test_optical_depth.cpp and
// tests/test_stability.cpp.
#include <smoketrace/smoke/optical_depth_pass.hpp>
#include <smoketrace/smoke/particle_system.hpp>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

namespace smoketrace::test {

// Unit roundoff of float: every rounding of a float operation is within this relative error.
inline constexpr double kFloatUnit = 0x1.0p-24;
// Roundings between the exact ray and the object-space ray the pass traces: the light direction when
// normalised in float (glm's v·inversesqrt(v·v): at most 4 on its length), the object-space origin and
// direction (1 each) and the hit t (1). Each moves a hit by at most kFloatUnit times its scale: 6 in all,
// 8 with margin.
inline constexpr double kRoundingsPerRay = 8.0;

// Length of the union of intervals, each clipped to t >= 0.
inline double union_length(std::vector<std::pair<double, double>> intervals) {
    std::sort(intervals.begin(), intervals.end());
    double length = 0.0, covered_to = 0.0;
    for (auto [lo, hi] : intervals) {
        lo = std::max(lo, 0.0);
        const double from = std::max(lo, covered_to);
        if (hi > from) length += hi - from;
        covered_to = std::max(covered_to, hi);
    }
    return length;
}

struct SphereAnswer {
    double length = 0.0;           // length of the union of [max(t0, 0), t1] over the spheres met
    double tolerance = 0.0;        // bound on |float pass − exact length| (see exact_spheres)
    std::uint32_t surfaces = 0;    // surfaces certainly met at 0 < t < t_cut (entries t0, exits t1)
    std::uint32_t ambiguous = 0;   // surfaces a float tracer may legitimately count or miss
    int covering = 0;              // spheres certainly containing the origin
    int covering_ambiguous = 0;    // spheres whose surface is within the tolerance of the origin
};

struct SphereQuery {
    double t_cut = std::numeric_limits<double>::infinity();  // surfaces counted below this t only
    double cut_margin = 0.0;    // a surface this close to t_cut may fall either side
    double displacement = 0.0;  // how far the scene itself may have moved (e.g. rounded when translated)
};

// The ray o + t·d (d normalised here), t > 0, against every sphere. Tolerance: the pass traces, in each
// sphere's object space, a ray whose direction was normalised in float and whose origin and direction were
// at most rounded to float once more; in world units that ray stays within eta = kRoundingsPerRay·u·
// (2|o − c| + r) of the exact one over the sphere (t ≤ |o − c| + r), plus q.displacement. Moving the line by
// eta changes the squared half chord s² = r² − p² by at most delta = 2r·eta + eta², so the half chord by at
// most s − √(s² − delta) (√(s² + delta) near tangency), and the chord's foot by eta: each endpoint moves by
// at most that plus eta, plus the rounding of t (kRoundingsPerRay·u·t). The union length is 1-Lipschitz in
// each endpoint, so the tolerance is the sum over endpoints. A sphere with |s²| < delta may be met or
// missed (its 2 surfaces are ambiguous); a surface within that distance of the origin may be dropped by
// the tracer's TMin (1 ambiguous, and up to TMin of length), one that close to t_cut may fall either side.
// TMin is the pass's, optical_depth_tmin() of the radius of the particle centred at o (the largest, if
// several are; 0 if none is).
inline SphereAnswer exact_spheres(const std::vector<Particle>& ps, glm::dvec3 o, glm::dvec3 d, const SphereQuery& q = {}) {
    d = glm::normalize(d);
    double tmin = 0.0;
    for (const Particle& p : ps)
        if (glm::dvec3(p.center) == o) tmin = std::max(tmin, double(optical_depth_tmin(p.radius)));
    SphereAnswer a;
    std::vector<std::pair<double, double>> intervals;
    for (const Particle& p : ps) {
        const glm::dvec3 c(p.center);
        const double r = p.radius;
        const glm::dvec3 f = o - c;
        const double mid = -glm::dot(f, d);  // t of the chord's midpoint
        const glm::dvec3 perp = f + mid * d;
        const double s2 = r * r - glm::dot(perp, perp);
        const double dist = glm::length(f);
        const double eta = kRoundingsPerRay * kFloatUnit * (2.0 * dist + r) + q.displacement;
        const double delta = 2.0 * r * eta + eta * eta;
        if (std::abs(dist - r) <= eta + tmin) ++a.covering_ambiguous;
        else if (dist < r) ++a.covering;
        if (s2 <= -delta) continue;  // certainly missed
        const double s = std::sqrt(std::max(s2, 0.0));
        const double ds = s2 > delta ? s - std::sqrt(s2 - delta) : std::sqrt(std::max(s2, 0.0) + delta);
        const double endpoint_error = ds + eta;
        const bool tangent = std::abs(s2) < delta;
        for (const double t : {mid - s, mid + s}) {
            if (t + endpoint_error <= 0.0) continue;  // certainly behind the origin
            a.tolerance += endpoint_error + kRoundingsPerRay * kFloatUnit * std::abs(t);
            const bool near_origin = std::abs(t) <= endpoint_error + tmin;
            const bool near_cut = std::abs(t - q.t_cut) <= endpoint_error + q.cut_margin;
            if (near_origin) a.tolerance += tmin;
            if (tangent || near_origin || near_cut) ++a.ambiguous;
            else if (t > 0.0 && t < q.t_cut) ++a.surfaces;
        }
        if (s2 > 0.0 && mid + s > 0.0) intervals.emplace_back(mid - s, mid + s);
    }
    a.length = union_length(std::move(intervals));
    return a;
}

}  // namespace smoketrace::test
