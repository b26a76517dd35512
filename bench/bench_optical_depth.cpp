// Bench section "optical_depth": the optical-depth pass (thesis 4.3.2) and resolve (4.3.3) for the particle
// counts of table B.1 (250…1500) and for 10k and 100k particles, against Embree 3 doing the same all-hits
// work over the same stand-in shape in the same run.
//
// Scene: the thesis's two tubes, the ground under them, light from above. Up to 1500 particles the
// TubeSettings defaults with only the count changed (table B.1 varies nothing else) and the thesis's
// default cutoff of 60 hits (4.4.3); at 10k and 100k no cutoff, and the particle radius shrinks with the
// count (bench_util.hpp, bench_particle_radius) so that a ray crosses about as many surfaces as at 750.
// The mean surfaces per ray and the cut-off rays are printed beside every time. Ours runs with sphere and
// with icosahedron stand-ins, Embree over the same two shapes, and each of ours is compared with the
// fastest Embree contender over its own shape (ours over spheres against Embree's sphere primitive is the
// headline; ours over spheres against Embree over icosahedra is printed too, but is not the same work).
// Embree's stand-ins:
//   * spheres: its own sphere primitive, one RTC_GEOMETRY_TYPE_SPHERE_POINT geometry of every particle's
//     (centre, radius). Its intersector hands the filter a sphere's entry and its exit as two hits (the
//     filter rejects the first, so the second follows; the duplicate filter below never fires on a
//     sphere): check_embree_spheres() verifies that before any sphere figure is taken;
//   * icosahedra, flattened: one mesh of every particle's world-space triangles (vertices
//     translate(centre)·scale(radius) in double, rounded once), a one-level BVH;
//   * icosahedra, instanced: one icosahedron, one RTC_GEOMETRY_TYPE_INSTANCE per particle, a two-level BVH
//     like ours.
// Each is asked in two ways:
//   * x1: one ray per rtcOccluded1; x8: packets of eight parallel neighbours per rtcOccluded8 with the
//     coherent context flag, Embree's answer to what our bundles do (ray_bundle.hpp). Not 16 as our
//     bundles: Debian's Embree 3.13.5 looped forever inside rtcOccluded16 on valid rays of this pass
//     (instanced layout, robust mode), reproducibly once other sections had run before this one, and
//     packets of 8 were no faster than single rays anyway (1.2-1.4x slower, measured here).
// Both tracers take the rays in bundle_order() in tasks of 16. Embree's work per ray is what our pass does:
// every crossing goes through a filter that records (t, ±1) and rejects it so the traversal goes on;
// Embree reports a ray through a shared edge or vertex on every triangle there, so the filter drops a
// second same-facing crossing of one particle (a convex stand-in is entered once and left once); at the
// (K+1)-th crossing it accepts, which ends the ray's occlusion query; a cut-off ray is followed by a
// ground-only query, as in ours; the hits land in one flat buffer of per-particle lists.
// Default build quality (RTC_BUILD_QUALITY_MEDIUM), robust mode on: without it Embree misses some of the
// exact edge crossings of this scene (its speed and its wrong answers are printed at 750 particles), so it
// would not be doing the same job. Times are medians over interleaved rounds; builds are timed separately
// (table B.1's "build AS" column) except in od_100k_ms. Every count checks that both did the same work:
// statuses, hit counts and path lengths of ours against every Embree contender over the same shape.
#include "bench_registry.hpp"
#include "bench_util.hpp"
#include "embree_device.hpp"
#include "support/embree_reference.hpp"
#include "timing.hpp"

