// Exact spheres through trace(), against a long-double analytic answer: rays from outside and from
// inside, tangent and near-tangent rays, tiny (1e-4) and huge (1e4) radii, spheres far from the origin
// (in the BLAS, and placed by double-precision instance transforms 1e5 away).
//
// Tolerance, derived rather than guessed. A root t of |f + t·d| = R (f = origin − centre) moves, when the
// ray's position at t is perturbed by δp, by |δt| ≤ (R / h)·|δp| / |d|, h = √(R² − perp²) the half
// chord (perp: the centre's distance from the ray line); R/h = 1 for a central ray and grows at grazing
// incidence. trace() perturbs the ray once: it takes it into object space in double and rounds the
// object-space origin and direction to float, a relative error ≤ e = u = 2⁻²⁴ of the object-space
// origin (whose world size is |o − C|, C the instance's translation) and of the direction. For the
// identity instance that rounding is exact and only the double root solver errs (e = kDoubleEps, relative
// to |o − centre|). So |δp| ≤ e·(|o − C| + t·|d|), and with the final rounding of t to float (u·|t|)
//     |t − t_ref| ≤ kSlack·( u·|t_ref| + (R/h)·e·(|o − C|/|d| + |t_ref|) ).
// The same δp decides whether a near-tangent ray must hit: if R − perp > kSlack·δ⊥ it must, if perp − R
// > kSlack·δ⊥ it must not; in between (a band a few ulps wide) either answer is correct and is not
// checked. An exactly tangent ray (perp = R in exact arithmetic, with exactly representable input)
// must report nothing.
#include <smoketrace/core/prng.hpp>
#include <smoketrace/trace/trace.hpp>

#include <catch2/catch.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

using namespace smoketrace;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
// Unit roundoff of float: the object-space ray and the reported t are rounded to float once each.
constexpr long double kU = 0x1p-24L;
// Relative error of the double-precision root solver (about ten rounded double operations, with margin).
constexpr long double kDoubleEps = 0x1p-48L;
// Factor over the first-order bounds above: covers second-order terms and the √3 of per-component
// rounding of 3-vectors (each component's error is bounded by u·|component| ≤ u·|vector|).
constexpr long double kSlack = 4.0L;

using ldvec = long double[3];

