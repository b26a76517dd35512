// The geometry layer against exact answers: the slab test (aabb.hpp), the watertight ray/triangle test
// (ray_triangle.hpp) and the ray/sphere roots (ray_sphere.hpp).
//
// "Exact" here means: configurations built from small dyadic numbers, whose every float operation is
// exact, or references computed in double from the float inputs (a float difference is exact in double,
// a double division is 2^29 times finer than the float results under test).
#include <smoketrace/geometry/aabb.hpp>
#include <smoketrace/core/prng.hpp>
#include <smoketrace/geometry/ray_sphere.hpp>
#include <smoketrace/geometry/ray_triangle.hpp>
#include <smoketrace/geometry/ray_triangle_block.hpp>
#include <smoketrace/accel/triangle_mesh.hpp>

#include <catch2/catch.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <iomanip>
#include <limits>
#include <vector>

using namespace smoketrace;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kEps = std::numeric_limits<float>::epsilon();

// ---------------------------------------------------------------------------------------------------
// Slab test

// The exact closed-box answer, in double: per axis, a zero direction component admits the ray iff the
// origin lies in the closed slab; otherwise the slab is the t interval between its two planes.
struct ExactSlab {
    bool hit;
    double t0, t1;
};
ExactSlab exact_slab(const Aabb& b, const Ray& r) {
    double t0 = r.tmin, t1 = r.tmax;
    for (int a = 0; a < 3; ++a) {
        const double o = r.origin[a], d = r.direction[a], lo = b.lo[a], hi = b.hi[a];
        if (d == 0.0) {
            if (o < lo || o > hi) return {false, t0, t1};
            continue;
        }
        double tn = (lo - o) / d, tf = (hi - o) / d;
        if (tn > tf) std::swap(tn, tf);
        t0 = std::max(t0, tn);
        t1 = std::min(t1, tf);
    }
    return {t0 <= t1, t0, t1};
}

// A float slab distance is (plane − o)·(1/d): three roundings, so within gamma(3) of the exact distance.
const float kSlabDistanceTol = rounding_gamma(3);
// A float hit may exceed the exact box by the far-side widening 2·gamma(3) plus gamma(3) on each side's
// own rounding; 8·gamma(3) bounds how loose "conservative" may be.
const float kSlabLooseness = 8.0f * rounding_gamma(3);

bool slab(const Aabb& b, const Ray& r, float& t_enter) { return intersect(b, BoxRay(r), r.tmax, t_enter); }

TEST_CASE("Slab test: +0 and -0 direction components, origin inside, outside and on the faces", "[geometry]") {
    const Aabb box{{0.0f, 0.0f, 0.0f}, {1.0f, 2.0f, 4.0f}};
    // Positions along a zero-direction axis, relative to that axis' slab [lo, hi].
    enum Where { below, on_lo, inside, on_hi, above };
    auto position = [&](int axis, Where w) {
        const float lo = box.lo[axis], hi = box.hi[axis];
        switch (w) {
            case below: return lo - 1.0f;
            case on_lo: return lo;
            case inside: return 0.5f * (lo + hi);
            case on_hi: return hi;
            default: return hi + 1.0f;
        }
    };
    int cases = 0;
    for (int moving = 0; moving < 3; ++moving) {
        const int a = (moving + 1) % 3, c = (moving + 2) % 3;  // the two axes with zero components
        for (Where wa : {below, on_lo, inside, on_hi, above})
            for (Where wc : {below, on_lo, inside, on_hi, above})
                for (float sa : {+0.0f, -0.0f})
                    for (float sc : {+0.0f, -0.0f}) {
                        Ray r;
                        r.origin[moving] = box.lo[moving] - 3.0f;  // enters the moving slab at t = 3 exactly
                        r.direction[moving] = 1.0f;
                        r.origin[a] = position(a, wa);
                        r.origin[c] = position(c, wc);
                        r.direction[a] = sa;
                        r.direction[c] = sc;
                        const bool expected = wa != below && wa != above && wc != below && wc != above;
                        float t_enter = -1.0f;
                        INFO("moving axis " << moving << " where " << wa << "," << wc << " signbits "
                                            << std::signbit(sa) << std::signbit(sc));
                        CHECK(slab(box, r, t_enter) == expected);
                        CHECK_FALSE(std::isnan(t_enter));
                        if (expected) CHECK(t_enter == 3.0f);
                        // Closed in t as well: a window ending exactly at the entry still hits.
                        r.tmax = 3.0f;
                        CHECK(slab(box, r, t_enter) == expected);
                        r.tmax = 2.5f;
                        CHECK_FALSE(slab(box, r, t_enter));
                        CHECK_FALSE(std::isnan(t_enter));
                        ++cases;
                    }
    }
    CHECK(cases == 3 * 25 * 4);
}

TEST_CASE("Slab test: origin on a slab plane with a parallel direction sees the closed box", "[geometry]") {
    // The 0·∞ case: (plane − o)·(1/±0) with plane == o is NaN and must not decide anything.
    const Aabb box{{-1.0f, -1.0f, -1.0f}, {1.0f, 1.0f, 1.0f}};
    for (int axis = 0; axis < 3; ++axis)
        for (float plane : {-1.0f, 1.0f})
            for (float zero : {+0.0f, -0.0f})
                for (float along : {1.0f, -1.0f}) {
                    Ray r;
                    const int other = (axis + 1) % 3;
                    r.origin = glm::vec3(0.0f);
                    r.origin[axis] = plane;
                    r.direction = glm::vec3(0.0f);
                    r.direction[axis] = zero;
                    r.direction[other] = along;
                    r.direction[(axis + 2) % 3] = zero;  // a second zero component, through the NaN path too
                    float t_enter = -1.0f;
                    CHECK(slab(box, r, t_enter));
                    CHECK(t_enter == 0.0f);  // the origin is in the closed box: entry clamps to tmin
                    // Start outside along the moving axis: enter through the face at t = 2.
                    r.origin[other] = -along * 3.0f;
                    CHECK(slab(box, r, t_enter));
                    CHECK(t_enter == 2.0f);
                    // The same, one ulp outside the face plane: a miss, and still no NaN.
                    r.origin[axis] = std::nextafter(plane, 2.0f * plane);
                    CHECK_FALSE(slab(box, r, t_enter));
                    CHECK_FALSE(std::isnan(t_enter));
                }
}

