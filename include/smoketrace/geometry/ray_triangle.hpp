#pragma once
// Watertight ray/triangle intersection: Woop, Benthin and Wald, "Watertight Ray/Triangle
// Intersection", JCGT 2(1), 2013.
//
// Face convention: a triangle's FRONT face is the side from which its vertices v0, v1, v2 appear
// counter-clockwise, i.e. the side its normal (v1 − v0) × (v2 − v0) points to. A closed mesh wound
// counter-clockwise seen from outside therefore shows front faces outward: a ray entering it hits a
// front face, a ray leaving it a back face.
//
// Shared edges and vertices: the ray is sheared so that it becomes the +z axis; each vertex's 2D
// position depends only on that vertex and the ray, so triangles sharing an edge compute its edge
// function from identical numbers and get exactly opposite values. Where an edge value is exactly 0
// (the ray passes through the edge or a vertex) a top-left style tie-break decides (thesis 2.2.1): an
// edge owns its points when, oriented with the triangle's 2D winding, it points up (dy > 0) or,
// horizontal, to the right. Of two triangles on either side of a shared edge exactly one owns it; of
// the fan of triangles around a vertex exactly one owns the vertex. So a ray through a shared edge or
// vertex of a closed mesh is reported once per crossing: never by none, never by two.
#include <smoketrace/geometry/ray.hpp>

#include <glm/common.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <cmath>
#include <utility>

namespace smoketrace {

// Per-ray set-up of the watertight test: the dominant axis kz and the shear that maps the ray
// direction to (0, 0, 1).
struct TriangleRay {
    glm::vec3 origin;
    glm::vec3 direction;
    int kx, ky, kz;
    float sx, sy, sz;
    float tmin;

