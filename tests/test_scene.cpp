// The two-level AccelScene: what commit() does per frame (none / refit / rebuild, accel_scene.hpp), the TLAS it
// leaves behind (exact boxes, node masks = OR of the subtree), and that a refit tree, however degraded
// by motion, answers every query with exactly the hits a freshly built one gives.
#include <smoketrace/accel/bvh_builder.hpp>
#include <smoketrace/core/prng.hpp>
#include <smoketrace/accel/accel_scene.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/trace/trace.hpp>

#include <catch2/catch.hpp>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <span>
#include <stdexcept>
#include <tuple>
#include <utility>
#include <vector>

using namespace smoketrace;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// A random rotation (normalised random quaternion), per-axis scale in [0.5, 1.5], a mirror with
// probability 1/4, and a translation in [0, extent)³.
AffineTransform random_transform(Pcg32& rng, float extent) {
    glm::dquat q(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    q = glm::normalize(q);
    glm::dmat3 scale(1.0);
    for (int a = 0; a < 3; ++a) scale[a][a] = rng.uniform(0.5f, 1.5f);
    if (rng.uniform01() < 0.25f) scale[0][0] = -scale[0][0];
    AffineTransform m;
    m.linear = glm::mat3_cast(q) * scale;
    m.translation = {rng.uniform(0, extent), rng.uniform(0, extent), rng.uniform(0, extent)};
    return m;
}

std::uint8_t random_mask(Pcg32& rng) { return std::uint8_t(1u << (rng.next_u32() % 8)); }

// n instances of three bottom levels (icosphere:1 mesh, non-opaque; a two-sphere set; an opaque
// icosahedron) at random transforms in [0, extent)³, random one-bit masks.
void populate(AccelScene& s, Pcg32& rng, int n, float extent) {
    const auto mesh = s.add_bottom_level(BottomLevel::from_mesh(make_icosphere(1, 1.0f), false));
    const auto spheres =
        s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 0.8f}, Sphere{{0.5f, 0, 0}, 0.6f}}, false));
    const auto ico = s.add_bottom_level(BottomLevel::from_mesh(make_icosahedron(1.0f), true));
    const std::uint32_t blas[] = {mesh, spheres, ico};
    for (int i = 0; i < n; ++i)
        s.add_instance(Instance{blas[i % 3], random_transform(rng, extent), random_mask(rng), std::uint32_t(1000 + i),
                                instance_flag_none});
}

// Commits both and requires the same scene: every instance's transform, world box, record and detail, the
// world-space triangles, the TLAS's leaf order and SAH cost.
void require_same_scene(AccelScene& bulk, AccelScene& one_by_one) {
    REQUIRE(bulk.instance_count() == one_by_one.instance_count());
    one_by_one.commit();
    bulk.commit();
    for (std::uint32_t i = 0; i < bulk.instance_count(); ++i) {
        INFO("instance " << i);
        REQUIRE(bulk.transform(i) == one_by_one.transform(i));
        REQUIRE(bulk.instance_bounds(i).lo == one_by_one.instance_bounds(i).lo);
        REQUIRE(bulk.instance_bounds(i).hi == one_by_one.instance_bounds(i).hi);
        const InstanceRecord &a = bulk.record(i), &b = one_by_one.record(i);
        REQUIRE(a.path == b.path);
        REQUIRE(a.mask == b.mask);
        REQUIRE(a.opaque == b.opaque);
        REQUIRE(a.user_id == b.user_id);
        if (a.path == InstancePath::world_sphere) {
            REQUIRE(a.sphere.offset == b.sphere.offset);
            REQUIRE(a.sphere.radius == b.sphere.radius);
        } else {
            REQUIRE(a.other.first_world_triangle == b.other.first_world_triangle);
            REQUIRE(a.other.world_triangle_count == b.other.world_triangle_count);
            REQUIRE(a.other.world_facing_flipped == b.other.world_facing_flipped);
            if (a.path == InstancePath::world_triangles)
                REQUIRE(a.other.blas == &bulk.bottom_level(bulk.instance(i).blas));
        }
        REQUIRE(bulk.detail(i).blas == &bulk.bottom_level(bulk.instance(i).blas));
        REQUIRE(bulk.detail(i).world_to_object_linear == one_by_one.detail(i).world_to_object_linear);
        // What a walk reads through the record: the same detail.
        REQUIRE(bulk.detail(i, a).blas == bulk.detail(i).blas);
        REQUIRE(bulk.detail(i, a).world_to_object_linear == bulk.detail(i).world_to_object_linear);
    }
    std::size_t triangles = 0;
    for (std::uint32_t i = 0; i < bulk.instance_count(); ++i)
        if (bulk.record(i).path == InstancePath::world_triangles) triangles += bulk.record(i).other.world_triangle_count;
    CHECK(std::memcmp(bulk.world_triangles(), one_by_one.world_triangles(), triangles * sizeof(MeshBlas::Triangle)) ==
          0);
    CHECK(bulk.tlas().prim_indices == one_by_one.tlas().prim_indices);
    CHECK(bulk.tlas_sah_cost() == one_by_one.tlas_sah_cost());
}

// The three bottom levels of the bulk tests, one per instance path: a unit sphere (world sphere), a quad
// (world triangles), an opaque icosphere (object space).
void add_path_bottom_levels(AccelScene& s) {
    TriangleMesh quad;
    quad.vertices = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    quad.triangles = {{0, 1, 2}, {0, 2, 3}};
    s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1.0f}}, false));
    s.add_bottom_level(BottomLevel::from_mesh(quad, false));
    s.add_bottom_level(BottomLevel::from_mesh(make_icosphere(1, 1.0f), true));
}

// Moves every instance by a random step of up to `step` per axis (keeping its linear part).
void jitter(AccelScene& s, Pcg32& rng, float step) {
    for (std::uint32_t i = 0; i < s.instance_count(); ++i) {
        AffineTransform m = s.instance(i).object_to_world;
        m.translation += glm::dvec3(rng.uniform(-step, step), rng.uniform(-step, step), rng.uniform(-step, step));
        s.set_transform(i, m);
    }
}

Ray random_ray(Pcg32& rng, float extent) {
    const glm::vec3 o(rng.uniform(-2, extent + 2), rng.uniform(-2, extent + 2), -5.0f);
    const glm::vec3 target(rng.uniform(0, extent), rng.uniform(0, extent), rng.uniform(0, extent));
    return Ray{o, 0.0f, target - o, kInf};
}

