// textbook::trace() (textbook/trace.hpp) is the definition the fast traces are held to: trace() under both
// top-level walks, trace_bundle() and trace_tile(), candidate by candidate, on the shipped scenes (every
// particle's light ray, camera rays) and on adversarial ones (shared edges and vertices, grazing and nested
// spheres, masks, every ray and instance flag, cutoffs at exactly K and K + 1 candidates, accept-and-end).
//
// "The same", as trace/trace.hpp states it:
//  * Without the world-space paths (InstancePaths::object_space_only): trace<TlasWalk::nearest_first> meets
//    the textbook's candidates in the same order, bit for bit, commits the same hit and counts the same, in
//    every scene whose mesh BLASes are single leaves (a larger mesh is walked through its wide tree there: the
//    same candidates in another order). The other walks meet the same candidates (as a set, bit for bit)
//    before the committed t and commit the same hit.
//  * With the world-space paths (the default) t differs by rounding: kWorldSphereT, world_triangle_t_bound().
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/render/camera.hpp>
#include <smoketrace/smoke/optical_depth_pass.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/accel/blas_wide_traversal.hpp>
#include <smoketrace/accel/bvh_traversal.hpp>
#include <smoketrace/accel/wide_bvh_traversal.hpp>
#include <smoketrace/textbook/trace.hpp>
#include <smoketrace/trace/blas_traversal.hpp>
#include <smoketrace/trace/trace.hpp>
#include <smoketrace/trace/trace_bundle.hpp>
#include <smoketrace/trace/trace_tile.hpp>

#include "support/mixed_scene.hpp"

#include <catch2/catch.hpp>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <filesystem>
#include <vector>

using namespace smoketrace;
using test::key_of;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// What a test's any-hit callback answers for the n-th candidate of a ray (n from 0).
enum class Policy { ignore, accept, end_at_third, alternate };
AnyHitDecision decide(Policy p, std::size_t n) {
    switch (p) {
        case Policy::ignore: return AnyHitDecision::ignore;
        case Policy::accept: return AnyHitDecision::accept;
        case Policy::end_at_third: return n == 2 ? AnyHitDecision::accept_and_end : AnyHitDecision::ignore;
        case Policy::alternate: return n % 2 ? AnyHitDecision::accept : AnyHitDecision::ignore;
    }
    return AnyHitDecision::ignore;
}

// A ray's candidates, in the order met, and its result; `ended` when the search stopped before the whole ray
// (the cutoff, ACCEPT_FIRST_HIT_AND_END_SEARCH or accept-and-end).
struct Seen {
    std::vector<TraceHit> candidates;
    TraceResult result;
    bool ended = false;
};

template <class Run>
Seen record(Policy p, std::uint32_t flags, Run&& run) {
    Seen s;
    s.result = run([&s, p](const TraceHit& h) {
        s.candidates.push_back(h);
        const AnyHitDecision d = decide(p, s.candidates.size() - 1);
        s.ended = s.ended || d == AnyHitDecision::accept_and_end;
        return d;
    });
    s.ended = s.ended || s.result.cut_off || (s.result.hit && (flags & ray_flag_accept_first_hit_and_end_search));
    return s;
}

Seen textbook_seen(const AccelScene& scene, const Ray& ray, std::uint32_t flags, std::uint8_t mask, Policy p,
                   TraceLimits limits = {}) {
    return record(p, flags, [&](auto&& any_hit) { return textbook::trace(scene, ray, flags, mask, any_hit, limits); });
}
template <TlasWalk Walk>
Seen fast_seen(const AccelScene& scene, const Ray& ray, std::uint32_t flags, std::uint8_t mask, Policy p,
               TraceLimits limits = {}) {
    return record(p, flags, [&](auto&& any_hit) { return trace<Walk>(scene, ray, flags, mask, any_hit, limits); });
}