    TriangleRay() = default;
    explicit TriangleRay(const Ray& r) : origin(r.origin), direction(r.direction), tmin(r.tmin) {
        const glm::vec3 a = glm::abs(r.direction);
        kz = (a.x > a.y) ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
        kx = (kz + 1) % 3;
        ky = (kx + 1) % 3;
        if (r.direction[kz] < 0.0f) std::swap(kx, ky);  // keep the winding of the 2D projection
        // One division: watertightness needs every triangle of a ray to see the same shear, not the
        // correctly rounded one.
        sz = 1.0f / r.direction[kz];
        sx = r.direction[kx] * sz;
        sy = r.direction[ky] * sz;
    }
};

struct TriangleHit {
    float t;
    glm::vec2 barycentrics;  // weights of v1 and v2 (DXR's convention); v0's is 1 − b.x − b.y
    bool front_face;
};

// The geometric normal (v1 − v0) × (v2 − v0) in double. The differences of floats are exact in double
// for any mesh whose coordinates span fewer than 29 binades, and the products of those 24-bit values are
// exact, so the normal is exactly zero iff the float triangle is degenerate (repeated or collinear vertices).
inline glm::dvec3 triangle_normal(const glm::vec3& v0, const glm::vec3& v1, const glm::vec3& v2) {
    const glm::dvec3 e1 = glm::dvec3(v1) - glm::dvec3(v0);
    const glm::dvec3 e2 = glm::dvec3(v2) - glm::dvec3(v0);
    return {e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x};
}

namespace detail {
// Top-left ownership of the edge p → q, winding-normalised by the sign of the 2D determinant.
// Only signs of exact float differences are used, so both triangles of a shared edge agree.
inline bool owns_edge(float px, float py, float qx, float qy, bool ccw) {
    float dx = qx - px, dy = qy - py;
    if (!ccw) { dx = -dx; dy = -dy; }
    return dy > 0.0f || (dy == 0.0f && dx > 0.0f);
}
}  // namespace detail

// The triangle as the sheared ray sees it: its vertices' 2D positions (the ray is the +z axis) and the
// three edge functions, each twice the signed area the ray's point makes with one edge.
struct ShearedTriangle {
    float ax, ay, bx, by, cx, cy;
    double u;  // edge v1 → v2, weight of v0
    double v;  // edge v2 → v0, weight of v1
    double w;  // edge v0 → v1, weight of v2
};

// The edge functions are evaluated in double: a product of two floats is exact there, so each sign is
// the exact sign for the sheared vertex positions and no FMA contraction can break the symmetry. The
// 8-wide kernel (ray_triangle_block.hpp) performs exactly these operations lane by lane.
inline ShearedTriangle shear_triangle(const TriangleRay& r, const glm::vec3& v0, const glm::vec3& v1,
                                      const glm::vec3& v2) {
    // Components picked by a runtime index through a pointer: glm's operator[] is a switch per access.
    const glm::vec3 a = v0 - r.origin;
    const glm::vec3 b = v1 - r.origin;
    const glm::vec3 c = v2 - r.origin;
    static_assert(sizeof(glm::vec3) == 3 * sizeof(float));
    const float *pa = &a.x, *pb = &b.x, *pc = &c.x;
    ShearedTriangle s;
    s.ax = pa[r.kx] - r.sx * pa[r.kz];
    s.ay = pa[r.ky] - r.sy * pa[r.kz];
    s.bx = pb[r.kx] - r.sx * pb[r.kz];
    s.by = pb[r.ky] - r.sy * pb[r.kz];
    s.cx = pc[r.kx] - r.sx * pc[r.kz];
    s.cy = pc[r.ky] - r.sy * pc[r.kz];
    s.u = double(s.cx) * double(s.by) - double(s.cy) * double(s.bx);
    s.v = double(s.ax) * double(s.cy) - double(s.ay) * double(s.cx);
    s.w = double(s.bx) * double(s.ay) - double(s.by) * double(s.ax);
    return s;
}

// Mixed strict signs of the edge functions: the ray passes outside the triangle. Bitwise, not
// short-circuit: one branch instead of up to six poorly predicted ones.
inline bool straddles(const ShearedTriangle& s) {
    const bool any_negative = (s.u < 0.0) | (s.v < 0.0) | (s.w < 0.0);
    const bool any_positive = (s.u > 0.0) | (s.v > 0.0) | (s.w > 0.0);
    return any_negative & any_positive;
}

// The rest of the test for a triangle that does not straddle: degeneracy, the tie-break on edges and
// vertices, and the distance. `n` is triangle_normal(v0, v1, v2), which a mesh BLAS keeps per triangle.
// Returns true and fills `hit` when t lies in [tmin, tmax].
inline bool finish_triangle_hit(const TriangleRay& r, const ShearedTriangle& s, const glm::vec3& v0,
                                const glm::dvec3& n, float tmax, TriangleHit& hit) {
    const double det = s.u + s.v + s.w;
    if (det == 0.0) return false;
    const bool ccw = det > 0.0;
    if (s.u == 0.0 && !detail::owns_edge(s.bx, s.by, s.cx, s.cy, ccw)) return false;
    if (s.v == 0.0 && !detail::owns_edge(s.cx, s.cy, s.ax, s.ay, ccw)) return false;
    if (s.w == 0.0 && !detail::owns_edge(s.ax, s.ay, s.bx, s.by, ccw)) return false;

    // The distance comes from the plane, in double, and not from the edge-weighted sum of the sheared
    // vertex depths: that sum carries an error proportional to the vertices' distance from the origin,
    // which for a large triangle seen from close by exceeds the box test's widening and would let a box
    // reject its own triangle's hit. The plane form's error is relative to t itself. It also rejects the
    // triangles the 2D test cannot see as degenerate: exactly collinear vertices (zero normal) whose
    // sheared projection rounded to a sliver, and a ray in the triangle's plane.
    const double n_dot_d = n.x * r.direction.x + n.y * r.direction.y + n.z * r.direction.z;
    if (n_dot_d == 0.0) return false;
    const glm::dvec3 p = glm::dvec3(v0) - glm::dvec3(r.origin);
    const double t = (n.x * p.x + n.y * p.y + n.z * p.z) / n_dot_d;
    if (!(t >= double(r.tmin) && t <= double(tmax))) return false;  // also rejects NaN
    hit.t = static_cast<float>(t);
    if (!(hit.t >= r.tmin && hit.t <= tmax)) return false;  // rounding to float must stay in range
    hit.barycentrics = glm::vec2(float(s.v / det), float(s.w / det));
    // The shear keeps the winding as seen from the origin looking along the ray, so a positive
    // determinant means the vertices run counter-clockwise for the viewer: the front face.
    hit.front_face = ccw;
    return true;
}

// Returns true and fills `hit` when the ray meets the triangle at t in [tmin, tmax].
// Degenerate triangles (repeated or collinear vertices) and triangles seen edge-on never hit.
inline bool intersect_triangle(const TriangleRay& r, const glm::vec3& v0, const glm::vec3& v1,
                               const glm::vec3& v2, float tmax, TriangleHit& hit) {
    const ShearedTriangle s = shear_triangle(r, v0, v1, v2);
    if (straddles(s)) return false;
    return finish_triangle_hit(r, s, v0, triangle_normal(v0, v1, v2), tmax, hit);
}

}  // namespace smoketrace
