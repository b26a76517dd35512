#pragma once
// Axis-aligned bounding boxes and the ray/box slab test used by every BVH traversal.
#include <smoketrace/ray.hpp>

#include <cmath>
#include <glm/common.hpp>
#include <glm/vec3.hpp>
#include <limits>

namespace smoketrace {

struct Aabb {
    glm::vec3 lo{std::numeric_limits<float>::infinity()};
    glm::vec3 hi{-std::numeric_limits<float>::infinity()};

    [[nodiscard]] bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
    void grow(const glm::vec3& p) { lo = glm::min(lo, p); hi = glm::max(hi, p); }
    void grow(const Aabb& b) { lo = glm::min(lo, b.lo); hi = glm::max(hi, b.hi); }
    [[nodiscard]] glm::vec3 extent() const { return hi - lo; }
    [[nodiscard]] glm::vec3 center() const { return 0.5f * (lo + hi); }
    // Full surface area; 0 for an empty box so that empty children cost nothing in the SAH.
    [[nodiscard]] float area() const {
        if (empty()) return 0.0f;
        const glm::vec3 e = extent();
        return 2.0f * (e.x * e.y + e.y * e.z + e.z * e.x);
    }
};

[[nodiscard]] inline Aabb merge(Aabb a, const Aabb& b) { a.grow(b); return a; }

// gamma(n) of pbrt-v4 (Pharr, Jakob, Humphreys, 3.9.1): a bound on the relative error of n rounded
// float operations, n·u/(1 − n·u) with u = 2^-24.
constexpr float rounding_gamma(int n) {
    constexpr float u = std::numeric_limits<float>::epsilon() * 0.5f;
    return (static_cast<float>(n) * u) / (1.0f - static_cast<float>(n) * u);
}

// A ray prepared for many box tests: reciprocal direction and, per axis, which slab plane is met
// first. Choosing the near plane by the sign bit of the reciprocal (not by comparing the two
// distances) is what makes −0 and +0 directions correct: 1/−0 = −∞ picks hi as the near plane.
struct BoxRay {
    glm::vec3 origin;
    glm::vec3 inv_dir;
    int near_is_hi[3];  // 1 where the direction component is negative (or −0)
    float tmin;

    explicit BoxRay(const Ray& r)
        : origin(r.origin), inv_dir(1.0f / r.direction.x, 1.0f / r.direction.y, 1.0f / r.direction.z),
          near_is_hi{std::signbit(inv_dir.x) ? 1 : 0, std::signbit(inv_dir.y) ? 1 : 0,
                     std::signbit(inv_dir.z) ? 1 : 0},
          tmin(r.tmin) {}
};

// Far distances are widened by 1 + 2·gamma(3) (pbrt-v4 6.1.2): the three rounded operations of a slab
// distance can then never make a box reject a ray that hits a primitive inside it.
inline constexpr float kSlabFarScale = 1.0f + 2.0f * rounding_gamma(3);

// Slab test: true if the ray meets the closed box for some t in [tmin, tmax]; t_enter receives the
// entry distance (clamped to tmin). tmax is widened by the same factor as the far distances, so a
// primitive lying in a face of its box, hit at exactly tmax, is never lost to the rounding of the
// box's entry distance. A direction component of ±0 gives 1/d = ±∞; where the origin also
// lies exactly on that slab plane, (plane − o)·(1/d) is 0·∞ = NaN. That NaN never reaches the result:
// the comparisons below are written "candidate > current ? candidate : current", which keeps the
// current value when the candidate is NaN — exactly right, because such a ray lies in the closed slab
// and that slab must not constrain it. t_enter and the return value are therefore never NaN.
inline bool intersect(const Aabb& b, const BoxRay& r, float tmax, float& t_enter) {
    float t0 = r.tmin;
    float t1 = tmax * kSlabFarScale;
    for (int a = 0; a < 3; ++a) {
        const float near_plane = r.near_is_hi[a] ? b.hi[a] : b.lo[a];
        const float far_plane = r.near_is_hi[a] ? b.lo[a] : b.hi[a];
        const float tn = (near_plane - r.origin[a]) * r.inv_dir[a];
        const float tf = (far_plane - r.origin[a]) * r.inv_dir[a] * kSlabFarScale;
        t0 = tn > t0 ? tn : t0;
        t1 = tf < t1 ? tf : t1;
    }
    t_enter = t0;
    return t0 <= t1;
}

}  // namespace smoketrace