bool same_bits(float a, float b) { return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b); }
bool same_hit(const TraceHit& a, const TraceHit& b) {
    return same_bits(a.t, b.t) && same_bits(a.barycentrics.x, b.barycentrics.x) &&
           same_bits(a.barycentrics.y, b.barycentrics.y) && same_bits(a.object_point.x, b.object_point.x) &&
           same_bits(a.object_point.y, b.object_point.y) && same_bits(a.object_point.z, b.object_point.z) &&
           a.instance_index == b.instance_index && a.instance_id == b.instance_id &&
           a.primitive_index == b.primitive_index && a.kind == b.kind && a.geometry == b.geometry;
}

// `ended`: the search stopped inside a leaf, whose triangles the fast trace counts whole (it tests them eight
// at a time, ray_triangle_block.hpp) and the textbook one by one, up to where it stopped.
void check_same_counters(const TraceCounters& a, const TraceCounters& b, bool ended = false) {
    CHECK(a.tlas_nodes == b.tlas_nodes);
    CHECK(a.blas_nodes == b.blas_nodes);
    CHECK(a.boxes_tested == b.boxes_tested);
    CHECK(a.instances_entered == b.instances_entered);
    if (ended) CHECK(a.primitives_tested >= b.primitives_tested);
    else CHECK(a.primitives_tested == b.primitives_tested);
    CHECK(a.any_hit_invocations == b.any_hit_invocations);
    CHECK(a.hits_accepted == b.hits_accepted);
}

// The same search: candidates in the same order with the same bits, the same result, every counter.
void check_same_search(const Seen& fast, const Seen& book) {
    REQUIRE(fast.candidates.size() == book.candidates.size());
    for (std::size_t k = 0; k < book.candidates.size(); ++k) {
        CAPTURE(k);
        CHECK(same_hit(fast.candidates[k], book.candidates[k]));
    }
    CHECK(fast.result.hit == book.result.hit);
    CHECK(fast.result.cut_off == book.result.cut_off);
    CHECK(same_hit(fast.result.committed, book.result.committed));
    CHECK(fast.ended == book.ended);
    check_same_counters(fast.result.counters, book.result.counters, book.ended);
}

// The candidates a search is bound to meet whatever its order: those before the committed t (DXR reports a
// candidate only while its t is within the current tmax, so one behind an opaque hit depends on the order).
std::vector<test::HitKey> bound_candidates(const Seen& s) {
    std::vector<test::HitKey> keys;
    for (const TraceHit& h : s.candidates)
        if (!s.result.hit || h.t < s.result.committed.t) keys.push_back(key_of(h));
    std::sort(keys.begin(), keys.end());
    return keys;
}

// The same candidates as a set, bit for bit, and the same committed hit: for walks that meet them in another
// order, under the ignore and accept policies (whose outcome does not depend on the order). `counters`: false
// for a tile, which counts its own work (trace_tile.hpp).
// A search cut off has met K candidates, which K depends on the order, as does whether an opaque hit came
// before the (K + 1)-th: then only, where neither committed one, the cutoff and the number are compared.
void check_same_outcome(const Seen& fast, const Seen& book, bool counters = true) {
    if (fast.result.cut_off || book.result.cut_off) {
        if (fast.result.hit || book.result.hit) return;
        CHECK(fast.result.cut_off == book.result.cut_off);
        CHECK(fast.candidates.size() == book.candidates.size());
        return;
    }
    CHECK(bound_candidates(fast) == bound_candidates(book));
    REQUIRE(fast.result.hit == book.result.hit);
    if (book.result.hit) CHECK(same_hit(fast.result.committed, book.result.committed));
    if (counters && !book.result.hit) {  // nothing shrank tmax: the same work, counted the same
        CHECK(fast.result.counters.instances_entered == book.result.counters.instances_entered);
        CHECK(fast.result.counters.primitives_tested == book.result.counters.primitives_tested);
        CHECK(fast.result.counters.any_hit_invocations == book.result.counters.any_hit_invocations);
    }
}