#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/geometry/ray_bundle.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/smoke/tube_generator.hpp>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <numeric>
#include <iterator>
#include <optional>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace smoketrace::bench {
namespace {

namespace er = embree_reference;

constexpr int kSmallCountRounds = 25;  // rounds of the comparison up to 1500 particles (see run_optical_depth)
constexpr std::uint32_t kCutoff = 60;  // the thesis's default optical depth cutoff point (4.4.3)
constexpr std::uint32_t kReportCount = 750;
constexpr std::uint32_t kLargeCount = 100'000;  // at kLargeSceneFrom and above: no cutoff, radius shrunk
const glm::vec3 kToLight(0.0f, 1.0f, 0.0f);
// Lengths of the two tracers are compared (a check that both did the same work, not a test) to this
// relative difference; see tests/embree_optical_depth.cpp for why it holds.
constexpr double kAgreementTolerance = 1e-4;

// The ground under the smoke (lowest particle surface at y = −separation − tube_radius − radius = −2.7).
GroundQuad ground_quad() {
    return GroundQuad{{glm::vec3(-20.0f, -3.0f, 20.0f), glm::vec3(20.0f, -3.0f, 20.0f), glm::vec3(20.0f, -3.0f, -20.0f),
                       glm::vec3(-20.0f, -3.0f, -20.0f)}};
}

TriangleMesh quad_mesh(const GroundQuad& g) {
    TriangleMesh m;
    m.vertices.assign(g.corners.begin(), g.corners.end());
    m.triangles = {{0, 1, 2}, {0, 2, 3}};
    return m;
}

// Embree's stand-ins: icosahedra in one world-space mesh or instanced, or its own sphere primitive.
enum class Layout { flattened, instanced, spheres };
// How Embree is asked: one ray per rtcOccluded1, or a packet of eight per rtcOccluded8.
enum class Query { single, packet8 };
const char* name_of(Layout l) {
    return l == Layout::flattened ? "embree_flattened" : l == Layout::instanced ? "embree_instanced" : "embree_spheres";
}

// The Embree side: the stand-ins and the ground in one scene, the ground alone in another (for the
// cut-off rays' ground check), and the pass over all particles.
class EmbreePass {
public:
    EmbreePass(const er::Device& device, const std::vector<Particle>& ps, Layout layout, bool robust)
        : layout_(layout), scene_(device, er::SceneOptions{RTC_BUILD_QUALITY_MEDIUM, robust}),
          ground_only_(device, er::SceneOptions{RTC_BUILD_QUALITY_MEDIUM, robust}), particle_count_(ps.size()) {
        const TriangleMesh unit = make_icosahedron(1.0f);
        triangles_per_particle_ = static_cast<std::uint32_t>(unit.triangles.size());
        ground_geometry_ = scene_.attach_mesh(quad_mesh(ground_quad()));
        if (layout == Layout::flattened) {
            TriangleMesh world;
            world.vertices.reserve(ps.size() * unit.vertices.size());
            world.triangles.reserve(ps.size() * unit.triangles.size());
            for (const Particle& p : ps) {
                const auto base = static_cast<std::uint32_t>(world.vertices.size());
                for (const glm::vec3& v : unit.vertices)
                    world.vertices.push_back(glm::vec3(glm::dvec3(p.center) + double(p.radius) * glm::dvec3(v)));
                for (const glm::uvec3& t : unit.triangles) world.triangles.push_back(t + base);
            }
            scene_.attach_mesh(world);
        } else if (layout == Layout::spheres) {
            RTCGeometry g = rtcNewGeometry(device.handle(), RTC_GEOMETRY_TYPE_SPHERE_POINT);
            auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                                                  4 * sizeof(float), ps.size()));
            if (v == nullptr) {
                rtcReleaseGeometry(g);
                device.check("sphere vertex buffer");
                throw std::runtime_error("embree: no sphere vertex buffer");
            }
            for (std::size_t i = 0; i < ps.size(); ++i) {
                v[4 * i + 0] = ps[i].center.x;
                v[4 * i + 1] = ps[i].center.y;
                v[4 * i + 2] = ps[i].center.z;
                v[4 * i + 3] = ps[i].radius;
            }
            rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_MEDIUM);
            rtcCommitGeometry(g);
            rtcAttachGeometry(scene_.handle(), g);
            rtcReleaseGeometry(g);
            device.check("spheres");
        } else {
            child_ = std::make_unique<er::Scene>(device, er::SceneOptions{RTC_BUILD_QUALITY_MEDIUM, robust});
            child_->attach_mesh(unit);
            child_->commit();
            for (std::size_t i = 0; i < ps.size(); ++i) {
                RTCGeometry g = rtcNewGeometry(device.handle(), RTC_GEOMETRY_TYPE_INSTANCE);
                rtcSetGeometryInstancedScene(g, child_->handle());
                const float r = ps[i].radius;
                const float xfm[12] = {r, 0, 0, 0, r, 0, 0, 0, r, ps[i].center.x, ps[i].center.y, ps[i].center.z};
                rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm);
                rtcCommitGeometry(g);
                const std::uint32_t id = rtcAttachGeometry(scene_.handle(), g);
                rtcReleaseGeometry(g);
                if (i == 0) first_instance_ = id;
            }
            device.check("instances");
        }
        scene_.commit();
        ground_only_.attach_mesh(quad_mesh(ground_quad()));
        ground_only_.commit();
    }

    // Fills `out` (statuses, counts, per-particle hit lists) for every particle, like OpticalDepthPass::run:
    // the rays in bundle_order(), tasks of 16 of them, each thread's hits in a scratch of its own, gathered
    // into particle order at the end. `query`: one ray per rtcOccluded1, or eight per rtcOccluded8 (the
    // coherent context flag: the rays of a packet are parallel neighbours).
    // With a smooth `kernel` (kernel_sums set) the filter also adds each exit's closed-form share
    // (particle_stretch_integral(), in the order Embree reports them) to its ray's sum, as our pass does after
    // its walk; no hits are kept, and (*kernel_sums)[i] is particle i's sum (ok rays).
    void run(const std::vector<Particle>& ps, glm::vec3 dir, std::uint32_t cutoff, Query query, OpticalDepthHits& out,
             const DensityKernel* kernel = nullptr, std::vector<float>* kernel_sums = nullptr) {
        const std::size_t n = ps.size();
        out.status.assign(n, DepthStatus::ok);
        out.hit_counts.assign(n, 0);
        kernel_ = kernel;
        kernel_sums_ = kernel_sums;
        if (kernel_sums_) kernel_sums_->assign(n, 0.0f);
        particles_ = ps.data();
        unit_dir_ = glm::normalize(glm::dvec3(dir));
        origins_.resize(n);
        for (std::size_t i = 0; i < n; ++i) origins_[i] = ps[i].center;
        bundle_order(origins_, dir, order_, order_scratch_);
        kept_at_.resize(n);
        for (Scratch& sc : scratch_) sc.kept.clear();
        const std::size_t tasks = (n + kParticlesPerTask - 1) / kParticlesPerTask;
        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(0, tasks, 1),
            [&](const tbb::blocked_range<std::size_t>& r) {
                Scratch& sc = scratch_.local();
                for (std::vector<std::uint32_t>& table : sc.seen)
                    if (table.size() != particle_count_) table.assign(particle_count_, 0);
                for (std::size_t task = r.begin(); task < r.end(); ++task) {
                    const std::size_t end = std::min(n, (task + 1) * kParticlesPerTask);
                    const std::size_t step = query == Query::single ? 1 : kPacket;
                    for (std::size_t k = task * kParticlesPerTask; k < end; k += step)
                        trace_rays(ps, std::span(order_).subspan(k, std::min(step, end - k)), dir, cutoff, sc, out);
                }
            },
            tbb::simple_partitioner());
        HitLists& lists = out.lists;
        lists.offsets.resize(n + 1);
        lists.offsets[0] = 0;
        if (kernel_sums_) {  // no hits kept
            std::fill(lists.offsets.begin(), lists.offsets.end(), 0u);
            lists.hits.clear();
            return;
        }
        for (std::size_t i = 0; i < n; ++i)
            lists.offsets[i + 1] = lists.offsets[i] + (out.status[i] == DepthStatus::ok ? out.hit_counts[i] : 0);
        lists.hits.resize(lists.offsets[n]);
        tbb::parallel_for(std::size_t(0), tasks, [&](std::size_t task) {
            for (std::size_t i = task * kParticlesPerTask; i < std::min(n, (task + 1) * kParticlesPerTask); ++i) {
                if (out.status[i] != DepthStatus::ok) continue;
                const SurfaceHit* from = kept_at_[i].scratch->kept.data() + kept_at_[i].offset;
                std::copy(from, from + out.hit_counts[i], lists.hits.begin() + lists.offsets[i]);
            }
        });
    }

