#pragma once
// Exact ray/sphere intersection: the procedural primitive of smoketrace (DXR's AABB geometry with an
// intersection shader, done natively). Entry is a front-face hit, exit a back-face hit.
#include <smoketrace/geometry/ray.hpp>

#include <glm/vec3.hpp>
#include <cmath>

namespace smoketrace {

struct SphereRoots {
    double t_enter;  // smaller root
    double t_exit;   // larger root
};

// Solves |o + t·d − c|² = r² in double precision, avoiding both classic cancellations:
//  * the discriminant is formed from the perpendicular distance of the centre to the ray line,
//    r² − |f − (f·d/d·d)·d|² with f = o − c (Haines et al., "Precision Improvements for Ray/Sphere
//    Intersection", Ray Tracing Gems ch. 7), not from b² − a·c, which loses every digit when the ray
//    starts far from a small sphere;
//  * the near root comes from c/q with q = −(b + sign(b)·√(a·h²)) (Numerical Recipes 5.6), not from
//    b − √…, which cancels when the ray starts just inside or just outside a large sphere.
// A tangent or missing ray (h² ≤ 0) has no roots: a grazing touch is not a crossing.
inline bool sphere_roots(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& center, double radius,
                         SphereRoots& roots) {
    const glm::dvec3 f = o - center;
    const double a = d.x * d.x + d.y * d.y + d.z * d.z;
    if (!(a > 0.0)) return false;
    const double inv_a = 1.0 / a;  // one division for two quotients: 1 ulp more in each, far below float t
    const double b = f.x * d.x + f.y * d.y + f.z * d.z;  // half the linear coefficient
    const glm::dvec3 perp = f - (b * inv_a) * d;        // centre's offset from the ray line
    const double r2 = radius * radius;
    const double h2 = r2 - (perp.x * perp.x + perp.y * perp.y + perp.z * perp.z);
    if (!(h2 > 0.0)) return false;
    const double c = (f.x * f.x + f.y * f.y + f.z * f.z) - r2;
    const double q = -(b + std::copysign(std::sqrt(a * h2), b));  // |q| ≥ √(a·h²) > 0
    double t0 = c / q;
    double t1 = q * inv_a;
    if (t0 > t1) { const double s = t0; t0 = t1; t1 = s; }
    roots = {t0, t1};
    return std::isfinite(t0) && std::isfinite(t1);
}

}  // namespace smoketrace