long double dot3(const long double* a, const long double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// One sphere in world space (centre and radius exactly as trace() sees them, in long double) and how
// precisely trace() knows the object-space ray for it (e: see the header). The origin's rounding error
// scales with its distance from the OBJECT-SPACE origin, i.e. from the instance's translation `frame`
// (a sphere of a set sits anywhere in its BLAS), not from the sphere's centre.
struct RefSphere {
    long double centre[3];
    long double radius;
    long double e;
    long double frame[3];
    std::uint32_t instance;
    std::uint32_t primitive;
};

// The analytic answer for a ray, in long double, solved the careful way (perpendicular distance, then
// the stable quadratic root pair) so that the reference itself loses nothing.
struct RefAnswer {
    enum class Kind { must_miss, must_hit, either } kind = Kind::must_miss;
    long double t_enter = 0, t_exit = 0;
    long double tol_enter = 0, tol_exit = 0;
};

RefAnswer reference(const RefSphere& s, const Ray& ray) {
    const long double o[3] = {ray.origin.x, ray.origin.y, ray.origin.z};
    const long double d[3] = {ray.direction.x, ray.direction.y, ray.direction.z};
    const long double f[3] = {o[0] - s.centre[0], o[1] - s.centre[1], o[2] - s.centre[2]};
    const long double a = dot3(d, d), b = dot3(f, d);
    const long double perp_v[3] = {f[0] - b / a * d[0], f[1] - b / a * d[1], f[2] - b / a * d[2]};
    const long double perp = std::sqrt(dot3(perp_v, perp_v));
    const long double g[3] = {o[0] - s.frame[0], o[1] - s.frame[1], o[2] - s.frame[2]};
    const long double dist = std::sqrt(dot3(f, f)), dlen = std::sqrt(a), frame_dist = std::sqrt(dot3(g, g));
    const long double t_closest = std::fabs(b / a);
    const long double dperp = s.e * (frame_dist + t_closest * dlen) + kDoubleEps * (dist + t_closest * dlen);
    RefAnswer ans;
    if (perp - s.radius > kSlack * dperp) return ans;  // must_miss
    ans.kind = s.radius - perp > kSlack * dperp ? RefAnswer::Kind::must_hit : RefAnswer::Kind::either;
    if (ans.kind == RefAnswer::Kind::either) return ans;
    const long double h2 = (s.radius - perp) * (s.radius + perp);
    const long double h = std::sqrt(h2);
    const long double q = -(b + std::copysign(std::sqrt(a * h2), b));
    const long double c = (perp - s.radius) * (perp + s.radius) + b * b / a;  // |f|² − R², without cancelling
    long double t0 = c / q, t1 = q / a;
    if (t0 > t1) std::swap(t0, t1);
    ans.t_enter = t0;
    ans.t_exit = t1;
    auto tol = [&](long double t) {
        return kSlack * (kU * std::fabs(t) + (s.radius / h) * (s.e * (frame_dist / dlen + std::fabs(t)) +
                                                                kDoubleEps * (dist / dlen + std::fabs(t))));
    };
    ans.tol_enter = tol(t0);
    ans.tol_exit = tol(t1);
    return ans;
}

// All hits of the ray, every sphere forced non-opaque and ignored by any-hit.
std::vector<TraceHit> all_hits(const AccelScene& s, const Ray& r) {
    std::vector<TraceHit> hits;
    trace(s, r, ray_flag_force_non_opaque, 0xFF, [&](const TraceHit& h) {
        hits.push_back(h);
        return AnyHitDecision::ignore;
    });
    return hits;
}

// Compares trace()'s hits with the reference for every sphere: a must_hit sphere reports its entry
// (front face) iff the entry lies in [tmin, tmax] and its exit (back face) iff the exit does, each
// within its tolerance; a must_miss sphere reports nothing; an `either` sphere is not checked, nor is a
// root within its tolerance of tmin/tmax. Returns the number of roots checked.
int compare(const AccelScene& scene, const std::vector<RefSphere>& spheres, const Ray& ray) {
    const std::vector<TraceHit> hits = all_hits(scene, ray);
    int checked = 0;
    for (const RefSphere& s : spheres) {
        const RefAnswer ref = reference(s, ray);
        std::vector<TraceHit> mine;
        for (const auto& h : hits)
            if (h.instance_index == s.instance && h.primitive_index == s.primitive) mine.push_back(h);
        CAPTURE(s.instance, s.primitive, double(s.radius), ray.origin.x, ray.origin.y, ray.origin.z,
                ray.direction.x, ray.direction.y, ray.direction.z);
        if (ref.kind == RefAnswer::Kind::either) {
            CHECK(mine.size() <= 2);
            continue;
        }
        if (ref.kind == RefAnswer::Kind::must_miss) {
            CHECK(mine.empty());
            ++checked;
            continue;
        }
        auto expect_root = [&](long double t, long double tol, HitKind kind) {
            const bool near_end = std::fabs(t - ray.tmin) <= tol || std::fabs(t - ray.tmax) <= tol;
            if (near_end) return;
            const bool inside = t > ray.tmin && t < ray.tmax;
            int found = 0;
            for (const auto& h : mine)
                if (h.kind == kind) {
                    ++found;
                    CAPTURE(double(t), double(h.t), double(tol));
                    CHECK(std::fabs((long double)h.t - t) <= tol);
                    CHECK(h.geometry == GeometryKind::spheres);
                }
            CAPTURE(double(t), inside);
            CHECK(found == (inside ? 1 : 0));
            ++checked;
        };
        expect_root(ref.t_enter, ref.tol_enter, HitKind::front_face);
        expect_root(ref.t_exit, ref.tol_exit, HitKind::back_face);
    }
    return checked;
}

// A one-sphere-BLAS scene: sphere (c, r) placed by `m`; returns the world-space reference sphere.
struct OneSphere {
    AccelScene scene;
    RefSphere ref;
};
OneSphere one_sphere(glm::vec3 c, float r, const AffineTransform& m = {}) {
    OneSphere o;
    const auto b = o.scene.add_bottom_level(BottomLevel::from_spheres({Sphere{c, r}}, true));
    o.scene.add_instance(Instance{b, m, 0xFF, 0, 0});
    o.scene.commit();
    // Uniform scale only (what particles use): the world sphere is the scaled, translated sphere.
    const long double s = m.linear[0][0];
    for (int k = 0; k < 3; ++k) o.ref.centre[k] = (long double)m.translation[k] + s * (long double)c[k];
    o.ref.radius = std::fabs(s) * (long double)r;
    const bool identity = m.linear == glm::dmat3(1.0) && m.translation == glm::dvec3(0.0);
    o.ref.e = identity ? 0.0L : kU;
    for (int k = 0; k < 3; ++k) o.ref.frame[k] = (long double)m.translation[k];
    o.ref.instance = 0;
    o.ref.primitive = 0;
    return o;
}

Ray make_ray(glm::vec3 o, glm::vec3 d, float tmin = 0.0f, float tmax = kInf) { return Ray{o, tmin, d, tmax}; }

}  // namespace

TEST_CASE("spheres: entry is a front-face hit, exit a back-face hit, at the analytic distances", "[sphere]") {
    OneSphere s = one_sphere({1.0f, 2.0f, 3.0f}, 1.5f);
    const Ray ray = make_ray({1.25f, 2.5f, -10.0f}, {0, 0, 1});
    const auto hits = all_hits(s.scene, ray);
    REQUIRE(hits.size() == 2);
    const auto& entry = hits[0].t < hits[1].t ? hits[0] : hits[1];
    const auto& exit = hits[0].t < hits[1].t ? hits[1] : hits[0];
    CHECK(entry.kind == HitKind::front_face);
    CHECK(exit.kind == HitKind::back_face);
    const double h = std::sqrt(1.5 * 1.5 - 0.25 * 0.25 - 0.5 * 0.5);
    CHECK(entry.t == float(13.0 - h));  // identity instance: t is the correctly rounded root
    CHECK(exit.t == float(13.0 + h));
    // The object-space point is on the sphere (to float rounding of o + t·d, |o|,|t·d| ≤ 14).
    CHECK(std::fabs(glm::length(entry.object_point - glm::vec3(1, 2, 3)) - 1.5f) <= 14.0f * 4.0f * float(kU));
    CHECK(compare(s.scene, {s.ref}, ray) == 2);
}