private:
    static constexpr std::size_t kPacket = 8;
    static constexpr std::size_t kParticlesPerTask = 16;  // as in our pass (optical_depth_pass.cpp)

    // A thread's working memory: the duplicate filter of each lane (seen[lane][particle] = (ray stamp << 2)
    // | 1 (entered) | 2 (left); a new ray takes a new stamp, so nothing is cleared per ray; one table per
    // lane, as the rays of a packet are in flight together), the lanes' hits of the query in flight, and
    // the hits of the thread's ok rays.
    struct Scratch {
        std::vector<std::uint32_t> seen[kPacket];
        std::uint32_t next = 0;
        std::vector<SurfaceHit> lane_hits[kPacket];
        std::vector<SurfaceHit> kept;
        std::uint32_t take() {
            if (++next == (1u << 30)) {  // stamps wrap: start over with clean tables
                for (std::vector<std::uint32_t>& table : seen) std::fill(table.begin(), table.end(), 0u);
                next = 1;
            }
            return next << 2;
        }
    };
    struct KeptAt {
        const Scratch* scratch;
        std::uint32_t offset;
    };

    // One ray's state in the filter. Embree hands the filter the ray's id: its lane.
    struct Lane {
        std::uint32_t* seen;  // the lane's duplicate filter table
        std::uint32_t stamp;
        std::vector<SurfaceHit>* hits;  // nullptr: count only
        std::uint32_t found;            // distinct crossings so far
        std::uint32_t limit;            // accept (end an occlusion query) at this many; 0 = never
        bool cut_off;
        bool ground;
        float ground_t;
        glm::vec3 origin;  // a smooth kernel's: the ray's origin, and its exits' shares so far
        double kernel_sum;
    };
    // The intersect context handed to Embree; Embree passes &base back to the filter.
    struct RayContext {
        RTCIntersectContext base;
        const EmbreePass* pass;
        glm::vec3 dir;
        Scratch* scratch;
        Lane lane[kPacket];
    };

    template <Layout L>
    static void filter(const RTCFilterFunctionNArguments* args) {
        auto* ctx = reinterpret_cast<RayContext*>(args->context);
        const EmbreePass& self = *ctx->pass;
        for (unsigned i = 0; i < args->N; ++i) {
            if (args->valid[i] != -1) continue;
            Lane& lane = ctx->lane[RTCRayN_id(args->ray, args->N, i)];
            const std::uint32_t geometry = RTCHitN_geomID(args->hit, args->N, i);
            const std::uint32_t instance = RTCHitN_instID(args->hit, args->N, i, 0);
            const float t = RTCRayN_tfar(args->ray, args->N, i);
            if (instance == RTC_INVALID_GEOMETRY_ID && geometry == self.ground_geometry_) {
                lane.ground = true;  // opaque: accepted, ends an occlusion query, shrinks an intersection's tfar
                lane.ground_t = std::min(lane.ground_t, t);
                continue;
            }
            // A sphere is one primitive; an icosahedron's triangles lie in particle order.
            const std::uint32_t particle =
                L == Layout::spheres     ? RTCHitN_primID(args->hit, args->N, i)
                : L == Layout::flattened ? RTCHitN_primID(args->hit, args->N, i) / self.triangles_per_particle_
                                         : instance - self.first_instance_;
            const float facing = RTCHitN_Ng_x(args->hit, args->N, i) * ctx->dir.x +
                                 RTCHitN_Ng_y(args->hit, args->N, i) * ctx->dir.y +
                                 RTCHitN_Ng_z(args->hit, args->N, i) * ctx->dir.z;
            const bool front = facing < 0.0f;
            const std::uint32_t bit = front ? 1u : 2u;
            std::uint32_t& seen = lane.seen[particle];
            if ((seen & ~3u) != lane.stamp) seen = lane.stamp;
            if (seen & bit) {  // the same crossing again, from the other triangle of an edge or vertex
                args->valid[i] = 0;
                continue;
            }
            seen |= bit;
            if (lane.hits) lane.hits->push_back(SurfaceHit{t, front ? +1 : -1});
            if (self.kernel_ && !front) {
                const Particle& p = self.particles_[particle];
                lane.kernel_sum += particle_stretch_integral(*self.kernel_, lane.origin, self.unit_dir_, p.center, p.radius);
            }
            ++lane.found;
            if (lane.limit != 0 && lane.found >= lane.limit) {
                lane.cut_off = true;  // accepted: the occlusion query ends for this ray
                continue;
            }
            args->valid[i] = 0;  // IgnoreHit(): the traversal goes on
        }
    }

    RayContext context(glm::vec3 dir, Scratch& sc, RTCIntersectContextFlags flags) const {
        RayContext ctx;
        rtcInitIntersectContext(&ctx.base);
        ctx.base.flags = flags;
        ctx.base.filter = layout_ == Layout::flattened   ? &filter<Layout::flattened>
                          : layout_ == Layout::instanced ? &filter<Layout::instanced>
                                                         : &filter<Layout::spheres>;
        ctx.pass = this;
        ctx.dir = dir;
        ctx.scratch = &sc;
        return ctx;
    }
    static Lane lane_of(Scratch& sc, std::size_t lane, std::vector<SurfaceHit>* hits, std::uint32_t limit) {
        return Lane{sc.seen[lane].data(), sc.take(), hits,  0, limit, false, false, std::numeric_limits<float>::infinity(),
                    glm::vec3(0.0f), 0.0};
    }

    static RTCRay embree_ray(const Particle& p, glm::vec3 dir, float tmax) {
        RTCRay r;
        r.org_x = p.center.x;
        r.org_y = p.center.y;
        r.org_z = p.center.z;
        r.tnear = optical_depth_tmin(p.radius);
        r.dir_x = dir.x;
        r.dir_y = dir.y;
        r.dir_z = dir.z;
        r.time = 0.0f;
        r.tfar = tmax;
        r.mask = ~0u;
        r.id = 0;
        r.flags = 0;
        return r;
    }

    // Crossings in front of the ground at ground_t, counted with no cutoff (an intersection query whose
    // tfar the ground shrinks).
    std::uint32_t count_in_front(const Particle& p, glm::vec3 dir, float ground_t, Scratch& sc) const {
        RayContext ctx = context(dir, sc, RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT);
        ctx.lane[0] = lane_of(sc, 0, nullptr, 0);
        RTCRayHit rh;
        rh.ray = embree_ray(p, dir, ground_t);
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene_.handle(), &ctx.base, &rh);
        return ctx.lane[0].found;
    }

    // The rays of particles `which` (one, or up to kPacket as one packet): their statuses and counts, and
    // the ok rays' hits kept in the thread's scratch.
    void trace_rays(const std::vector<Particle>& ps, std::span<const std::uint32_t> which, glm::vec3 dir,
                    std::uint32_t cutoff, Scratch& sc, OpticalDepthHits& out) {
        const std::uint32_t limit = cutoff == 0 ? 0 : cutoff + 1;
        RayContext ctx = context(dir, sc, which.size() == 1 ? RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT
                                                           : RTC_INTERSECT_CONTEXT_FLAG_COHERENT);
        for (std::size_t l = 0; l < which.size(); ++l) {
            sc.lane_hits[l].clear();
            ctx.lane[l] = lane_of(sc, l, kernel_sums_ ? nullptr : &sc.lane_hits[l], limit);
            ctx.lane[l].origin = ps[which[l]].center;
        }
        if (which.size() == 1) {
            RTCRay ray = embree_ray(ps[which[0]], dir, kOpticalDepthTmax);
            rtcOccluded1(scene_.handle(), &ctx.base, &ray);
        } else {
            alignas(32) int valid[kPacket];
            alignas(32) RTCRay8 rays;
            for (std::size_t l = 0; l < kPacket; ++l) {
                const bool used = l < which.size();
                valid[l] = used ? -1 : 0;
                const RTCRay r = embree_ray(ps[which[used ? l : 0]], dir, kOpticalDepthTmax);
                rays.org_x[l] = r.org_x, rays.org_y[l] = r.org_y, rays.org_z[l] = r.org_z, rays.tnear[l] = r.tnear;
                rays.dir_x[l] = r.dir_x, rays.dir_y[l] = r.dir_y, rays.dir_z[l] = r.dir_z, rays.time[l] = r.time;
                rays.tfar[l] = r.tfar, rays.mask[l] = r.mask, rays.id[l] = std::uint32_t(l), rays.flags[l] = 0;
            }
            rtcOccluded8(valid, scene_.handle(), &ctx.base, &rays);
        }
        for (std::size_t l = 0; l < which.size(); ++l) {
            const std::uint32_t i = which[l];
            const Lane& lane = ctx.lane[l];
            if (lane.cut_off) {
                // Cut off before the whole ray was seen: does the ground lie on it?
                RTCIntersectContext plain;
                rtcInitIntersectContext(&plain);
                RTCRayHit g;
                g.ray = embree_ray(ps[i], dir, kOpticalDepthTmax);
                g.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                g.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
                rtcIntersect1(ground_only_.handle(), &plain, &g);
                if (g.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
                    out.status[i] = DepthStatus::cutoff;
                    out.hit_counts[i] = cutoff + 1;
                } else {
                    out.status[i] = DepthStatus::occluded;
                    out.hit_counts[i] = count_in_front(ps[i], dir, g.ray.tfar, sc);
                }
                continue;
            }
            if (lane.ground) {  // the occlusion query ended at the ground: count what lies in front of it
                out.status[i] = DepthStatus::occluded;
                out.hit_counts[i] = count_in_front(ps[i], dir, lane.ground_t, sc);
                continue;
            }
            out.status[i] = DepthStatus::ok;
            if (kernel_sums_) {
                out.hit_counts[i] = lane.found;
                (*kernel_sums_)[i] = float(lane.kernel_sum);
                continue;
            }
            out.hit_counts[i] = static_cast<std::uint32_t>(sc.lane_hits[l].size());
            kept_at_[i] = {&sc, static_cast<std::uint32_t>(sc.kept.size())};
            sc.kept.insert(sc.kept.end(), sc.lane_hits[l].begin(), sc.lane_hits[l].end());
        }
    }

    Layout layout_;
    er::Scene scene_;
    er::Scene ground_only_;
    std::unique_ptr<er::Scene> child_;
    std::size_t particle_count_;
    std::uint32_t triangles_per_particle_ = 0;
    std::uint32_t ground_geometry_ = RTC_INVALID_GEOMETRY_ID;
    std::uint32_t first_instance_ = 0;
    std::vector<glm::vec3> origins_;
    std::vector<std::uint32_t> order_;
    BundleOrderScratch order_scratch_;
    std::vector<KeptAt> kept_at_;
    tbb::enumerable_thread_specific<Scratch> scratch_;
    // The run in flight's kernel (null: the union walk's hits), its particles, the rays' direction in double.
    const DensityKernel* kernel_ = nullptr;
    std::vector<float>* kernel_sums_ = nullptr;
    const Particle* particles_ = nullptr;
    glm::dvec3 unit_dir_{0.0};
};