// The instances of `s` over copies of its bottom levels, every instance on trace()'s general path.
AccelScene object_space_copy(const AccelScene& s) {
    AccelScene c(InstancePaths::object_space_only);
    std::uint32_t blases = 0;
    std::vector<Instance> instances;
    for (std::uint32_t i = 0; i < s.instance_count(); ++i) {
        instances.push_back(s.instance(i));
        blases = std::max(blases, instances.back().blas + 1);
    }
    for (std::uint32_t b = 0; b < blases; ++b) c.add_bottom_level(s.bottom_level(b));
    c.add_instances(instances);
    c.commit();
    return c;
}

std::vector<std::filesystem::path> shipped_scenes() {
    std::vector<std::filesystem::path> files;
    for (const auto& e : std::filesystem::directory_iterator(std::filesystem::path(SMOKETRACE_ASSET_DIR) / "scenes"))
        if (e.path().extension() == ".json") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    return files;
}

// A shipped scene as the optical-depth pass and the view see it (billboards turned to the camera).
struct Shipped {
    SceneDescription desc;
    SmokeScene smoke;
};
Shipped load_shipped(const std::filesystem::path& file) {
    SceneDescription d = load_scene_file(file);
    std::optional<GroundQuad> ground;
    if (d.ground) ground = GroundQuad{d.ground->corners};
    SmokeScene smoke(d.smoke.particles, StandInShape{}, ground, true);
    smoke.update(d.smoke.particles, d.camera.position);
    return Shipped{std::move(d), std::move(smoke)};
}

// Particle p's optical-depth ray, as OptDepthPass builds it (optical_depth_pass.hpp).
Ray light_ray(const SceneDescription& d, const Particle& p) {
    return Ray{p.center, optical_depth_tmin(p.radius), glm::normalize(d.light.direction), kOpticalDepthTmax};
}

// A world sphere's t against the object-space root: both are double roots within a few ulps of double of the
// same number, each rounded once to float, so at most one float ulp apart.
constexpr double kWorldSphereT = 0x1p-23;

}  // namespace

TEST_CASE("textbook trace: the shipped scenes' light rays meet what the fast traces meet", "[textbook][trace]") {
    std::size_t rays = 0, candidates = 0;
    for (const auto& file : shipped_scenes()) {
        CAPTURE(file.string());
        const Shipped s = load_shipped(file);
        const AccelScene& fast = s.smoke.scene();
        const AccelScene general = object_space_copy(fast);
        const auto& particles = s.desc.smoke.particles;
        for (std::size_t i = 0; i < particles.size(); ++i) {
            CAPTURE(i);
            const Ray ray = light_ray(s.desc, particles[i]);
            // Without the world-space paths: the same walk, bit for bit.
            const Seen book = textbook_seen(general, ray, ray_flag_none, kLightRayMask, Policy::ignore);
            check_same_search(fast_seen<TlasWalk::nearest_first>(general, ray, ray_flag_none, kLightRayMask,
                                                                Policy::ignore), book);
            check_same_outcome(fast_seen<TlasWalk::all_hits>(general, ray, ray_flag_none, kLightRayMask,
                                                            Policy::ignore), book);
            // With them: every particle a world sphere, its t within kWorldSphereT; the same walk and counters.
            const Seen book_w = textbook_seen(fast, ray, ray_flag_none, kLightRayMask, Policy::ignore);
            const Seen fast_w = fast_seen<TlasWalk::nearest_first>(fast, ray, ray_flag_none, kLightRayMask,
                                                                   Policy::ignore);
            REQUIRE(fast_w.candidates.size() == book_w.candidates.size());
            for (std::size_t k = 0; k < book_w.candidates.size(); ++k) {
                const TraceHit &a = fast_w.candidates[k], &b = book_w.candidates[k];
                CHECK(a.instance_index == b.instance_index);
                CHECK(a.primitive_index == b.primitive_index);
                CHECK(a.kind == b.kind);
                CHECK(std::abs(double(a.t) - double(b.t)) <= kWorldSphereT * std::abs(double(b.t)));
            }
            check_same_counters(fast_w.result.counters, book_w.result.counters);
            ++rays;
            candidates += book.candidates.size();
        }
    }
    CHECK(rays > 1000);
    CHECK(candidates > 10 * rays);
}