TEST_CASE("Slab test: random rays against the exact box, with zero components and origins on faces",
          "[geometry]") {
    // Boxes include flat ones (lo == hi on an axis); directions have random ±0 components; origins are
    // placed on face planes, inside or outside. Every exact hit must be a float hit (conservative); a
    // float hit may only be looser than exact by kSlabLooseness; neither result nor t_enter is NaN.
    Pcg32 rng(20240601);
    int exact_hits = 0, checked = 0;
    for (int i = 0; i < 400000; ++i) {
        Aabb box;
        for (int a = 0; a < 3; ++a) {
            const float x = rng.uniform(-4.0f, 4.0f), y = rng.uniform(-4.0f, 4.0f);
            box.lo[a] = std::min(x, y);
            box.hi[a] = rng.next_u32() % 5 == 0 ? box.lo[a] : std::max(x, y);
        }
        Ray r;
        for (int a = 0; a < 3; ++a) {
            switch (rng.next_u32() % 5) {
                case 0: r.origin[a] = box.lo[a]; break;
                case 1: r.origin[a] = box.hi[a]; break;
                default: r.origin[a] = rng.uniform(-8.0f, 8.0f);
            }
            switch (rng.next_u32() % 4) {
                case 0: r.direction[a] = (rng.next_u32() & 1) ? 0.0f : -0.0f; break;
                default: {
                    const float d = rng.uniform(-1.0f, 1.0f);
                    r.direction[a] = std::abs(d) < 1e-3f ? 0.5f : d;  // no tiny components: 1/d stays finite
                }
            }
        }
        if (rng.next_u32() % 3 == 0) r.tmax = rng.uniform(0.0f, 8.0f);
        if (rng.next_u32() % 3 == 0) r.tmin = rng.uniform(0.0f, 2.0f);
        if (r.tmin > r.tmax) continue;

        float t_enter = -1.0f;
        const bool got = slab(box, r, t_enter);
        const ExactSlab ex = exact_slab(box, r);
        INFO("ray " << i);
        REQUIRE_FALSE(std::isnan(t_enter));
        if (ex.hit) {
            ++exact_hits;
            REQUIRE(got);
            REQUIRE(std::abs(double(t_enter) - ex.t0) <= kSlabDistanceTol * std::abs(ex.t0));
        }
        if (got && std::isfinite(ex.t1)) REQUIRE(ex.t0 <= ex.t1 + kSlabLooseness * std::max(std::abs(ex.t0), std::abs(ex.t1)));
        ++checked;
    }
    CHECK(exact_hits > checked / 10);  // the sample really exercises hits, not only misses
}

// A random float triangle lying in a face of its own box (flat along one axis) or with an edge on an
// edge of its box (that edge parallel to an axis and the triangle flat in another axis).
std::array<glm::vec3, 3> triangle_on_box_boundary(Pcg32& rng, float scale, const glm::vec3& offset, bool edge) {
    std::array<glm::vec3, 3> v;
    for (auto& p : v) p = offset + scale * glm::vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    const int flat = int(rng.next_u32() % 3);
    for (auto& p : v) p[flat] = offset[flat];
    if (edge) v[1][(flat + 1) % 3] = v[0][(flat + 1) % 3];  // edge v0–v1 on the box edge
    return v;
}

// Shoots rays at random points of the triangle from random directions and requires the triangle's box
// to accept every ray the triangle test hits, with tmax equal to the hit's own t: the situation of a
// traversal whose committed hit lies at this triangle's t. The ray's distance to the hit is 2^[-3, 3);
// the triangle's size is that distance times 2^[min_size_log2, max_size_log2).
void check_box_accepts_hits(float min_size_log2, float max_size_log2, int rays, std::uint64_t seed) {
    Pcg32 rng(seed);
    int hits = 0;
    for (int i = 0; i < rays; ++i) {
        const float distance = std::exp2(std::floor(rng.uniform(-3.0f, 3.0f)));
        const float size = distance * std::exp2(std::floor(rng.uniform(min_size_log2, max_size_log2)));
        const glm::vec3 offset(rng.uniform(-100, 100), rng.uniform(-100, 100), rng.uniform(-100, 100));
        const auto v = triangle_on_box_boundary(rng, size, offset, rng.next_u32() & 1);
        if (is_degenerate(v[0], v[1], v[2])) continue;
        float b1 = rng.uniform01(), b2 = rng.uniform01();
        if (b1 + b2 > 1.0f) { b1 = 1.0f - b1; b2 = 1.0f - b2; }
        const glm::vec3 target = v[0] + b1 * (v[1] - v[0]) + b2 * (v[2] - v[0]);
        Ray r;
        r.direction = glm::vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        if (rng.next_u32() % 3 == 0) r.direction[rng.next_u32() % 3] = 0.0f;
        if (glm::length(r.direction) < 0.1f) continue;
        r.direction = glm::normalize(r.direction);
        r.origin = target - distance * r.direction;
        TriangleHit h;
        if (!intersect_triangle(TriangleRay(r), v[0], v[1], v[2], kInf, h)) continue;
        ++hits;
        Aabb box;
        for (const auto& p : v) box.grow(p);
        float t_enter;
        INFO("ray " << i << " origin " << r.origin.x << "," << r.origin.y << "," << r.origin.z << " dir "
                    << r.direction.x << "," << r.direction.y << "," << r.direction.z << " triangle t " << h.t);
        REQUIRE(intersect(box, BoxRay(r), kInf, t_enter));
        REQUIRE(intersect(box, BoxRay(r), h.t, t_enter));
        REQUIRE(t_enter <= h.t * kSlabFarScale);
    }
    CHECK(hits > rays / 4);
}

