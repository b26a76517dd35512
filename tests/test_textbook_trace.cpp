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
#include <smoketrace/textbook/trace.hpp>
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

// A ray's candidates, in the order met, and its result.
struct Seen {
    std::vector<TraceHit> candidates;
    TraceResult result;
};

template <class Run>
Seen record(Policy p, Run&& run) {
    Seen s;
    s.result = run([&s, p](const TraceHit& h) {
        s.candidates.push_back(h);
        return decide(p, s.candidates.size() - 1);
    });
    return s;
}

Seen textbook_seen(const AccelScene& scene, const Ray& ray, std::uint32_t flags, std::uint8_t mask, Policy p,
                   TraceLimits limits = {}) {
    return record(p, [&](auto&& any_hit) { return textbook::trace(scene, ray, flags, mask, any_hit, limits); });
}
template <TlasWalk Walk>
Seen fast_seen(const AccelScene& scene, const Ray& ray, std::uint32_t flags, std::uint8_t mask, Policy p,
               TraceLimits limits = {}) {
    return record(p, [&](auto&& any_hit) { return trace<Walk>(scene, ray, flags, mask, any_hit, limits); });
}

bool same_bits(float a, float b) { return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b); }
bool same_hit(const TraceHit& a, const TraceHit& b) {
    return same_bits(a.t, b.t) && same_bits(a.barycentrics.x, b.barycentrics.x) &&
           same_bits(a.barycentrics.y, b.barycentrics.y) && same_bits(a.object_point.x, b.object_point.x) &&
           same_bits(a.object_point.y, b.object_point.y) && same_bits(a.object_point.z, b.object_point.z) &&
           a.instance_index == b.instance_index && a.instance_id == b.instance_id &&
           a.primitive_index == b.primitive_index && a.kind == b.kind && a.geometry == b.geometry;
}

void check_same_counters(const TraceCounters& a, const TraceCounters& b) {
    CHECK(a.tlas_nodes == b.tlas_nodes);
    CHECK(a.blas_nodes == b.blas_nodes);
    CHECK(a.boxes_tested == b.boxes_tested);
    CHECK(a.instances_entered == b.instances_entered);
    CHECK(a.primitives_tested == b.primitives_tested);
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
    check_same_counters(fast.result.counters, book.result.counters);
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
// order, under the ignore and accept policies (whose outcome does not depend on the order).
void check_same_outcome(const Seen& fast, const Seen& book) {
    CHECK(bound_candidates(fast) == bound_candidates(book));
    REQUIRE(fast.result.hit == book.result.hit);
    CHECK(fast.result.cut_off == book.result.cut_off);
    if (book.result.hit) CHECK(same_hit(fast.result.committed, book.result.committed));
    if (!book.result.hit) {  // nothing shrank tmax: the same work, counted the same
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