namespace {

// Every candidate of each ray of a bundle of light rays (kBundleWidth neighbours, as the optical-depth pass
// groups them), against the textbook ray by ray.
void check_bundle(const AccelScene& scene, const RayBundle& bundle, std::uint32_t flags, std::uint8_t mask,
                  TraceLimits limits) {
    std::vector<TraceHit> got[kBundleWidth];
    const BundleResults results = trace_bundle(scene, bundle, flags, mask, [&](unsigned lane, const TraceHit& h) {
        got[lane].push_back(h);
        return AnyHitDecision::ignore;
    }, limits);
    for (unsigned lane = 0; lane < bundle.count; ++lane) {
        CAPTURE(lane);
        check_same_outcome(Seen{got[lane], results[lane]},
                           textbook_seen(scene, bundle.ray(lane), flags, mask, Policy::ignore, limits));
    }
}

// The camera rays of a tile under `policy` (ignore or accept), against the textbook ray by ray.
void check_tile(const AccelScene& scene, const RayTile& start, std::uint32_t flags, std::uint8_t mask, Policy policy) {
    TileScratch scratch;
    TileResults results;
    RayTile tile = start;
    std::vector<TraceHit> got[kTileRays];
    trace_tile(scene, tile, flags, mask, [&](unsigned lane, const TraceHit& h) {
        got[lane].push_back(h);
        return decide(policy, got[lane].size() - 1);
    }, results, scratch);
    for (unsigned r = 0; r < start.rows(); ++r)
        for (unsigned c = 0; c < start.columns(); ++c) {
            const unsigned lane = RayTile::lane(c, r);
            CAPTURE(c, r);
            const Seen book = textbook_seen(scene, start.ray(lane), flags, mask, policy);
            if (policy == Policy::ignore) check_same_outcome(Seen{got[lane], results[lane]}, book, false);
            REQUIRE(results[lane].hit == book.result.hit);
            if (book.result.hit) CHECK(same_hit(results[lane].committed, book.result.committed));
        }
}

}  // namespace

TEST_CASE("textbook trace: trace_bundle() gives the shipped scenes' light rays the textbook's candidates",
          "[textbook][trace]") {
    for (const auto& file : shipped_scenes()) {
        CAPTURE(file.string());
        const Shipped s = load_shipped(file);
        const AccelScene general = object_space_copy(s.smoke.scene());
        const auto& particles = s.desc.smoke.particles;
        for (const std::uint32_t cutoff : {0u, s.desc.render.cutoff, 3u}) {
            // Bundles of consecutive particles: the tubes' particles lie in order, so these are neighbours.
            for (std::size_t first = 0; first < particles.size(); first += kBundleWidth) {
                RayBundle bundle(glm::normalize(s.desc.light.direction));
                for (std::size_t i = first; i < std::min(particles.size(), first + kBundleWidth); ++i) {
                    const Ray r = light_ray(s.desc, particles[i]);
                    bundle.add(r.origin, r.tmin, r.tmax);
                }
                check_bundle(general, bundle, ray_flag_none, kLightRayMask, TraceLimits{cutoff});
            }
        }
    }
}

