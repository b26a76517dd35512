// trace(): every ray flag and rule listed in trace.hpp, each with a scene built so that the test fails
// if that rule were broken (each was checked by breaking the rule in a scratch copy of trace.hpp).
//
// Geometry used throughout: quads, two triangles wound counter-clockwise seen from +z (so a ray coming
// down the −z axis meets their FRONT face, ray_triangle.hpp), stacked along z; rays go down x = 0.3,
// y = 0.2, which avoids the quad's diagonal. All coordinates and distances are small integers or
// halves, exact in float, so hit distances are exact and compared with ==. The last sections (the
// world-triangles path against the object-space path, and the two TLAS walks against each other) use
// random affine maps instead, with the tolerances derived where they are used.
#include <smoketrace/core/prng.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/trace/trace.hpp>

#include <catch2/catch.hpp>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

using namespace smoketrace;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// A square of half-size h in the plane z, counter-clockwise seen from +z.
TriangleMesh quad(float z, float h = 1.0f) {
    TriangleMesh m;
    m.vertices = {{-h, -h, z}, {h, -h, z}, {h, h, z}, {-h, h, z}};
    m.triangles = {{0, 1, 2}, {0, 2, 3}};
    return m;
}

Ray make_ray(glm::vec3 o, glm::vec3 d, float tmin = 0.0f, float tmax = kInf) { return Ray{o, tmin, d, tmax}; }

// The ray that goes down through the stacks from z = 10: meets a quad at z after t = 10 − z.
Ray down_ray(float tmin = 0.0f, float tmax = kInf) { return make_ray({0.3f, 0.2f, 10.0f}, {0, 0, -1}, tmin, tmax); }
Ray up_ray(float tmin = 0.0f, float tmax = kInf) { return make_ray({0.3f, 0.2f, -10.0f}, {0, 0, 1}, tmin, tmax); }

AffineTransform translation(glm::dvec3 t) { return AffineTransform::translate_scale(t, 1.0); }

Instance instance_of(std::uint32_t blas, AffineTransform m = {}, std::uint8_t mask = 0xFF, std::uint32_t user_id = 0,
                     std::uint8_t flags = instance_flag_none) {
    return Instance{blas, m, mask, user_id, flags};
}

// One quad BLAS at z = 0, instanced once per z in `zs` (instance i at zs[i], user id 100 + i).
AccelScene stacked_quads(const std::vector<float>& zs, bool opaque, std::uint8_t flags = instance_flag_none,
                    InstancePaths paths = InstancePaths::fastest) {
    AccelScene s(paths);
    const auto b = s.add_bottom_level(BottomLevel::from_mesh(quad(0.0f), opaque));
    for (std::size_t i = 0; i < zs.size(); ++i)
        s.add_instance(instance_of(b, translation({0, 0, zs[i]}), 0xFF, 100 + std::uint32_t(i), flags));
    s.commit();
    return s;
}

std::vector<float> layers(int n) {  // z = 1, 2, …, n
    std::vector<float> z;
    for (int i = 1; i <= n; ++i) z.push_back(float(i));
    return z;
}

// Every candidate the ray meets, via an any-hit that records and ignores (the optical-depth pattern).
struct AllHits {
    std::vector<TraceHit> hits;
    TraceResult result;
};
AllHits all_hits(const AccelScene& s, const Ray& r, std::uint32_t flags = ray_flag_none, std::uint8_t mask = 0xFF,
                 const TraceLimits& limits = {}, TlasWalk walk = TlasWalk::nearest_first) {
    AllHits a;
    auto record = [&](const TraceHit& h) {
        a.hits.push_back(h);
        return AnyHitDecision::ignore;
    };
    a.result = walk == TlasWalk::all_hits ? trace<TlasWalk::all_hits>(s, r, flags, mask, record, limits)
                                          : trace(s, r, flags, mask, record, limits);
    std::sort(a.hits.begin(), a.hits.end(), [](const TraceHit& x, const TraceHit& y) { return x.t < y.t; });
    return a;
}

std::vector<float> ts_of(const std::vector<TraceHit>& hits) {
    std::vector<float> t;
    for (const auto& h : hits) t.push_back(h.t);
    return t;
}