TEST_CASE("spheres: a ray starting inside reports only the exit", "[sphere]") {
    OneSphere s = one_sphere({0, 0, 0}, 2.0f);
    for (const glm::vec3 o : {glm::vec3(0, 0, 0), glm::vec3(0.5f, -0.3f, 1.0f), glm::vec3(1.9f, 0, 0)}) {
        for (const glm::vec3 d : {glm::vec3(1, 0, 0), glm::vec3(-1, 0, 0), glm::vec3(0.3f, -2.0f, 0.7f)}) {
            const Ray ray = make_ray(o, d);
            const auto hits = all_hits(s.scene, ray);
            REQUIRE(hits.size() == 1);
            CHECK(hits[0].kind == HitKind::back_face);
            CHECK(compare(s.scene, {s.ref}, ray) == 2);  // the entry (t < 0) is checked as absent
        }
    }
    // From the centre the exit is at t = R/|d| exactly.
    const auto hits = all_hits(s.scene, make_ray({0, 0, 0}, {0, 0, 4}));
    REQUIRE(hits.size() == 1);
    CHECK(hits[0].t == 0.5f);
}

TEST_CASE("spheres: exactly tangent rays report nothing", "[sphere]") {
    // perp = R exactly: axis-aligned rays at distance R from the centre, with power-of-two radii and
    // directions of any length (b/a inexact for |d| = 3), in the BLAS and through exact (power-of-two
    // scale, integer translation) instance transforms, also far from the origin.
    int tested = 0;
    for (const float r : {0x1p-13f, 0.5f, 1.0f, 8.0f, 0x1p13f}) {
        for (const float len : {1.0f, 3.0f, 0x1p-5f}) {
            for (int axis = 0; axis < 3; ++axis) {
                glm::vec3 d(0.0f), off(0.0f);
                d[axis] = len;
                off[(axis + 1) % 3] = r;
                glm::vec3 o = off - 5.0f * r * glm::normalize(d);
                OneSphere blas = one_sphere({0, 0, 0}, r);
                CHECK(all_hits(blas.scene, make_ray(o, d)).empty());
                CHECK(all_hits(blas.scene, make_ray(o, -d, -kInf, kInf)).empty());
                // Same geometry 1e5 away via an exact instance transform: unit sphere scaled by r.
                const glm::dvec3 far(100000.0, -100000.0, 200000.0);
                OneSphere inst = one_sphere({0, 0, 0}, 1.0f, AffineTransform::translate_scale(far, r));
                const glm::vec3 o_far = glm::vec3(glm::dvec3(o) + far);
                if (glm::dvec3(o_far) == glm::dvec3(o) + far) {  // representable: still exactly tangent
                    CHECK(all_hits(inst.scene, make_ray(o_far, d)).empty());
                    ++tested;
                }
            }
        }
    }
    CHECK(tested >= 10);
}

TEST_CASE("spheres: near-tangent rays hit just inside and miss just outside", "[sphere]") {
    // Ray from (−5, 1, 0)·R along x, tilted by ε towards (hit) or away from (miss) the sphere: the line
    // passes the centre at perp ≈ R·(1 ∓ 5ε). ε down to 2⁻⁴⁰: far below float resolution of the
    // origin, yet decided exactly since the BLAS sphere is tested in double on the exact float ray.
    int hits_checked = 0;
    for (const float r : {1e-4f, 1.0f, 1e4f}) {
        OneSphere s = one_sphere({0, 0, 0}, r);
        for (int k = 8; k <= 40; k += 4) {
            const float eps = std::ldexp(1.0f, -k);
            for (const float sign : {-1.0f, 1.0f}) {
                const Ray ray = make_ray({-5.0f * r, r, 0.0f}, {1.0f, sign * eps, 0.0f});
                const RefAnswer ref = reference(s.ref, ray);
                CAPTURE(r, k, sign);
                CHECK(ref.kind == (sign < 0 ? RefAnswer::Kind::must_hit : RefAnswer::Kind::must_miss));
                const auto hits = all_hits(s.scene, ray);
                CHECK(hits.size() == (sign < 0 ? 2u : 0u));
                hits_checked += compare(s.scene, {s.ref}, ray);
            }
        }
    }
    CHECK(hits_checked == 3 * 9 * (2 + 1));
}

TEST_CASE("spheres: a tiny sphere seen from far away (no cancellation)", "[sphere]") {
    // Radius 1e-4, ray origins 1e5 away: |f|²/R² = 1e18 exceeds 1/ε of double, so b² − a·c cancels to
    // noise; the perpendicular-distance form keeps the answer. Axis-aligned and slightly oblique rays
    // whose line passes within the sphere (offsets up to 0.9 R), directions of several lengths.
    const glm::vec3 c(0.3f, -0.2f, 0.1f);
    const float r = 1e-4f;
    OneSphere s = one_sphere(c, r);
    int checked = 0;
    for (const float oy : {0.0f, 0.5f, -0.9f})
        for (const float oz : {0.0f, 0.3f})
            for (const float len : {1.0f, 3.0f, 1e-3f})
                for (const float slope : {0.0f, 0x1p-12f}) {
                    const glm::vec3 d = len * glm::vec3(1.0f, slope, 0.0f);
                    // Origin 1e5 back along the line through c + (0, oy, oz)·R (rounded to float).
                    const glm::vec3 target = c + glm::vec3(0.0f, oy * r, oz * r);
                    const glm::vec3 o = glm::vec3(glm::dvec3(target) - 1e5 * glm::dvec3(d) / double(len));
                    const Ray ray = make_ray(o, d);
                    const RefAnswer ref = reference(s.ref, ray);
                    CAPTURE(oy, oz, len, slope);
                    REQUIRE(ref.kind == RefAnswer::Kind::must_hit);
                    const auto hits = all_hits(s.scene, ray);
                    CHECK(hits.size() == 2);
                    checked += compare(s.scene, {s.ref}, ray);
                }
    CHECK(checked == 3 * 2 * 3 * 2 * 2);
}

