// trace_tile(): camera rays traced a tile at a time must each see exactly what trace() shows them alone; and
// the mesh BLAS's tile query (closest hit) what closest_hit() shows each ray alone.
//
// The kernel first, lane by lane against the scalar shear it stands for (bit for bit, no tolerance: the same
// operations), on rays through triangle edges and vertices too. Then tiles against trace() on a random scene
// of every instance kind and on smoke scenes (the shipped ones and adversarial ones: billboards at the same
// depth, a billboard's shared diagonal through a pixel centre, the eye inside the smoke), compared on what
// DXR fixes whatever the order: the candidates when every one is ignored (t bit for bit), the closest hit,
// a first-hit end and the cutoff.
#include <smoketrace/geometry/ray_triangle_tile.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/render/camera.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/trace/blas_tile_traversal.hpp>
#include <smoketrace/trace/trace.hpp>
#include <smoketrace/trace/trace_tile.hpp>

#include <catch2/catch.hpp>

#include "support/fixtures.hpp"
#include "support/mixed_scene.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <filesystem>
#include <limits>
#include <vector>

using namespace smoketrace;
using namespace smoketrace::test;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

bool same_bits(float a, float b) { return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b); }
bool same_bits(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

// Every ray of `tile` against trace(): candidates (every one ignored), the closest hit (every one accepted,
// the flags as given), a first-hit end and a cutoff of `cutoff` any-hit calls. Returns the candidates seen.
std::size_t check_tile(const AccelScene& scene, RayTile tile, std::uint32_t extra_flags, std::uint8_t mask,
                       std::uint32_t cutoff) {
    TileScratch scratch;
    TileResults results;
    std::size_t seen = 0, ties = 0;
    const RayTile start = tile;
    {
        std::vector<HitKey> got[kTileRays];
        RayTile t = start;
        trace_tile(scene, t, ray_flag_force_non_opaque | extra_flags, mask,
                   [&](unsigned lane, const TraceHit& h) {
                       got[lane].push_back(key_of(h));
                       return AnyHitDecision::ignore;
                   },
                   results, scratch);
        for (unsigned r = 0; r < kTileRows; ++r)
            for (unsigned c = 0; c < kTileColumns; ++c) {
                const unsigned lane = RayTile::lane(c, r);
                if (r >= tile.rows() || c >= tile.columns()) {
                    CHECK(got[lane].empty());
                    continue;
                }
                std::vector<HitKey> expected;
                trace(scene, start.ray(lane), ray_flag_force_non_opaque | extra_flags, mask, [&](const TraceHit& h) {
                    expected.push_back(key_of(h));
                    return AnyHitDecision::ignore;
                });
                std::sort(got[lane].begin(), got[lane].end());
                std::sort(expected.begin(), expected.end());
                CAPTURE(c, r);
                CHECK(got[lane] == expected);
                CHECK(results[lane].counters.any_hit_invocations == expected.size());
                seen += expected.size();
            }
    }
    for (const std::uint32_t flags :
         {extra_flags, extra_flags | std::uint32_t(ray_flag_accept_first_hit_and_end_search)}) {
        RayTile t = start;
        trace_tile(scene, t, flags, mask, [](unsigned, const TraceHit&) { return AnyHitDecision::accept; }, results,
                   scratch);
        for (unsigned r = 0; r < tile.rows(); ++r)
            for (unsigned c = 0; c < tile.columns(); ++c) {
                const unsigned lane = RayTile::lane(c, r);
                const TraceResult alone = trace(scene, start.ray(lane), flags, mask);
                CAPTURE(c, r, flags);
                REQUIRE(results[lane].hit == alone.hit);
                if (!alone.hit || (flags & ray_flag_accept_first_hit_and_end_search)) continue;
                const TraceHit got = results[lane].committed;
                CHECK(same_bits(got.t, alone.committed.t));
                CHECK(t.tmax(lane) == alone.committed.t);
                if (key_of(got) == key_of(alone.committed)) continue;
                // A tie: two surfaces at exactly that t, committed in the order met. The tile's must be one
                // of the ray's candidates there.
                bool candidate = false;
                trace(scene, start.ray(lane), flags | ray_flag_force_non_opaque, mask, [&](const TraceHit& h) {
                    candidate = candidate || key_of(h) == key_of(got);
                    return AnyHitDecision::ignore;
                });
                CHECK(candidate);
                ++ties;
            }
    }
    {
        RayTile t = start;
        trace_tile(scene, t, ray_flag_force_non_opaque | extra_flags, mask,
                   [](unsigned, const TraceHit&) { return AnyHitDecision::ignore; }, results, scratch,
                   TraceLimits{cutoff});
        for (unsigned r = 0; r < tile.rows(); ++r)
            for (unsigned c = 0; c < tile.columns(); ++c) {
                const unsigned lane = RayTile::lane(c, r);
                const TraceResult alone = trace(scene, start.ray(lane), ray_flag_force_non_opaque | extra_flags, mask,
                                                [](const TraceHit&) { return AnyHitDecision::ignore; },
                                                TraceLimits{cutoff});
                CHECK(results[lane].cut_off == alone.cut_off);
            }
    }
    // Ties are the exception: billboards sharing a centre (the adversarial scene below) make them.
    CHECK(ties <= seen / 4);
    return seen;
}

// The shipped scene's smoke, billboards turned to its camera.
struct SmokeView {
    std::vector<Particle> particles;
    SmokeScene scene;
    Camera camera;
};

SmokeView smoke_view(std::vector<Particle> particles, const std::optional<GroundQuad>& ground, const glm::vec3& eye,
                     const glm::vec3& look_at, float fov, int size) {
    SmokeScene scene(particles, StandInShape{}, ground, true);
    scene.update(particles, eye);
    return SmokeView{std::move(particles), std::move(scene), Camera(eye, look_at, glm::vec3(0, 1, 0), fov, size, size)};
}

constexpr std::uint8_t kOpaqueView = kViewRayMask & std::uint8_t(~kBillboardMask);

// A view along axis k % 3 (the negative way for even k) from a random eye, with image-plane offsets whose middle
// column and row are x = y = 0 exactly: the tile's middle ray is the axis itself, and triangles with an edge or a
// vertex on it give float edge functions of exactly 0 (the double path).
struct AxisView {
    glm::vec3 eye, forward{0.0f}, right{0.0f}, up{0.0f};
    float x[kTileColumns], y[kTileRows];

    AxisView(Pcg32& rng, int k) {
        const float spread = rng.uniform(0.01f, 1.5f);
        for (unsigned i = 0; i < kTileColumns; ++i) x[i] = spread * (float(int(i) - 8) / 8.0f);
        for (unsigned i = 0; i < kTileRows; ++i) y[i] = spread * (float(8 - int(i)) / 8.0f);
        const int axis = k % 3;
        forward[axis] = k % 2 ? 1.0f : -1.0f;
        right[(axis + 1) % 3] = 1.0f;
        up[(axis + 2) % 3] = 1.0f;
        eye = glm::vec3(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3));
    }
    [[nodiscard]] RayTile tile() const { return RayTile(eye, forward, right, up, x, kTileColumns, y, kTileRows, 0.0f); }
    // Triangle j of a run in front of the eye: every even one has a vertex at `on_axis` (a point on the middle
    // ray), every fourth from the second an edge through it.
    void triangle(Pcg32& rng, const glm::vec3& on_axis, int j, glm::vec3 (&v)[3]) const {
        for (glm::vec3& p : v)
            p = eye + forward * rng.uniform(0.5f, 9.0f) + right * rng.uniform(-4, 4) + up * rng.uniform(-4, 4);
        if (j % 2 == 0) v[j % 3] = on_axis;
        if (j % 4 == 1) v[1] = on_axis + (v[0] - on_axis) * -1.0f;
    }
};