// Every candidate, as a sortable tuple; the any-hit ignores all (optical-depth pattern). With opaque
// geometry in the scene the candidate set depends on the traversal order (an opaque hit met early
// shrinks tmax and hides the non-opaque hits behind it), so only the candidates nearer than the final
// committed hit are defined (rule 6: tmax never drops below it); `cut` keeps just those.
using HitKey = std::tuple<float, std::uint32_t, std::uint32_t, int>;
std::vector<HitKey> all_hits(const AccelScene& s, const Ray& r, std::uint8_t mask,
                             std::uint32_t flags = ray_flag_none) {
    std::vector<HitKey> keys;
    const TraceResult res = trace(s, r, flags, mask, [&](const TraceHit& h) {
        keys.emplace_back(h.t, h.instance_index, h.primitive_index, int(h.kind));
        return AnyHitDecision::ignore;
    });
    if (res.hit) std::erase_if(keys, [&](const HitKey& k) { return !(std::get<0>(k) < res.committed.t); });
    std::sort(keys.begin(), keys.end());
    return keys;
}

// The 4-wide tree trace() walks, against the same definition: below the root, every used slot's box is
// exactly the union of the instances' world boxes under it and its mask their OR, every unused slot is
// empty with mask 0, and every instance sits in exactly one leaf slot.
struct WideCheck {
    std::vector<int> seen;
    int bad_box = 0, bad_mask = 0, bad_unused = 0, nodes = 0;
};
void check_wide_node(const AccelScene& s, std::uint32_t node, WideCheck& c, Aabb& box, std::uint8_t& mask) {
    const WideBvhNode& n = s.wide_tlas().nodes()[node];
    ++c.nodes;
    for (unsigned i = 0; i < kWideBvhWidth; ++i) {
        Aabb slot;
        slot.lo = {n.bounds[0][i], n.bounds[1][i], n.bounds[2][i]};
        slot.hi = {n.bounds[3][i], n.bounds[4][i], n.bounds[5][i]};
        if (slot.empty()) {
            c.bad_unused += (n.mask[i] != 0 || n.count[i] != 0 || slot.lo.x != kInf || slot.hi.x != -kInf) ? 1 : 0;
            continue;
        }
        Aabb below;
        std::uint8_t m = 0;
        if (n.count[i] == 0) {
            check_wide_node(s, n.child[i], c, below, m);
        } else {
            for (std::uint32_t j = n.child[i]; j < n.child[i] + n.count[i]; ++j) {
                const std::uint32_t inst = s.tlas().prim_indices[j];
                ++c.seen[inst];
                below.grow(s.instance_bounds(inst));
                m |= s.instance(inst).mask;
            }
        }
        c.bad_box += (below.lo != slot.lo || below.hi != slot.hi) ? 1 : 0;
        c.bad_mask += m != n.mask[i] ? 1 : 0;
        box.grow(below);
        mask |= m;
    }
}
void check_wide_tlas(const AccelScene& s) {
    WideCheck c;
    c.seen.assign(s.instance_count(), 0);
    if (s.instance_count() == 0) {
        CHECK(s.wide_tlas().empty());
        return;
    }
    Aabb box;
    std::uint8_t mask = 0;
    check_wide_node(s, 0, c, box, mask);
    CHECK(mask == s.wide_tlas().root_mask());
    CHECK(c.nodes == int(s.wide_tlas().node_count()));  // every node reachable, none twice
    CHECK(c.bad_box == 0);
    CHECK(c.bad_mask == 0);
    CHECK(c.bad_unused == 0);
    CHECK(std::all_of(c.seen.begin(), c.seen.end(), [](int k) { return k == 1; }));
    // Collapsing halves the depth: at most about half as many nodes as the binary tree has inner nodes.
    CHECK(s.wide_tlas().node_count() <= s.tlas().nodes.size() / 2);
}

// Checks the committed TLAS against its definition: every leaf box is exactly the union of its
// instances' world boxes, every inner box exactly the union of its children's, every node mask exactly
// the OR of the masks below it; every instance sits in exactly one leaf.
void check_tlas_invariants(const AccelScene& s) {
    const Bvh& t = s.tlas();
    REQUIRE(t.nodes.size() == s.tlas_node_masks().size());
    std::vector<int> seen(s.instance_count(), 0);
    int bad_box = 0, bad_mask = 0;
    for (std::size_t k = 0; k < t.nodes.size(); ++k) {
        if (k == 1) continue;  // padding slot of the pair layout
        const BvhNode& n = t.nodes[k];
        Aabb box;
        std::uint8_t mask = 0;
        if (n.is_leaf()) {
            for (std::uint32_t j = n.first; j < n.first + n.count; ++j) {
                const std::uint32_t i = t.prim_indices[j];
                ++seen[i];
                box.grow(s.instance_bounds(i));
                mask |= s.instance(i).mask;
            }
        } else {
            box = merge(t.nodes[n.first].bounds, t.nodes[n.first + 1].bounds);
            mask = s.tlas_node_masks()[n.first] | s.tlas_node_masks()[n.first + 1];
        }
        bad_box += (box.lo != n.bounds.lo || box.hi != n.bounds.hi) ? 1 : 0;
        bad_mask += mask != s.tlas_node_masks()[k] ? 1 : 0;
    }
    CHECK(bad_box == 0);
    CHECK(bad_mask == 0);
    CHECK(std::all_of(seen.begin(), seen.end(), [](int c) { return c == 1; }));
    check_wide_tlas(s);
}

std::vector<unsigned char> tlas_bytes(const AccelScene& s) {
    const auto& n = s.tlas().nodes;
    std::vector<unsigned char> b(n.size() * sizeof(BvhNode));
    if (!n.empty()) std::memcpy(b.data(), n.data(), b.size());
    return b;
}

}  // namespace