// Instance A: a large quad at z = 1 plus a small triangle up at z = 9.5 far off the ray, so A's world box
// reaches up to z = 9.5 and the TLAS walk enters A before B, a small quad at z = 5: A's box is met first
// (t = 0.5 against 4.5) and lies higher along z (centre 5.25 against 5), the two orders a traversal may
// follow (wide_bvh_traversal.hpp). For the down ray, A's hit (t = 9) is therefore the first candidate,
// B's (t = 5) the nearer one. (Checked in the tests that rely on it: with plain accept, two commits happen.)
AccelScene far_first_scene(bool opaque) {
    TriangleMesh a = quad(1.0f, 4.0f);
    a.vertices.insert(a.vertices.end(), {{3.5f, 3.5f, 9.5f}, {3.9f, 3.5f, 9.5f}, {3.5f, 3.9f, 9.5f}});
    a.triangles.push_back({4, 5, 6});
    AccelScene s;
    s.add_instance(instance_of(s.add_bottom_level(BottomLevel::from_mesh(a, opaque))));
    s.add_instance(instance_of(s.add_bottom_level(BottomLevel::from_mesh(quad(5.0f, 0.5f), opaque))));
    s.commit();
    return s;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------
// Rules 2, 3, 5, 6: opacity and the any-hit call.

TEST_CASE("trace: opaque hits commit without any-hit, non-opaque hits call it once", "[trace]") {
    for (const bool opaque : {true, false}) {
        const AccelScene s = stacked_quads({4.0f}, opaque);
        int calls = 0;
        const TraceResult r = trace(s, down_ray(), ray_flag_none, 0xFF, [&](const TraceHit&) {
            ++calls;
            return AnyHitDecision::accept;
        });
        CHECK(r.hit);
        CHECK(r.committed.t == 6.0f);
        CHECK(calls == (opaque ? 0 : 1));
        CHECK(r.counters.any_hit_invocations == std::uint32_t(calls));
        CHECK(r.counters.hits_accepted == 1);
    }
}

TEST_CASE("trace: opacity = geometry, overridden by instance force flags, overridden by ray force flags", "[trace]") {
    // The full table of DXR's precedence. If any override were ignored or applied in the wrong order, the
    // row where it decides would call any-hit when it must not (or not when it must), and the CULL_OPAQUE
    // / CULL_NON_OPAQUE rows (rule 3, applied to the FINAL opacity) would keep or drop the wrong hit.
    const std::uint8_t instance_forces[] = {instance_flag_none, instance_flag_force_opaque,
                                            instance_flag_force_non_opaque};
    const std::uint32_t ray_forces[] = {ray_flag_none, ray_flag_force_opaque, ray_flag_force_non_opaque};
    int rows = 0;
    for (const bool geometry_opaque : {true, false})
        for (const std::uint8_t inst : instance_forces)
            for (const std::uint32_t rf : ray_forces) {
                bool expected = geometry_opaque;
                if (inst == instance_flag_force_opaque) expected = true;
                if (inst == instance_flag_force_non_opaque) expected = false;
                if (rf == ray_flag_force_opaque) expected = true;
                if (rf == ray_flag_force_non_opaque) expected = false;
                CAPTURE(geometry_opaque, int(inst), rf, expected);
                const AccelScene s = stacked_quads({4.0f}, geometry_opaque, inst);

                const AllHits plain = all_hits(s, down_ray(), rf);
                CHECK(plain.result.counters.any_hit_invocations == (expected ? 0u : 1u));
                CHECK(plain.result.hit == expected);  // an opaque hit commits; an ignored non-opaque one does not

                const AllHits cull_o = all_hits(s, down_ray(), rf | ray_flag_cull_opaque);
                CHECK(cull_o.result.hit == false);
                CHECK(cull_o.result.counters.any_hit_invocations == (expected ? 0u : 1u));

                const TraceResult cull_n = trace(s, down_ray(), rf | ray_flag_cull_non_opaque, 0xFF);
                CHECK(cull_n.hit == expected);
                CHECK(cull_n.counters.any_hit_invocations == 0u);
                ++rows;
            }
    CHECK(rows == 18);
}

TEST_CASE("trace: CULL_OPAQUE and CULL_NON_OPAQUE act per instance in a mixed scene", "[trace]") {
    // Opaque quad at z = 4 (t = 6) in front of a non-opaque one at z = 2 (t = 8).
    AccelScene s;
    const auto o = s.add_bottom_level(BottomLevel::from_mesh(quad(0.0f), true));
    const auto n = s.add_bottom_level(BottomLevel::from_mesh(quad(0.0f), false));
    s.add_instance(instance_of(o, translation({0, 0, 4})));
    s.add_instance(instance_of(n, translation({0, 0, 2})));
    s.commit();
    // Without culling the opaque quad hides the other: a closest-hit sees t = 6 only.
    const TraceResult none = trace(s, down_ray(), ray_flag_none, 0xFF);
    CHECK(none.committed.t == 6.0f);
    CHECK(none.counters.any_hit_invocations == 0);
    // CULL_OPAQUE: the opaque quad is invisible, the non-opaque one behind it is found.
    const TraceResult co = trace(s, down_ray(), ray_flag_cull_opaque, 0xFF);
    REQUIRE(co.hit);
    CHECK(co.committed.t == 8.0f);
    CHECK(co.committed.instance_index == 1);
    CHECK(co.counters.any_hit_invocations == 1);
    // CULL_NON_OPAQUE from below: the non-opaque quad (met first, t = 12) is skipped, the opaque one is hit.
    const AllHits cn = all_hits(s, up_ray(), ray_flag_cull_non_opaque);
    CHECK(cn.hits.empty());
    REQUIRE(cn.result.hit);
    CHECK(cn.result.committed.t == 14.0f);
    CHECK(cn.result.committed.instance_index == 0);
}

// ---------------------------------------------------------------------------------------------------
// Rule 4: facing culls, TRIANGLE_CULL_DISABLE, TRIANGLE_FRONT_CLOCKWISE, spheres exempt.

TEST_CASE("trace: CULL_BACK / CULL_FRONT skip triangle hits of that facing", "[trace]") {
    // A quad takes the world-triangles path unless the scene is told object space only: rule 4 on both.
    const InstancePaths paths = GENERATE(InstancePaths::fastest, InstancePaths::object_space_only);
    const AccelScene s = stacked_quads({0.0f}, true, instance_flag_none, paths);
    REQUIRE((s.record(0).path == InstancePath::world_triangles) == (paths == InstancePaths::fastest));
    // From above the quad shows its front face, from below its back face.
    const TraceResult down = trace(s, down_ray(), ray_flag_none, 0xFF);
    const TraceResult up = trace(s, up_ray(), ray_flag_none, 0xFF);
    REQUIRE(down.hit);
    REQUIRE(up.hit);
    CHECK(down.committed.kind == HitKind::front_face);
    CHECK(up.committed.kind == HitKind::back_face);

    CHECK(trace(s, down_ray(), ray_flag_cull_back_facing_triangles, 0xFF).hit);
    CHECK_FALSE(trace(s, up_ray(), ray_flag_cull_back_facing_triangles, 0xFF).hit);
    CHECK_FALSE(trace(s, down_ray(), ray_flag_cull_front_facing_triangles, 0xFF).hit);
    CHECK(trace(s, up_ray(), ray_flag_cull_front_facing_triangles, 0xFF).hit);

    // A culled hit is never a candidate either: no any-hit call for it.
    const AccelScene t = stacked_quads({0.0f}, false, instance_flag_none, paths);
    CHECK(all_hits(t, up_ray(), ray_flag_cull_back_facing_triangles).result.counters.any_hit_invocations == 0);
    CHECK(all_hits(t, down_ray(), ray_flag_cull_back_facing_triangles).result.counters.any_hit_invocations == 1);
}

TEST_CASE("trace: a culled nearer face does not hide the farther one", "[trace]") {
    // Two quads: the top one (z = 2) flipped so it faces down, the bottom one (z = 0) faces up.
    // Down ray meets the back of z = 2 at t = 8, then the front of z = 0 at t = 10.
    // A quad takes the world-triangles path unless the scene is told object space only: rule 4 on both.
    const InstancePaths paths = GENERATE(InstancePaths::fastest, InstancePaths::object_space_only);
    AccelScene s(paths);
    TriangleMesh flipped = quad(0.0f);
    for (auto& tri : flipped.triangles) std::swap(tri.y, tri.z);
    const auto up_facing = s.add_bottom_level(BottomLevel::from_mesh(quad(0.0f), true));
    const auto down_facing = s.add_bottom_level(BottomLevel::from_mesh(flipped, true));
    s.add_instance(instance_of(down_facing, translation({0, 0, 2})));
    s.add_instance(instance_of(up_facing, translation({0, 0, 0})));
    s.commit();
    const TraceResult plain = trace(s, down_ray(), ray_flag_none, 0xFF);
    CHECK(plain.committed.t == 8.0f);
    CHECK(plain.committed.kind == HitKind::back_face);
    const TraceResult culled = trace(s, down_ray(), ray_flag_cull_back_facing_triangles, 0xFF);
    REQUIRE(culled.hit);
    CHECK(culled.committed.t == 10.0f);
    CHECK(culled.committed.kind == HitKind::front_face);
    CHECK(culled.committed.instance_index == 1);
}

TEST_CASE("trace: TRIANGLE_CULL_DISABLE exempts only the flagged instance from facing culls", "[trace]") {
    // Two quads seen from below (back faces): z = 0 flagged, z = 2 not.
    // A quad takes the world-triangles path unless the scene is told object space only: rule 4 on both.
    const InstancePaths paths = GENERATE(InstancePaths::fastest, InstancePaths::object_space_only);
    AccelScene s(paths);
    const auto b = s.add_bottom_level(BottomLevel::from_mesh(quad(0.0f), false));
    s.add_instance(instance_of(b, translation({0, 0, 0}), 0xFF, 0, instance_flag_triangle_cull_disable));
    s.add_instance(instance_of(b, translation({0, 0, 2}), 0xFF, 1, instance_flag_none));
    s.commit();
    const AllHits culled = all_hits(s, up_ray(), ray_flag_cull_back_facing_triangles);
    REQUIRE(culled.hits.size() == 1);
    CHECK(culled.hits[0].instance_index == 0);
    CHECK(culled.hits[0].kind == HitKind::back_face);
    const AllHits culled_front = all_hits(s, down_ray(), ray_flag_cull_front_facing_triangles);
    REQUIRE(culled_front.hits.size() == 1);
    CHECK(culled_front.hits[0].instance_index == 0);
    CHECK(all_hits(s, up_ray()).hits.size() == 2);
}

TEST_CASE("trace: TRIANGLE_FRONT_CLOCKWISE reverses which face is the front", "[trace]") {
    // A quad takes the world-triangles path unless the scene is told object space only: rule 4 on both.
    const InstancePaths paths = GENERATE(InstancePaths::fastest, InstancePaths::object_space_only);
    const AccelScene s = stacked_quads({0.0f}, true, instance_flag_triangle_front_clockwise, paths);
    const TraceResult down = trace(s, down_ray(), ray_flag_none, 0xFF);
    const TraceResult up = trace(s, up_ray(), ray_flag_none, 0xFF);
    REQUIRE(down.hit);
    REQUIRE(up.hit);
    CHECK(down.committed.kind == HitKind::back_face);
    CHECK(up.committed.kind == HitKind::front_face);
    // And the culls follow the reversed facing.
    CHECK_FALSE(trace(s, down_ray(), ray_flag_cull_back_facing_triangles, 0xFF).hit);
    CHECK(trace(s, up_ray(), ray_flag_cull_back_facing_triangles, 0xFF).hit);
    CHECK(trace(s, down_ray(), ray_flag_cull_front_facing_triangles, 0xFF).hit);
    CHECK_FALSE(trace(s, up_ray(), ray_flag_cull_front_facing_triangles, 0xFF).hit);
}

TEST_CASE("trace: facing culls and the winding flag never apply to spheres", "[trace]") {
    // A unit sphere at the origin, non-opaque; the down ray enters at t = 10 − √(1 − 0.13) and leaves
    // at t = 10 + √0.87.
    for (const std::uint8_t inst_flags :
         {std::uint8_t(instance_flag_none), std::uint8_t(instance_flag_triangle_front_clockwise)}) {
        AccelScene s;
        const auto b = s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1.0f}}, false));
        s.add_instance(instance_of(b, {}, 0xFF, 0, inst_flags));
        s.commit();
        const std::uint32_t all_culls = ray_flag_cull_back_facing_triangles | ray_flag_cull_front_facing_triangles;
        for (const std::uint32_t f : {std::uint32_t(ray_flag_none), all_culls}) {
            CAPTURE(int(inst_flags), f);
            const AllHits a = all_hits(s, down_ray(), f);
            REQUIRE(a.hits.size() == 2);
            CHECK(a.hits[0].kind == HitKind::front_face);
            CHECK(a.hits[1].kind == HitKind::back_face);
            CHECK(a.hits[0].geometry == GeometryKind::spheres);
        }
    }
}