TEST_CASE("Slab test is conservative: triangles in the faces and on the edges of their box", "[geometry]") {
    // Triangles no larger than half the ray's distance to them.
    check_box_accepts_hits(-4.0f, 0.0f, 300000, 11);
}

TEST_CASE("Slab test is conservative: large triangles in box faces seen from close by", "[geometry]") {
    // A ground triangle 2000 wide hit from 1 unit above it: the box must still accept the ray at
    // tmax = the triangle's own t. (The watertight test's t carries an error relative to |v − o|, not
    // to t, so this is where a widening by 1 + 2·gamma(3) of t alone is not enough.)
    const glm::vec3 v0(-1000, -1000, 0), v1(1000, -1000, 0), v2(0, 1000, 0);
    Aabb box;
    box.grow(v0);
    box.grow(v1);
    box.grow(v2);
    Ray r;
    r.origin = {0.1f, 0.1f, 1.0f};
    r.direction = {0.3f, -1.9f, -0.1f};
    TriangleHit h;
    REQUIRE(intersect_triangle(TriangleRay(r), v0, v1, v2, kInf, h));
    float t_enter;
    INFO("triangle t " << std::setprecision(9) << h.t << ", exact t " << (0.0 - 1.0) / double(r.direction.z));
    CHECK(intersect(box, BoxRay(r), h.t, t_enter));
    // The same over random configurations: triangles up to 2^12 times the ray's distance to them.
    check_box_accepts_hits(0.0f, 12.0f, 300000, 12);
}

// ---------------------------------------------------------------------------------------------------
// Watertight ray/triangle

// Double-precision reference: o + t·d = v0 + b1·(v1 − v0) + b2·(v2 − v0), Cramer's rule.
struct ExactTriangle {
    double t, b1, b2;
    bool front;  // the ray meets the side the normal (v1 − v0) × (v2 − v0) points to
};
ExactTriangle exact_triangle(const Ray& r, const glm::vec3& v0, const glm::vec3& v1, const glm::vec3& v2) {
    const glm::dvec3 o(r.origin), d(r.direction), a(v0), e1 = glm::dvec3(v1) - a, e2 = glm::dvec3(v2) - a;
    const glm::dvec3 p = glm::cross(d, e2);
    const double det = glm::dot(e1, p);
    const glm::dvec3 s = o - a, q = glm::cross(s, e1);
    return {glm::dot(e2, q) / det, glm::dot(s, p) / det, glm::dot(d, q) / det,
            glm::dot(glm::cross(e1, e2), d) < 0.0};
}

// Tolerances for well-conditioned triangles (every angle ≥ 15°, incidence |cos| ≥ 0.25, vertices and
// origin within a few units): the sheared vertex coordinates carry three float roundings each, on values
// as large as |v − o|; measured worst errors are 5.5 eps (t, relative) and 28 eps (barycentrics,
// absolute) over 640k rays, so these bounds hold with a margin of about 3.
constexpr float kTriangleTRelTol = 16.0f * kEps;
constexpr float kTriangleBaryTol = 96.0f * kEps;

double min_angle(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    auto angle = [](const glm::dvec3& p, const glm::dvec3& q, const glm::dvec3& r) {
        return std::acos(std::clamp(glm::dot(glm::normalize(q - p), glm::normalize(r - p)), -1.0, 1.0));
    };
    return std::min(angle(a, b, c), std::min(angle(b, c, a), angle(c, a, b)));
}

TEST_CASE("Watertight triangle: t, barycentrics and face side of a simple triangle", "[geometry]") {
    const glm::vec3 v0(0, 0, 0), v1(1, 0, 0), v2(0, 1, 0);  // counter-clockwise seen from +z
    Ray r;
    r.origin = {0.25f, 0.5f, 2.0f};
    r.direction = {0.0f, 0.0f, -1.0f};
    TriangleHit h;
    REQUIRE(intersect_triangle(TriangleRay(r), v0, v1, v2, kInf, h));
    CHECK(h.t == 2.0f);
    CHECK(h.barycentrics.x == 0.25f);  // weight of v1
    CHECK(h.barycentrics.y == 0.5f);   // weight of v2
    CHECK(h.front_face);               // seen from +z the vertices run counter-clockwise

    r.origin.z = -2.0f;
    r.direction.z = 1.0f;
    REQUIRE(intersect_triangle(TriangleRay(r), v0, v1, v2, kInf, h));
    CHECK(h.t == 2.0f);
    CHECK_FALSE(h.front_face);
    // Reversed winding swaps the sides; the barycentrics follow the vertex order.
    REQUIRE(intersect_triangle(TriangleRay(r), v0, v2, v1, kInf, h));
    CHECK(h.front_face);
    CHECK(h.barycentrics.x == 0.5f);
    CHECK(h.barycentrics.y == 0.25f);

    // The t window is closed: [tmin, tmax] = [2, 2] hits, one ulp either side misses.
    r.tmin = 2.0f;
    CHECK(intersect_triangle(TriangleRay(r), v0, v1, v2, 2.0f, h));
    CHECK_FALSE(intersect_triangle(TriangleRay(r), v0, v1, v2, std::nextafter(2.0f, 0.0f), h));
    r.tmin = std::nextafter(2.0f, 3.0f);
    CHECK_FALSE(intersect_triangle(TriangleRay(r), v0, v1, v2, kInf, h));
    // Behind the origin: no hit.
    r.tmin = 0.0f;
    r.direction.z = -1.0f;
    CHECK_FALSE(intersect_triangle(TriangleRay(r), v0, v1, v2, kInf, h));
}