TEST_CASE("spheres: huge radius, rays starting just inside and just outside", "[sphere]") {
    // Radius 1e4: an origin 0.01 inside the surface going outward exits at t ≈ 0.01; an origin just
    // outside going inward enters at t ≈ 0.01. The near root is c/q, not b − √…, which would cancel.
    const float r = 1e4f;
    OneSphere s = one_sphere({0, 0, 0}, r);
    int checked = 0;
    for (const float gap : {-0.5f, -0.0078125f, 0.0078125f, 0.5f}) {  // multiples of the float ulp at 1e4
        for (const glm::vec3 dir : {glm::vec3(1, 0, 0), glm::vec3(1, 0.25f, -0.5f), glm::vec3(-1, 0.1f, 0)}) {
            const glm::vec3 o(r + gap, 3.0f, -2.0f);
            for (const float sign : {1.0f, -1.0f}) {
                const Ray ray = make_ray(o, sign * dir);
                const auto hits = all_hits(s.scene, ray);
                CAPTURE(gap, sign);
                // Inside (perp < R): one exit; outside: two or none depending on direction.
                const RefAnswer ref = reference(s.ref, ray);
                if (ref.kind == RefAnswer::Kind::must_hit && ref.t_enter < 0 && ref.t_exit > 0) CHECK(hits.size() == 1);
                checked += compare(s.scene, {s.ref}, ray);
            }
        }
    }
    CHECK(checked >= 3 * 4 * 2);
    // From the centre: the exit at exactly R.
    const auto hits = all_hits(s.scene, make_ray({0, 0, 0}, {0, -1, 0}));
    REQUIRE(hits.size() == 1);
    CHECK(hits[0].t == r);
}

TEST_CASE("spheres: far from the origin via double instance transforms", "[sphere]") {
    // Unit-sphere BLAS placed at 1e5-scale offsets by translate_scale (double), radii 1e-4 … 1e4, ray
    // origins near the sphere (float: at 1e5 their spacing is 2⁻⁷). A float object-to-world transform
    // would round the centre by up to 4e-3 and miss the 1e-4 spheres entirely.
    Pcg32 rng(11);
    int checked = 0, hit_rays = 0;
    for (const double scale : {1e-4, 1e-2, 0.37, 3.0, 1e4}) {
        const glm::dvec3 centre(100000.3, -100000.7, 250000.1);
        OneSphere s = one_sphere({0, 0, 0}, 1.0f, AffineTransform::translate_scale(centre, scale));
        for (int k = 0; k < 64; ++k) {
            // Origin: the float point nearest to centre + (3 … 100 radii, or 1e4 for tiny spheres whose
            // nearest float neighbours are that far) in a random direction.
            const double reach = std::max(scale * (3.0 + 97.0 * rng.uniform01()), 0.05);
            const glm::dvec3 dir = glm::normalize(glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)));
            const glm::vec3 o = glm::vec3(centre + reach * dir);
            // Aim at a random point within 1.2 radii of the centre (so some rays miss).
            const glm::dvec3 aim = centre + 1.2 * scale * glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
            const glm::vec3 d = glm::vec3(aim - glm::dvec3(o));
            const Ray ray = make_ray(o, d);
            CAPTURE(scale, k);
            hit_rays += reference(s.ref, ray).kind == RefAnswer::Kind::must_hit ? 1 : 0;
            checked += compare(s.scene, {s.ref}, ray);
        }
    }
    CHECK(checked >= 5 * 64);
    CHECK(hit_rays >= 5 * 64 / 3);
}

TEST_CASE("spheres: a sphere set against the analytic answer, rays from inside and outside", "[sphere]") {
    // 300 spheres (radii 0.05 … 2) in one BLAS, instanced twice: as is (identity, exact object ray) and
    // scaled by 2.5 and moved 1e3 away (rounded object ray). Random rays start anywhere in the cloud,
    // often inside spheres, with and without a tmin/tmax window.
    Pcg32 rng(12);
    std::vector<Sphere> set;
    for (int i = 0; i < 300; ++i)
        set.push_back(Sphere{{rng.uniform(0, 20), rng.uniform(0, 20), rng.uniform(0, 20)}, rng.uniform(0.05f, 2.0f)});
    AccelScene scene;
    const auto b = scene.add_bottom_level(BottomLevel::from_spheres(set, true));
    const AffineTransform moved = AffineTransform::translate_scale({1000.0, -1000.0, 500.0}, 2.5);
    scene.add_instance(Instance{b, {}, 0xFF, 0, 0});
    scene.add_instance(Instance{b, moved, 0xFF, 1, 0});
    scene.commit();
    std::vector<RefSphere> refs;
    for (std::uint32_t inst = 0; inst < 2; ++inst)
        for (std::uint32_t i = 0; i < set.size(); ++i) {
            RefSphere r;
            const long double s = inst == 0 ? 1.0L : 2.5L;
            for (int k = 0; k < 3; ++k)
                r.centre[k] = (inst == 0 ? 0.0L : (long double)moved.translation[k]) + s * (long double)set[i].center[k];
            r.radius = s * (long double)set[i].radius;
            r.e = inst == 0 ? 0.0L : kU;
            for (int k = 0; k < 3; ++k) r.frame[k] = inst == 0 ? 0.0L : (long double)moved.translation[k];
            r.instance = inst;
            r.primitive = i;
            refs.push_back(r);
        }
    int checked = 0, found = 0;
    for (int k = 0; k < 300; ++k) {
        const std::uint32_t inst = k % 2;
        const double s = inst == 0 ? 1.0 : 2.5;
        const glm::dvec3 base = inst == 0 ? glm::dvec3(0.0) : moved.translation;
        const glm::vec3 o = glm::vec3(base + s * glm::dvec3(rng.uniform(0, 20), rng.uniform(0, 20), rng.uniform(0, 20)));
        const glm::vec3 d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        const float tmin = k % 3 == 0 ? rng.uniform(0, 5) : 0.0f;
        const float tmax = k % 5 == 0 ? rng.uniform(5, 20) : kInf;
        const Ray ray = make_ray(o, d, tmin, tmax);
        found += int(all_hits(scene, ray).size());
        checked += compare(scene, refs, ray);
    }
    // Every sphere is checked for every ray (once if missed, once per root if hit) but for the few
    // within a rounding band of tangency or whose root is within tolerance of tmin/tmax.
    CHECK(checked >= 300 * 600 * 99 / 100);
    CHECK(found > 300);
}