// A 256² camera at a random point within `reach` of the origin, looking a random way, with a random field of
// view (5° to 120°).
Camera random_camera(Pcg32& rng, float reach) {
    const glm::vec3 eye = rng.uniform(0.0f, reach) * random_unit(rng);
    const glm::vec3 at = eye + random_unit(rng);
    const glm::vec3 up = std::abs(glm::normalize(at - eye).y) > 0.99f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    return Camera(eye, at, up, rng.uniform(5.0f, 120.0f), 256, 256);
}

// Every tile of the view, billboards (every candidate) and the opaque surface (closest hit).
std::size_t check_smoke_view(const SmokeView& v, glm::vec2 offset) {
    std::size_t seen = 0;
    const Camera& cam = v.camera;
    for (int y0 = 0; y0 < cam.height(); y0 += int(kTileRows))
        for (int x0 = 0; x0 < cam.width(); x0 += int(kTileColumns)) {
            const int cols = std::min(int(kTileColumns), cam.width() - x0),
                      rows = std::min(int(kTileRows), cam.height() - y0);
            const RayTile tile = cam.tile(x0, y0, cols, rows, offset, 1e-3f);
            CAPTURE(x0, y0);
            seen += check_tile(v.scene.scene(), tile, ray_flag_none, kBillboardMask, 3);
            check_tile(v.scene.scene(), tile, ray_flag_force_opaque, kOpaqueView, 1);
        }
    return seen;
}

}  // namespace

TEST_CASE("ray tile: lane (c, r) is the camera's ray of that pixel, bit for bit", "[trace-tile]") {
    const Camera cam(glm::vec3(1, 2, 9), glm::vec3(0.2f, 0.1f, -1), glm::vec3(0, 1, 0), 50.0f, 70, 45);
    for (int y0 : {0, 16, 32})
        for (int x0 : {0, 16, 64}) {
            const int cols = std::min(16, 70 - x0), rows = std::min(16, 45 - y0);
            const RayTile tile = cam.tile(x0, y0, cols, rows, glm::vec2(0.5f), 1e-3f);
            REQUIRE(tile.columns() == unsigned(cols));
            for (int r = 0; r < rows; ++r)
                for (int c = 0; c < cols; ++c) {
                    const Ray a = tile.ray(RayTile::lane(c, r)), b = cam.ray(x0 + c, y0 + r, 1e-3f);
                    CAPTURE(x0, y0, c, r);
                    CHECK(std::memcmp(&a, &b, sizeof(Ray)) == 0);
                }
        }
}