TEST_CASE("trace: mirroring (negative determinant) transforms keep face sides", "[trace]") {
    // Closed convex meshes (icosphere:1, and a tetrahedron, which takes the world-triangles path;
    // counter-clockwise seen from outside) and a sphere, placed by transforms with and without mirroring
    // and with non-uniform scale. Every ray through the centre enters (front face) and then leaves (back
    // face). Deciding facing from the WORLD winding would flip both under a mirror; so would forgetting
    // that the object-space ray runs the other way round.
    const TriangleMesh mesh = make_icosphere(1, 1.0f);
    TriangleMesh tetra;
    tetra.vertices = {{0.57f, 0.57f, 0.57f}, {0.57f, -0.57f, -0.57f}, {-0.57f, 0.57f, -0.57f}, {-0.57f, -0.57f, 0.57f}};
    tetra.triangles = {{0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}};
    for (glm::uvec3& t : tetra.triangles) {  // wind each face counter-clockwise seen from outside
        const glm::vec3 a = tetra.vertices[t.x], b = tetra.vertices[t.y], c = tetra.vertices[t.z];
        if (glm::dot(glm::cross(b - a, c - a), a + b + c) < 0.0f) std::swap(t.y, t.z);
    }
    const glm::dmat3 mirrors[] = {glm::dmat3(1.0), glm::dmat3(glm::dvec3(-1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1)),
                                  glm::dmat3(glm::dvec3(1, 0, 0), glm::dvec3(0, 0, 1), glm::dvec3(0, 1, 0)),  // swap y, z
                                  -glm::dmat3(1.0)};
    int checked = 0;
    for (const auto& mirror : mirrors) {
        AffineTransform m;
        // Non-uniform scale times a rotation about z by 0.5 rad, times the mirror.
        const double c = std::cos(0.5), sn = std::sin(0.5);
        const glm::dmat3 rot(glm::dvec3(c, sn, 0), glm::dvec3(-sn, c, 0), glm::dvec3(0, 0, 1));
        const glm::dmat3 scale(glm::dvec3(2.0, 0, 0), glm::dvec3(0, 0.7, 0), glm::dvec3(0, 0, 1.3));
        m.linear = rot * scale * mirror;
        m.translation = {3.0, -1.0, 2.0};
        const double det = m.determinant();
        CAPTURE(det);

        AccelScene s;
        const auto tri = s.add_bottom_level(BottomLevel::from_mesh(mesh, false));
        const auto sph = s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1.0f}}, false));
        const auto tet = s.add_bottom_level(BottomLevel::from_mesh(tetra, false));
        s.add_instance(instance_of(tri, m));
        AffineTransform far = m, other = m;
        far.translation += glm::dvec3(20.0, 0.0, 0.0);
        other.translation -= glm::dvec3(20.0, 0.0, 0.0);
        s.add_instance(instance_of(sph, far));
        s.add_instance(instance_of(tet, other));
        s.commit();
        REQUIRE(s.record(2).path == InstancePath::world_triangles);

        for (int inst = 0; inst < 3; ++inst) {
            const glm::dvec3 centre = inst == 0 ? m.translation : inst == 1 ? far.translation : other.translation;
            for (int k = 0; k < 16; ++k) {
                // Directions spread over the sphere (a golden-angle spiral), rays from 10 units out.
                const double z = 1.0 - (k + 0.5) / 8.0, r = std::sqrt(1.0 - z * z), phi = 2.39996 * k;
                const glm::dvec3 dir(r * std::cos(phi), r * std::sin(phi), z);
                const Ray ray = make_ray(glm::vec3(centre - 10.0 * dir), glm::vec3(dir), 0.0f, 20.0f);  // stops short of the other instance
                const AllHits a = all_hits(s, ray);
                CAPTURE(inst, k);
                REQUIRE(a.hits.size() == 2);
                CHECK(a.hits[0].kind == HitKind::front_face);
                CHECK(a.hits[1].kind == HitKind::back_face);
                // Cull back faces: only the entry remains for the mesh; spheres are exempt.
                const AllHits culled = all_hits(s, ray, ray_flag_cull_back_facing_triangles);
                CHECK(culled.hits.size() == (inst == 1 ? 2u : 1u));
                if (!culled.hits.empty()) CHECK(culled.hits[0].kind == HitKind::front_face);
                ++checked;
            }
        }
        // The world-space geometry check that makes "front = outside" independent of trace(): the
        // entry triangle's world winding normal, times sign(det), points against the ray.
        const Ray ray = make_ray(glm::vec3(m.translation + glm::dvec3(0.1, 0.2, 10.0)), {0, 0, -1});
        const AllHits a = all_hits(s, ray);
        REQUIRE(a.hits.size() == 2);
        const glm::uvec3 t = mesh.triangles[a.hits[0].primitive_index];
        const glm::dvec3 w0 = m.point(glm::dvec3(mesh.vertices[t.x])), w1 = m.point(glm::dvec3(mesh.vertices[t.y])),
                         w2 = m.point(glm::dvec3(mesh.vertices[t.z]));
        const glm::dvec3 outward = glm::cross(w1 - w0, w2 - w0) * (det < 0.0 ? -1.0 : 1.0);
        CHECK(glm::dot(outward, glm::dvec3(ray.direction)) < 0.0);
        CHECK(a.hits[0].kind == HitKind::front_face);
    }
    CHECK(checked == 4 * 3 * 16);
}

// ---------------------------------------------------------------------------------------------------
// Rule 1: instance masks, and the node masks that prune whole subtrees.

TEST_CASE("trace: an instance is visible iff InstanceMask & InclusionMask != 0", "[trace]") {
    // Eight non-opaque quads on the ray, instance i has mask bit i only; every inclusion mask 0…255.
    AccelScene s;
    const auto b = s.add_bottom_level(BottomLevel::from_mesh(quad(0.0f), false));
    for (std::uint32_t i = 0; i < 8; ++i)
        s.add_instance(instance_of(b, translation({0, 0, double(i)}), std::uint8_t(1u << i), i));
    s.commit();
    for (unsigned incl = 0; incl < 256; ++incl) {
        const AllHits a = all_hits(s, down_ray(), ray_flag_none, std::uint8_t(incl));
        std::set<std::uint32_t> seen;
        for (const auto& h : a.hits) seen.insert(h.instance_index);
        std::set<std::uint32_t> expected;
        for (std::uint32_t i = 0; i < 8; ++i)
            if (incl & (1u << i)) expected.insert(i);
        CAPTURE(incl);
        CHECK(seen == expected);
        CHECK(a.hits.size() == expected.size());
        CHECK(a.result.counters.instances_entered == expected.size());
    }
}