TEST_CASE("textbook trace: the shipped scenes' camera rays, one by one and by tiles", "[textbook][trace]") {
    std::size_t candidates = 0;
    for (const auto& file : shipped_scenes()) {
        CAPTURE(file.string());
        const Shipped s = load_shipped(file);
        const AccelScene general = object_space_copy(s.smoke.scene());
        const auto& cam = s.desc.camera;
        const Camera camera(cam.position, cam.look_at, cam.up, cam.fov_deg, 48, 48);
        for (int y = 0; y < 48; ++y)
            for (int x = 0; x < 48; ++x) {
                CAPTURE(x, y);
                const Ray ray = camera.ray(x, y, 1e-3f);
                for (const Policy p : {Policy::ignore, Policy::accept, Policy::end_at_third, Policy::alternate}) {
                    const Seen book = textbook_seen(general, ray, ray_flag_none, kViewRayMask, p);
                    check_same_search(fast_seen<TlasWalk::nearest_first>(general, ray, ray_flag_none, kViewRayMask, p),
                                      book);
                    if (p == Policy::ignore) candidates += book.candidates.size();
                }
            }
        for (int y0 = 0; y0 < 48; y0 += int(kTileRows))
            for (int x0 = 0; x0 < 48; x0 += int(kTileColumns))
                for (const Policy p : {Policy::ignore, Policy::accept})
                    check_tile(general, camera.tile(x0, y0, int(kTileColumns), int(kTileRows), glm::vec2(0.5f), 1e-3f),
                               ray_flag_none, kViewRayMask, p);
    }
    CHECK(candidates > 48 * 48);
}

namespace {

// Spheres nested (one centre, three radii), overlapping and far apart in one sphere-set BLAS (a binary tree of
// several leaves, walked alike by both).
std::vector<Sphere> sphere_cluster() {
    std::vector<Sphere> s = {{{0, 0, 0}, 1.0f}, {{0, 0, 0}, 0.5f}, {{0, 0, 0}, 0.25f}, {{0.6f, 0, 0}, 0.5f},
                             {{-0.6f, 0.1f, 0}, 0.5f}};
    for (int k = 0; k < 12; ++k) s.push_back({{1.5f * float(k % 4) - 2.0f, 1.5f * float(k / 4) - 1.5f, 2.0f}, 0.4f});
    return s;
}

// An adversarial scene: nested and overlapping spheres (a multi-leaf sphere set, and single spheres under
// similarity and general transforms), icosahedra (one-leaf meshes), glass and opaque quads, opaque balls;
// masks 1, 2, 4, 8 and every combination of the four instance flags.
AccelScene adversarial_scene(Pcg32& rng, InstancePaths paths) {
    AccelScene s(paths);
    const std::uint32_t blas[] = {
        s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1.0f}}, false)),
        s.add_bottom_level(BottomLevel::from_spheres(sphere_cluster(), false)),
        s.add_bottom_level(BottomLevel::from_mesh(make_icosahedron(1.0f), false)),
        s.add_bottom_level(BottomLevel::from_mesh(test::quad(), false)),
        s.add_bottom_level(BottomLevel::from_mesh(test::quad(), true)),
        s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0.1f, 0, 0}, 0.5f}}, true)),
    };
    for (int i = 0; i < 120; ++i) {
        const int kind = i % 6;
        const AffineTransform m = test::random_transform(rng, kind == 0 ? i % 12 < 6 : kind == 5, i);
        s.add_instance(Instance{blas[kind], m, std::uint8_t(1u << (i % 4)), std::uint32_t(1000 + i),
                                std::uint8_t((i / 6) % 16)});
    }
    s.commit();
    return s;
}