TEST_CASE("Watertight triangle: random triangles against the double-precision answer", "[geometry]") {
    Pcg32 rng(99);
    int hits = 0, fronts = 0;
    for (int i = 0; i < 200000; ++i) {
        std::array<glm::vec3, 3> v;
        for (auto& p : v) p = glm::vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        if (min_angle(v[0], v[1], v[2]) < 15.0 * 3.14159265358979323846 / 180.0) continue;
        const float b1 = rng.uniform(0.05f, 0.9f), b2 = rng.uniform(0.05f, 0.9f);
        if (b1 + b2 > 0.95f) continue;
        const glm::vec3 target = v[0] + b1 * (v[1] - v[0]) + b2 * (v[2] - v[0]);
        Ray r;
        r.direction = glm::vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        if (glm::length(r.direction) < 0.1f) continue;
        const glm::dvec3 n = glm::normalize(glm::cross(glm::dvec3(v[1] - v[0]), glm::dvec3(v[2] - v[0])));
        if (std::abs(glm::dot(n, glm::normalize(glm::dvec3(r.direction)))) < 0.25) continue;
        r.origin = target - rng.uniform(0.5f, 4.0f) * r.direction;

        const ExactTriangle ex = exact_triangle(r, v[0], v[1], v[2]);
        TriangleHit h{};
        INFO("ray " << i);
        REQUIRE(intersect_triangle(TriangleRay(r), v[0], v[1], v[2], kInf, h));  // interior point: must hit
        ++hits;
        fronts += h.front_face;
        CHECK(std::abs(h.t - ex.t) <= kTriangleTRelTol * ex.t);
        CHECK(std::abs(h.barycentrics.x - ex.b1) <= kTriangleBaryTol);
        CHECK(std::abs(h.barycentrics.y - ex.b2) <= kTriangleBaryTol);
        CHECK(h.front_face == ex.front);
        // A window ending just before the exact t misses.
        CHECK_FALSE(intersect_triangle(TriangleRay(r), v[0], v[1], v[2], float(ex.t * (1.0 - 4.0 * kTriangleTRelTol)), h));
    }
    CHECK(hits > 50000);
    CHECK(fronts > hits / 3);  // both sides are exercised
    CHECK(fronts < 2 * hits / 3);
}

// --- Shared edges and vertices -----------------------------------------------------------------------
//
// Configurations are built from small dyadic numbers and rays from small integer directions whose
// dominant component is a power of two, with the origin at target − direction. Then every operation of
// the shear is exact and the ray passes EXACTLY through the target (verified below), so the edge
// functions are exactly 0 and the tie-break rule alone decides. Each configuration is also mapped by
// all 48 axis permutations and reflections (exact), so every dominant axis, shear sign and winding is
// exercised.

using Tri = std::array<glm::vec3, 3>;