TEST_CASE("trace: a ray whose mask excludes every instance visits no TLAS node and enters no instance", "[trace]") {
    AccelScene s;
    const auto b = s.add_bottom_level(BottomLevel::from_mesh(quad(0.0f), true));
    for (std::uint32_t i = 0; i < 64; ++i)
        s.add_instance(instance_of(b, translation({double(i % 4), double(i / 4 % 4), double(i / 16)}),
                                   std::uint8_t(1u << (i % 4))));  // masks use bits 0…3 only
    s.commit();
    for (const std::uint8_t incl : {std::uint8_t(0x00), std::uint8_t(0x10), std::uint8_t(0xF0)}) {
        const TraceResult r = trace(s, down_ray(), ray_flag_none, incl);
        CHECK_FALSE(r.hit);
        CHECK(r.counters.tlas_nodes == 0);
        CHECK(r.counters.instances_entered == 0);
        CHECK(r.counters.boxes_tested == 0);
    }
    // The same ray with a matching mask does work, so the zeros above are the mask's doing.
    const TraceResult r = trace(s, down_ray(), ray_flag_none, 0x01);
    CHECK(r.hit);
    CHECK(r.counters.tlas_nodes > 0);
}

namespace {
// Brute-force count of the TLAS nodes a traversal must visit when nothing shrinks tmax. Binary tree
// (TlasWalk::nearest_first): a node is visited iff its mask and every ancestor's mask intersect the
// inclusion mask and the ray meets its box and every ancestor's box. 4-wide tree (TlasWalk::all_hits):
// the root if any instance can match, and every child (wide node or leaf) whose mask and ancestors'
// masks intersect the inclusion mask and whose box and ancestors' boxes the ray meets. Both also count
// the leaves' instances that pass the per-instance mask test.
struct ExpectedVisits {
    std::uint32_t nodes = 0;
    std::uint32_t instances = 0;
};
void count_binary(const AccelScene& s, const BoxRay& r, float tmax, std::uint8_t incl, std::uint32_t node,
                  ExpectedVisits& out) {
    if ((s.tlas_node_masks()[node] & incl) == 0) return;
    const BvhNode& n = s.tlas().nodes[node];
    float t;
    if (!intersect(n.bounds, r, tmax, t)) return;
    ++out.nodes;
    if (n.is_leaf()) {
        for (std::uint32_t k = n.first; k < n.first + n.count; ++k)
            if (s.instance(s.tlas().prim_indices[k]).mask & incl) ++out.instances;
        return;
    }
    count_binary(s, r, tmax, incl, n.first, out);
    count_binary(s, r, tmax, incl, n.first + 1, out);
}
void count_wide(const AccelScene& s, const BoxRay& r, float tmax, std::uint8_t incl, std::uint32_t node,
                ExpectedVisits& out) {
    const WideBvhNode& n = s.wide_tlas().nodes()[node];
    ++out.nodes;
    for (unsigned i = 0; i < kWideBvhWidth; ++i) {
        if ((n.mask[i] & incl) == 0) continue;
        Aabb box;
        box.lo = {n.bounds[0][i], n.bounds[1][i], n.bounds[2][i]};
        box.hi = {n.bounds[3][i], n.bounds[4][i], n.bounds[5][i]};
        float t;
        if (!intersect(box, r, tmax, t)) continue;
        if (n.count[i] == 0) {
            count_wide(s, r, tmax, incl, n.child[i], out);
            continue;
        }
        ++out.nodes;
        for (std::uint32_t k = n.child[i]; k < n.child[i] + n.count[i]; ++k)
            if (s.instance(s.tlas().prim_indices[k]).mask & incl) ++out.instances;
    }
}
ExpectedVisits count_visits(const AccelScene& s, const BoxRay& r, float tmax, std::uint8_t incl, TlasWalk walk) {
    ExpectedVisits out;
    if (walk == TlasWalk::nearest_first) count_binary(s, r, tmax, incl, 0, out);
    else if (!s.wide_tlas().empty() && (s.wide_tlas().root_mask() & incl) != 0) count_wide(s, r, tmax, incl, 0, out);
    return out;
}
}  // namespace

TEST_CASE("trace: node masks prune subtrees whose instances the inclusion mask excludes", "[trace]") {
    // Two interleaved populations along x: mask 0x01 instances at even x, 0x02 at odd x; a few blocks
    // of each so that whole TLAS subtrees hold one population only. The ray runs along x through all.
    AccelScene s;
    const auto b = s.add_bottom_level(BottomLevel::from_mesh(quad(0.0f, 0.4f), false));
    for (int block = 0; block < 8; ++block)
        for (int i = 0; i < 16; ++i) {
            const std::uint8_t mask = (block % 2 == 0) ? 0x01 : 0x02;
            AffineTransform m;  // quad turned to face x: rotate z → x
            m.linear = glm::dmat3(glm::dvec3(0, 0, -1), glm::dvec3(0, 1, 0), glm::dvec3(1, 0, 0));
            m.translation = {block * 16.0 + i, 0.0, 0.0};
            s.add_instance(instance_of(b, m, mask));
        }
    s.commit();
    const Ray ray = make_ray({-1.0f, 0.1f, 0.05f}, {1, 0, 0});
    const BoxRay box_ray(ray);
    for (const TlasWalk walk : {TlasWalk::nearest_first, TlasWalk::all_hits})
        for (const std::uint8_t incl : {std::uint8_t(0x01), std::uint8_t(0x02), std::uint8_t(0x03), std::uint8_t(0x04)}) {
            const ExpectedVisits expected = count_visits(s, box_ray, ray.tmax, incl, walk);
            const AllHits a = all_hits(s, ray, ray_flag_none, incl, {}, walk);
            CAPTURE(int(incl), int(walk));
            CHECK(a.result.counters.tlas_nodes == expected.nodes);
            CHECK(a.result.counters.instances_entered == expected.instances);
            CHECK(a.hits.size() == (incl == 0x03 ? 128u : incl == 0x04 ? 0u : 64u));
        }
    // The scene must actually exercise pruning: with one population the nodes visited are well below
    // the count for both (a per-instance mask test alone would visit every node of the full count).
    const ExpectedVisits one = count_visits(s, box_ray, ray.tmax, 0x01, TlasWalk::nearest_first);
    const ExpectedVisits both = count_visits(s, box_ray, ray.tmax, 0x03, TlasWalk::nearest_first);
    CHECK(one.nodes * 3 < both.nodes * 2);
}

// ---------------------------------------------------------------------------------------------------
// Rule 6: the any-hit decisions; candidates only in [tmin, committed tmax].

TEST_CASE("trace: any-hit ignore commits nothing and keeps tmax", "[trace]") {
    const AccelScene s = stacked_quads(layers(6), false);
    const AllHits a = all_hits(s, down_ray());
    CHECK_FALSE(a.result.hit);
    CHECK(a.result.counters.hits_accepted == 0);
    // All six surfaces were candidates, so no ignored hit narrowed the search.
    CHECK(ts_of(a.hits) == std::vector<float>{4, 5, 6, 7, 8, 9});
    CHECK(a.result.counters.any_hit_invocations == 6);

    // Accepting only the farthest surface commits exactly it: an ignore before it never lowered tmax.
    const TraceResult far = trace(s, down_ray(), ray_flag_none, 0xFF, [](const TraceHit& h) {
        return h.t == 9.0f ? AnyHitDecision::accept : AnyHitDecision::ignore;
    });
    REQUIRE(far.hit);
    CHECK(far.committed.t == 9.0f);
    CHECK(far.committed.instance_index == 0);
    CHECK(far.committed.instance_id == 100);
}

TEST_CASE("trace: any-hit accept commits the closest accepted candidate", "[trace]") {
    const AccelScene s = stacked_quads(layers(6), false);
    for (const Ray& ray : {down_ray(), up_ray()}) {
        const TraceResult r = trace(s, ray, ray_flag_none, 0xFF);  // AcceptAll
        REQUIRE(r.hit);
        CHECK(r.committed.t == (ray.direction.z < 0 ? 4.0f : 11.0f));
        // Accept all but the nearest: the second nearest is committed.
        const float nearest = ray.direction.z < 0 ? 4.0f : 11.0f, second = ray.direction.z < 0 ? 5.0f : 12.0f;
        const TraceResult r2 = trace(s, ray, ray_flag_none, 0xFF, [&](const TraceHit& h) {
            return h.t == nearest ? AnyHitDecision::ignore : AnyHitDecision::accept;
        });
        REQUIRE(r2.hit);
        CHECK(r2.committed.t == second);
    }
}