TEST_CASE("scene: commit() does no TLAS work when nothing changed", "[scene]") {
    Pcg32 rng(1);
    AccelScene s;
    populate(s, rng, 200, 30.0f);
    CHECK_FALSE(s.committed());
    CHECK(s.commit() == TlasUpdate::rebuild);
    CHECK(s.committed());
    const auto before = tlas_bytes(s);
    const auto* data = s.tlas().nodes.data();
    const double sah = s.tlas_sah_cost_at_build();
    for (int frame = 0; frame < 3; ++frame) CHECK(s.commit() == TlasUpdate::none);
    CHECK(s.tlas().nodes.data() == data);
    CHECK(tlas_bytes(s) == before);
    CHECK(s.tlas_sah_cost_at_build() == sah);
    // Setting a mask to the value it already has is no change either.
    s.set_mask(7, s.instance(7).mask);
    CHECK(s.commit() == TlasUpdate::none);
    CHECK(std::string(to_string(TlasUpdate::none)) == "none");
    CHECK(std::string(to_string(TlasUpdate::refit)) == "refit");
    CHECK(std::string(to_string(TlasUpdate::rebuild)) == "rebuild");
}

TEST_CASE("scene: setting every transform to the value it already has is no change", "[scene]") {
    // An application that writes all transforms every frame, most of them unchanged (resting
    // particles), must not pay a TLAS refit for it: "a frame with no transform change does no TLAS
    // work", as set_mask() already treats an unchanged mask.
    Pcg32 rng(12);
    AccelScene s;
    populate(s, rng, 100, 30.0f);
    REQUIRE(s.commit() == TlasUpdate::rebuild);
    for (std::uint32_t i = 0; i < s.instance_count(); ++i) s.set_transform(i, s.instance(i).object_to_world);
    CHECK(s.committed());
    CHECK(s.commit() == TlasUpdate::none);
}

TEST_CASE("scene: transforms and masks refit, adding and removing instances rebuild", "[scene]") {
    Pcg32 rng(2);
    AccelScene s;
    populate(s, rng, 100, 30.0f);
    REQUIRE(s.commit() == TlasUpdate::rebuild);
    const std::vector<std::uint32_t> order = s.tlas().prim_indices;

    // A small move: refit, same topology (leaf order kept), boxes updated.
    AffineTransform m = s.instance(3).object_to_world;
    m.translation.x += 0.01;
    s.set_transform(3, m);
    CHECK_FALSE(s.committed());
    CHECK(s.commit() == TlasUpdate::refit);
    CHECK(s.tlas().prim_indices == order);
    check_tlas_invariants(s);

    // A mask change alone: refit, node masks follow.
    s.set_mask(5, std::uint8_t(s.instance(5).mask ^ 0x81));
    CHECK(s.commit() == TlasUpdate::refit);
    check_tlas_invariants(s);

    // Adding an instance: rebuild, even together with transform changes.
    jitter(s, rng, 0.01f);
    s.add_instance(Instance{0, random_transform(rng, 30.0f), 0x40, 7, instance_flag_none});
    CHECK(s.commit() == TlasUpdate::rebuild);
    CHECK(s.instance_count() == 101);
    check_tlas_invariants(s);
    CHECK(s.commit() == TlasUpdate::none);

    // Removing one: rebuild.
    s.remove_instance(0);
    CHECK(s.commit() == TlasUpdate::rebuild);
    CHECK(s.instance_count() == 100);
    check_tlas_invariants(s);
}

TEST_CASE("scene: removing an instance removes its geometry and renumbers the later ones", "[scene]") {
    // Three unit spheres on the z axis at z = 0, 3, 6, user ids 10, 11, 12.
    AccelScene s;
    const auto b = s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1.0f}}, true));
    for (std::uint32_t i = 0; i < 3; ++i)
        s.add_instance(Instance{b, AffineTransform::translate_scale({0, 0, 3.0 * i}, 1.0), 0xFF, 10 + i, 0});
    s.commit();
    const Ray down{{0, 0, 20}, 0.0f, {0, 0, -1}, kInf};
    TraceResult r = trace(s, down, ray_flag_none, 0xFF);
    CHECK(r.committed.instance_index == 2);
    CHECK(r.committed.instance_id == 12);
    s.remove_instance(2);
    CHECK(s.commit() == TlasUpdate::rebuild);
    r = trace(s, down, ray_flag_none, 0xFF);
    CHECK(r.committed.instance_index == 1);
    CHECK(r.committed.instance_id == 11);
    CHECK(r.committed.t == 16.0f);  // the sphere at z = 3, entered at z = 4
    s.remove_instance(0);
    s.commit();
    r = trace(s, Ray{{0, 0, -20}, 0.0f, {0, 0, 1}, kInf}, ray_flag_none, 0xFF);
    CHECK(r.committed.instance_index == 0);
    CHECK(r.committed.instance_id == 11);
    CHECK(r.committed.t == 22.0f);
}

TEST_CASE("scene: removing a world-triangles instance keeps the others' triangles in place", "[scene]") {
    // Quads at z = 0, 3, 6 (user ids 20, 21, 22) take the world-triangles path, whose triangles sit in
    // one array in instance order; removing the first must move the others' slots with them.
    TriangleMesh quad;
    quad.vertices = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    quad.triangles = {{0, 1, 2}, {0, 2, 3}};
    AccelScene s;
    const auto b = s.add_bottom_level(BottomLevel::from_mesh(quad, false));
    for (std::uint32_t i = 0; i < 3; ++i)
        s.add_instance(Instance{b, AffineTransform::translate_scale({0, 0, 3.0 * i}, 1.0), 0xFF, 20 + i, 0});
    s.remove_instance(0);  // before any commit: only the stored instances hold the slots yet
    s.commit();
    REQUIRE(s.record(1).path == InstancePath::world_triangles);
    std::vector<std::pair<float, std::uint32_t>> hits;  // (t, user id)
    trace(s, Ray{{0.3f, 0.2f, 20.0f}, 0.0f, {0, 0, -1}, kInf}, ray_flag_none, 0xFF, [&](const TraceHit& h) {
        hits.emplace_back(h.t, h.instance_id);
        return AnyHitDecision::ignore;
    });
    std::sort(hits.begin(), hits.end());
    REQUIRE(hits.size() == 2);
    CHECK(hits[0] == std::pair<float, std::uint32_t>(14.0f, 22));
    CHECK(hits[1] == std::pair<float, std::uint32_t>(17.0f, 21));
}