// ---------------------------------------------------------------------------------------------------
// The world-sphere fast path (InstanceRecord::world_sphere: one sphere, similarity transform) against
// the general object-space path, and non-similarity transforms (ellipsoids), which must take the latter.
//
// Tolerance. Both paths solve in double from the same float ray, with inputs that differ by double
// rounding (the fast path rounds L·c and s·r, the general path L⁻¹(o − T) and L⁻¹d): a perturbation of
// the centre's distance from the ray line of at most a few 2⁻⁵³ of the sizes involved, bounded here by
// δ = 2⁻⁴⁰·(|o − T| + |L·c| + |t_c|·|d| + R), t_c the parameter of closest approach. A root then moves
// by at most (R/h)·δ/|d| (h the half chord), and both are rounded to float (≤ 2⁻²³·|t| apart after
// that), so tol(t) = 2⁻²²·|t| + 4·(R/h)·δ/|d|. Within δ of tangency either path may hit or miss (not
// checked), as may a root within tol of tmin or tmax.

namespace {

struct Ld3 {
    long double x = 0, y = 0, z = 0;
};
Ld3 ld(const glm::dvec3& v) { return {v.x, v.y, v.z}; }
Ld3 operator+(Ld3 a, Ld3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Ld3 operator-(Ld3 a, Ld3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Ld3 operator*(long double s, Ld3 a) { return {s * a.x, s * a.y, s * a.z}; }
long double dot(Ld3 a, Ld3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
long double len(Ld3 a) { return std::sqrt(dot(a, a)); }

// One sphere against a ray, both given in long double: roots, half chord, closest approach.
struct LdRoots {
    bool crosses = false;  // perp < radius
    long double perp = 0, h = 0, t_closest = 0, t_enter = 0, t_exit = 0;
};
LdRoots ld_roots(Ld3 o, Ld3 d, Ld3 centre, long double radius) {
    LdRoots r;
    const Ld3 f = o - centre;
    const long double a = dot(d, d), b = dot(f, d);
    r.t_closest = -b / a;
    r.perp = len(f - (b / a) * d);
    if (!(r.perp < radius)) return r;
    r.crosses = true;
    const long double h2 = (radius - r.perp) * (radius + r.perp);
    r.h = std::sqrt(h2);
    const long double q = -(b + std::copysign(std::sqrt(a * h2), b));
    const long double c = (r.perp - radius) * (r.perp + radius) + b * b / a;
    r.t_enter = std::min(c / q, q / a);
    r.t_exit = std::max(c / q, q / a);
    return r;
}

// A rotation from Gram–Schmidt on two random vectors, in double; `mirror` flips the third axis.
glm::dmat3 random_rotation(Pcg32& rng, bool mirror) {
    glm::dvec3 a, b;
    do a = glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)); while (glm::length(a) < 0.1);
    do b = glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)); while (glm::length(glm::cross(a, b)) < 0.1);
    const glm::dvec3 x = glm::normalize(a), y = glm::normalize(b - glm::dot(b, x) * x);
    return glm::dmat3(x, y, mirror ? -glm::cross(x, y) : glm::cross(x, y));
}

// All hits (force non-opaque, any-hit ignores) with the counters.
struct Listing {
    std::vector<TraceHit> hits;
    TraceCounters counters;
};
Listing listing(const AccelScene& s, const Ray& r) {
    Listing l;
    l.counters = trace(s, r, ray_flag_force_non_opaque, 0xFF, [&](const TraceHit& h) {
        l.hits.push_back(h);
        return AnyHitDecision::ignore;
    }).counters;
    return l;
}

}  // namespace