TEST_CASE("trace: any-hit accept_and_end commits that candidate and ends the search", "[trace]") {
    // The far-first scene: the first candidate offered is the FARTHER surface (t = 9), so only ending the
    // search stops the nearer one (t = 5) from being offered after it.
    const AccelScene s = far_first_scene(false);
    int calls = 0;
    float first_t = 0.0f;
    const TraceResult r = trace(s, down_ray(), ray_flag_none, 0xFF, [&](const TraceHit& h) {
        if (calls++ == 0) first_t = h.t;
        return AnyHitDecision::accept_and_end;
    });
    CHECK(calls == 1);
    CHECK(first_t == 9.0f);
    CHECK(r.counters.any_hit_invocations == 1);
    REQUIRE(r.hit);
    CHECK(r.committed.t == 9.0f);
    CHECK(r.counters.hits_accepted == 1);
    CHECK_FALSE(r.cut_off);
    // Plain accept on the same scene goes on to the nearer surface.
    int accept_calls = 0;
    const TraceResult all = trace(s, down_ray(), ray_flag_none, 0xFF, [&](const TraceHit&) {
        ++accept_calls;
        return AnyHitDecision::accept;
    });
    CHECK(accept_calls == 2);
    CHECK(all.committed.t == 5.0f);

    // Ignore the first two candidates, then accept_and_end: exactly three calls, the third committed.
    const AccelScene layered = stacked_quads(layers(6), false);
    int n = 0;
    float third_t = 0.0f;
    const TraceResult r3 = trace(layered, down_ray(), ray_flag_none, 0xFF, [&](const TraceHit& h) {
        if (++n < 3) return AnyHitDecision::ignore;
        third_t = h.t;
        return AnyHitDecision::accept_and_end;
    });
    CHECK(n == 3);
    REQUIRE(r3.hit);
    CHECK(r3.committed.t == third_t);
}

TEST_CASE("trace: any-hit sees candidates only in [tmin, current committed tmax]", "[trace]") {
    // 32 parallel quads in ONE BLAS in shuffled order, so leaf order is not t order; rays both ways, so
    // whatever the order inside a leaf, one of the two directions meets a nearer hit before a farther
    // one and a missing tmax check would hand a candidate beyond the committed t to any-hit.
    TriangleMesh m;
    std::vector<int> order(32);
    for (int i = 0; i < 32; ++i) order[i] = (i * 13) % 32;  // a permutation (13 is coprime with 32)
    for (int i : order) {
        const TriangleMesh q = quad(float(i) * 0.25f);
        const auto base = std::uint32_t(m.vertices.size());
        m.vertices.insert(m.vertices.end(), q.vertices.begin(), q.vertices.end());
        for (auto t : q.triangles) m.triangles.push_back(t + glm::uvec3(base));
    }
    AccelScene s;
    s.add_instance(instance_of(s.add_bottom_level(BottomLevel::from_mesh(m, false))));
    s.commit();
    for (const Ray& ray : {down_ray(0.5f, 100.0f), up_ray(0.5f, 100.0f)}) {
        float committed = ray.tmax;
        std::vector<float> seen;
        bool in_range = true;
        const TraceResult r = trace(s, ray, ray_flag_none, 0xFF, [&](const TraceHit& h) {
            in_range = in_range && h.t >= ray.tmin && h.t <= committed;
            seen.push_back(h.t);
            committed = h.t;
            return AnyHitDecision::accept;
        });
        CHECK(in_range);
        REQUIRE(r.hit);
        CHECK(r.committed.t == (ray.direction.z < 0 ? 10.0f - 7.75f : 10.0f));
        // Exactly the decreasing record of accepted t's was offered: each call lowered tmax.
        CHECK(std::is_sorted(seen.rbegin(), seen.rend()));
    }
    // A sphere reports two candidates; once its entry is accepted the exit lies beyond the committed
    // tmax and must not be offered.
    AccelScene sph;
    sph.add_instance(instance_of(sph.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 2.0f}}, false))));
    sph.commit();
    std::vector<float> offered;
    const TraceResult rs = trace(sph, down_ray(), ray_flag_none, 0xFF, [&](const TraceHit& h) {
        offered.push_back(h.t);
        return AnyHitDecision::accept;
    });
    REQUIRE(rs.hit);
    CHECK(offered.size() == 1);
    CHECK(rs.committed.kind == HitKind::front_face);
    // tmin cuts off the near quads: with tmin = 4 the down ray (t = 10 − z) sees z ≤ 6 only, and z = 6 is
    // at exactly t = 4 (inclusive).
    const AllHits a = all_hits(s, down_ray(4.0f, 100.0f));
    REQUIRE_FALSE(a.hits.empty());
    CHECK(a.hits.front().t == 4.0f);
    CHECK(a.hits.size() == 25);  // z = 0, 0.25, …, 6
}

TEST_CASE("trace: [tmin, tmax] is closed at both ends, exactly", "[trace]") {
    for (const bool opaque : {true, false}) {
        const AccelScene s = stacked_quads({4.0f}, opaque);  // the down ray meets it at t = 6 exactly
        CHECK(all_hits(s, down_ray(0.0f, 6.0f)).hits.size() == (opaque ? 0u : 1u));
        CHECK(trace(s, down_ray(0.0f, 6.0f), ray_flag_none, 0xFF).hit);
        CHECK_FALSE(trace(s, down_ray(0.0f, std::nextafter(6.0f, 0.0f)), ray_flag_none, 0xFF).hit);
        CHECK(trace(s, down_ray(6.0f, kInf), ray_flag_none, 0xFF).hit);
        CHECK_FALSE(trace(s, down_ray(std::nextafter(6.0f, kInf), kInf), ray_flag_none, 0xFF).hit);
    }
    // Spheres too: a sphere of radius 2 at z = 0 is entered by the down ray along the axis at t = 8.
    AccelScene s;
    s.add_instance(instance_of(s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 2.0f}}, true))));
    s.commit();
    const Ray axis = make_ray({0, 0, 10}, {0, 0, -1}, 0.0f, 8.0f);
    const TraceResult r = trace(s, axis, ray_flag_none, 0xFF);
    REQUIRE(r.hit);
    CHECK(r.committed.t == 8.0f);
    CHECK_FALSE(trace(s, make_ray({0, 0, 10}, {0, 0, -1}, 0.0f, std::nextafter(8.0f, 0.0f)), ray_flag_none, 0xFF).hit);
    // tmin just past the entry: only the exit (t = 12) remains.
    const TraceResult exit_only = trace(s, make_ray({0, 0, 10}, {0, 0, -1}, std::nextafter(8.0f, kInf), kInf),
                                        ray_flag_none, 0xFF);
    REQUIRE(exit_only.hit);
    CHECK(exit_only.committed.t == 12.0f);
    CHECK(exit_only.committed.kind == HitKind::back_face);
}

// ---------------------------------------------------------------------------------------------------
// Rules 7 and 8.

TEST_CASE("trace: ACCEPT_FIRST_HIT_AND_END_SEARCH ends at the first commit, nearest or not", "[trace]") {
    // The far-first scene (see far_first_scene): the first commit is the farther surface.
    for (const bool opaque : {true, false}) {
        const AccelScene s = far_first_scene(opaque);
        CAPTURE(opaque);
        const TraceResult all = trace(s, down_ray(), ray_flag_none, 0xFF);
        REQUIRE(all.hit);
        CHECK(all.committed.t == 5.0f);
        CHECK(all.counters.hits_accepted == 2);  // the walk order assumed above: far hit committed first

        const TraceResult first = trace(s, down_ray(), ray_flag_accept_first_hit_and_end_search, 0xFF);
        REQUIRE(first.hit);
        CHECK(first.counters.hits_accepted == 1);
        CHECK(first.counters.any_hit_invocations == (opaque ? 0u : 1u));
        CHECK(first.committed.t == 9.0f);
        CHECK(first.counters.instances_entered == 1);
    }
    // An ignored candidate is not a commit: the search goes on to the next one.
    const AccelScene s = stacked_quads(layers(4), false);
    int calls = 0;
    const TraceResult r = trace(s, down_ray(), ray_flag_accept_first_hit_and_end_search, 0xFF, [&](const TraceHit&) {
        return ++calls == 1 ? AnyHitDecision::ignore : AnyHitDecision::accept;
    });
    CHECK(calls == 2);
    CHECK(r.counters.hits_accepted == 1);
}