TEST_CASE("scene: records and details stay each instance's own through adds, removals, masks and transforms",
          "[scene]") {
    // A mesh, a quad (world triangles), a two-sphere set and a single sphere, interleaved. All but the
    // single sphere keep their detail in a side array, in instance order, so removing one moves the later
    // ones' slots; the single sphere's is derived (a world sphere, or the general path when stretched).
    // Each commit lays the records out in leaf order; the changes in between find them through their slots.
    Pcg32 rng(91);
    AccelScene s;
    TriangleMesh quad;
    quad.vertices = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    quad.triangles = {{0, 1, 2}, {0, 2, 3}};
    std::vector<BottomLevel> levels;
    levels.push_back(BottomLevel::from_mesh(make_icosphere(1, 1.0f), false));
    levels.push_back(BottomLevel::from_mesh(quad, false));
    levels.push_back(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 0.8f}, Sphere{{0.5f, 0, 0}, 0.6f}}, false));
    levels.push_back(BottomLevel::from_spheres({Sphere{{0.1f, 0, 0}, 0.7f}}, false));
    for (BottomLevel& b : levels) s.add_bottom_level(std::move(b));
    auto make = [&](int i) {
        const std::uint32_t blas = std::uint32_t(std::min(i % 5, 3));
        const AffineTransform m = blas == 3 && i % 2 == 0
                                      ? AffineTransform::translate_scale(random_transform(rng, 30).translation, 1.5)
                                      : random_transform(rng, 30);  // per-axis scales: stretched spheres
        return Instance{blas, m, 0xFF, std::uint32_t(500 + i), instance_flag_none};
    };
    std::vector<Instance> batch;
    for (int i = 0; i < 100; ++i) s.add_instance(make(i));
    for (int i = 100; i < 200; ++i) batch.push_back(make(i));
    s.add_instances(batch);
    REQUIRE(s.commit() == TlasUpdate::rebuild);
    for (const std::uint32_t gone : {0u, 7u, 50u, 51u, 120u, 3u}) s.remove_instance(gone);
    s.add_instance(make(200));
    for (std::uint32_t i = 0; i < s.instance_count(); i += 4) s.set_transform(i, make(int(i) + 3).object_to_world);
    REQUIRE(s.commit() == TlasUpdate::rebuild);
    for (std::uint32_t i = 1; i < s.instance_count(); i += 4) s.set_transform(i, make(int(i) + 3).object_to_world);
    for (std::uint32_t i = 2; i < s.instance_count(); i += 5) s.set_mask(i, std::uint8_t(1u << (i % 3)));
    s.commit();

    int paths[3] = {}, stretched_spheres = 0;
    for (std::uint32_t i = 0; i < s.instance_count(); ++i) {
        INFO("instance " << i);
        const Instance& in = s.instance(i);
        REQUIRE(s.detail(i).blas == &s.bottom_level(in.blas));
        REQUIRE(s.detail(i).world_to_object_linear == in.object_to_world.inverse().linear);
        REQUIRE(s.detail(i, s.record(i)).blas == &s.bottom_level(in.blas));
        REQUIRE(s.detail(i, s.record(i)).world_to_object_linear == in.object_to_world.inverse().linear);
        ++paths[int(s.record(i).path)];
        stretched_spheres += in.blas == 3 && s.record(i).path == InstancePath::object_space ? 1 : 0;
    }
    REQUIRE(paths[int(InstancePath::world_sphere)] > 10);
    REQUIRE(paths[int(InstancePath::world_triangles)] > 10);
    REQUIRE(stretched_spheres > 10);

    // The same instances added afresh, one by one: the same hits.
    AccelScene fresh;
    fresh.add_bottom_level(BottomLevel::from_mesh(make_icosphere(1, 1.0f), false));
    fresh.add_bottom_level(BottomLevel::from_mesh(quad, false));
    fresh.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 0.8f}, Sphere{{0.5f, 0, 0}, 0.6f}}, false));
    fresh.add_bottom_level(BottomLevel::from_spheres({Sphere{{0.1f, 0, 0}, 0.7f}}, false));
    for (std::uint32_t i = 0; i < s.instance_count(); ++i) fresh.add_instance(s.instance(i));
    fresh.commit();
    for (std::uint32_t i = 0; i < s.instance_count(); ++i) {
        INFO("instance " << i);
        const InstanceRecord &a = s.record(i), &b = fresh.record(i);
        REQUIRE((a.mask == b.mask && a.opaque == b.opaque && a.path == b.path && a.flags == b.flags));
        REQUIRE((a.user_id == b.user_id && a.object_to_world_translation == b.object_to_world_translation));
        if (a.path == InstancePath::world_sphere) {
            REQUIRE((a.sphere.offset == b.sphere.offset && a.sphere.radius == b.sphere.radius));
        } else {
            REQUIRE(a.other.first_world_triangle == b.other.first_world_triangle);
            REQUIRE(a.other.world_triangle_count == b.other.world_triangle_count);
            REQUIRE(a.other.world_facing_flipped == b.other.world_facing_flipped);
        }
    }
    for (std::uint32_t k = 0; k < s.instance_count(); ++k)
        REQUIRE(&s.leaf_record(k) == &s.record(s.tlas().prim_indices[k]));
    int hits = 0;
    for (int k = 0; k < 400; ++k) {
        const Ray r = random_ray(rng, 30);
        for (const std::uint8_t mask : {std::uint8_t(0xFF), std::uint8_t(2)}) {
            const std::vector<HitKey> a = all_hits(s, r, mask), b = all_hits(fresh, r, mask);
            REQUIRE(a == b);
            hits += int(a.size());
        }
    }
    CHECK(hits > 400);
}

TEST_CASE("scene: a scene with every instance removed traces as empty", "[scene]") {
    AccelScene s;
    const auto b = s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1.0f}}, true));
    s.add_instance(Instance{b, {}, 0xFF, 0, 0});
    s.commit();
    s.remove_instance(0);
    CHECK(s.commit() == TlasUpdate::rebuild);
    const TraceResult r = trace(s, Ray{{0, 0, 5}, 0.0f, {0, 0, -1}, kInf}, ray_flag_none, 0xFF);
    CHECK_FALSE(r.hit);
    CHECK(r.counters.instances_entered == 0);
}