// Embree's sphere primitive must report both crossings of a sphere, each through the filter, for its
// figures to be the same work as ours: two particles in a column under the light, traced by the pass
// itself with both kinds of query. The lower one's ray leaves its own sphere and crosses the upper one
// (exit, entry, exit); the upper one's ray only leaves its own. Throws if Embree reports anything else.
void check_embree_spheres(const er::Device& device) {
    constexpr float kRadius = 0.3f;
    std::vector<Particle> ps(2);
    ps[0].center = glm::vec3(0.0f, 0.0f, 0.0f);
    ps[1].center = glm::vec3(0.0f, 1.0f, 0.0f);
    ps[0].radius = ps[1].radius = kRadius;
    const std::vector<std::vector<SurfaceHit>> expected = {{{0.3f, -1}, {0.7f, +1}, {1.3f, -1}}, {{0.3f, -1}}};
    // Embree's float sphere test against the exact t: a few ulps of t ≤ 1.3 are ~1e-7; 1e-5 leaves room
    // for its formulation and still tells every crossing from the next (0.4 apart).
    constexpr float kTolerance = 1e-5f;
    EmbreePass pass(device, ps, Layout::spheres, true);
    for (const Query q : {Query::single, Query::packet8}) {
        OpticalDepthHits hits;
        pass.run(ps, glm::normalize(kToLight), 0, q, hits);
        for (std::size_t i = 0; i < ps.size(); ++i) {
            std::vector<SurfaceHit> got(hits.lists.of(i).begin(), hits.lists.of(i).end());
            std::sort(got.begin(), got.end(), [](const SurfaceHit& a, const SurfaceHit& b) { return a.t < b.t; });
            bool same = hits.status[i] == DepthStatus::ok && got.size() == expected[i].size();
            for (std::size_t k = 0; same && k < got.size(); ++k)
                same = got[k].value == expected[i][k].value && std::abs(got[k].t - expected[i][k].t) <= kTolerance;
            if (!same) {
                std::ostringstream what;
                what << "bench optical_depth: Embree's sphere primitive (" << (q == Query::single ? "x1" : "x8")
                     << ") gave particle " << i << " " << got.size() << " crossings:";
                for (const SurfaceHit& h : got)
                    what << " (t " << h.t << ", " << (h.value > 0 ? "entry" : "exit") << ")";
                what << "; expected " << expected[i].size() << " (an entry and an exit per sphere in front)";
                throw std::runtime_error(what.str());
            }
        }
    }
}

struct Times {
    double build = 0, pass = 0, resolve = 0, total = 0;  // medians, ms
};

// What one tracer's answers hold beside their lengths: the mean surfaces a ray crossed (an ok ray's hits,
// an occluded ray's crossings in front of the ground, a cut-off ray's cutoff + 1) and the rays cut off.
struct Work {
    double hits_per_ray = 0;
    std::size_t cut_off = 0;
};

Work work_of(const std::vector<DepthStatus>& status, const std::vector<std::uint32_t>& hit_counts) {
    Work w{mean_of(hit_counts), 0};
    for (const DepthStatus s : status) w.cut_off += s == DepthStatus::cutoff;
    return w;
}