TEST_CASE("ray tile: shear_lanes() and finish_lanes() are the scalar test lane by lane, through edges and vertices too",
          "[trace-tile]") {
    // Tiles whose middle column and row have x = y = 0 exactly, looking along an axis: their middle ray is
    // the axis itself, and triangles with an edge or a vertex on that axis give float edge functions of
    // exactly 0 (the double path). Random triangles around them, some sharing that vertex.
    Pcg32 rng(23);
    constexpr unsigned W = simd::kFloatLanes;
    std::size_t kept = 0, zero_edges = 0, finished = 0, finished_on_edge = 0;
    for (int k = 0; k < 400; ++k) {
        const AxisView view(rng, k);
        const glm::vec3& eye = view.eye;
        const RayTile tile = view.tile();
        const TileTriangleRays rays(tile);
        if (!rays.shared_axes) continue;
        const glm::vec3 on_axis = eye + view.forward * rng.uniform(1.0f, 9.0f);
        for (int j = 0; j < 20; ++j) {
            glm::vec3 v[3];
            view.triangle(rng, on_axis, j, v);
            const glm::dvec3 normal = triangle_normal(v[0], v[1], v[2]);
            const glm::dvec3 p = glm::dvec3(v[0]) - glm::dvec3(eye);
            const double n_dot_p = normal.x * p.x + normal.y * p.y + normal.z * p.z;
            for (unsigned first = 0; first < kTileRays; first += W) {
                ShearedLanes<W> out{};
                const unsigned keep = shear_lanes<W>(rays, first, W == 32 ? ~0u : (1u << W) - 1u,
                                                     relative(rays, eye, v[0], v[1], v[2]), out);
                // finish_lanes() against finish_triangle_hit(), lane by lane.
                FinishedLanes<W> done{};
                finish_lanes<W>(tile, first, keep, out, normal, n_dot_p, done);
                CHECK((done.hit & done.on_edge) == 0);
                CHECK(((done.hit | done.on_edge) & ~keep) == 0);
                for (unsigned m = keep; m != 0; m &= m - 1) {
                    const unsigned i = unsigned(std::countr_zero(m));
                    TriangleHit expected{};
                    const bool hit = finish_triangle_hit(rays.ray(first + i), out.lane(i), v[0], normal,
                                                         tile.tmax(first + i), expected);
                    CAPTURE(k, j, first, i);
                    if (done.on_edge >> i & 1u) {
                        ++finished_on_edge;
                        continue;
                    }
                    const float t = static_cast<float>(done.t[i]);
                    REQUIRE(bool(done.hit >> i & 1u && t >= tile.tmin() && t <= tile.tmax(first + i)) == hit);
                    if (!hit) continue;
                    ++finished;
                    CHECK(same_bits(t, expected.t));
                    const glm::vec2 b = lane_barycentrics(out, i);
                    CHECK(same_bits(b.x, expected.barycentrics.x));
                    CHECK(same_bits(b.y, expected.barycentrics.y));
                    CHECK(bool(done.front >> i & 1u) == expected.front_face);
                }
                for (unsigned i = 0; i < W; ++i) {
                    const TriangleRay alone(tile.ray(first + i)), from_table = rays.ray(first + i);
                    REQUIRE(std::memcmp(&alone, &from_table, sizeof(TriangleRay)) == 0);
                    const ShearedTriangle s = shear_triangle(alone, v[0], v[1], v[2]);
                    CAPTURE(k, j, first, i);
                    REQUIRE(bool(keep >> i & 1u) == !straddles(s));
                    CHECK(same_bits(out.ax[i], s.ax));
                    CHECK(same_bits(out.ay[i], s.ay));
                    CHECK(same_bits(out.bx[i], s.bx));
                    CHECK(same_bits(out.by[i], s.by));
                    CHECK(same_bits(out.cx[i], s.cx));
                    CHECK(same_bits(out.cy[i], s.cy));
                    zero_edges += (s.u == 0.0) + (s.v == 0.0) + (s.w == 0.0);
                    if (!(keep >> i & 1u)) continue;
                    ++kept;
                    CHECK(same_bits(out.u[i], s.u));
                    CHECK(same_bits(out.v[i], s.v));
                    CHECK(same_bits(out.w[i], s.w));
                }
            }
        }
    }
    CHECK(kept > 10000);
    CHECK(zero_edges > 100);
    CHECK(finished > 5000);
    CHECK(finished_on_edge > 50);
}