// The scene keeps a uniform scale without its matrix and any other linear part in a slot of its own
// (AccelScene::StoredInstance): instance() must still give back every transform bit for bit, including the
// near misses of a uniform scale (a -0.0 off the diagonal, diagonals equal as numbers but not as bits),
// through transforms that turn from one form to the other, removals that renumber the slots, and bulk adds.
TEST_CASE("scene: instance() gives back each instance's transform bit for bit", "[scene]") {
    const auto same_bits = [](const AffineTransform& a, const AffineTransform& b) {
        return std::memcmp(&a.linear, &b.linear, sizeof(a.linear)) == 0 &&
               std::memcmp(&a.translation, &b.translation, sizeof(a.translation)) == 0;
    };
    Pcg32 rng(1234);
    std::vector<AffineTransform> forms;
    forms.push_back(AffineTransform::translate_scale({1, 2, 3}, 0.25));
    forms.push_back(random_transform(rng, 10.0f));
    AffineTransform negative_zero = AffineTransform::translate_scale({0, 0, 0}, 2.0);
    negative_zero.linear[1][0] = -0.0;
    forms.push_back(negative_zero);
    AffineTransform signed_diagonal = AffineTransform::translate_scale({4, 5, 6}, 1.0);
    signed_diagonal.linear[2][2] = -1.0;
    forms.push_back(signed_diagonal);
    forms.push_back(AffineTransform::translate_scale({-1, 0, 1}, -3.0));
    forms.push_back(random_transform(rng, 10.0f));

    AccelScene s;
    const auto b = s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1.0f}}, true));
    std::vector<Instance> expected;
    for (std::uint32_t i = 0; i < 40; ++i)
        expected.push_back(Instance{b, forms[i % forms.size()], std::uint8_t(i), 100 + i, std::uint8_t(i % 3)});
    s.add_instances(std::span(expected).first(20));
    for (std::uint32_t i = 20; i < 40; ++i) s.add_instance(expected[i]);
    const auto check_all = [&] {
        REQUIRE(s.instance_count() == expected.size());
        for (std::uint32_t i = 0; i < expected.size(); ++i) {
            const Instance in = s.instance(i);
            REQUIRE(same_bits(in.object_to_world, expected[i].object_to_world));
            REQUIRE(same_bits(s.transform(i), expected[i].object_to_world));
            REQUIRE(in.blas == expected[i].blas);
            REQUIRE(in.mask == expected[i].mask);
            REQUIRE(in.user_id == expected[i].user_id);
            REQUIRE(in.flags == expected[i].flags);
            REQUIRE(s.detail(i).world_to_object_linear == expected[i].object_to_world.inverse().linear);
        }
    };
    check_all();
    for (int frame = 0; frame < 6; ++frame) {
        for (std::uint32_t i = 0; i < expected.size(); ++i) {
            expected[i].object_to_world = forms[(i + std::size_t(frame) * 7 + 1) % forms.size()];
            s.set_transform(i, expected[i].object_to_world);
        }
        s.remove_instance(std::uint32_t(frame * 3 % expected.size()));
        expected.erase(expected.begin() + frame * 3 % expected.size());
        check_all();
        s.commit();
    }
}

TEST_CASE("scene: a singular instance transform is rejected", "[scene]") {
    AccelScene s;
    const auto b = s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1.0f}}, true));
    AffineTransform flat;
    flat.linear[2][2] = 0.0;  // squashes z
    CHECK_THROWS_AS(s.add_instance(Instance{b, flat, 0xFF, 0, 0}), std::domain_error);
    CHECK_THROWS_AS(s.add_instance(Instance{5, {}, 0xFF, 0, 0}), std::out_of_range);
    CHECK(s.instance_count() == 0);
    // A rejected set_transform() leaves the instance as it was: transform, box and record.
    const AffineTransform at = AffineTransform::translate_scale({1, 2, 3}, 2.0);
    s.add_instance(Instance{b, at, 0xFF, 0, 0});
    s.commit();
    const Aabb box = s.instance_bounds(0);
    CHECK_THROWS_AS(s.set_transform(0, flat), std::domain_error);
    AffineTransform huge = at;
    huge.translation.x = 1e300;  // finite, but its box does not fit in float
    CHECK_THROWS_AS(s.set_transform(0, huge), std::domain_error);
    CHECK(s.transform(0) == at);
    CHECK(s.instance_bounds(0).lo == box.lo);
    CHECK(s.instance_bounds(0).hi == box.hi);
    CHECK(s.record(0).sphere.offset == glm::dvec3(0.0));
    CHECK(s.record(0).sphere.radius == 2.0);
    CHECK(s.commit() == TlasUpdate::none);
}

TEST_CASE("scene: add_instances() gives the scene of add_instance() one by one, and adds none on error",
          "[scene]") {
    // Every kind of instance path (world sphere, world triangles, object space), rotated, mirrored and
    // scaled, in batches large enough that the set-up runs on several threads.
    Pcg32 rng(12);
    std::vector<Instance> instances;
    for (std::uint32_t i = 0; i < 20000; ++i) {
        AffineTransform m = AffineTransform::translate_scale(
            {rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(-50, 50)}, rng.uniform(0.1f, 2.0f));
        const glm::quat turn = glm::angleAxis(rng.uniform(0, 6.28f), glm::vec3(0, 1, 0));
        if (i % 3 == 1) m.linear = glm::dmat3(glm::mat3_cast(turn)) * m.linear;
        if (i % 5 == 2) m.linear[0] = -m.linear[0];  // mirrored
        instances.push_back(Instance{i % 3, m, std::uint8_t(1u << (i % 3)), i, std::uint8_t(i % 7 == 0 ? 2 : 0)});
    }
    AccelScene one_by_one, bulk;
    add_path_bottom_levels(one_by_one);
    add_path_bottom_levels(bulk);
    for (const Instance& in : instances) one_by_one.add_instance(in);
    bulk.reserve_instances(instances.size());
    CHECK(bulk.add_instances(std::span(instances).first(7000)) == 0);
    CHECK(bulk.add_instances(std::span(instances).subspan(7000)) == 7000);
    // A bad batch (a singular transform last, a missing bottom level) adds nothing.
    std::vector<Instance> bad(instances.begin(), instances.begin() + 5000);
    bad.back().object_to_world.linear[2] = glm::dvec3(0.0);  // squashes z: singular
    CHECK_THROWS_AS(bulk.add_instances(bad), std::domain_error);
    bad.back() = Instance{9, {}, 0xFF, 0, 0};
    CHECK_THROWS_AS(bulk.add_instances(bad), std::out_of_range);
    REQUIRE(bulk.instance_count() == one_by_one.instance_count());
    require_same_scene(bulk, one_by_one);
}