TEST_CASE("trace: SKIP_CLOSEST_HIT_SHADER reports whether, not what", "[trace]") {
    const AccelScene s = stacked_quads(layers(3), true);
    const TraceResult full = trace(s, down_ray(), ray_flag_none, 0xFF);
    REQUIRE(full.hit);
    CHECK(full.committed.t == 7.0f);
    CHECK(full.committed.instance_index == 2);

    const TraceResult skip = trace(s, down_ray(), ray_flag_skip_closest_hit_shader, 0xFF);
    CHECK(skip.hit);
    const TraceHit blank{};
    CHECK(skip.committed.t == blank.t);
    CHECK(skip.committed.instance_index == blank.instance_index);
    CHECK(skip.committed.primitive_index == blank.primitive_index);
    // A miss is still a miss.
    CHECK_FALSE(trace(s, make_ray({5, 5, 10}, {0, 0, -1}), ray_flag_skip_closest_hit_shader, 0xFF).hit);
    // Shadow-ray usage: skip + accept-first still answers "occluded".
    CHECK(trace(s, down_ray(), ray_flag_skip_closest_hit_shader | ray_flag_accept_first_hit_and_end_search, 0xFF).hit);
}

// ---------------------------------------------------------------------------------------------------
// Beyond DXR: the any-hit cutoff (thesis 4.4.3: a particle whose hit count is LARGER than the cutoff is
// fully dark; exactly `cutoff` hits still fit, and hit_resolver.hpp's DepthStatus::cutoff is "more hits
// than the cutoff allows").

TEST_CASE("trace: any-hit cutoff with K-1 and K+1 surfaces", "[trace]") {
    constexpr std::uint32_t K = 5;
    const TraceLimits limits{K};
    // K − 1 surfaces: every one seen, no cutoff.
    {
        const AllHits a = all_hits(stacked_quads(layers(K - 1), false), down_ray(), ray_flag_none, 0xFF, limits);
        CHECK(a.hits.size() == K - 1);
        CHECK(a.result.counters.any_hit_invocations == K - 1);
        CHECK_FALSE(a.result.cut_off);
    }
    // K + 1 surfaces: any-hit runs exactly K times, then the search ends and says so.
    {
        const AllHits a = all_hits(stacked_quads(layers(K + 1), false), down_ray(), ray_flag_none, 0xFF, limits);
        CHECK(a.hits.size() == K);
        CHECK(a.result.counters.any_hit_invocations == K);
        CHECK(a.result.cut_off);
    }
    // Opaque hits call no any-hit and so never count toward the cutoff.
    {
        const AccelScene s = stacked_quads(layers(K + 3), true);
        const TraceResult r = trace(s, down_ray(), ray_flag_none, 0xFF, AcceptAll{}, limits);
        CHECK_FALSE(r.cut_off);
        CHECK(r.committed.t == 10.0f - float(K + 3));
    }
    // No limit (0): every surface (the up ray starts below all 40 layers).
    const AllHits unlimited = all_hits(stacked_quads(layers(40), false), up_ray());
    CHECK(unlimited.hits.size() == 40);
    CHECK_FALSE(unlimited.result.cut_off);
}

TEST_CASE("trace: exactly K surfaces under an any-hit cutoff of K are not cut off", "[trace]") {
    // All K surfaces fit: any-hit ran K times and no candidate was left over, so nothing was cut and
    // cut_off must stay false; else a particle with exactly `cutoff` hits would be rendered fully dark,
    // where the thesis darkens only hit counts LARGER than the cutoff. (The search may still end right
    // after the K-th call only if it can tell that no further candidate exists; it has to look.)
    constexpr std::uint32_t K = 5;
    for (const std::uint32_t k : {1u, K, 12u}) {
        CAPTURE(k);
        const AllHits a = all_hits(stacked_quads(layers(int(k)), false), up_ray(), ray_flag_none, 0xFF, TraceLimits{k});
        CHECK(a.hits.size() == k);
        CHECK(a.result.counters.any_hit_invocations == k);
        CHECK_FALSE(a.result.cut_off);
    }
}

// ---------------------------------------------------------------------------------------------------
// Rule 9: no duplicate any-hit, shared edges and vertices reported once.

TEST_CASE("trace: one any-hit per primitive crossing, shared vertices and edges reported once", "[trace]") {
    const TriangleMesh ico = make_icosphere(2, 1.0f);
    AccelScene s;
    s.add_instance(instance_of(s.add_bottom_level(BottomLevel::from_mesh(ico, false))));
    s.add_instance(instance_of(s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1.0f}}, false)),
                               translation({5, 0, 0})));
    s.commit();
    auto check_two_crossings = [&](const Ray& ray, std::uint32_t instance) {
        const AllHits a = all_hits(s, ray);
        REQUIRE(a.hits.size() == 2);
        CHECK(a.hits[0].instance_index == instance);
        CHECK(a.hits[0].kind == HitKind::front_face);
        CHECK(a.hits[1].kind == HitKind::back_face);
        if (instance == 0) CHECK(a.hits[0].primitive_index != a.hits[1].primitive_index);
        else CHECK(a.hits[0].primitive_index == a.hits[1].primitive_index);  // a sphere's entry and exit
    };
    // Through every vertex and its antipode (each shared by 5 or 6 triangles): ray from 2v towards −v
    // passes exactly through v at t = 1 (2v − v is exact in float).
    for (std::size_t i = 0; i < ico.vertices.size(); ++i) {
        const glm::vec3 v = ico.vertices[i];
        CAPTURE(i);
        check_two_crossings(make_ray(2.0f * v, -v, 0.0f, 3.5f), 0);  // tmax: stop before the sphere
    }
    // Through every edge midpoint towards the centre.
    std::set<std::pair<unsigned, unsigned>> edges;
    for (const auto& t : ico.triangles)
        for (int e = 0; e < 3; ++e) {
            const unsigned a = t[e], b = t[(e + 1) % 3];
            edges.insert({std::min(a, b), std::max(a, b)});
        }
    for (const auto& [a, b] : edges) {
        const glm::vec3 mid = 0.5f * (ico.vertices[a] + ico.vertices[b]);
        check_two_crossings(make_ray(3.0f * mid, -mid, 0.0f, 5.0f), 0);
    }
    // The sphere: exactly one entry and one exit call, whatever the ray.
    for (int k = 0; k < 8; ++k) check_two_crossings(make_ray({5.0f + 0.1f * k, -3.0f, 0.05f * k}, {0, 1, 0}), 1);
}

// ---------------------------------------------------------------------------------------------------
// The world-triangles path (InstancePath::world_triangles): a mesh of up to kMaxWorldTriangles triangles
// in one leaf is kept transformed and tested in world space. It must stay watertight and agree with
// the object-space path.

namespace {

// A random affine map: non-uniform scale (0.2 … 5 per axis, a third of them mirrored) times a rotation,
// translated by base + up to ±30.
AffineTransform random_affine(Pcg32& rng, const glm::dvec3& base, int i) {
    auto unit = [&] {
        glm::dvec3 v;
        do v = glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)); while (glm::length(v) < 0.1);
        return glm::normalize(v);
    };
    const glm::dvec3 x = unit();
    glm::dvec3 y;
    do y = unit(); while (glm::length(glm::cross(x, y)) < 0.1);
    y = glm::normalize(y - glm::dot(y, x) * x);
    const glm::dmat3 rot(x, y, glm::cross(x, y));
    const glm::dvec3 sc(0.2 + 4.8 * rng.uniform01(), 0.2 + 4.8 * rng.uniform01(), (i % 3 == 0 ? -1.0 : 1.0) * (0.2 + 4.8 * rng.uniform01()));
    AffineTransform m;
    m.linear = rot * glm::dmat3(glm::dvec3(sc.x, 0, 0), glm::dvec3(0, sc.y, 0), glm::dvec3(0, 0, sc.z));
    m.translation = base + glm::dvec3(rng.uniform(-30, 30), rng.uniform(-30, 30), rng.uniform(-30, 30));
    return m;
}

}  // namespace