// Rays that make trouble: toward a random instance's centre; grazing a unit sphere (instances 0, 6, 12, …),
// past its rim by 2^-8 … 2^-30 of its radius, either side; through a vertex or an edge's midpoint of an
// icosahedron (instances 2, 8, 14, …), where ray_triangle.hpp's tie-break decides.
Ray adversarial_ray(Pcg32& rng, const AccelScene& s, int k) {
    const std::uint32_t kinds = std::uint32_t(s.instance_count()) / 6;
    glm::dvec3 from(rng.uniform(-25, 25), rng.uniform(-25, 25), rng.uniform(-25, 25));
    glm::dvec3 target(0.0);
    if (k % 3 == 0) {
        target = s.transform(rng.below(std::uint32_t(s.instance_count()))).translation;
    } else if (k % 3 == 1) {
        const AffineTransform m = s.transform(6 * rng.below(kinds));
        const glm::dvec3 u(test::random_unit(rng));
        glm::dvec3 d = glm::cross(u, glm::dvec3(test::random_unit(rng)));
        d = glm::normalize(d);
        const glm::dvec3 closest = u * (1.0 + (k % 2 ? 1.0 : -1.0) * std::ldexp(1.0, -8 - k % 23));
        from = m.point(closest - 20.0 * d);  // the object-space ray passes `closest` at right angles
        target = m.point(closest);
    } else {
        const AffineTransform m = s.transform(6 * rng.below(kinds) + 2);
        const TriangleMesh ico = make_icosahedron(1.0f);
        const glm::uvec3 tri = ico.triangles[rng.below(std::uint32_t(ico.triangles.size()))];
        const glm::dvec3 a(ico.vertices[tri.x]), b(ico.vertices[tri.y]);
        target = m.point(k % 2 ? a : 0.5 * (a + b));
    }
    return Ray{glm::vec3(from), 0.0f, glm::vec3(target - from), kInf};
}

}  // namespace

TEST_CASE("textbook trace: adversarial rays, every ray flag, masks, cutoffs at K and K + 1, accept-and-end",
          "[textbook][trace]") {
    Pcg32 rng(34);
    const AccelScene general = adversarial_scene(rng, InstancePaths::object_space_only);
    std::size_t candidates = 0, cut = 0;
    for (int k = 0; k < 3000; ++k) {
        const Ray ray = adversarial_ray(rng, general, k);
        const std::uint32_t flags = std::uint32_t(k) % 256;  // every combination of the eight ray flags
        const std::uint8_t mask = k % 7 == 0 ? 0xFF : std::uint8_t(rng.below(256));
        CAPTURE(k, flags, int(mask));
        const Seen all = textbook_seen(general, ray, flags, mask, Policy::ignore);
        const std::uint32_t n = all.result.counters.any_hit_invocations;
        candidates += n;
        for (const Policy p : {Policy::ignore, Policy::accept, Policy::end_at_third, Policy::alternate})
            for (const std::uint32_t K : {0u, n, n > 0 ? n - 1 : 0u}) {
                CAPTURE(int(p), K);
                const Seen book = textbook_seen(general, ray, flags, mask, p, TraceLimits{K});
                check_same_search(fast_seen<TlasWalk::nearest_first>(general, ray, flags, mask, p, TraceLimits{K}),
                                  book);
                // Another order commits another hit first, so ACCEPT_FIRST_HIT_AND_END_SEARCH ends elsewhere.
                if ((p == Policy::ignore || p == Policy::accept) && !(flags & ray_flag_accept_first_hit_and_end_search))
                    check_same_outcome(fast_seen<TlasWalk::all_hits>(general, ray, flags, mask, p, TraceLimits{K}),
                                       book);
                if (p != Policy::ignore || K == 0) continue;
                // The cutoff: exactly K candidates are never cut off; the (K + 1)-th ends the search uncalled.
                CHECK(book.result.cut_off == (K < n));
                CHECK(book.result.counters.any_hit_invocations == K);
                cut += book.result.cut_off;
            }
        // SKIP_CLOSEST_HIT_SHADER leaves the committed hit default; ACCEPT_FIRST_HIT_AND_END_SEARCH commits once.
        if (flags & ray_flag_skip_closest_hit_shader) CHECK(same_hit(all.result.committed, TraceHit{}));
        if (flags & ray_flag_accept_first_hit_and_end_search) CHECK(all.result.counters.hits_accepted <= 1);
    }
    CHECK(candidates > 3000);
    CHECK(cut > 300);
}