TEST_CASE("scene: set_transforms() gives the scene of set_transform() one by one, and changes nothing on error",
          "[scene]") {
    // 20,000 instances over the three paths, every linear part a uniform scale (no matrix slot yet); the new
    // transforms leave some alone, turn some (a matrix slot given, in instance order), turn some back to a
    // scale (the slot kept), mirror and move the rest: in chunks enough for several threads.
    Pcg32 rng(31);
    std::vector<Instance> instances;
    for (std::uint32_t i = 0; i < 20000; ++i)
        instances.push_back(Instance{i % 3,
                                     AffineTransform::translate_scale({rng.uniform(-50, 50), rng.uniform(-50, 50),
                                                                       rng.uniform(-50, 50)},
                                                                      rng.uniform(0.1f, 2.0f)),
                                     std::uint8_t(1u << (i % 3)), i, 0});
    auto frame = [&](int f) {
        std::vector<AffineTransform> m;
        for (std::uint32_t i = 0; i < instances.size(); ++i) {
            AffineTransform t = instances[i].object_to_world;
            const std::uint32_t kind = (i * 7 + std::uint32_t(f)) % 5;
            if (kind == 0) {
                m.push_back(t);  // unchanged
                continue;
            }
            t.translation += glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
            if (kind == 1 || kind == 2)
                t.linear = glm::dmat3(glm::mat3_cast(glm::angleAxis(rng.uniform(0, 6.28f), glm::vec3(0, 1, 0)))) *
                           t.linear;
            if (kind == 2) t.linear[0] = -t.linear[0];  // mirrored
            m.push_back(t);
        }
        return m;
    };
    AccelScene one_by_one, bulk;
    add_path_bottom_levels(one_by_one);
    add_path_bottom_levels(bulk);
    one_by_one.add_instances(instances);
    bulk.add_instances(instances);
    one_by_one.commit();
    bulk.commit();
    for (int f = 0; f < 3; ++f) {
        INFO("frame " << f);
        const std::vector<AffineTransform> m = frame(f);
        // Instances 0 and 1 are left out of the bulk call's range, the rest set in two calls.
        for (std::uint32_t i = 2; i < m.size(); ++i) one_by_one.set_transform(i, m[i]);
        bulk.set_transforms(2, std::span(m).subspan(2, 9000));
        bulk.set_transforms(9002, std::span(m).subspan(9002));
        require_same_scene(bulk, one_by_one);
    }
    // Rejected: a range past the last instance; a batch with two bad transforms, of which the lower one is
    // named. The scene is left as it was, and a good batch after them gives the one-by-one scene still.
    const std::vector<AffineTransform> m = frame(3);
    CHECK_THROWS_AS(bulk.set_transforms(1, m), std::out_of_range);
    CHECK_THROWS_AS(bulk.set_transforms(20001, std::span(m).first(0)), std::out_of_range);
    std::vector<AffineTransform> bad = m;
    bad[15000].linear[2] = glm::dvec3(0.0);  // singular
    bad[9000].translation.y = 1e300;         // a box past float
    CHECK_THROWS_WITH(bulk.set_transforms(0, bad), Catch::Contains("instance 9000 "));
    CHECK(bulk.commit() == TlasUpdate::none);
    require_same_scene(bulk, one_by_one);
    for (std::uint32_t i = 0; i < m.size(); ++i) one_by_one.set_transform(i, m[i]);
    bulk.set_transforms(0, m);
    require_same_scene(bulk, one_by_one);
    bulk.set_transforms(0, m);  // the same again: no change
    CHECK(bulk.commit() == TlasUpdate::none);
}

TEST_CASE("scene: node masks are the OR of the subtree after build, refit and mask changes", "[scene]") {
    Pcg32 rng(3);
    AccelScene s;
    populate(s, rng, 500, 40.0f);
    s.commit();
    check_tlas_invariants(s);
    for (int frame = 0; frame < 10; ++frame) {
        for (int k = 0; k < 20; ++k) s.set_mask(rng.next_u32() % 500, std::uint8_t(rng.next_u32()));
        jitter(s, rng, 0.2f);
        s.commit();
        check_tlas_invariants(s);
    }
    // A mask no instance has any more must prune the whole tree at the root.
    for (std::uint32_t i = 0; i < s.instance_count(); ++i) s.set_mask(i, std::uint8_t(s.instance(i).mask & 0x7F));
    REQUIRE(s.commit() == TlasUpdate::refit);
    CHECK((s.tlas_node_masks()[0] & 0x80) == 0);
    Pcg32 rays(4);
    for (int k = 0; k < 50; ++k) {
        const TraceResult r = trace(s, random_ray(rays, 40.0f), ray_flag_none, 0x80);
        CHECK(r.counters.tlas_nodes == 0);
        CHECK_FALSE(r.hit);
    }
}

TEST_CASE("scene: the rebuild policy rebuilds exactly when the refit SAH passes the threshold", "[scene]") {
    // Each frame predicts the decision independently: refit a copy of the current TLAS to the new boxes
    // and compare its SAH cost with kTlasRebuildSahRatio × the cost at the last build. Jitter degrades
    // the tree a few percent per frame, so the ratio creeps up to the threshold and the decision is
    // tested right at it; occasional teleports of many instances degrade it at once.
    Pcg32 rng(5);
    AccelScene s;
    populate(s, rng, 2000, 50.0f);
    REQUIRE(s.commit() == TlasUpdate::rebuild);
    int refits = 0, rebuilds = 0;
    double highest_refit_ratio = 0.0, lowest_rebuild_ratio = 1e30;
    for (int frame = 0; frame < 120; ++frame) {
        jitter(s, rng, 1.0f);
        if (frame % 15 == 14)  // teleport a tenth of the instances
            for (int k = 0; k < 200; ++k) {
                const std::uint32_t i = rng.next_u32() % 2000;
                AffineTransform m = s.instance(i).object_to_world;
                m.translation = {rng.uniform(0, 50), rng.uniform(0, 50), rng.uniform(0, 50)};
                s.set_transform(i, m);
            }
        Bvh predicted = s.tlas();
        std::vector<Aabb> boxes(s.instance_count());
        for (std::uint32_t i = 0; i < s.instance_count(); ++i) boxes[i] = s.instance_bounds(i);
        predicted.refit(boxes);
        const double at_build = s.tlas_sah_cost_at_build();
        const bool expect_rebuild = predicted.sah_cost() > kTlasRebuildSahRatio * at_build;

        const TlasUpdate u = s.commit();
        CAPTURE(frame, predicted.sah_cost(), at_build);
        const double ratio = predicted.sah_cost() / at_build;
        if (u == TlasUpdate::refit) highest_refit_ratio = std::max(highest_refit_ratio, ratio);
        else lowest_rebuild_ratio = std::min(lowest_rebuild_ratio, ratio);
        CHECK(u == (expect_rebuild ? TlasUpdate::rebuild : TlasUpdate::refit));
        if (u == TlasUpdate::rebuild) {
            ++rebuilds;
            // A rebuild is a fresh SAH build of the current boxes, grouped by instance mask as AccelScene
            // builds its TLAS, and becomes the new reference.
            std::vector<std::uint32_t> masks(s.instance_count());
            for (std::uint32_t i = 0; i < s.instance_count(); ++i) masks[i] = s.instance(i).mask;
            const Bvh fresh = build_grouped_bvh(boxes, masks, BvhBuildSettings{.max_leaf_size = 1});
            CHECK(s.tlas_sah_cost() == fresh.sah_cost());
            CHECK(s.tlas_sah_cost_at_build() == s.tlas_sah_cost());
            CHECK(s.tlas().prim_indices == fresh.prim_indices);
        } else {
            ++refits;
            CHECK(s.tlas_sah_cost_at_build() == at_build);
            CHECK(s.tlas_sah_cost() == predicted.sah_cost());
            CHECK(s.tlas_sah_cost() <= kTlasRebuildSahRatio * at_build);
        }
        check_tlas_invariants(s);
    }
    // Both branches of the policy were exercised, close to the threshold on both sides (so a policy
    // with a different ratio, e.g. 1.1 or 1.3, would have decided some frame differently).
    CHECK(refits >= 20);
    CHECK(rebuilds >= 5);
    CHECK(highest_refit_ratio > kTlasRebuildSahRatio - 0.02);
    CHECK(lowest_rebuild_ratio < kTlasRebuildSahRatio + 0.02);
}