TEST_CASE("spheres: the world-sphere fast path agrees with the object-space path", "[sphere][trace]") {
    // 60 one-sphere BLASes, the sphere off its object origin (so the centre's offset is exercised),
    // each placed by uniform scale (0.3 … 3) × rotation (a third mirrored) + translation: all take the
    // fast path. The same instances of two-sphere BLASes, the same sphere (primitive 0) plus a
    // concentric one of a quarter its radius (primitive 1, dropped from the comparison), take the
    // general path with the same bounds, hence the same TLAS and the same traversal: hits must agree in
    // number, kind and order, t and object_point to the tolerance above, and the counters exactly (the
    // general path tests two primitives per instance). Rays: random, from inside spheres, and near
    // tangency (relative offsets 1e-3 … 1e-12 and 0, blurred to ~1e-7 by the float origin); near the
    // origin and 3e4 away.
    constexpr int kSpheres = 60;
    Pcg32 rng(61);
    int compared_hits = 0, compared_rays = 0, committed_compared = 0, near_tangent = 0;
    for (const glm::dvec3 base : {glm::dvec3(0.0), glm::dvec3(3e4, -1e4, 2e4)}) {
        AccelScene fast, general;
        struct World {
            Ld3 centre;
            long double radius;
            double scale;
            glm::dvec3 translation, offset;
        };
        std::vector<World> world;
        for (int i = 0; i < kSpheres; ++i) {
            const Sphere sp{{rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)}, rng.uniform(0.2f, 1.5f)};
            const double s = 0.3 + 2.7 * double(rng.uniform01());
            AffineTransform m;
            m.linear = s * random_rotation(rng, i % 3 == 0);
            m.translation = base + glm::dvec3(rng.uniform(-20, 20), rng.uniform(-20, 20), rng.uniform(-20, 20));
            const auto bf = fast.add_bottom_level(BottomLevel::from_spheres({sp}, false));
            const auto bg = general.add_bottom_level(BottomLevel::from_spheres({sp, Sphere{sp.center, 0.25f * sp.radius}}, false));
            REQUIRE(general.bottom_level(bg).spheres.bvh().nodes[0].is_leaf());  // one leaf, like the fast path
            fast.add_instance(Instance{bf, m, 0xFF, std::uint32_t(i), 0});
            general.add_instance(Instance{bg, m, 0xFF, std::uint32_t(i), 0});
            const glm::dvec3 offset = m.linear * glm::dvec3(sp.center);
            world.push_back({ld(m.translation) + ld(offset), (long double)s * sp.radius, s, m.translation, offset});
        }
        fast.commit();
        general.commit();
        for (int i = 0; i < kSpheres; ++i) {
            REQUIRE(fast.record(std::uint32_t(i)).path == InstancePath::world_sphere);
            REQUIRE(general.record(std::uint32_t(i)).path == InstancePath::object_space);
        }

        for (int k = 0; k < 1200; ++k) {
            glm::dvec3 o, d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
            if (glm::length(d) < 1e-3) continue;
            const World& w = world[rng.below(kSpheres)];
            const glm::dvec3 centre(double(w.centre.x), double(w.centre.y), double(w.centre.z));
            const double radius = double(w.radius);
            if (k % 3 == 0) {  // anywhere
                o = base + glm::dvec3(rng.uniform(-25, 25), rng.uniform(-25, 25), rng.uniform(-25, 25));
            } else if (k % 3 == 1) {  // inside a sphere
                o = centre + 0.95 * radius / std::sqrt(3.0) * glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
            } else {  // near tangency: the line passes the centre at radius·(1 + ε)
                const double eps[] = {1e-3, -1e-3, 1e-6, -1e-6, 1e-9, -1e-9, 1e-12, -1e-12, 0.0};
                const glm::dvec3 any(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
                const glm::dvec3 n = glm::normalize(glm::cross(d, any));
                o = centre + radius * (1.0 + eps[k % 9]) * n - 3.0 * radius * glm::normalize(d);
            }
            const float tmin = k % 7 == 0 ? rng.uniform(0, 2) : 0.0f;
            const float tmax = k % 11 == 0 ? rng.uniform(2, 30) : kInf;
            const Ray ray = make_ray(glm::vec3(o), glm::vec3(d), tmin, tmax);
            const Ld3 ro{ray.origin.x, ray.origin.y, ray.origin.z}, rd{ray.direction.x, ray.direction.y, ray.direction.z};
            const long double dlen = len(rd);

            // Which instances are decided (not within δ of tangency, no root within tol of tmin/tmax),
            // and each decided instance's root tolerance.
            std::vector<bool> decided(kSpheres, true);
            std::vector<long double> tol(kSpheres, 0);
            for (int i = 0; i < kSpheres; ++i) {
                const World& s = world[i];
                const LdRoots r = ld_roots(ro, rd, s.centre, s.radius);
                const long double delta = 0x1p-40L * (len(ro - ld(s.translation)) + len(ld(s.offset)) +
                                                      std::fabs(r.t_closest) * dlen + s.radius);
                if (std::fabs(r.perp - s.radius) <= delta) {
                    decided[i] = false;
                    continue;
                }
                if (!r.crosses) continue;
                if (s.radius - r.perp < 1e-5L * s.radius) ++near_tangent;  // R/h > 200: the tolerance at work
                auto tol_at = [&](long double t) { return 0x1p-22L * std::fabs(t) + 4.0L * (s.radius / r.h) * delta / dlen; };
                tol[i] = std::max(tol_at(r.t_enter), tol_at(r.t_exit));
                for (const long double t : {r.t_enter, r.t_exit})
                    if (std::fabs(t - tmin) <= tol[i] || std::fabs(t - tmax) <= tol[i]) decided[i] = false;
            }

            const Listing f = listing(fast, ray), g_all = listing(general, ray);
            std::vector<TraceHit> fd, gd;  // hits of decided instances; the general path's primitive 0 only
            int inner_hits = 0;
            for (const TraceHit& h : f.hits) {
                CHECK(h.primitive_index == 0);
                if (decided[h.instance_index]) fd.push_back(h);
            }
            for (const TraceHit& h : g_all.hits) {
                if (h.primitive_index != 0) ++inner_hits;
                else if (decided[h.instance_index]) gd.push_back(h);
            }
            CAPTURE(k, base.x, ray.origin.x, ray.origin.y, ray.origin.z, ray.direction.x, ray.direction.y,
                    ray.direction.z, tmin, tmax);
            REQUIRE(fd.size() == gd.size());
            for (std::size_t j = 0; j < fd.size(); ++j) {
                const TraceHit &a = fd[j], &b = gd[j];
                CAPTURE(j, a.instance_index, b.instance_index, a.t, b.t);
                REQUIRE(a.instance_index == b.instance_index);
                CHECK(a.kind == b.kind);
                CHECK(a.instance_id == b.instance_id);
                CHECK(a.geometry == GeometryKind::spheres);
                const long double dt = std::fabs((long double)a.t - b.t);
                CHECK(dt <= tol[a.instance_index]);
                // object_point: o' + t·d' in object space; apart by the t difference times |d'| = |d|/s,
                // plus the float rounding of the point.
                const double tol_p = double(dt * dlen) / world[a.instance_index].scale * 1.01 +
                                     0x1p-21 * double(std::max({std::fabs(a.object_point.x), std::fabs(a.object_point.y),
                                                                std::fabs(a.object_point.z), 1e-30f}));
                for (int c = 0; c < 3; ++c) CHECK(std::fabs(double(a.object_point[c]) - b.object_point[c]) <= tol_p);
                ++compared_hits;
            }
            // The same traversal, the same instances entered, one primitive per instance against two.
            CHECK(f.counters.tlas_nodes == g_all.counters.tlas_nodes);
            CHECK(f.counters.boxes_tested == g_all.counters.boxes_tested);
            CHECK(f.counters.instances_entered == g_all.counters.instances_entered);
            CHECK(f.counters.blas_nodes == g_all.counters.blas_nodes);
            CHECK(f.counters.blas_nodes == f.counters.instances_entered);
            CHECK(2 * f.counters.primitives_tested == g_all.counters.primitives_tested);
            CHECK(f.counters.any_hit_invocations == f.hits.size());
            CHECK(g_all.counters.any_hit_invocations == g_all.hits.size());
            CHECK(f.counters.hits_accepted == 0);
            ++compared_rays;

            // Opaque: the closest hit, and the first commit in traversal order, are the same hit.
            const bool all_decided = std::all_of(decided.begin(), decided.end(), [](bool b) { return b; });
            if (!all_decided || inner_hits > 0) continue;
            for (const std::uint32_t flags : {std::uint32_t(ray_flag_force_opaque),
                                              std::uint32_t(ray_flag_force_opaque | ray_flag_accept_first_hit_and_end_search)}) {
                const TraceResult rf = trace(fast, ray, flags, 0xFF), rg = trace(general, ray, flags, 0xFF);
                REQUIRE(rf.hit == rg.hit);
                CHECK(rf.counters.hits_accepted == rg.counters.hits_accepted);
                if (!rf.hit) continue;
                CHECK(rf.committed.instance_index == rg.committed.instance_index);
                CHECK(rf.committed.kind == rg.committed.kind);
                CHECK(std::fabs((long double)rf.committed.t - rg.committed.t) <= tol[rf.committed.instance_index]);
                ++committed_compared;
            }
        }
    }
    CHECK(compared_rays >= 2 * 1150);
    CHECK(compared_hits >= 1800);
    CHECK(committed_compared >= 1000);
    CHECK(near_tangent >= 100);
}