TEST_CASE("trace_tile: every ray of a tile meets what trace() shows it alone (every instance kind)", "[trace-tile]") {
    Pcg32 rng(57);
    const AccelScene s = mixed_scene(rng);
    std::size_t seen = 0;
    for (int k = 0; k < 24; ++k) {
        const glm::vec3 eye = 45.0f * random_unit(rng);
        const glm::vec3 at(rng.uniform(-8, 8), rng.uniform(-8, 8), rng.uniform(-8, 8));
        const int size = 40 + int(rng.below(60));
        const Camera cam(eye, at, glm::vec3(0, 1, 0), rng.uniform(10.0f, 90.0f), size, size);
        const int x0 = int(rng.below(unsigned(size))), y0 = int(rng.below(unsigned(size)));
        const int cols = std::min(int(kTileColumns), size - x0), rows = std::min(int(kTileRows), size - y0);
        RayTile tile =
            cam.tile(x0, y0, cols, rows, glm::vec2(rng.uniform01(), rng.uniform01()), rng.uniform(0.0f, 40.0f));
        // Some rays end early, as a pixel's ground does.
        for (unsigned lane = 0; lane < kTileRays; ++lane)
            if (rng.below(4) == 0) tile.set_tmax(lane, rng.uniform(30.0f, 60.0f));
        const std::uint8_t mask = std::uint8_t(1u + rng.below(7));
        const std::uint32_t flags = k % 3 == 1   ? ray_flag_cull_back_facing_triangles
                                    : k % 3 == 2 ? ray_flag_cull_front_facing_triangles
                                                 : ray_flag_none;
        CAPTURE(k);
        seen += check_tile(s, tile, flags, mask, 1 + rng.below(4));
    }
    CHECK(seen > 2000);
}

TEST_CASE("trace_tile: the shipped scenes' camera rays meet the billboards and ground trace() shows them",
          "[trace-tile]") {
    std::size_t seen = 0;
    for (const char* name : {"two_tubes_above.json", "two_tubes_right.json"}) {
        const SceneDescription d =
            load_scene_file(std::filesystem::path(SMOKETRACE_ASSET_DIR) / "scenes" / name);
        std::optional<GroundQuad> ground;
        if (d.ground) ground = GroundQuad{d.ground->corners};
        const SmokeView v = smoke_view(d.smoke.particles, ground, d.camera.position, d.camera.look_at,
                                       d.camera.fov_deg, 64);
        CAPTURE(name);
        seen += check_smoke_view(v, glm::vec2(0.5f));
        seen += check_smoke_view(v, glm::vec2(0.125f, 0.875f));
    }
    CHECK(seen > 20000);
}

TEST_CASE("trace_tile: billboards at the same depth, a diagonal through a pixel centre, the eye in the smoke",
          "[trace-tile]") {
    const GroundQuad ground{
        {glm::vec3(-20, -3, 20), glm::vec3(20, -3, 20), glm::vec3(20, -3, -20), glm::vec3(-20, -3, -20)}};
    SECTION("the same depth: particles sharing a centre, and on a sphere around the eye") {
        std::vector<Particle> ps;
        for (int i = 0; i < 6; ++i) {
            Particle p = particle(glm::vec3(0.3f, 0.2f, -6.0f), 0.5f + 0.25f * float(i));
            p.rotation = 0.4f * float(i);
            ps.push_back(p);
        }
        for (int i = 0; i < 40; ++i) {
            const float a = 0.05f * float(i);
            ps.push_back(particle(8.0f * glm::vec3(std::sin(a) * 0.3f, std::cos(a) * 0.2f, -1.0f) /
                                      glm::length(glm::vec3(std::sin(a) * 0.3f, std::cos(a) * 0.2f, -1.0f)),
                                  0.7f));
        }
        const SmokeView v = smoke_view(ps, ground, glm::vec3(0.0f), glm::vec3(0, 0, -1), 60.0f, 48);
        CHECK(check_smoke_view(v, glm::vec2(0.5f)) > 2000);
    }
    SECTION("a billboard's shared diagonal through the middle pixel's centre") {
        // 33 × 33 pixels: the middle column and row have x = y = 0 exactly, so the middle ray is the view
        // axis, which passes through the centre of a quad facing the eye, on the edge its two triangles share.
        const SmokeView v = smoke_view({particle(glm::vec3(0, 0, -5), 1.0f), particle(glm::vec3(0, 0, -7), 2.0f)},
                                       ground, glm::vec3(0.0f), glm::vec3(0, 0, -1), 40.0f, 33);
        const Ray axis = v.camera.ray(16, 16, 1e-3f);
        REQUIRE(axis.direction == glm::vec3(0, 0, -1));
        std::size_t layers = 0;
        trace(v.scene.scene(), axis, ray_flag_force_non_opaque, kBillboardMask, [&](const TraceHit&) {
            ++layers;
            return AnyHitDecision::ignore;
        });
        CHECK(layers == 2);  // one triangle of each quad, never both
        CHECK(check_smoke_view(v, glm::vec2(0.5f)) > 500);
    }
    SECTION("the eye inside the smoke") {
        std::vector<Particle> ps;
        Pcg32 rng(5);
        for (int i = 0; i < 300; ++i)
            ps.push_back(particle(glm::vec3(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-2, 2)), 0.4f));
        const SmokeView v = smoke_view(ps, ground, glm::vec3(0.1f, 0.0f, 0.2f), glm::vec3(1, 0.3f, -1), 90.0f, 48);
        CHECK(check_smoke_view(v, glm::vec2(0.5f)) > 7000);
    }
}

