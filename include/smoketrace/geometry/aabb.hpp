#pragma once
// Axis-aligned bounding boxes and the ray/box slab test used by every BVH traversal.
#include <smoketrace/geometry/ray.hpp>

#include <cmath>
#include <cstddef>
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

// The box as six floats lo.x, lo.y, lo.z, hi.x, hi.y, hi.z: the slab test below picks a plane by index.
static_assert(sizeof(Aabb) == 6 * sizeof(float) && offsetof(Aabb, hi) == 3 * sizeof(float));
inline const float* planes(const Aabb& b) { return &b.lo.x; }

// Far distances are widened by 1 + 2·gamma(3) (pbrt-v4 6.1.2): the three rounded operations of a slab
// distance can then never make a box reject a ray that hits a primitive inside it. The factor is folded
// into the far planes' reciprocal (inv_far = inv_dir·scale, rounded once), which is the same number of
// roundings as scaling each far distance afterwards, so the same bound holds.
inline constexpr float kSlabFarScale = 1.0f + 2.0f * rounding_gamma(3);

// A ray prepared for many box tests: reciprocal direction and, per axis, the index (into planes()) of
// the slab plane met first. Choosing the near plane by the sign bit of the reciprocal (not by comparing
// the two distances) is what makes −0 and +0 directions correct: 1/−0 = −∞ picks hi as the near plane.
struct BoxRay {
    glm::vec3 origin;
    glm::vec3 inv_dir;
    glm::vec3 inv_far;  // inv_dir · kSlabFarScale
    int near[3];        // a or a + 3: the plane entered first on axis a
    int far[3];
    float tmin;

    explicit BoxRay(const Ray& r)
        : origin(r.origin), inv_dir(1.0f / r.direction.x, 1.0f / r.direction.y, 1.0f / r.direction.z),
          inv_far(inv_dir * kSlabFarScale), tmin(r.tmin) {
        for (int a = 0; a < 3; ++a) {
            const bool negative = std::signbit(inv_dir[a]);
            near[a] = a + 3 * int(negative);  // arithmetic, not a branch on the ray's direction
            far[a] = a + 3 - 3 * int(negative);
        }
    }
};

// Slab test: true if the ray meets the closed box for some t in [tmin, tmax]; t_enter receives the
// entry distance (clamped to tmin). tmax is widened by the same factor as the far distances, so a
// primitive lying in a face of its box, hit at exactly tmax, is never lost to the rounding of the
// box's entry distance.
//
// A direction component of ±0 gives 1/d = ±∞; where the origin also lies exactly on that slab plane,
// (plane − o)·(1/d) is 0·∞ = NaN. That NaN never reaches the result: the comparisons below are written
// "candidate > current ? candidate : current", which keeps the current value when the candidate is NaN —
// exactly right, because such a ray lies in the closed slab and that slab must not constrain it.
// t_enter and the return value are therefore never NaN.
[[gnu::always_inline]] inline bool intersect(const Aabb& b, const BoxRay& r, float tmax, float& t_enter) {
    const float* p = planes(b);
    const float nx = (p[r.near[0]] - r.origin.x) * r.inv_dir.x;
    const float ny = (p[r.near[1]] - r.origin.y) * r.inv_dir.y;
    const float nz = (p[r.near[2]] - r.origin.z) * r.inv_dir.z;
    const float fx = (p[r.far[0]] - r.origin.x) * r.inv_far.x;
    const float fy = (p[r.far[1]] - r.origin.y) * r.inv_far.y;
    const float fz = (p[r.far[2]] - r.origin.z) * r.inv_far.z;
    float t0 = r.tmin, t1 = tmax * kSlabFarScale;
    t0 = nx > t0 ? nx : t0;
    t0 = ny > t0 ? ny : t0;
    t0 = nz > t0 ? nz : t0;
    t1 = fx < t1 ? fx : t1;
    t1 = fy < t1 ? fy : t1;
    t1 = fz < t1 ? fz : t1;
    t_enter = t0;
    return t0 <= t1;
}

}  // namespace smoketrace