TEST_CASE("scene: set_rebuild_ratio(infinity) refits however degraded the tree", "[scene]") {
    Pcg32 rng(6);
    AccelScene s;
    populate(s, rng, 1000, 50.0f);
    s.set_rebuild_ratio(std::numeric_limits<double>::infinity());
    REQUIRE(s.commit() == TlasUpdate::rebuild);
    const double at_build = s.tlas_sah_cost_at_build();
    // Shuffle every instance to a random place: the refit tree degrades far past the default ratio.
    for (std::uint32_t i = 0; i < s.instance_count(); ++i) {
        AffineTransform m = s.instance(i).object_to_world;
        m.translation = {rng.uniform(0, 50), rng.uniform(0, 50), rng.uniform(0, 50)};
        s.set_transform(i, m);
    }
    CHECK(s.commit() == TlasUpdate::refit);
    CHECK(s.tlas_sah_cost() > 2.0 * kTlasRebuildSahRatio * at_build);
    // The default policy would have rebuilt the same change.
    s.set_rebuild_ratio(kTlasRebuildSahRatio);
    jitter(s, rng, 0.0f);  // the same transforms again: no change, no TLAS work
    CHECK(s.commit() == TlasUpdate::none);
    jitter(s, rng, 1e-3f);  // a real (tiny) move: the degraded tree is now measured against the policy
    CHECK(s.commit() == TlasUpdate::rebuild);
    CHECK(s.tlas_sah_cost() < s.tlas_sah_cost_at_build() * 1.0000001);
}

TEST_CASE("scene: after many random frames a refit TLAS returns exactly the hits of a fresh build", "[scene]") {
    // Three scenes over the same instances: refit only, the default policy, and (at the end) a fresh
    // build of the final state. Motion: jitter, rotations, mask changes, for 100 frames. Hits are
    // compared bit for bit (t, instance, primitive, facing): the TLAS decides only which instances are
    // visited, never how one is intersected, so any difference would be a lost or extra instance.
    constexpr int kInstances = 600, kFrames = 100, kRays = 400;
    constexpr float kExtent = 20.0f;
    Pcg32 setup(7);
    AccelScene refit_only, policy;
    {
        Pcg32 a = setup, b = setup;
        populate(refit_only, a, kInstances, kExtent);
        populate(policy, b, kInstances, kExtent);
    }
    refit_only.set_rebuild_ratio(std::numeric_limits<double>::infinity());
    REQUIRE(refit_only.commit() == TlasUpdate::rebuild);
    REQUIRE(policy.commit() == TlasUpdate::rebuild);
    Pcg32 motion(8);
    int policy_rebuilds = 0;
    for (int frame = 0; frame < kFrames; ++frame) {
        for (std::uint32_t i = 0; i < kInstances; ++i) {
            AffineTransform m = refit_only.instance(i).object_to_world;
            m.translation += glm::dvec3(motion.uniform(-0.4f, 0.4f), motion.uniform(-0.4f, 0.4f), motion.uniform(-0.4f, 0.4f));
            if (i % 7 == 0) {  // some also turn
                const double c = std::cos(0.1), sn = std::sin(0.1);
                m.linear = glm::dmat3(glm::dvec3(c, sn, 0), glm::dvec3(-sn, c, 0), glm::dvec3(0, 0, 1)) * m.linear;
            }
            refit_only.set_transform(i, m);
            policy.set_transform(i, m);
        }
        for (int k = 0; k < 5; ++k) {
            const std::uint32_t i = motion.next_u32() % kInstances;
            const std::uint8_t mask = random_mask(motion);
            refit_only.set_mask(i, mask);
            policy.set_mask(i, mask);
        }
        CHECK(refit_only.commit() == TlasUpdate::refit);
        policy_rebuilds += policy.commit() == TlasUpdate::rebuild ? 1 : 0;
    }
    AccelScene fresh;
    {
        Pcg32 c = setup;
        populate(fresh, c, kInstances, kExtent);
        for (std::uint32_t i = 0; i < kInstances; ++i) {
            fresh.set_transform(i, refit_only.instance(i).object_to_world);
            fresh.set_mask(i, refit_only.instance(i).mask);
        }
        REQUIRE(fresh.commit() == TlasUpdate::rebuild);
    }
    // The refit tree really is degraded (else this test would compare two identical trees).
    CHECK(refit_only.tlas_sah_cost() > 1.5 * fresh.tlas_sah_cost());
    CHECK(policy_rebuilds > 0);

    Pcg32 rays(9);
    int total_hits = 0, compared_closest = 0;
    for (int k = 0; k < kRays; ++k) {
        const Ray ray = random_ray(rays, kExtent);
        const std::uint8_t mask = k % 4 == 0 ? std::uint8_t(0xFF) : std::uint8_t(rays.next_u32());
        CAPTURE(k, int(mask));
        // Every surface as a non-opaque candidate: the complete set, order-independent.
        const auto every = all_hits(fresh, ray, mask, ray_flag_force_non_opaque);
        CHECK(all_hits(refit_only, ray, mask, ray_flag_force_non_opaque) == every);
        CHECK(all_hits(policy, ray, mask, ray_flag_force_non_opaque) == every);
        total_hits += int(every.size());
        // With the scene's own opacity: the candidates before the first opaque surface.
        const auto expected = all_hits(fresh, ray, mask);
        CHECK(all_hits(refit_only, ray, mask) == expected);
        CHECK(all_hits(policy, ray, mask) == expected);

        const TraceResult f = trace(fresh, ray, ray_flag_none, mask);
        const TraceResult r = trace(refit_only, ray, ray_flag_none, mask);
        const TraceResult p = trace(policy, ray, ray_flag_none, mask);
        REQUIRE(f.hit == r.hit);
        REQUIRE(f.hit == p.hit);
        if (!f.hit) continue;
        CHECK(r.committed.t == f.committed.t);
        CHECK(p.committed.t == f.committed.t);
        // The same closest surface, unless another surface lies at exactly the same t: then either is
        // right.
        const bool tie = std::count_if(every.begin(), every.end(),
                                       [&](const HitKey& h) { return std::get<0>(h) == f.committed.t; }) > 1;
        if (tie) continue;
        ++compared_closest;
        CHECK(r.committed.instance_index == f.committed.instance_index);
        CHECK(r.committed.primitive_index == f.committed.primitive_index);
        CHECK(r.committed.kind == f.committed.kind);
        CHECK(p.committed.instance_index == f.committed.instance_index);
        CHECK(p.committed.primitive_index == f.committed.primitive_index);
    }
    CHECK(total_hits > 3 * kRays);  // the rays do cross the instances (about 4.5 surfaces per ray)
    CHECK(compared_closest > kRays / 2);
}