// ---------------------------------------------------------------------------------------------------
// The closest-hit tile query of a mesh BLAS (trace/blas_tile_traversal.hpp) against closest_hit() per ray.

namespace {

// A height field of side × side quads over [-2, 2]², two triangles each, every vertex on a dyadic grid (rays
// through shared edges and vertices are common), and a closed icosphere hovering over it.
TriangleMesh terrain_and_ball(int side) {
    TriangleMesh m;
    for (int j = 0; j <= side; ++j)
        for (int i = 0; i <= side; ++i) {
            const float x = -2.0f + 4.0f * float(i) / float(side), z = -2.0f + 4.0f * float(j) / float(side);
            m.vertices.emplace_back(x, float((i * 7 + j * 3) % 5) / 16.0f, z);
        }
    for (int j = 0; j < side; ++j)
        for (int i = 0; i < side; ++i) {
            const std::uint32_t a = std::uint32_t(j * (side + 1) + i), b = a + 1, c = a + std::uint32_t(side + 1),
                                d = c + 1;
            m.triangles.emplace_back(a, c, b);
            m.triangles.emplace_back(b, c, d);
        }
    const TriangleMesh ball = make_icosphere(3, 0.75f);
    const auto base = std::uint32_t(m.vertices.size());
    for (const glm::vec3& v : ball.vertices) m.vertices.push_back(v + glm::vec3(0.25f, 1.0f, -0.5f));
    for (const glm::uvec3& t : ball.triangles) m.triangles.push_back(t + glm::uvec3(base));
    return m;
}

// n random triangles of edge about 0.3 in [-2, 2]³: overlaps and near-ties.
TriangleMesh random_triangles(int n, Pcg32& rng) {
    TriangleMesh m;
    for (int k = 0; k < n; ++k) {
        const glm::vec3 c(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-2, 2));
        for (int j = 0; j < 3; ++j) m.vertices.push_back(c + 0.3f * random_unit(rng));
        const auto b = std::uint32_t(3 * k);
        m.triangles.emplace_back(b, b + 1, b + 2);
    }
    return m;
}

// Every ray of `tile` against closest_hit() alone: the same hit or miss, t, barycentrics and facing bit for
// bit, the same triangle unless another one is hit at exactly the same t. Returns the rays that hit.
std::size_t check_blas_tile(const MeshBlas& blas, RayTile tile) {
    const RayTile before = tile;
    BlasTileHits hits;
    TraversalStats stats;
    closest_hit(blas, tile, hits, stats);
    std::size_t hit_count = 0;
    for (unsigned r = 0; r < tile.rows(); ++r)
        for (unsigned c = 0; c < tile.columns(); ++c) {
            const unsigned lane = RayTile::lane(c, r);
            const Ray ray = before.ray(lane);
            BlasHit want;
            BlasCounters counters;
            const bool found = closest_hit(blas, ray, want, counters);
            CAPTURE(lane, ray.origin.x, ray.origin.y, ray.origin.z, ray.direction.x, ray.direction.y, ray.direction.z);
            REQUIRE(hits.found_at(lane) == found);
            if (!found) {
                REQUIRE(same_bits(tile.tmax(lane), before.tmax(lane)));
                continue;
            }
            ++hit_count;
            const BlasHit& got = hits.hit[lane];
            REQUIRE(same_bits(got.t, want.t));
            REQUIRE(same_bits(tile.tmax(lane), want.t));
            if (got.primitive != want.primitive) {
                // A tie: the other triangle must be hit at the same t by this ray alone.
                const Ray at_t{ray.origin, ray.tmin, ray.direction, want.t};
                bool other_hit = false;
                BlasHit h;
                any_hit_traversal(blas, at_t, [&](const BlasHit& cand) {
                    other_hit = other_hit || (cand.primitive == got.primitive && same_bits(cand.t, got.t));
                    return AnyHitDecision::ignore;
                }, h, counters);
                REQUIRE(other_hit);
                continue;
            }
            REQUIRE(same_bits(got.barycentrics.x, want.barycentrics.x));
            REQUIRE(same_bits(got.barycentrics.y, want.barycentrics.y));
            REQUIRE(got.front_face == want.front_face);
        }
    return hit_count;
}

}  // namespace