struct CsvRow {
    std::uint32_t particles;
    float radius;
    std::uint32_t cutoff;  // 0: none
    std::string tracer;
    std::string stand_in;
    int threads;
    Times t;
    double ratio_vs_embree;  // total / the fastest Embree contender over the same stand-in, same count and threads
    Work work;
};

// How many particles two answers disagree on: status, hit count, or length beyond kAgreementTolerance.
// One kind is counted apart: an ok ray with the same length whose hit counts differ by an even number
// grazed a corner or an edge of one tracer's icosahedron and missed the other's, an entry and an exit at
// one point. Embree's flattened layout rounds every vertex to float in world space, so its icosahedra
// are not ours to the last bit (the instanced layout's are): at 100k particles of radius 0.03 a few of
// the 100k rays pass within that rounding of an edge.
struct Disagreements {
    std::size_t differ = 0;
    std::size_t grazing = 0;
    [[nodiscard]] std::size_t total() const { return differ + grazing; }
    Disagreements& operator+=(const Disagreements& o) {
        differ += o.differ;
        grazing += o.grazing;
        return *this;
    }
};

Disagreements disagreements(const OpticalPathLengths& ours, OpticalDepthHits& embree) {
    std::vector<float> lengths(embree.status.size());
    resolve_optical_path_lengths(embree.lists, embree.status, lengths, HitSort::adaptive);
    Disagreements d;
    for (std::size_t i = 0; i < lengths.size(); ++i) {
        const bool same_status = ours.status()[i] == embree.status[i];
        const bool same_length = embree.status[i] != DepthStatus::ok ||
                                 std::abs(double(ours.lengths()[i]) - double(lengths[i])) <=
                                     kAgreementTolerance * double(lengths[i]);
        const std::uint32_t a = ours.hit_counts()[i], b = embree.hit_counts[i];
        if (same_status && same_length && a == b) continue;
        const bool grazing = same_status && same_length && embree.status[i] == DepthStatus::ok &&
                             (std::max(a, b) - std::min(a, b)) % 2 == 0;
        (grazing ? d.grazing : d.differ) += 1;
    }
    return d;
}

// One tracer of the comparison: ours (pass + resolve through OpticalPathLengths) or an Embree layout (pass).
struct Contender {
    std::string tracer, stand_in;
    std::optional<SmokeScene> ours;
    std::unique_ptr<OpticalPathLengths> depths;
    std::unique_ptr<EmbreePass> embree;
    Layout layout = Layout::flattened;
    Query query = Query::single;
    OpticalDepthHits embree_hits;
    double build_ms = 0;
    std::vector<double> pass, resolve, total;

    void run_once(const std::vector<Particle>& ps, std::span<const std::uint32_t> all, glm::vec3 dir,
                  std::uint32_t cutoff) {
        const auto t0 = std::chrono::steady_clock::now();
        if (ours) {
            FrameTimings ft;
            depths->update(*ours, ps, all, kToLight, OpticalDepthSettings{cutoff}, HitSort::adaptive, ft);
            total.push_back(elapsed_ms(t0));
            pass.push_back(ft.od_pass);
            resolve.push_back(ft.resolve);
        } else {
            embree->run(ps, dir, cutoff, query, embree_hits);
            total.push_back(elapsed_ms(t0));
            pass.push_back(total.back());
            resolve.push_back(0.0);
        }
    }
    Times medians() {
        Times t{build_ms, stats_of(pass).median, stats_of(resolve).median, stats_of(total).median};
        pass.clear();
        resolve.clear();
        total.clear();
        return t;
    }
    [[nodiscard]] Work work() const {
        return ours ? work_of(depths->status(), depths->hit_counts())
                    : work_of(embree_hits.status, embree_hits.hit_counts);
    }
};

// The contenders, in the order of the table's columns: ours over spheres and icosahedra, then Embree.
constexpr int kOursSphere = 0, kOursIcosahedron = 1, kFirstEmbree = 2;
struct EmbreeKind {
    Layout layout;
    Query query;
};
constexpr EmbreeKind kEmbreeKinds[] = {{Layout::flattened, Query::single}, {Layout::instanced, Query::single},
                                       {Layout::flattened, Query::packet8}, {Layout::instanced, Query::packet8},
                                       {Layout::spheres, Query::single},   {Layout::spheres, Query::packet8}};
constexpr int kContenders = kFirstEmbree + int(std::size(kEmbreeKinds));

// The smooth density kernels (density_kernel.hpp) on one count's scene: our pass + resolve over spheres with
// the uniform kernel (eq. 3.1: the hits kept, sorted and walked) and with each smooth kernel (the exits'
// closed-form shares summed, nothing kept), against Embree's sphere primitive, one ray per query (the
// faster of its two sphere queries above), doing the same: its filter adds each exit's share (the same
// particle_stretch_integral(), one at a time where ours takes a bundle's exits over lanes). Interleaved
// rounds, medians; both must agree on every status and count, and on every sum to its roundings.
struct KernelTimes {
    double uniform = 0;
    double ours[3] = {}, embree[3] = {};
};
constexpr DensityKernel kBenchKernels[3] = {kGaussianKernel, kPoly1Kernel, kPoly2Kernel};

std::size_t kernel_disagreements(const OpticalPathLengths& ours, const OpticalDepthHits& embree,
                                 const std::vector<float>& embree_sums) {
    std::size_t differ = 0;
    for (std::size_t i = 0; i < embree_sums.size(); ++i) {
        if (ours.status()[i] != embree.status[i] || ours.hit_counts()[i] != embree.hit_counts[i]) {
            ++differ;
            continue;
        }
        if (embree.status[i] != DepthStatus::ok) continue;
        // The same shares summed in another order and rounded to float: 2^-24 of l each, and n·2^-53 of it.
        const double l = embree_sums[i];
        differ += std::abs(double(ours.lengths()[i]) - l) > (0x1p-23 + double(ours.hit_counts()[i]) * 0x1p-53) * l;
    }
    return differ;
}