TEST_CASE("spheres: a single sphere under a non-similarity transform (an ellipsoid) takes the general path", "[sphere][trace]") {
    // Which transforms the fast path takes: similarities only (tolerance 1e-12 relative).
    const Sphere sp{{0.3f, -0.2f, 0.1f}, 0.8f};
    Pcg32 rng(62);
    const glm::dmat3 rot = random_rotation(rng, false), mirrored = random_rotation(rng, true);
    auto takes_fast_path = [&](const glm::dmat3& linear, std::vector<Sphere> spheres = {}) {
        AccelScene s;
        const auto b = s.add_bottom_level(BottomLevel::from_spheres(spheres.empty() ? std::vector<Sphere>{sp} : spheres, true));
        s.add_instance(Instance{b, AffineTransform{linear, glm::dvec3(1, 2, 3)}, 0xFF, 0, 0});
        s.commit();
        return s.record(0).path == InstancePath::world_sphere;
    };
    CHECK(takes_fast_path(glm::dmat3(1.0)));
    CHECK(takes_fast_path(2.5 * rot));
    CHECK(takes_fast_path(0.01 * mirrored));
    CHECK_FALSE(takes_fast_path(rot * glm::dmat3(glm::dvec3(1, 0, 0), glm::dvec3(0, 1 + 1e-9, 0), glm::dvec3(0, 0, 1))));
    CHECK_FALSE(takes_fast_path(glm::dmat3(glm::dvec3(1, 0, 0), glm::dvec3(1e-6, 1, 0), glm::dvec3(0, 0, 1))));  // shear
    CHECK_FALSE(takes_fast_path(2.0 * rot, {sp, Sphere{{5, 5, 5}, 1.0f}}));                                      // two spheres
    {
        AccelScene s;  // a mesh never does (this one takes the world-triangles path)
        TriangleMesh m;
        m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
        m.triangles = {{0, 1, 2}};
        s.add_instance(Instance{s.add_bottom_level(BottomLevel::from_mesh(m, true)), {}, 0xFF, 0, 0});
        s.commit();
        CHECK(s.record(0).path == InstancePath::world_triangles);
    }

    // Ellipsoids against the analytic answer in object space (long double): the ray taken into object
    // space exactly, then the sphere. The general path errs there by double rounding amplified by the
    // condition number (≤ 3 here), so δ = 2⁻⁴⁰·(|o' − c| + |t_c|·|d'| + r) and tol as above.
    const glm::dmat3 scales[] = {
        glm::dmat3(glm::dvec3(2.0, 0, 0), glm::dvec3(0, 0.7, 0), glm::dvec3(0, 0, 1.3)),
        glm::dmat3(glm::dvec3(1.0, 0, 0), glm::dvec3(0, 1.0 + 1e-9, 0), glm::dvec3(0, 0, 1.0)),  // just not uniform
        glm::dmat3(glm::dvec3(1.0, 0, 0), glm::dvec3(0.5, 1.0, 0), glm::dvec3(0, 0.3, 1.0)),     // shear
    };
    int checked = 0;
    for (const glm::dmat3& scale : scales) {
        for (const bool mirror : {false, true}) {
            AffineTransform m;
            m.linear = random_rotation(rng, mirror) * scale;
            m.translation = glm::dvec3(rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-10, 10));
            AccelScene s;
            s.add_instance(Instance{s.add_bottom_level(BottomLevel::from_spheres({sp}, false)), m, 0xFF, 7, 0});
            s.commit();
            REQUIRE(s.record(0).path == InstancePath::object_space);
            // The exact inverse in long double (adjugate over determinant).
            const glm::dmat3& L = m.linear;
            long double inv[3][3];  // inv[row][col]
            const long double a00 = L[0][0], a01 = L[1][0], a02 = L[2][0], a10 = L[0][1], a11 = L[1][1], a12 = L[2][1],
                              a20 = L[0][2], a21 = L[1][2], a22 = L[2][2];
            const long double det = a00 * (a11 * a22 - a12 * a21) - a01 * (a10 * a22 - a12 * a20) + a02 * (a10 * a21 - a11 * a20);
            inv[0][0] = (a11 * a22 - a12 * a21) / det, inv[0][1] = (a02 * a21 - a01 * a22) / det, inv[0][2] = (a01 * a12 - a02 * a11) / det;
            inv[1][0] = (a12 * a20 - a10 * a22) / det, inv[1][1] = (a00 * a22 - a02 * a20) / det, inv[1][2] = (a02 * a10 - a00 * a12) / det;
            inv[2][0] = (a10 * a21 - a11 * a20) / det, inv[2][1] = (a01 * a20 - a00 * a21) / det, inv[2][2] = (a00 * a11 - a01 * a10) / det;
            auto to_object = [&](Ld3 v) {
                return Ld3{inv[0][0] * v.x + inv[0][1] * v.y + inv[0][2] * v.z, inv[1][0] * v.x + inv[1][1] * v.y + inv[1][2] * v.z,
                           inv[2][0] * v.x + inv[2][1] * v.y + inv[2][2] * v.z};
            };
            const Ld3 c{sp.center.x, sp.center.y, sp.center.z};
            const glm::dvec3 world_centre = m.point(glm::dvec3(sp.center));
            for (int k = 0; k < 200; ++k) {
                const glm::dvec3 d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
                if (glm::length(d) < 1e-3) continue;
                // Half from anywhere near, half from inside (object-space points within 0.9 r).
                const glm::dvec3 o = k % 2 == 0
                                         ? world_centre + glm::dvec3(rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(-4, 4))
                                         : m.point(glm::dvec3(sp.center) + 0.9 * double(sp.radius) / std::sqrt(3.0) *
                                                                             glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)));
                const Ray ray = make_ray(glm::vec3(o), glm::vec3(d));
                const Ld3 oo = to_object(Ld3{ray.origin.x, ray.origin.y, ray.origin.z} - ld(m.translation));
                const Ld3 od = to_object(Ld3{ray.direction.x, ray.direction.y, ray.direction.z});
                const LdRoots r = ld_roots(oo, od, c, sp.radius);
                const long double delta = 0x1p-40L * (len(oo - c) + std::fabs(r.t_closest) * len(od) + sp.radius);
                if (std::fabs(r.perp - sp.radius) <= delta) continue;
                const auto hits = all_hits(s, ray);
                CAPTURE(k, ray.origin.x, ray.origin.y, ray.origin.z, ray.direction.x, ray.direction.y, ray.direction.z);
                if (!r.crosses) {
                    CHECK(hits.empty());
                    ++checked;
                    continue;
                }
                auto tol_at = [&](long double t) { return 0x1p-22L * std::fabs(t) + 4.0L * (sp.radius / r.h) * delta / len(od); };
                if (std::fabs(r.t_enter) <= tol_at(r.t_enter) || std::fabs(r.t_exit) <= tol_at(r.t_exit)) continue;
                std::vector<std::pair<long double, HitKind>> want;
                if (r.t_enter > 0) want.push_back({r.t_enter, HitKind::front_face});
                if (r.t_exit > 0) want.push_back({r.t_exit, HitKind::back_face});
                REQUIRE(hits.size() == want.size());
                for (std::size_t j = 0; j < want.size(); ++j) {
                    CHECK(hits[j].kind == want[j].second);
                    CHECK(hits[j].instance_id == 7);
                    CHECK(std::fabs((long double)hits[j].t - want[j].first) <= tol_at(want[j].first));
                    // The object-space point lies on the object sphere.
                    const Ld3 p{hits[j].object_point.x, hits[j].object_point.y, hits[j].object_point.z};
                    CHECK(std::fabs(len(p - c) - sp.radius) <= 1e-5L);
                }
                ++checked;
            }
        }
    }
    CHECK(checked >= 3 * 2 * 180);
}