TEST_CASE("Mesh BLAS tile query: every ray's closest hit is closest_hit()'s for that ray alone", "[trace-tile]") {
    Pcg32 rng(71);
    const MeshBlas ground(terrain_and_ball(24));
    const MeshBlas soup(random_triangles(3000, rng));
    std::size_t hit = 0, tiles = 0;
    for (int k = 0; k < 60; ++k) {
        const MeshBlas& blas = k % 3 == 2 ? soup : ground;
        // Eyes around and inside the meshes; eyes on the dyadic grid look along grid-aligned directions too.
        const glm::vec3 eye = k % 4 == 0 ? glm::vec3(0.5f, 0.75f, 0.25f) : rng.uniform(2.0f, 9.0f) * random_unit(rng);
        const glm::vec3 at = k % 5 == 0 ? glm::vec3(0.5f, 0.0f, 0.25f)
                                        : glm::vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        const int size = 32 + int(rng.below(200));
        const glm::vec3 up = std::abs(glm::normalize(at - eye).y) > 0.99f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
        const Camera cam(eye, at, up, rng.uniform(10.0f, 100.0f), size, size);
        const int x0 = int(rng.below(unsigned(size))), y0 = int(rng.below(unsigned(size)));
        const int cols = std::min(int(1 + rng.below(kTileColumns)), size - x0);
        const int rows = std::min(int(1 + rng.below(kTileRows)), size - y0);
        RayTile tile = cam.tile(x0, y0, cols, rows, glm::vec2(rng.uniform01(), rng.uniform01()),
                                k % 2 == 0 ? 0.0f : rng.uniform(0.0f, 3.0f));
        // Some rays end early.
        if (k % 3 == 1)
            for (unsigned lane = 0; lane < kTileRays; ++lane)
                if (rng.below(3) == 0) tile.set_tmax(lane, rng.uniform(0.5f, 8.0f));
        CAPTURE(k, size, x0, y0, cols, rows);
        hit += check_blas_tile(blas, tile);
        ++tiles;
    }
    CHECK(hit > 1500);  // most tiles see the meshes (2056 rays hit)
}

TEST_CASE("Mesh BLAS tile query: whole images, including tiles whose rays change dominant axis", "[trace-tile]") {
    const MeshBlas blas(terrain_and_ball(16));
    // A wide view along a diagonal: the dominant axis of the camera rays changes inside some tiles, whose rays
    // are then tested in a pack per axis group.
    std::size_t hit = 0, mixed = 0;
    for (const glm::vec3& eye : {glm::vec3(4.0f, 4.0f, 4.0f), glm::vec3(0.0f, 3.0f, 0.0f), glm::vec3(-3.0f, 0.5f, 2.0f)}) {
        const Camera cam(eye, glm::vec3(0.0f), std::abs(eye.x) + std::abs(eye.z) == 0 ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0),
                         90.0f, 96, 80);
        for (int y0 = 0; y0 < 80; y0 += 16)
            for (int x0 = 0; x0 < 96; x0 += 16) {
                const RayTile tile = cam.tile(x0, y0, 16, 16, glm::vec2(0.5f), 0.0f);
                mixed += !TileTriangleRays(tile).shared_axes;
                hit += check_blas_tile(blas, tile);
            }
    }
    CHECK(mixed > 0);
    CHECK(hit > 3000);  // 4222 rays hit
}

TEST_CASE("Mesh BLAS tile query: a wide node's children are culled as outside() and distance_to_box() cull them",
          "[trace-tile]") {
    // visible_children() tests eight boxes in lanes of doubles; lane by lane it must make the scalar tests'
    // decisions and distances, bit for bit: boxes around, inside and behind the frustum, touching the eye, and
    // huge and tiny ones.
    Pcg32 rng(73);
    long visible = 0, culled = 0;
    for (int k = 0; k < 400; ++k) {
        const Camera cam = random_camera(rng, 20.0f);
        const glm::vec3& eye = cam.position();
        const RayTile tile = cam.tile(int(rng.below(240)), int(rng.below(240)), 16, 16, glm::vec2(0.5f), 0.0f);
        float bounds[6][8];
        Aabb boxes[8];
        for (unsigned i = 0; i < 8; ++i) {
            const float size = std::pow(10.0f, rng.uniform(-4.0f, 2.0f));
            const glm::vec3 c = i == 0 ? eye : eye + rng.uniform(0.0f, 40.0f) * random_unit(rng);
            boxes[i].lo = c - size * glm::vec3(rng.uniform01(), rng.uniform01(), rng.uniform01());
            boxes[i].hi = c + size * glm::vec3(rng.uniform01(), rng.uniform01(), rng.uniform01());
            const float* p = planes(boxes[i]);
            for (int j = 0; j < 6; ++j) bounds[j][i] = p[j];
        }
        const unsigned used = 1 + rng.below(8);
        const float reach = k % 3 == 0 ? std::numeric_limits<float>::infinity() : rng.uniform(1.0f, 30.0f);
        alignas(64) float dist[8];
        const unsigned got = visible_children<8>(tile, bounds, used, reach, dist);
        for (unsigned i = 0; i < 8; ++i) {
            CAPTURE(k, i);
            const bool want = i < used && !tile.outside(boxes[i]) && distance_to_box(tile.origin(), boxes[i]) <= reach;
            REQUIRE(bool(got >> i & 1u) == want);
            if (want) REQUIRE(same_bits(dist[i], distance_to_box(tile.origin(), boxes[i])));
            (want ? visible : culled) += i < used;
        }
    }
    CHECK(visible > 200);
    CHECK(culled > 200);
}