KernelTimes compare_kernels(tbb::task_arena& arena, const SmokeScene& scene, EmbreePass& embree,
                            const std::vector<Particle>& ps, std::span<const std::uint32_t> all, glm::vec3 dir,
                            std::uint32_t cutoff, int rounds, bool warm_up, std::size_t& disagreements) {
    const std::size_t n = ps.size();
    OpticalPathLengths uniform(n);
    std::vector<OpticalPathLengths> ours;
    for (int k = 0; k < 3; ++k) ours.emplace_back(n);
    OpticalDepthHits embree_hits;
    std::vector<std::vector<float>> embree_sums(3);
    std::vector<double> t_uniform, t_ours[3], t_embree[3];
    auto round = [&](bool keep) {
        FrameTimings ft;
        const double u = time_once_ms([&] {
            uniform.update(scene, ps, all, kToLight, OpticalDepthSettings{cutoff}, HitSort::adaptive, ft);
        });
        if (keep) t_uniform.push_back(u);
        for (int k = 0; k < 3; ++k) {
            OpticalDepthSettings settings{cutoff};
            settings.kernel = kBenchKernels[k];
            const double o = time_once_ms([&] { ours[k].update(scene, ps, all, kToLight, settings, HitSort::adaptive, ft); });
            const double e = time_once_ms(
                [&] { embree.run(ps, dir, cutoff, Query::single, embree_hits, &kBenchKernels[k], &embree_sums[k]); });
            if (keep) t_ours[k].push_back(o), t_embree[k].push_back(e);
            if (keep && t_ours[k].size() == 1) disagreements += kernel_disagreements(ours[k], embree_hits, embree_sums[k]);
        }
    };
    arena.execute([&] {
        if (warm_up) round(false);
        for (int r = 0; r < rounds; ++r) round(true);
    });
    KernelTimes t;
    t.uniform = stats_of(t_uniform).median;
    for (int k = 0; k < 3; ++k) t.ours[k] = stats_of(t_ours[k]).median, t.embree[k] = stats_of(t_embree[k]).median;
    return t;
}