glm::vec3 symmetry(const glm::vec3& p, int s) {
    static constexpr int kPerm[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
    const int* perm = kPerm[s % 6];
    const int signs = s / 6;  // 0…7
    glm::vec3 q;
    for (int a = 0; a < 3; ++a) q[a] = ((signs >> a) & 1 ? -1.0f : 1.0f) * p[perm[a]];
    return q;
}
constexpr int kSymmetries = 48;

// The ray's sheared offset from `target` (TriangleRay's own formula): (0, 0) means the ray passes
// exactly through the target as the triangle test sees it.
bool passes_exactly_through(const Ray& r, const glm::vec3& target) {
    const TriangleRay tr(r);
    const glm::vec3 a = target - r.origin;
    return a[tr.kx] - tr.sx * a[tr.kz] == 0.0f && a[tr.ky] - tr.sy * a[tr.kz] == 0.0f;
}

int count_hits(const std::vector<Tri>& tris, const Ray& r, int* fronts = nullptr) {
    int n = 0;
    const TriangleRay tr(r);
    for (const Tri& t : tris) {
        TriangleHit h;
        if (intersect_triangle(tr, t[0], t[1], t[2], kInf, h)) {
            ++n;
            REQUIRE(std::isfinite(h.t));
            REQUIRE(std::isfinite(h.barycentrics.x));
            REQUIRE(std::isfinite(h.barycentrics.y));
            if (fronts) *fronts += h.front_face;
        }
    }
    return n;
}

// Integer directions (i, j, ±4) with |i|, |j| ≤ 3: the dominant component is a power of two.
std::vector<glm::vec3> dyadic_directions() {
    std::vector<glm::vec3> dirs;
    for (int i = -3; i <= 3; ++i)
        for (int j = -3; j <= 3; ++j)
            for (float z : {4.0f, -4.0f}) dirs.emplace_back(float(i), float(j), z);
    return dirs;
}

// Shoots every dyadic direction, under every symmetry, exactly through each target, and requires
// exactly one hit among `tris` (a surface that covers the targets' neighbourhood once).
void check_exactly_one(const std::vector<Tri>& tris, const std::vector<glm::vec3>& targets, const char* what) {
    const auto dirs = dyadic_directions();
    long rays = 0;
    for (int s = 0; s < kSymmetries; ++s) {
        std::vector<Tri> mapped;
        for (const Tri& t : tris) mapped.push_back({symmetry(t[0], s), symmetry(t[1], s), symmetry(t[2], s)});
        for (const glm::vec3& target0 : targets) {
            const glm::vec3 target = symmetry(target0, s);
            for (const glm::vec3& d0 : dirs) {
                Ray r;
                r.direction = symmetry(d0, s);
                r.origin = target - r.direction;
                INFO(what << ": symmetry " << s << " target " << target.x << "," << target.y << "," << target.z
                          << " direction " << r.direction.x << "," << r.direction.y << "," << r.direction.z);
                REQUIRE(passes_exactly_through(r, target));
                REQUIRE(count_hits(mapped, r) == 1);
                ++rays;
            }
        }
    }
    CHECK(rays == long(kSymmetries) * long(targets.size()) * long(dirs.size()));
}

// Maps the z = 0 plane onto the tilted plane z = x/2 + y/4 (exact for dyadic x, y).
glm::vec3 tilt(const glm::vec3& p) { return {p.x, p.y, 0.5f * p.x + 0.25f * p.y}; }

TEST_CASE("Watertight triangle: rays exactly through the shared diagonal of a quad hit exactly one triangle",
          "[geometry]") {
    const glm::vec3 c0(0, 0, 0), c1(1, 0, 0), c2(1, 1, 0), c3(0, 1, 0);
    for (bool tilted : {false, true})
        for (bool reversed : {false, true})
            for (int diagonal = 0; diagonal < 2; ++diagonal) {
                auto m = [&](glm::vec3 p) { return tilted ? tilt(p) : p; };
                std::vector<Tri> tris = diagonal == 0 ? std::vector<Tri>{{m(c0), m(c1), m(c2)}, {m(c0), m(c2), m(c3)}}
                                                      : std::vector<Tri>{{m(c0), m(c1), m(c3)}, {m(c1), m(c2), m(c3)}};
                if (reversed)
                    for (Tri& t : tris) std::swap(t[1], t[2]);
                std::vector<glm::vec3> targets;  // points of the shared diagonal, exact in float
                for (int k = 1; k < 8; ++k) {
                    const float f = float(k) / 8.0f;
                    targets.push_back(m(diagonal == 0 ? glm::vec3(f, f, 0) : glm::vec3(1.0f - f, f, 0)));
                }
                check_exactly_one(tris, targets, "quad diagonal");
            }
}

TEST_CASE("Watertight triangle: rays exactly through the centre vertex and the spokes of a fan hit exactly one",
          "[geometry]") {
    // Fans around the origin, rims listed counter-clockwise, valence 3 to 8.
    const std::vector<std::vector<glm::vec3>> rims = {
        {{1, 0, 0}, {-1, 1, 0}, {-1, -1, 0}},
        {{1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}},
        {{2, 0, 0}, {1, 2, 0}, {-2, 1, 0}, {-1, -2, 0}, {1, -2, 0}},
        {{1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {-1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}, {0, -1, 0}, {1, -1, 0}},
    };
    const glm::vec3 centre(0.0f);
    for (bool tilted : {false, true})
        for (bool reversed : {false, true})
            for (const auto& rim : rims) {
                auto m = [&](glm::vec3 p) { return tilted ? tilt(p) : p; };
                std::vector<Tri> tris;
                std::vector<glm::vec3> targets{m(centre)};
                for (std::size_t i = 0; i < rim.size(); ++i) {
                    Tri t{m(centre), m(rim[i]), m(rim[(i + 1) % rim.size()])};
                    if (reversed) std::swap(t[1], t[2]);
                    tris.push_back(t);
                    for (int k = 1; k < 4; ++k) targets.push_back(m(rim[i] * (float(k) / 4.0f)));  // on spoke i
                }
                check_exactly_one(tris, targets, "fan");
            }
}

TEST_CASE("Watertight triangle: oblique rays with arbitrary float directions through a fan and a quad",
          "[geometry]") {
    // Directions that are not dyadic: the ray passes through (or within rounding of) the vertex or edge
    // point, and the triangles of the flat surface must still report it exactly once.
    const std::vector<glm::vec3> rim = {{1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {-1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}, {0, -1, 0}, {1, -1, 0}};
    std::vector<Tri> tris;
    for (std::size_t i = 0; i < rim.size(); ++i) tris.push_back({tilt({0, 0, 0}), tilt(rim[i]), tilt(rim[(i + 1) % rim.size()])});
    Pcg32 rng(5);
    int exact = 0;
    const int kRays = 200000;
    for (int i = 0; i < kRays; ++i) {
        glm::vec3 target;
        const std::uint32_t kind = rng.next_u32() % 3;
        if (kind == 0) target = tilt({0, 0, 0});                                          // the centre vertex
        else if (kind == 1) target = tilt(rim[rng.next_u32() % 8] * rng.uniform(0.01f, 0.99f));  // near a spoke
        else target = tilt(glm::vec3(rng.uniform(-0.99f, 0.99f), rng.uniform(-0.99f, 0.99f), 0));  // anywhere
        Ray r;
        r.direction = glm::vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        if (glm::length(r.direction) < 0.1f) continue;
        r.origin = target - rng.uniform(0.1f, 10.0f) * r.direction;
        // Skip rays too close to the plane (their crossing could lie outside the fan).
        const glm::dvec3 n = glm::normalize(glm::dvec3(-0.5, -0.25, 1.0));
        if (std::abs(glm::dot(n, glm::normalize(glm::dvec3(r.direction)))) < 0.05) continue;
        exact += passes_exactly_through(r, target);
        INFO("ray " << i);
        REQUIRE(count_hits(tris, r) == 1);
    }
    CHECK(exact > 0);  // some rays do meet the target exactly, through the tie-break
}

TEST_CASE("Watertight triangle: a closed octahedron is entered once and left once through its vertices and edges",
          "[geometry]") {
    const glm::vec3 px(1, 0, 0), nx(-1, 0, 0), py(0, 1, 0), ny(0, -1, 0), pz(0, 0, 1), nz(0, 0, -1);
    // Counter-clockwise seen from outside.
    const std::vector<Tri> octa = {{px, py, pz}, {py, nx, pz}, {nx, ny, pz}, {ny, px, pz},
                                   {py, px, nz}, {nx, py, nz}, {ny, nx, nz}, {px, ny, nz}};
    for (const Tri& t : octa) {
        const glm::vec3 n = glm::cross(t[1] - t[0], t[2] - t[0]);
        REQUIRE(glm::dot(n, t[0] + t[1] + t[2]) > 0.0f);  // outward
    }
    // Targets on the surface: the six vertices and points of the twelve edges; the ray runs from
    // outside through the target and on through an interior point (so it crosses the surface twice).
    std::vector<glm::vec3> targets = {px, nx, py, ny, pz, nz};
    for (const Tri& t : octa)
        for (int e = 0; e < 3; ++e)
            for (int k = 1; k < 4; ++k) targets.push_back(t[e] + (t[(e + 1) % 3] - t[e]) * (float(k) / 4.0f));
    Pcg32 rng(8);
    long rays = 0;
    for (const glm::vec3& target : targets)
        for (int i = 0; i < 400; ++i) {
            // Interior point with dyadic coordinates, |x| + |y| + |z| < 1.
            const glm::vec3 q(float(int(rng.next_u32() % 9) - 4) / 16.0f, float(int(rng.next_u32() % 9) - 4) / 16.0f,
                              float(int(rng.next_u32() % 9) - 4) / 16.0f);
            Ray r;
            r.direction = q - target;
            r.origin = target - r.direction;  // exact: small dyadic numbers
            int fronts = 0;
            INFO("target " << target.x << "," << target.y << "," << target.z << " through " << q.x << "," << q.y << "," << q.z);
            REQUIRE(count_hits(octa, r, &fronts) == 2);
            REQUIRE(fronts == 1);  // one entry (front face), one exit (back face)
            ++rays;
        }
    CHECK(rays == long(targets.size()) * 400);
}

TEST_CASE("Watertight triangle: the 8-wide block kernel computes the scalar test's numbers bit for bit",
          "[geometry]") {
    // Triangles sharing vertices on a dyadic grid (so rays pass exactly through vertices and edges), a few
    // degenerate ones, and some at large and tiny scales; rays of every dominant axis and sign, with zero
    // direction components. Random block starts and lengths: a mismatch in one sheared value, edge
    // function or straddle decision (the block kernel decides most in float, see its header) would break
    // the shared-edge guarantee between the two kernels.
    Pcg32 rng(21);
    auto grid = [&] { return float(int(rng.below(9)) - 4) / 4.0f; };
    std::vector<Tri> tris;
    while (tris.size() < 61) {
        Tri t{glm::vec3(grid(), grid(), grid()), glm::vec3(grid(), grid(), grid()), glm::vec3(grid(), grid(), grid())};
        const float scale = tris.size() % 10 == 9 ? 1e4f : tris.size() % 10 == 8 ? 1e-4f : 1.0f;
        for (glm::vec3& v : t) v *= scale;
        tris.push_back(t);
    }
    tris.push_back({glm::vec3(1, 0, 0), glm::vec3(1, 0, 0), glm::vec3(0, 1, 0)});  // repeated vertex
    tris.push_back({glm::vec3(0, 0, 0), glm::vec3(1, 1, 1), glm::vec3(2, 2, 2)});  // collinear
    const std::size_t n = tris.size();

    long lanes_checked = 0, kept = 0, on_edge = 0, near_edge = 0;
    for (int i = 0; i < 20000; ++i) {
        Ray r;
        std::uint32_t first = rng.below(std::uint32_t(n));
        r.direction = i % 3 == 0 ? glm::vec3(grid(), grid(), grid())  // dyadic, often with zero components
                                 : glm::vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        if (r.direction == glm::vec3(0.0f)) continue;
        if (i % 2 == 0) {
            r.origin = glm::vec3(grid(), grid(), grid()) * 2.0f;
        } else {
            // From a grid point exactly through a point of an edge of the block's first triangle (small
            // dyadic numbers: exact): the shear's rounding leaves the edge function a few ulps from 0,
            // where a float edge function can have the wrong sign.
            const Tri& t = tris[first];
            const int e = int(rng.below(3));
            const glm::vec3 target = t[e] + (float(rng.below(9)) / 8.0f) * (t[(e + 1) % 3] - t[e]);
            r.origin = glm::vec3(grid(), grid(), grid()) * 2.0f;
            r.direction = target - r.origin;
            if (r.direction == glm::vec3(0.0f)) continue;
        }
        const TriangleRay tr(r);
        const unsigned lanes = std::min<unsigned>(1 + rng.below(kTriangleBlockLanes), unsigned(n - first));
        // Lanes past `lanes` hold triangles too, which the kernel must mask off.
        TriangleBlock tb;
        for (unsigned l = 0; l < kTriangleBlockLanes; ++l) {
            const Tri& t = tris[(first + l) % n];
            tb.set(l, t[0], t[1], t[2], l);
        }
        ShearedBlock block;
        const unsigned keep = shear_block(tr, tb, lanes, block);
        REQUIRE((keep >> lanes) == 0u);
        for (unsigned l = 0; l < lanes; ++l) {
            const Tri& t = tris[first + l];
            const ShearedTriangle want = shear_triangle(tr, t[0], t[1], t[2]);
            const ShearedTriangle got = block.lane(l);
            INFO("ray " << i << " triangle " << first + l);
            REQUIRE(std::bit_cast<std::uint32_t>(got.ax) == std::bit_cast<std::uint32_t>(want.ax));
            REQUIRE(std::bit_cast<std::uint32_t>(got.ay) == std::bit_cast<std::uint32_t>(want.ay));
            REQUIRE(std::bit_cast<std::uint32_t>(got.bx) == std::bit_cast<std::uint32_t>(want.bx));
            REQUIRE(std::bit_cast<std::uint32_t>(got.by) == std::bit_cast<std::uint32_t>(want.by));
            REQUIRE(std::bit_cast<std::uint32_t>(got.cx) == std::bit_cast<std::uint32_t>(want.cx));
            REQUIRE(std::bit_cast<std::uint32_t>(got.cy) == std::bit_cast<std::uint32_t>(want.cy));
            REQUIRE(bool(keep >> l & 1u) == !straddles(want));
            ++lanes_checked;
            // Within a few float roundings of an edge, where the float products can round together.
            const double scale = std::abs(double(want.ax)) + std::abs(double(want.ay)) + std::abs(double(want.bx)) +
                                 std::abs(double(want.by)) + std::abs(double(want.cx)) + std::abs(double(want.cy));
            near_edge += std::min({std::abs(want.u), std::abs(want.v), std::abs(want.w)}) < 1e-6 * scale * scale;
            if (!(keep >> l & 1u)) continue;
            ++kept;
            on_edge += want.u == 0.0 || want.v == 0.0 || want.w == 0.0;
            REQUIRE(std::bit_cast<std::uint64_t>(got.u) == std::bit_cast<std::uint64_t>(want.u));
            REQUIRE(std::bit_cast<std::uint64_t>(got.v) == std::bit_cast<std::uint64_t>(want.v));
            REQUIRE(std::bit_cast<std::uint64_t>(got.w) == std::bit_cast<std::uint64_t>(want.w));
        }
    }
    CHECK(lanes_checked > 5000);
    CHECK(kept > 100);  // both outcomes occur
    CHECK(kept < lanes_checked - 100);
    CHECK(on_edge > 100);  // rays exactly through edges and vertices: the float signs are uncertain there
    CHECK(near_edge > 1000);
}

TEST_CASE("Watertight triangle: degenerate triangles never hit and never produce NaN", "[geometry]") {
    Pcg32 rng(3);
    int tested = 0;
    for (int i = 0; i < 200000; ++i) {
        const glm::vec3 a(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        const glm::vec3 e(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        Tri t;
        switch (i % 6) {
            case 0: t = {a, a, a}; break;                                  // one point
            case 1: t = {a, a, a + e}; break;                              // v0 == v1
            case 2: t = {a + e, a, a}; break;                              // v1 == v2
            case 3: t = {a, a + e, a}; break;                              // v2 == v0
            case 4: t = {a, a + e, a + 2.0f * e}; break;                   // collinear (as rounded)
            default: t = {a + 0.5f * e, a, a + e}; break;                  // collinear, middle vertex first
        }
        if (!is_degenerate(t[0], t[1], t[2])) continue;  // rounding made it a (thin) real triangle
        ++tested;
        // Aim at a point of the degenerate triangle (a vertex or a point between two of them).
        const glm::vec3 target = t[rng.next_u32() % 3] + rng.uniform01() * (t[1] - t[0]);
        Ray r;
        r.direction = glm::vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        if (glm::length(r.direction) < 0.1f) continue;
        r.origin = target - r.direction;
        TriangleHit h{-1.0f, glm::vec2(-1.0f), false};
        INFO("case " << i % 6 << " v0 " << t[0].x << "," << t[0].y << "," << t[0].z << " v1 " << t[1].x << ","
                     << t[1].y << "," << t[1].z << " v2 " << t[2].x << "," << t[2].y << "," << t[2].z << " origin "
                     << r.origin.x << "," << r.origin.y << "," << r.origin.z << " dir " << r.direction.x << ","
                     << r.direction.y << "," << r.direction.z);
        REQUIRE_FALSE(intersect_triangle(TriangleRay(r), t[0], t[1], t[2], kInf, h));
    }
    CHECK(tested > 100000);
}

TEST_CASE("Watertight triangle: a collinear triangle seen through its own line", "[geometry]") {
    // Minimal case of the above: exactly collinear vertices (v2 = 2·v1), the ray aimed at v1.
    const glm::vec3 v0(0.0f), v1(0.1f, 0.1f, 0.1f), v2 = 2.0f * v1;
    REQUIRE(is_degenerate(v0, v1, v2));
    Ray r;
    r.origin = {0.1f, 0.3f, -1.0f};
    r.direction = v1 - r.origin;
    TriangleHit h;
    CHECK_FALSE(intersect_triangle(TriangleRay(r), v0, v1, v2, kInf, h));
}

TEST_CASE("Watertight triangle: thin but valid triangles give finite results", "[geometry]") {
    Pcg32 rng(4);
    int hits = 0;
    for (int i = 0; i < 100000; ++i) {
        const glm::vec3 a(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        const glm::vec3 e(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        glm::vec3 c = a + 0.5f * e;
        c[rng.next_u32() % 3] += std::exp2(float(-int(rng.next_u32() % 20) - 4));  // a sliver off the line
        if (is_degenerate(a, a + e, c)) continue;
        Ray r;
        r.direction = glm::vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        r.origin = c - r.direction;
        TriangleHit h;
        if (!intersect_triangle(TriangleRay(r), a, a + e, c, kInf, h)) continue;
        ++hits;
        REQUIRE(std::isfinite(h.t));
        REQUIRE(h.barycentrics.x >= 0.0f);
        REQUIRE(h.barycentrics.y >= 0.0f);
        REQUIRE(h.barycentrics.x + h.barycentrics.y <= 1.0f + kEps);
    }
    CHECK(hits > 100);
}

// ---------------------------------------------------------------------------------------------------
// Ray/sphere roots
//
// Analytic cases: direction d = (1, 2, 2) (|d| = 3), offset p ⟂ d with p·d = 0, origin o = c + p − D·d.
// Then |o + t·d − c|² = |p|² + 9·(t − D)², so t = D ± √((r² − |p|²)/9). With dyadic c, p, D, r every
// input is exact, and the reference costs two roundings (a division and a square root) plus one for
// D ± s. The kernel must match within a few ulps of each root's magnitude, also where the textbook
// formula cancels catastrophically.

constexpr double kRootUlps = 8.0 * std::numeric_limits<double>::epsilon();  // 8 double ulps (relative)

void check_sphere(const glm::dvec3& c, const glm::dvec3& p, double D, double radius) {
    const glm::dvec3 d(1, 2, 2);
    REQUIRE(glm::dot(p, d) == 0.0);
    const glm::dvec3 o = c + p - D * d;
    const double s = std::sqrt((radius * radius - glm::dot(p, p)) / 9.0);
    SphereRoots roots{};
    INFO("D " << D << " radius " << radius << " |p| " << glm::length(p));
    REQUIRE(sphere_roots(o, d, c, radius, roots));
    const double scale = std::max(std::abs(D), s);  // roots are D ± s: error relative to that size
    CHECK(std::abs(roots.t_enter - (D - s)) <= kRootUlps * scale);
    CHECK(std::abs(roots.t_exit - (D + s)) <= kRootUlps * scale);
    CHECK(roots.t_enter <= roots.t_exit);
}

TEST_CASE("Sphere roots against analytic double answers", "[geometry]") {
    SECTION("generic") { check_sphere({0.5, -1, 2}, {2, -1, 0}, 3.0, 4.0); }
    SECTION("through the centre") { check_sphere({1, 1, 1}, {0, 0, 0}, 2.0, 1.5); }
    SECTION("origin inside: the entry is behind the origin") { check_sphere({0, 0, 0}, {0.25, 0.25, -0.375}, 0.125, 2.0); }
    SECTION("small sphere far away (b² − ac would cancel)") {
        check_sphere({1024, 0, 0}, {2.0 / 1024, -1.0 / 1024, 0}, 1048576.0, 1.0 / 256);
    }
    SECTION("origin just inside a large sphere (b − √(b² − ac) would cancel)") {
        // The same construction with D just below s: the origin lies less than 3/512 inside a sphere of
        // radius ~1000 and the entry root D − s is tiny and negative. The reference D − s is formed in long
        // double (11 more bits), the textbook b − √… in double loses ~17 bits here.
        const glm::dvec3 d(1, 2, 2), p(2, -1, 0);
        const double radius = 1000.5;
        const long double s = std::sqrt((static_cast<long double>(radius) * radius - 5.0L) / 9.0L);
        const double D = std::floor(double(s) * 1024.0) / 1024.0 - 1.0 / 1024;  // s − D in (2^-10, 2^-9)
        REQUIRE(double(s - D) > 1.0 / 1024);
        SphereRoots roots{};
        REQUIRE(sphere_roots(p - D * d, d, glm::dvec3(0), radius, roots));
        const double t_enter = double(D - s), t_exit = double(D + s);
        // 1e-13 relative: 2^-43, far above the kernel's ~2^-52, far below the textbook formula's 2e-11 here.
        CHECK(std::abs(roots.t_enter - t_enter) <= 1e-13 * std::abs(t_enter));
        CHECK(std::abs(roots.t_exit - t_exit) <= kRootUlps * t_exit);
    }
    SECTION("an unnormalised direction scales the roots") {
        const glm::dvec3 d(0, 0, 4), o(0.5, 0, -8);  // sphere r = 1 at 0: z = ±√0.75
        SphereRoots roots{};
        REQUIRE(sphere_roots(o, d, glm::dvec3(0), 1.0, roots));
        CHECK(std::abs(roots.t_enter - (8.0 - std::sqrt(0.75)) / 4.0) <= kRootUlps * 2.0);
        CHECK(std::abs(roots.t_exit - (8.0 + std::sqrt(0.75)) / 4.0) <= kRootUlps * 2.0);
    }
    SECTION("a miss, a tangent ray and a zero direction have no roots") {
        SphereRoots roots{};
        CHECK_FALSE(sphere_roots({0, 2, -5}, {0, 0, 1}, glm::dvec3(0), 1.0, roots));  // passes at distance 2
        CHECK_FALSE(sphere_roots({0, 1, -5}, {0, 0, 1}, glm::dvec3(0), 1.0, roots));  // tangent: touches only
        CHECK_FALSE(sphere_roots({0, 0, -5}, {0, 0, 0}, glm::dvec3(0), 1.0, roots));
    }
}

TEST_CASE("Sphere roots: random spheres against the long double textbook formula", "[geometry]") {
    // Well-conditioned cases only (origin within 10 radii, the ray passing at most 0.9 r from the centre),
    // where the textbook formula in long double (64-bit significand) is good to ~1e-15.
    Pcg32 rng(21);
    for (int i = 0; i < 20000; ++i) {
        const glm::dvec3 c(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-5, 5));
        const double radius = rng.uniform(0.1f, 3.0f);
        const glm::dvec3 o = c + radius * glm::dvec3(rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-10, 10));
        const glm::dvec3 target = c + 0.5 * radius * glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        const glm::dvec3 d = (target - o) * double(rng.uniform(0.25f, 4.0f));
        using L = long double;
        const L a = L(d.x) * d.x + L(d.y) * d.y + L(d.z) * d.z;
        const glm::dvec3 f = o - c;
        const L b = L(f.x) * d.x + L(f.y) * d.y + L(f.z) * d.z;
        const L cc = L(f.x) * f.x + L(f.y) * f.y + L(f.z) * f.z - L(radius) * radius;
        const L disc = b * b - a * cc;
        REQUIRE(disc > 0);
        const L t0 = (-b - std::sqrt(disc)) / a, t1 = (-b + std::sqrt(disc)) / a;
        SphereRoots roots{};
        REQUIRE(sphere_roots(o, d, c, radius, roots));
        const double scale = double(std::max(std::abs(t0), std::abs(t1)));
        CHECK(std::abs(roots.t_enter - double(t0)) <= 1e-12 * scale);
        CHECK(std::abs(roots.t_exit - double(t1)) <= 1e-12 * scale);
    }
}

}  // namespace