TEST_CASE("ray tile: shear_sieve() passes every lane shear_lanes() keeps, and packed rays are the tile's",
          "[trace-tile]") {
    // The tiles and triangles of the shear_lanes() test above (rays through edges and vertices too): the sieve
    // may pass a lane the full test then drops, never the other way round. Then the same lanes packed
    // (PackedTileRays) from random rows: each packed ray is its lane's, the sieve and the full test give it the
    // same answers there, and the padding after the last ray is zeros.
    Pcg32 rng(29);
    constexpr unsigned W = simd::kFloatLanes;
    constexpr unsigned kAll = W == 32 ? ~0u : (1u << W) - 1u;
    std::size_t kept = 0, sifted_out = 0, packed_rays = 0;
    for (int k = 0; k < 300; ++k) {
        const AxisView view(rng, k);
        const glm::vec3& eye = view.eye;
        RayTile tile = view.tile();
        for (unsigned lane = 0; lane < kTileRays; ++lane)
            if (rng.below(4) == 0) tile.set_tmax(lane, rng.uniform(0.5f, 9.0f));
        const TileTriangleRays rays(tile);
        if (!rays.shared_axes) continue;
        // A random set of lanes per row, packed.
        PackedTileRays<W> packed;
        for (unsigned r = 0; r < kTileRows; ++r)
            for (unsigned first = RayTile::lane(0, r); first < RayTile::lane(0, r + 1); first += W)
                packed.add(tile, rays, first, rng.next_u32() & kAll);
        packed.close();
        packed_rays += packed.count;
        const unsigned end = (packed.count + W - 1) / W * W;
        for (unsigned j = 0; j < end; ++j) {
            CAPTURE(k, j, packed.count);
            if (j >= packed.count) {
                REQUIRE((packed.sx[j] == 0.0f && packed.sy[j] == 0.0f && packed.dx[j] == 0.0f &&
                         packed.dy[j] == 0.0f && packed.dz[j] == 0.0f && packed.tmax[j] == 0.0f));
                continue;
            }
            const unsigned lane = packed.lane[j];
            REQUIRE((j == 0 || packed.lane[j - 1] < lane));
            REQUIRE(same_bits(packed.sx[j], rays.sx[lane]));
            REQUIRE(same_bits(packed.sy[j], rays.sy[lane]));
            REQUIRE(same_bits(packed.dx[j], tile.direction(lane).x));
            REQUIRE(same_bits(packed.dy[j], tile.direction(lane).y));
            REQUIRE(same_bits(packed.dz[j], tile.direction(lane).z));
            REQUIRE(same_bits(packed.tmax[j], tile.tmax(lane)));
        }
        const glm::vec3 on_axis = eye + view.forward * rng.uniform(1.0f, 9.0f);
        for (int j = 0; j < 20; ++j) {
            glm::vec3 v[3];
            view.triangle(rng, on_axis, j, v);
            const RelativeTriangle rel = relative(rays, eye, v[0], v[1], v[2]);
            for (unsigned first = 0; first < kTileRays; first += W) {
                ShearedLanes<W> out{};
                const unsigned keep = shear_lanes<W>(rays, first, kAll, rel, out);
                const unsigned sieve = shear_sieve<W>(rays.sx + first, rays.sy + first, kAll, rel);
                CAPTURE(k, j, first);
                REQUIRE((keep & ~sieve) == 0);
                kept += unsigned(std::popcount(keep));
                sifted_out += unsigned(std::popcount(~sieve & kAll));
                REQUIRE(shear_sieve<W>(rays.sx + first, rays.sy + first, 0u, rel) == 0u);
            }
            for (unsigned first = 0; first < end; first += W) {
                const unsigned lanes = packed.count - first >= W ? kAll : (1u << (packed.count - first)) - 1u;
                ShearedLanes<W> out{};
                const unsigned keep = shear_lanes<W>(packed.sx + first, packed.sy + first, lanes, rel, out);
                const unsigned sieve = shear_sieve<W>(packed.sx + first, packed.sy + first, lanes, rel);
                REQUIRE((keep & ~sieve) == 0);
                for (unsigned i = 0; i < W && first + i < packed.count; ++i) {
                    const ShearedTriangle s = shear_triangle(TriangleRay(tile.ray(packed.lane[first + i])), v[0],
                                                             v[1], v[2]);
                    CAPTURE(k, j, first, i);
                    REQUIRE(bool(keep >> i & 1u) == !straddles(s));
                }
            }
        }
    }
    CHECK(kept > 10000);
    CHECK(sifted_out > 500000);  // the sieve does drop what the triangles certainly straddle
    CHECK(packed_rays > 10000);
}