void run_optical_depth(const BenchOptions& options) {
    const std::vector<std::uint32_t> counts =
        options.quick ? std::vector<std::uint32_t>{250, 750, 1500, 10'000, kLargeCount}
                      : std::vector<std::uint32_t>{250, 500, 750, 1000, 1250, 1500, 10'000, kLargeCount};
    const int all_threads = tbb::info::default_concurrency();
    tbb::task_arena one_thread(1);
    tbb::task_arena every_thread(all_threads);
    const er::Device device = bench_embree_device();
    const glm::vec3 dir = glm::normalize(kToLight);
    std::vector<CsvRow> csv;
    const std::ios_base::fmtflags cout_flags = std::cout.flags();  // restored for report() and later sections
    const std::streamsize cout_precision = std::cout.precision();

    check_embree_spheres(device);
    std::cout << "Embree's sphere primitive reports the entry and the exit of each sphere (x1 and x8): checked\n"
              << "Two tubes, ground, light from above; up to 1500 particles TubeSettings defaults and cutoff "
              << kCutoff << ", from 10k on no cutoff and radius 0.35*sqrt(750/N).\nms, medians of "
              << std::max(options.repeats, kSmallCountRounds) << " interleaved rounds up to 1500 particles, "
              << options.repeats << " at 10k and 100k (quick: 1). Embree (robust mode, all hits through a filter):\n"
              << "over icosahedra, flattened / instanced layout; over its sphere primitive; one ray per query (x1)\n"
              << "or packets of eight (x8). Ratios: ours / the fastest Embree contender over the same shape\n";
    std::cout << std::setw(7) << "count" << std::setw(4) << "thr" << " |" << std::setw(27)
              << "sphere: pass resolve total"
              << " |" << std::setw(27) << "icosahedron: pass resolve total" << " |" << std::setw(9) << "ico flat"
              << std::setw(9) << "ico inst" << std::setw(9) << "flat x8" << std::setw(9) << "inst x8" << " |"
              << std::setw(9) << "sph x1" << std::setw(9) << "sph x8" << " |" << std::setw(9) << "sph/Esph"
              << std::setw(9) << "ico/Eico" << "\n";

    std::vector<double> fit_counts, fit_sphere, fit_icosa, fit_embree_icosa, fit_embree_sphere;
    double report_ratio = 0, report_speedup_icosa = 0, report_sphere_ratio = 0, report_embree = 0;
    double large_sphere_ratio = 0, large_ms = 0, large_hits = 0;
    Disagreements icosa_disagreements, sphere_disagreements;
    std::size_t kernel_disagreements_total = 0;
    CsvFile kernel_csv("particles,threads,tracer,kernel,total_ms,ratio_vs_uniform,ratio_vs_embree");
    for (const std::uint32_t n : counts) {
        const bool large = n >= kLargeSceneFrom;
        TubeSettings settings;
        settings.particles = n;
        settings.particle_radius = bench_particle_radius(n, settings.particle_radius);
        const std::uint32_t cutoff = large ? 0 : kCutoff;
        const std::vector<Particle> ps = generate_tubes(settings);
        std::vector<std::uint32_t> all(n);
        std::iota(all.begin(), all.end(), 0u);
        const int build_repeats = large ? 1 : options.repeats;

        // Builds, all threads. Ours: stand-in BLAS + instances + TLAS build (SmokeScene + commit). Embree:
        // each contender its own scene.
        std::vector<Contender> c(kContenders);
        c[kOursSphere].tracer = c[kOursIcosahedron].tracer = "smoketrace";
        c[kOursSphere].stand_in = "sphere";
        c[kOursIcosahedron].stand_in = "icosahedron";
        every_thread.execute([&] {
            for (const int k : {kOursSphere, kOursIcosahedron}) {
                const StandInShape shape{k == kOursSphere ? StandInKind::sphere : StandInKind::icosahedron, 0};
                c[k].build_ms = time_ms(build_repeats, [&] {
                    c[k].ours.reset();
                    c[k].ours.emplace(ps, shape, ground_quad(), false);
                    c[k].ours->update(ps, glm::vec3(0.0f, 0.0f, 10.0f));
                }).median;
                c[k].depths = std::make_unique<OpticalPathLengths>(n);
            }
            for (int k = kFirstEmbree; k < kContenders; ++k) {
                const EmbreeKind kind = kEmbreeKinds[k - kFirstEmbree];
                c[k].layout = kind.layout;
                c[k].query = kind.query;
                c[k].stand_in = kind.layout == Layout::spheres ? "sphere" : "icosahedron";
                c[k].tracer = std::string(name_of(kind.layout)) + (kind.query == Query::single ? "_x1" : "_x8");
                c[k].build_ms = time_ms(build_repeats, [&] {
                    c[k].embree.reset();
                    c[k].embree = std::make_unique<EmbreePass>(device, ps, kind.layout, true);
                }).median;
            }
        });

        for (const int threads : {1, all_threads}) {
            tbb::task_arena& arena = threads == 1 ? one_thread : every_thread;
            // Round-robin over the tracers, so that the shared machine's load hits them alike. Small counts
            // get a warm-up round (first-frame allocations, cold caches, idle TBB workers would dominate);
            // at 10k and 100k one pass takes long enough that these are noise, and quick mode runs one round.
            // Up to 1500 particles a round of all of them takes a few ms, so it runs at least
            // kSmallCountRounds rounds: with five, the 750-particle ratio spread over 2.5-3.3x in three runs
            // of the same binary on this shared machine.
            const int rounds =
                large ? (options.quick ? 1 : options.repeats) : std::max(options.repeats, kSmallCountRounds);
            arena.execute([&] {
                if (!large) {
                    for (Contender& k : c) k.run_once(ps, all, dir, cutoff);
                    for (Contender& k : c) k.medians();
                }
                for (int r = 0; r < rounds; ++r)
                    for (Contender& k : c) k.run_once(ps, all, dir, cutoff);
            });
            Times t[kContenders];
            for (int k = 0; k < kContenders; ++k) t[k] = c[k].medians();
            double embree_icosa = std::numeric_limits<double>::infinity(), embree_sphere = embree_icosa;
            for (int k = kFirstEmbree; k < kContenders; ++k) {
                double& best = c[k].layout == Layout::spheres ? embree_sphere : embree_icosa;
                best = std::min(best, t[k].total);
            }
            std::cout << std::setw(7) << n << std::setw(4) << threads << " |" << std::fixed << std::setprecision(3)
                      << std::setw(9) << t[kOursSphere].pass << std::setw(8) << t[kOursSphere].resolve << std::setw(10)
                      << t[kOursSphere].total << " |" << std::setw(9) << t[kOursIcosahedron].pass << std::setw(8)
                      << t[kOursIcosahedron].resolve << std::setw(10) << t[kOursIcosahedron].total << " |";
            for (int k = kFirstEmbree; k < kContenders; ++k)
                std::cout << std::setw(9) << t[k].total << (k == kFirstEmbree + 3 ? " |" : "");
            std::cout << " |" << std::setprecision(2) << std::setw(9) << t[kOursSphere].total / embree_sphere
                      << std::setw(9) << t[kOursIcosahedron].total / embree_icosa << "\n"
                      << std::defaultfloat;
            for (int k = 0; k < kContenders; ++k)
                csv.push_back({n, settings.particle_radius, cutoff, c[k].tracer, c[k].stand_in, threads, t[k],
                               t[k].total / (c[k].stand_in == "sphere" ? embree_sphere : embree_icosa), c[k].work()});
            if (threads == all_threads) {
                fit_counts.push_back(n);
                fit_sphere.push_back(t[kOursSphere].total);
                fit_icosa.push_back(t[kOursIcosahedron].total);
                fit_embree_icosa.push_back(embree_icosa);
                fit_embree_sphere.push_back(embree_sphere);
                if (n == kReportCount) {
                    report_ratio = t[kOursIcosahedron].total / embree_icosa;
                    report_speedup_icosa = embree_icosa / t[kOursSphere].total;
                    report_sphere_ratio = t[kOursSphere].total / embree_sphere;
                    report_embree = embree_icosa;
                }
                if (n == kLargeCount) large_sphere_ratio = t[kOursSphere].total / embree_sphere;
            }
        }
        // Both did the same work: our answers against each Embree contender's over the same shape (last runs).
        Disagreements differ_icosa, differ_sphere;
        for (int k = kFirstEmbree; k < kContenders; ++k) {
            if (c[k].layout == Layout::spheres)
                differ_sphere += disagreements(*c[kOursSphere].depths, c[k].embree_hits);
            else
                differ_icosa += disagreements(*c[kOursIcosahedron].depths, c[k].embree_hits);
        }
        icosa_disagreements += differ_icosa;
        sphere_disagreements += differ_sphere;
        const Work ws = c[kOursSphere].work(), wi = c[kOursIcosahedron].work();
        std::cout << std::fixed << std::setprecision(2) << "        radius " << settings.particle_radius << ", cutoff "
                  << (cutoff ? std::to_string(cutoff) : std::string("none")) << ": surfaces per ray " << ws.hits_per_ray
                  << " (spheres), " << wi.hits_per_ray << " (icosahedra); cut off " << ws.cut_off << " and "
                  << wi.cut_off << " of " << n << "; Embree disagreements " << differ_sphere.differ << " (spheres), "
                  << differ_icosa.differ << " (icosahedra), grazing " << differ_sphere.grazing + differ_icosa.grazing
                  << "\n"
                  << "        builds (all threads, ms): sphere " << c[kOursSphere].build_ms << ", icosahedron "
                  << c[kOursIcosahedron].build_ms << "; embree flattened " << c[kFirstEmbree].build_ms << ", instanced "
                  << c[kFirstEmbree + 1].build_ms << ", spheres " << c[kFirstEmbree + 4].build_ms << "\n"
                  << std::defaultfloat;

        if (n == kReportCount || n == 10'000 || n == kLargeCount) {
            std::cout << "        density kernels over spheres (ms; ours pass + resolve, Embree spheres x1 summing the "
                         "same shares in its filter):\n"
                      << "          thr |  uniform | gaussian    poly1    poly2 | x uniform: gauss  poly1  poly2 | "
                         "embree x1: gauss    poly1    poly2 | ours/embree: gauss poly1 poly2\n";
            for (const int threads : {1, all_threads}) {
                tbb::task_arena& arena = threads == 1 ? one_thread : every_thread;
                const int rounds =
                    large ? (options.quick ? 1 : options.repeats) : std::max(options.repeats, kSmallCountRounds);
                const KernelTimes t = compare_kernels(arena, *c[kOursSphere].ours, *c[kFirstEmbree + 4].embree, ps, all,
                                                      dir, cutoff, rounds, !large, kernel_disagreements_total);
                std::cout << std::fixed << std::setprecision(3) << "          " << std::setw(3) << threads << " |"
                          << std::setw(9) << t.uniform << " |";
                for (const double o : t.ours) std::cout << std::setw(9) << o;
                std::cout << " |           " << std::setprecision(2);
                for (const double o : t.ours) std::cout << std::setw(7) << o / t.uniform;
                std::cout << " |           " << std::setprecision(3);
                for (const double e : t.embree) std::cout << std::setw(9) << e;
                std::cout << " |             " << std::setprecision(2);
                for (int k = 0; k < 3; ++k) std::cout << std::setw(6) << t.ours[k] / t.embree[k];
                std::cout << "\n" << std::defaultfloat;
                kernel_csv.row(n, threads, "smoketrace", "uniform", t.uniform, 1.0, "");
                for (int k = 0; k < 3; ++k) {
                    kernel_csv.row(n, threads, "smoketrace", kBenchKernels[k].name(), t.ours[k], t.ours[k] / t.uniform,
                                   t.ours[k] / t.embree[k]);
                    kernel_csv.row(n, threads, "embree_spheres_x1", kBenchKernels[k].name(), t.embree[k],
                                   t.embree[k] / t.uniform, "");
                    if (threads == all_threads && (n == kReportCount || n == kLargeCount)) {
                        const std::string at = n == kLargeCount ? "_100k" : "";
                        report("od_kernel_" + kBenchKernels[k].name() + "_ratio_vs_uniform" + at, t.ours[k] / t.uniform);
                        report("od_kernel_" + kBenchKernels[k].name() + "_ratio_vs_embree" + at, t.ours[k] / t.embree[k]);
                    }
                }
            }
        }
        if (n == kReportCount) {
            // Why Embree runs in robust mode here: without it, the flattened layout misses crossings of the
            // shared edges every ray leaves its own particle through (light from above). Its speed is shown
            // beside, with the ratio it would give, but it is not the reference: it does not do the same job.
            const double ours_icosa = report_ratio * report_embree;
            for (const Query q : {Query::single, Query::packet8}) {
                EmbreePass fast(device, ps, Layout::flattened, false);
                OpticalDepthHits hits;
                double ms = 0;
                every_thread.execute([&] {
                    ms = time_ms(options.repeats, [&] { fast.run(ps, dir, cutoff, q, hits); }).median;
                });
                std::cout << "        embree flattened " << (q == Query::single ? "x1" : "x8")
                          << " without robust mode: " << std::fixed << std::setprecision(3) << ms << " ms ("
                          << std::setprecision(2) << ms / report_embree
                          << "x the robust reference; ours over icosahedra " << ours_icosa / ms
                          << "x its time), wrong on " << disagreements(*c[kOursIcosahedron].depths, hits).total()
                          << " of " << n << " particles (not used)\n"
                          << std::defaultfloat;
            }
        }
        if (n == kLargeCount) {
            // Cold: scene (BLAS, instances, TLAS build) + pass + resolve, all threads, sphere stand-ins.
            c.clear();  // free the Embree scenes first
            OpticalPathLengths od(n);
            every_thread.execute([&] {
                large_ms = time_ms(options.quick ? 1 : options.repeats, [&] {
                    SmokeScene scene(ps, StandInShape{StandInKind::sphere, 0}, ground_quad(), false);
                    scene.update(ps, glm::vec3(0.0f, 0.0f, 10.0f));
                    FrameTimings ft;
                    od.update(scene, ps, all, kToLight, OpticalDepthSettings{cutoff}, HitSort::adaptive, ft);
                }).median;
            });
            const Work w = work_of(od.status(), od.hit_counts());
            large_hits = w.hits_per_ray;
            std::cout << "        " << n << " particles from scratch (scene, TLAS build, pass, resolve): " << std::fixed
                      << std::setprecision(1) << large_ms << " ms; " << std::setprecision(2) << w.hits_per_ray
                      << " surfaces per ray, " << w.cut_off << " cut off\n"
                      << std::defaultfloat;
        }
    }

    std::cout << "Embree and ours disagree on " << sphere_disagreements.differ << " particle answers over spheres and "
              << icosa_disagreements.differ << " over icosahedra (must be 0); grazing (same length, an entry and an "
              << "exit more in one of them): " << sphere_disagreements.grazing << " and " << icosa_disagreements.grazing
              << " (summed over the contenders)\n";
    // The growth of the cost with the count, separately for the two kinds of scene: table B.1's (the
    // radius kept: surfaces per ray grow with the count) and the large counts' (about as many per ray).
    std::vector<std::size_t> b1, big;
    for (std::size_t i = 0; i < fit_counts.size(); ++i) (fit_counts[i] < kLargeSceneFrom ? b1 : big).push_back(i);
    auto exponent = [&](const std::vector<std::size_t>& which, const std::vector<double>& ms) {
        std::vector<double> x, y;
        for (const std::size_t i : which) {
            x.push_back(fit_counts[i]);
            y.push_back(ms[i]);
        }
        return fit_exponent(x, y);
    };
    std::cout << "Cost exponent (log-log least squares of ms vs count, all threads):\n" << std::fixed
              << std::setprecision(2);
    for (const auto& [label, which] : {std::pair{"  table B.1 counts (cutoff 60):         ", &b1},
                                       std::pair{"  10k, 100k (no cutoff, radius shrunk): ", &big}})
        std::cout << label << "sphere " << exponent(*which, fit_sphere) << ", icosahedron "
                  << exponent(*which, fit_icosa) << ", embree spheres " << exponent(*which, fit_embree_sphere)
                  << ", embree icosahedra " << exponent(*which, fit_embree_icosa) << "\n";
    std::cout.flags(cout_flags);
    std::cout.precision(cout_precision);

    CsvFile file("particles,radius,cutoff,tracer,stand_in,threads,build_ms,pass_ms,resolve_ms,total_ms,"
                 "ratio_vs_embree,hits_per_ray,cut_off");
    for (const CsvRow& r : csv)
        file.row(r.particles, r.radius, r.cutoff, r.tracer, r.stand_in, r.threads, r.t.build, r.t.pass, r.t.resolve,
                 r.t.total, r.ratio_vs_embree, r.work.hits_per_ray, r.work.cut_off);
    file.write(std::filesystem::path(options.results_dir) / "optical_depth.csv");

    report("od_sphere_speedup_vs_embree_sphere", 1.0 / report_sphere_ratio);
    report("od_sphere_ratio_vs_embree_sphere", report_sphere_ratio);
    report("od_pass_ratio_vs_embree", report_ratio);
    report("od_sphere_speedup_vs_embree_icosahedron", report_speedup_icosa);
    report("od_sphere_ratio_vs_embree_sphere_100k", large_sphere_ratio);
    report("od_100k_ms", large_ms);
    report("od_100k_hits_per_ray", large_hits);
    report("od_embree_sphere_disagreements", double(sphere_disagreements.differ));
    report("od_embree_disagreements", double(icosa_disagreements.differ));
    report("od_embree_grazing", double(sphere_disagreements.grazing + icosa_disagreements.grazing));
    std::cout << "Embree and ours disagree on " << kernel_disagreements_total
              << " particles' kernel sums, statuses or counts (must be 0)\n";
    report("od_kernel_embree_disagreements", double(kernel_disagreements_total));
    kernel_csv.write(std::filesystem::path(options.results_dir) / "optical_depth_kernels.csv");
}

const RegisterSection kOpticalDepthSection{{"optical_depth",
                                            "optical-depth pass + resolve (thesis 4.3.2-4.3.3, table B.1 counts, "
                                            "10k, 100k) vs Embree 3 all-hits over spheres and icosahedra",
                                            &run_optical_depth}};

}  // namespace
}  // namespace smoketrace::bench