TEST_CASE("textbook trace: a ray through a shared vertex or edge of a closed mesh crosses it once each way",
          "[textbook][trace]") {
    // An icosphere of 320 triangles (a BLAS of several leaves: the fast trace walks its wide tree, so the
    // candidates are compared as sets) under the identity, so that a ray aimed at a vertex or an edge's midpoint
    // from outside meets it exactly (float vertices; a midpoint of two floats is rounded, and may fall in a face).
    const TriangleMesh mesh = make_icosphere(2, 1.0f);
    for (const InstancePaths paths : {InstancePaths::object_space_only, InstancePaths::fastest}) {
        AccelScene s(paths);
        s.add_instance(Instance{s.add_bottom_level(BottomLevel::from_mesh(mesh, false)), AffineTransform{}, 0xFF, 7, 0});
        s.commit();
        Pcg32 rng(7);
        std::size_t rays = 0;
        for (const glm::uvec3& tri : mesh.triangles)
            for (int k = 0; k < 6; ++k) {
                const glm::vec3 a = mesh.vertices[tri[k % 3]], b = mesh.vertices[tri[(k + 1) % 3]];
                const glm::vec3 target = k < 3 ? a : 0.5f * (a + b);
                // From outside, toward the centre's side, so that the ray enters at the target and leaves elsewhere.
                const glm::vec3 from = 3.0f * target + 0.5f * test::random_unit(rng);
                const Ray ray{from, 0.0f, target - from, kInf};
                CAPTURE(rays, k);
                const Seen book = textbook_seen(s, ray, ray_flag_none, 0xFF, Policy::ignore);
                REQUIRE(book.candidates.size() == 2);
                CHECK(book.candidates[0].kind != book.candidates[1].kind);  // one front face, one back face
                check_same_outcome(fast_seen<TlasWalk::nearest_first>(s, ray, ray_flag_none, 0xFF, Policy::ignore), book);
                check_same_outcome(fast_seen<TlasWalk::all_hits>(s, ray, ray_flag_none, 0xFF, Policy::ignore), book);
                ++rays;
            }
        CHECK(rays == 6 * mesh.triangles.size());
    }
}

TEST_CASE("textbook trace: the fast walks reach the leaves textbook::walk_bvh reaches", "[textbook][trace]") {
    // traverse_bvh(): the same leaves in the same order with the same counts, also when a leaf lowers tmax;
    // the wide walks (the TLAS's and a mesh BLAS's): the same leaves, as sets, while tmax stays.
    Pcg32 rng(5);
    const AccelScene scene = adversarial_scene(rng, InstancePaths::object_space_only);
    const TriangleMesh mesh = make_icosphere(3, 2.0f);
    const MeshBlas blas(mesh);
    using Leaf = std::pair<std::uint32_t, std::uint32_t>;
    for (int k = 0; k < 2000; ++k) {
        CAPTURE(k);
        const bool in_mesh = k % 2 == 1;
        const glm::vec3 from(rng.uniform(-25, 25), rng.uniform(-25, 25), rng.uniform(-25, 25));
        const glm::vec3 to = in_mesh ? 2.2f * test::random_unit(rng) : glm::vec3(test::random_unit(rng)) * 10.0f;
        const Ray ray{from, 0.0f, to - from, kInf};
        const Bvh& bvh = in_mesh ? blas.bvh() : scene.tlas();
        const std::uint8_t mask = std::uint8_t(rng.below(256));
        auto admit = [&](std::uint32_t node) { return in_mesh || (scene.tlas_node_masks()[node] & mask) != 0; };
        for (const bool shrink : {false, true}) {
            // Every third leaf lowers tmax, as a commit there would.
            std::vector<Leaf> book, fast;
            float tmax_book = kInf, tmax_fast = kInf;
            auto leaf_of = [&](std::vector<Leaf>& seen, float& tmax) {
                return [&, shrink](std::uint32_t first, std::uint32_t count) {
                    seen.push_back({first, count});
                    if (shrink && seen.size() % 3 == 0) tmax = std::min(tmax, 40.0f - float(seen.size()));
                    return false;
                };
            };
            std::uint32_t nodes = 0, boxes = 0;
            textbook::walk_bvh(bvh, ray, tmax_book, admit, leaf_of(book, tmax_book), nodes, boxes);
            TraversalStats stats;
            traverse_bvh(bvh, BoxRay(ray), tmax_fast, leaf_of(fast, tmax_fast), stats, admit);
            CHECK(fast == book);
            CHECK(stats.nodes_visited == nodes);
            CHECK(stats.boxes_tested == boxes);
            if (shrink) continue;
            std::vector<Leaf> wide;
            auto collect = [&](std::uint32_t first, std::uint32_t count) {
                wide.push_back({first, count});
                return false;
            };
            TraversalStats wide_stats;
            if (in_mesh) {
                traverse_blas_wide<BlasWalkOrder::any_order>(blas.wide(), BoxRay(ray), tmax_fast, collect, wide_stats);
                for (Leaf& l : book) l.first = blas.leaf_block(l.first);  // a wide leaf names its first block
            } else {
                traverse_wide_bvh(scene.wide_tlas(), BoxRay(ray), tmax_fast, mask, collect, wide_stats);
            }
            std::sort(book.begin(), book.end());
            std::sort(wide.begin(), wide.end());
            CHECK(wide == book);
        }
    }
}