TEST_CASE("ray tile: on a tile whose rays change dominant axis each lane has its own TriangleRay and axis group",
          "[trace-tile]") {
    // Wide views along diagonals, as in the BLAS test above: every lane's TriangleRay field for field the one
    // TriangleRay(tile.ray(lane)) makes, and the lane in exactly the group of its axes.
    std::size_t mixed = 0;
    for (const glm::vec3& eye :
         {glm::vec3(4.0f, 4.0f, 4.0f), glm::vec3(-3.0f, 0.5f, 2.0f), glm::vec3(1.0f, -2.0f, 2.0f)}) {
        const Camera cam(eye, glm::vec3(0.0f), glm::vec3(0, 1, 0), 90.0f, 96, 80);
        for (int y0 = 0; y0 < 80; y0 += 16)
            for (int x0 = 0; x0 < 96; x0 += 16) {
                const RayTile tile = cam.tile(x0, y0, 16, 16, glm::vec2(0.5f), 0.0f);
                const TileTriangleRays rays(tile);
                unsigned groups = 0;
                for (unsigned lane = 0; lane < kTileRays; ++lane) {
                    const TriangleRay alone(tile.ray(lane)), from_table = rays.ray(lane);
                    CAPTURE(x0, y0, lane);
                    REQUIRE(std::memcmp(&alone, &from_table, sizeof(TriangleRay)) == 0);
                    unsigned in = 0;
                    for (unsigned g = 0; g < kAxisGroups; ++g) {
                        if (!((rays.groups >> g) & 1u)) continue;
                        if (!((rays.group_columns[g][lane / kTileColumns] >> (lane % kTileColumns)) & 1u)) continue;
                        ++in;
                        const RayAxes a = axes_of_group(g);
                        REQUIRE((a.kx == alone.kx && a.ky == alone.ky && a.kz == alone.kz));
                        groups |= 1u << g;
                    }
                    REQUIRE(in == 1);
                }
                REQUIRE(groups == rays.groups);
                REQUIRE(rays.shared_axes == (std::popcount(groups) == 1));
                mixed += !rays.shared_axes;
            }
    }
    CHECK(mixed > 0);
}

TEST_CASE("ray tile: shadow_lanes() keeps every ray that meets the box", "[trace-tile]") {
    // Random boxes in front of, around and behind random tiles: a ray of the grid that enters a box (the slab
    // test of a single ray, to any distance) lies on a column and a row of its shadow; and the shadow stays
    // small for a small box in front (the test is not passed by keeping everything).
    Pcg32 rng(31);
    long met = 0, narrow_shadows = 0;
    for (int k = 0; k < 2000; ++k) {
        const Camera cam = random_camera(rng, 10.0f);
        const glm::vec3& eye = cam.position();
        const int columns = 1 + int(rng.below(kTileColumns)), rows = 1 + int(rng.below(kTileRows));
        const RayTile tile = cam.tile(int(rng.below(240)), int(rng.below(240)), columns, rows, glm::vec2(0.5f), 0.0f);
        // Around a ray of the grid (behind the eye too), of a size from a thousandth to twice its distance.
        const float distance = rng.uniform(-2.0f, 20.0f);
        const float size = std::abs(distance) * std::pow(10.0f, rng.uniform(-3.0f, 0.3f)) + 1e-3f;
        const unsigned lane = RayTile::lane(rng.below(unsigned(columns)), rng.below(unsigned(rows)));
        const glm::vec3 c = eye + distance * tile.direction(lane) + 0.5f * size * random_unit(rng);
        const Aabb box{c - size * glm::vec3(rng.uniform01(), rng.uniform01(), rng.uniform01()),
                       c + size * glm::vec3(rng.uniform01(), rng.uniform01(), rng.uniform01())};
        TileLineSet shadow_columns = 0, shadow_rows = 0;
        const bool any = tile.shadow_lanes(box, shadow_columns, shadow_rows);
        REQUIRE((shadow_columns & ~tile.all_columns()) == 0);
        REQUIRE((shadow_rows & ~tile.all_rows()) == 0);
        for (unsigned r = 0; r < unsigned(rows); ++r)
            for (unsigned col = 0; col < unsigned(columns); ++col) {
                float t_enter;
                if (!intersect(box, BoxRay(tile.ray(RayTile::lane(col, r))), kInf, t_enter)) continue;
                CAPTURE(k, col, r);
                REQUIRE(any);
                REQUIRE(((shadow_columns >> col) & 1u));
                REQUIRE(((shadow_rows >> r) & 1u));
                ++met;
            }
        narrow_shadows += any && std::popcount(shadow_columns) < columns && std::popcount(shadow_rows) < rows;
    }
    CHECK(met > 10000);
    CHECK(narrow_shadows > 100);
}