TEST_CASE("trace: world-space quads are watertight along their shared diagonal", "[trace]") {
    // Rays aimed at points of the world-space diagonal v0–v2 (in float: on it or within an ulp of it),
    // from random origins on either side: exactly one of the two triangles reports each, never both,
    // never neither. Near the origin and 1e4 away. (Not at v0 or v2 themselves: a corner of an open
    // quad is on its boundary, where the tie-break may rightly give the hit to neither.)
    Pcg32 rng(7);
    int rays = 0;
    for (const glm::dvec3 base : {glm::dvec3(0.0), glm::dvec3(1e4, -2e4, 5e3)}) {
        AccelScene s;
        const auto b = s.add_bottom_level(BottomLevel::from_mesh(quad(0.0f), false));
        for (int i = 0; i < 20; ++i) s.add_instance(instance_of(b, random_affine(rng, base, i), 0xFF, std::uint32_t(i)));
        s.commit();
        for (std::uint32_t i = 0; i < 20; ++i) {
            REQUIRE(s.record(i).path == InstancePath::world_triangles);
            const AffineTransform& m = s.instance(i).object_to_world;
            const glm::vec3 w0 = glm::vec3(m.point({-1, -1, 0})), w2 = glm::vec3(m.point({1, 1, 0}));
            const glm::dvec3 normal = glm::normalize(glm::transpose(glm::inverse(m.linear)) * glm::dvec3(0, 0, 1));
            for (int k = 0; k < 40; ++k) {
                const float lambda = rng.uniform(0.01f, 0.99f);
                const glm::vec3 target = w0 + lambda * (w2 - w0);
                glm::dvec3 side(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
                const glm::dvec3 from = glm::dvec3(target) + 3.0 * normal + side;
                const Ray ray = make_ray(glm::vec3(from), target - glm::vec3(from), 0.0f, 2.0f);
                std::uint32_t mine = 0;
                for (const TraceHit& h : all_hits(s, ray).hits) mine += h.instance_index == i;
                CAPTURE(i, k, lambda);
                CHECK(mine == 1u);
                ++rays;
            }
        }
    }
    CHECK(rays == 2 * 20 * 40);
}

TEST_CASE("trace: the world-triangles path agrees with the object-space path", "[trace]") {
    // The same 30 quads (random affine maps, mirrored ones too) in a scene with the world-space paths and
    // in one without: same TLAS, so the same hits in the same order, with the same primitive, facing
    // and counters; t and barycentrics to the tolerance below. Rays from random points toward points
    // of the quads, and random rays; rule 4 culls and TRIANGLE_FRONT_CLOCKWISE on some instances.
    //
    // Tolerance. Both paths are float geometry within a few float ulps of the exact world quad: the
    // world path rounds the transformed vertices (≤ 2⁻²⁴·M each, M the largest coordinate magnitude
    // among ray origin, vertices and translation), the object path the transformed ray. Either moves
    // the hit point along the ray by at most ~4·2⁻²⁴·M / cos θ (θ between ray and normal), so t by that
    // over |d|, plus the final rounding of t (2⁻²⁴·t) in each. Barycentrics move by the in-plane shift
    // over the triangle's smallest height. Hits within that shift of an edge may go to either triangle,
    // and rays within ~1° of the plane may miss in one path: both are left out (not compared).
    Pcg32 rng(11);
    int compared = 0;
    for (const glm::dvec3 base : {glm::dvec3(0.0), glm::dvec3(-3e3, 2e3, 1e3)}) {
        AccelScene fast, general(InstancePaths::object_space_only);
        const auto bf = fast.add_bottom_level(BottomLevel::from_mesh(quad(0.0f), false));
        const auto bg = general.add_bottom_level(BottomLevel::from_mesh(quad(0.0f), false));
        std::vector<AffineTransform> ms;
        for (int i = 0; i < 30; ++i) {
            ms.push_back(random_affine(rng, base, i));
            const std::uint8_t flags = i % 4 == 1 ? instance_flag_triangle_front_clockwise
                                     : i % 4 == 2 ? instance_flag_triangle_cull_disable : instance_flag_none;
            fast.add_instance(instance_of(bf, ms.back(), 0xFF, std::uint32_t(i), flags));
            general.add_instance(instance_of(bg, ms.back(), 0xFF, std::uint32_t(i), flags));
        }
        fast.commit();
        general.commit();
        for (int k = 0; k < 1500; ++k) {
            const std::uint32_t i = rng.below(30);
            const AffineTransform& m = ms[i];
            const glm::dvec3 target = m.point({rng.uniform(-1.2f, 1.2f), rng.uniform(-1.2f, 1.2f), 0.0});
            const glm::dvec3 from = base + glm::dvec3(rng.uniform(-40, 40), rng.uniform(-40, 40), rng.uniform(-40, 40));
            const Ray ray = make_ray(glm::vec3(from), glm::vec3(target - from));
            const std::uint32_t flags = k % 3 == 0 ? ray_flag_none : k % 3 == 1 ? ray_flag_cull_back_facing_triangles
                                                                               : ray_flag_cull_front_facing_triangles;
            std::vector<TraceHit> hf, hg;
            const TraceResult rf = trace(fast, ray, flags, 0xFF, [&](const TraceHit& h) { hf.push_back(h); return AnyHitDecision::ignore; });
            const TraceResult rg = trace(general, ray, flags, 0xFF, [&](const TraceHit& h) { hg.push_back(h); return AnyHitDecision::ignore; });
            // The error scale of a hit on instance h (see the tolerance above): the shift of the hit point
            // along the ray, cos θ, and the smallest singular value of the instance's linear map (≥ |det|
            // over the largest product of two column lengths), which turns object distances into world ones.
            struct Scale {
                double shift, cos_theta, smin;
            };
            auto scale_of = [&](const TraceHit& h) {
                const AffineTransform& mi = ms[h.instance_index];
                const glm::dvec3 d = glm::normalize(glm::dvec3(ray.direction));
                const glm::dvec3 n = glm::normalize(glm::transpose(glm::inverse(mi.linear)) * glm::dvec3(0, 0, 1));
                const double cos_theta = std::abs(glm::dot(n, d));
                const double M = std::max({double(glm::length(ray.origin)), glm::length(mi.translation) + 15.0, 1.0});
                const double c0 = glm::length(mi.linear[0]), c1 = glm::length(mi.linear[1]), c2 = glm::length(mi.linear[2]);
                return Scale{4.0 * std::ldexp(M, -24) / std::max(cos_theta, 1e-30), cos_theta,
                             std::abs(glm::determinant(mi.linear)) / std::max({c0 * c1, c0 * c2, c1 * c2})};
            };
            // Left out: a ray within ~1° of a quad's plane, or a hit within 8 shifts of an edge.
            auto doubtful = [&](const TraceHit& h) {
                const Scale sc = scale_of(h);
                const glm::dvec3 p = ms[h.instance_index].inverse().point(glm::dvec3(ray.origin) + double(h.t) * glm::dvec3(ray.direction));
                const double edge = std::min({std::abs(1.0 - std::abs(p.x)), std::abs(1.0 - std::abs(p.y)), std::abs(p.x - p.y) / std::sqrt(2.0)});
                return sc.cos_theta < 0.02 || edge * sc.smin < 8.0 * sc.shift;
            };
            if (std::any_of(hf.begin(), hf.end(), doubtful) || std::any_of(hg.begin(), hg.end(), doubtful)) continue;
            CAPTURE(k, i, flags);
            REQUIRE(hf.size() == hg.size());
            CHECK(rf.counters.tlas_nodes == rg.counters.tlas_nodes);
            CHECK(rf.counters.instances_entered == rg.counters.instances_entered);
            CHECK(rf.counters.primitives_tested == rg.counters.primitives_tested);
            CHECK(rf.counters.any_hit_invocations == rg.counters.any_hit_invocations);
            for (std::size_t j = 0; j < hf.size(); ++j) {
                const TraceHit &a = hf[j], &g = hg[j];
                CHECK(a.instance_index == g.instance_index);
                CHECK(a.primitive_index == g.primitive_index);
                CHECK(a.kind == g.kind);
                CHECK(a.geometry == GeometryKind::triangles);
                const Scale sc = scale_of(g);
                const double tol_t = 2.0 * sc.shift / double(glm::length(ray.direction)) + std::ldexp(double(g.t), -23);
                CHECK(std::abs(double(a.t) - double(g.t)) <= tol_t);
                const double tol_b = 4.0 * sc.shift / sc.smin;  // in-plane shift over the smallest height
                CHECK(std::abs(double(a.barycentrics.x) - double(g.barycentrics.x)) <= tol_b);
                CHECK(std::abs(double(a.barycentrics.y) - double(g.barycentrics.y)) <= tol_b);
                ++compared;
            }
        }
    }
    CHECK(compared > 1000);
}

TEST_CASE("trace: both TLAS walks go near to far along the ray", "[trace]") {
    // 64 opaque quads stacked along z, rays straight down and straight up. The binary walk takes the
    // nearer child first at every node, so the first leaf it reaches holds the nearest quad, whose commit
    // prunes every other subtree: one instance entered. The 4-wide walk takes each node's children in the
    // ray's order along the node's axis (wide_bvh_traversal.hpp): at most the leaves of the nearest node.
    // A walk in slot order, or against the ray's order, would enter most of the 64 for one direction.
    const AccelScene s = stacked_quads(layers(64), true);
    for (const TlasWalk walk : {TlasWalk::nearest_first, TlasWalk::all_hits})
        for (const Ray& r : {make_ray({0.3f, 0.2f, 100.0f}, {0, 0, -1}), up_ray()}) {
            const TraceResult res = walk == TlasWalk::all_hits ? trace<TlasWalk::all_hits>(s, r, ray_flag_none, 0xFF)
                                                               : trace(s, r, ray_flag_none, 0xFF);
            REQUIRE(res.hit);
            CHECK(res.committed.t == (r.direction.z < 0 ? 36.0f : 11.0f));  // the quads at z = 64 and z = 1
            CAPTURE(int(walk), r.direction.z, res.counters.instances_entered);
            CHECK(res.counters.instances_entered <= (walk == TlasWalk::nearest_first ? 1u : 4u));
        }
}

TEST_CASE("trace: the two TLAS walks find the same hits", "[trace]") {
    // A random scene of quads, icospheres and spheres with mixed masks and opacities; random rays. Either
    // walk must report the same candidates (as a set: their order may differ), commit the same closest
    // hit, and agree on the cutoff, which depends on the number of candidates only.
    Pcg32 rng(23);
    AccelScene s;
    const std::uint32_t blases[] = {s.add_bottom_level(BottomLevel::from_mesh(quad(0.0f), false)),
                                    s.add_bottom_level(BottomLevel::from_mesh(make_icosphere(1, 1.0f), false)),
                                    s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1.0f}}, false)),
                                    s.add_bottom_level(BottomLevel::from_mesh(quad(0.0f), true))};
    for (int i = 0; i < 300; ++i)
        s.add_instance(instance_of(blases[i % 4], random_affine(rng, glm::dvec3(0.0), i), std::uint8_t(1u << (i % 3)),
                                   std::uint32_t(i)));
    s.commit();
    int compared = 0;
    for (int k = 0; k < 3000; ++k) {
        const glm::vec3 o(rng.uniform(-40, 40), rng.uniform(-40, 40), rng.uniform(-40, 40));
        const glm::vec3 to(rng.uniform(-20, 20), rng.uniform(-20, 20), rng.uniform(-20, 20));
        const Ray ray = make_ray(o, to - o);
        const std::uint8_t incl = std::uint8_t(1u + rng.below(7));
        auto key = [](const TraceHit& h) { return std::tuple(h.instance_index, h.primitive_index, h.kind, h.t); };
        std::vector<std::tuple<std::uint32_t, std::uint32_t, HitKind, float>> hits[2];
        TraceResult closest[2], cut[2];
        for (int w = 0; w < 2; ++w) {
            const TlasWalk walk = w == 0 ? TlasWalk::nearest_first : TlasWalk::all_hits;
            for (const TraceHit& h : all_hits(s, ray, ray_flag_force_non_opaque, incl, {}, walk).hits)
                hits[w].push_back(key(h));
            std::sort(hits[w].begin(), hits[w].end());
            auto ignore = [](const TraceHit&) { return AnyHitDecision::ignore; };
            if (walk == TlasWalk::all_hits) {
                closest[w] = trace<TlasWalk::all_hits>(s, ray, ray_flag_none, incl);
                cut[w] = trace<TlasWalk::all_hits>(s, ray, ray_flag_force_non_opaque, incl, ignore, TraceLimits{3});
            } else {
                closest[w] = trace(s, ray, ray_flag_none, incl);
                cut[w] = trace(s, ray, ray_flag_force_non_opaque, incl, ignore, TraceLimits{3});
            }
        }
        CAPTURE(k, int(incl));
        CHECK(hits[0] == hits[1]);
        CHECK(closest[0].hit == closest[1].hit);
        if (closest[0].hit && closest[1].hit) {
            CHECK(closest[0].committed.t == closest[1].committed.t);
            CHECK(closest[0].committed.instance_index == closest[1].committed.instance_index);
        }
        CHECK(cut[0].cut_off == cut[1].cut_off);
        CHECK(cut[0].cut_off == (hits[0].size() > 3));
        compared += int(hits[0].size());
    }
    CHECK(compared > 3000);

    // Directed: three leaves of one 4-wide node, ordered along x by their boxes' centres (0, 1, 7) for a
    // ray going +x. The first (a quad at x = 0) commits t = 100; the second's box starts beyond that; the
    // third, last in that order, is a long box whose quad at x = −40 is the nearest hit (t = 60). A walk
    // that stopped at the first leaf beyond tmax would return the quad at x = 0.
    AccelScene d;
    auto facing_x = [](float x, float h) {  // a quad in the plane x, counter-clockwise seen from −x
        TriangleMesh m;
        m.vertices = {{x, -h, -h}, {x, -h, h}, {x, h, h}, {x, h, -h}};
        m.triangles = {{0, 1, 2}, {0, 2, 3}};
        return m;
    };
    TriangleMesh long_one = facing_x(-40.0f, 1.0f);
    long_one.vertices.insert(long_one.vertices.end(), {{54.0f, 0.2f, 0.2f}, {54.0f, 0.3f, 0.2f}, {54.0f, 0.2f, 0.3f}});
    long_one.triangles.push_back({4, 5, 6});
    d.add_instance(instance_of(d.add_bottom_level(BottomLevel::from_mesh(facing_x(0.0f, 1.0f), true)), {}, 0xFF, 0));
    d.add_instance(instance_of(d.add_bottom_level(BottomLevel::from_mesh(facing_x(1.0f, 1.0f), true)), {}, 0xFF, 1));
    d.add_instance(instance_of(d.add_bottom_level(BottomLevel::from_mesh(long_one, true)), {}, 0xFF, 2));
    d.commit();
    REQUIRE(d.wide_tlas().node_count() == 1);
    for (const TlasWalk walk : {TlasWalk::nearest_first, TlasWalk::all_hits}) {
        const Ray ray = make_ray({-100.0f, 0.1f, -0.1f}, {1, 0, 0});
        const TraceResult r = walk == TlasWalk::all_hits ? trace<TlasWalk::all_hits>(d, ray, ray_flag_none, 0xFF)
                                                         : trace(d, ray, ray_flag_none, 0xFF);
        CAPTURE(int(walk));
        REQUIRE(r.hit);
        CHECK(r.committed.t == 60.0f);
        CHECK(r.committed.instance_id == 2);
    }
}