TEST_CASE("textbook trace: a BLAS's own queries are the textbook's for one instance under the identity",
          "[textbook][trace]") {
    const TriangleMesh mesh = make_icosphere(2, 1.5f);
    const BottomLevel meshes = BottomLevel::from_mesh(mesh, false);
    const BottomLevel spheres = BottomLevel::from_spheres(sphere_cluster(), false);
    Pcg32 rng(3);
    for (const BottomLevel* b : {&meshes, &spheres}) {
        AccelScene scene(InstancePaths::object_space_only);
        scene.add_instance(Instance{scene.add_bottom_level(*b), AffineTransform{}, 0xFF, 0, 0});
        scene.commit();
        for (int k = 0; k < 1000; ++k) {
            CAPTURE(k);
            const glm::vec3 from = 8.0f * test::random_unit(rng);
            const Ray ray{from, 0.0f, 2.0f * test::random_unit(rng) - from, kInf};
            const Seen book = textbook_seen(scene, ray, ray_flag_none, 0xFF, Policy::ignore);
            const Seen closest = textbook_seen(scene, ray, ray_flag_none, 0xFF, Policy::accept);
            std::vector<test::HitKey> seen;
            BlasHit best, none;
            BlasCounters counters;
            auto ignore = [&](const BlasHit& h) {
                seen.push_back({0u, h.primitive, h.front_face ? HitKind::front_face : HitKind::back_face,
                                std::bit_cast<std::uint32_t>(h.t)});
                return AnyHitDecision::ignore;
            };
            const bool triangles = b->kind == GeometryKind::triangles;
            const bool found = triangles ? closest_hit(b->mesh, ray, best, counters)
                                         : closest_hit(b->spheres, ray, best, counters);
            if (triangles) any_hit_traversal(b->mesh, ray, ignore, none, counters);
            else any_hit_traversal(b->spheres, ray, ignore, none, counters);
            std::sort(seen.begin(), seen.end());
            CHECK(seen == bound_candidates(book));
            REQUIRE(found == closest.result.hit);
            if (!found) continue;
            CHECK(same_bits(best.t, closest.result.committed.t));
            CHECK(best.primitive == closest.result.committed.primitive_index);
            CHECK(same_bits(best.barycentrics.x, closest.result.committed.barycentrics.x));
            CHECK(same_bits(best.barycentrics.y, closest.result.committed.barycentrics.y));
        }
    }
}