TEST_CASE("scene: a deformed mesh bottom level, refit in place, traces as a fresh scene over the new vertices",
          "[scene][refit]") {
    // A deforming icosphere (object-space path) and a deforming quad (world-triangles path), instanced
    // several times beside a sphere set. After update_mesh_vertices() and commit(), the scene must answer
    // as one built from scratch over the deformed meshes: same world boxes, same hits bit for bit.
    const TriangleMesh sphere_mesh = make_icosphere(2, 1.0f);
    TriangleMesh quad;
    quad.vertices = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    quad.triangles = {{0, 1, 2}, {0, 2, 3}};
    constexpr int kInstances = 60;
    constexpr float kExtent = 12.0f;
    auto make_scene = [&](AccelScene& s, const TriangleMesh& mesh, const TriangleMesh& q) {
        const std::uint32_t blas[] = {
            s.add_bottom_level(BottomLevel::from_mesh(mesh, false)),
            s.add_bottom_level(BottomLevel::from_mesh(q, false)),
            s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 0.7f}}, false)),
        };
        Pcg32 rng(101);
        for (int i = 0; i < kInstances; ++i)
            s.add_instance(Instance{blas[i % 3], random_transform(rng, kExtent), random_mask(rng), std::uint32_t(i),
                                    instance_flag_none});
    };
    AccelScene s;
    make_scene(s, sphere_mesh, quad);
    REQUIRE(s.commit() == TlasUpdate::rebuild);
    REQUIRE(s.record(1).path == InstancePath::world_triangles);

    // A bulge along x and a twist of the quad.
    TriangleMesh bulged = sphere_mesh;
    for (glm::vec3& v : bulged.vertices) v *= 1.0f + 0.3f * std::max(v.x, 0.0f);
    TriangleMesh twisted = quad;
    twisted.vertices[2] = {1.5f, 1.2f, 0.4f};
    CHECK(s.update_mesh_vertices(0, bulged.vertices) == BlasUpdate::refit);
    CHECK(s.update_mesh_vertices(1, twisted.vertices) == BlasUpdate::refit);
    CHECK_FALSE(s.committed());
    CHECK(s.commit() != TlasUpdate::none);
    check_tlas_invariants(s);

    AccelScene fresh;
    make_scene(fresh, bulged, twisted);
    REQUIRE(fresh.commit() == TlasUpdate::rebuild);
    for (std::uint32_t i = 0; i < kInstances; ++i) {
        CHECK(s.instance_bounds(i).lo == fresh.instance_bounds(i).lo);
        CHECK(s.instance_bounds(i).hi == fresh.instance_bounds(i).hi);
    }
    Pcg32 rays(102);
    int total_hits = 0;
    for (int k = 0; k < 600; ++k) {
        const Ray ray = random_ray(rays, kExtent);
        const auto every = all_hits(fresh, ray, 0xFF, ray_flag_force_non_opaque);
        REQUIRE(all_hits(s, ray, 0xFF, ray_flag_force_non_opaque) == every);
        total_hits += int(every.size());
        const TraceResult f = trace(fresh, ray, ray_flag_none, 0xFF);
        const TraceResult r = trace(s, ray, ray_flag_none, 0xFF);
        REQUIRE(f.hit == r.hit);
        if (f.hit) CHECK(r.committed.t == f.committed.t);
    }
    CHECK(total_hits > 200);
}

TEST_CASE("scene: update_mesh_vertices rejects a missing bottom level, spheres and a wrong vertex count",
          "[scene][refit]") {
    AccelScene s;
    const auto mesh = s.add_bottom_level(BottomLevel::from_mesh(make_icosphere(1, 1.0f), true));
    const auto spheres = s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1.0f}}, true));
    s.add_instance(Instance{mesh, AffineTransform::translate_scale({0, 0, 0}, 1.0), 0xFF, 0, 0});
    REQUIRE(s.commit() == TlasUpdate::rebuild);
    const std::vector<glm::vec3> three(3, glm::vec3(0.0f));
    CHECK_THROWS_AS(s.update_mesh_vertices(7, three), std::out_of_range);
    CHECK_THROWS_WITH(s.update_mesh_vertices(spheres, three), Catch::Contains("holds spheres"));
    CHECK_THROWS_WITH(s.update_mesh_vertices(mesh, three), Catch::Contains("3 vertices given"));
    // Nothing changed: the next commit has no work.
    CHECK(s.commit() == TlasUpdate::none);
}
