#pragma once
// The optical-depth pass, ours against Embree 3 doing the same all-hits work over the same stand-ins
// (sections "optical_depth" and "threads"): the scene of each particle count, Embree's side of the pass
// (EmbreePass: its sphere primitive, or icosahedra flattened or instanced; single rays or packets of eight)
// and the contenders of one count. bench_optical_depth.cpp says what each does and why it is the same work.
#include "bench_util.hpp"
#include "support/embree_reference.hpp"
#include "timing.hpp"

#include <smoketrace/geometry/ray_bundle.hpp>
#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/smoke/tube_generator.hpp>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace smoketrace::bench::optical_depth {

namespace er = embree_reference;

inline constexpr std::uint32_t kCutoff = 60;  // the thesis's default optical depth cutoff point (4.4.3)
inline constexpr std::uint32_t kLargeCount = 100'000;  // at kLargeSceneFrom and above: no cutoff, radius shrunk
inline const glm::vec3 kToLight(0.0f, 1.0f, 0.0f);

// The scene of `n` particles: the two tubes with the TubeSettings defaults but the count (table B.1 varies
// nothing else), the radius shrunk from kLargeSceneFrom on (bench_particle_radius).
inline TubeSettings tube_settings(std::uint32_t n) {
    TubeSettings settings;
    settings.particles = n;
    settings.particle_radius = bench_particle_radius(n, settings.particle_radius);
    return settings;
}
// Its cutoff: the thesis's up to 1500 particles, none from kLargeSceneFrom on.
inline std::uint32_t cutoff_for(std::uint32_t n) { return n >= kLargeSceneFrom ? 0 : kCutoff; }

// The ground under the smoke (lowest particle surface at y = −separation − tube_radius − radius = −2.7).
inline GroundQuad ground_quad() {
    return GroundQuad{{glm::vec3(-20.0f, -3.0f, 20.0f), glm::vec3(20.0f, -3.0f, 20.0f), glm::vec3(20.0f, -3.0f, -20.0f),
                       glm::vec3(-20.0f, -3.0f, -20.0f)}};
}

// Embree's stand-ins: icosahedra in one world-space mesh or instanced, or its own sphere primitive.
enum class Layout { flattened, instanced, spheres };
// How Embree is asked: one ray per rtcOccluded1, or a packet of eight per rtcOccluded8.
enum class Query { single, packet8 };
inline const char* name_of(Layout l) {
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
        ground_geometry_ = scene_.attach_mesh(er::quad_mesh(ground_quad()));
        if (layout == Layout::flattened) {
            scene_.attach_mesh(er::flattened_stand_ins(ps, unit));
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
        ground_only_.attach_mesh(er::quad_mesh(ground_quad()));
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
inline void check_embree_spheres(const er::Device& device) {
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

inline Work work_of(const std::vector<DepthStatus>& status, const std::vector<std::uint32_t>& hit_counts) {
    Work w{mean_of(hit_counts), 0};
    for (const DepthStatus s : status) w.cut_off += s == DepthStatus::cutoff;
    return w;
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
inline constexpr int kOursSphere = 0, kOursIcosahedron = 1, kFirstEmbree = 2;
struct EmbreeKind {
    Layout layout;
    Query query;
};
inline constexpr EmbreeKind kEmbreeKinds[] = {{Layout::flattened, Query::single}, {Layout::instanced, Query::single},
                                       {Layout::flattened, Query::packet8}, {Layout::instanced, Query::packet8},
                                       {Layout::spheres, Query::single},   {Layout::spheres, Query::packet8}};
inline constexpr int kContenders = kFirstEmbree + int(std::size(kEmbreeKinds));


// The contenders of one count in kContenders' order, each built `build_repeats` times (the median in
// build_ms): ours, a SmokeScene over each stand-in shape and its first update (the TLAS build), and each
// Embree kind its own scene (robust mode). The builds take the threads of the arena this is called in.
inline std::vector<Contender> make_contenders(const er::Device& device, const std::vector<Particle>& ps,
                                              int build_repeats) {
    std::vector<Contender> c(kContenders);
    c[kOursSphere].tracer = c[kOursIcosahedron].tracer = "smoketrace";
    c[kOursSphere].stand_in = "sphere";
    c[kOursIcosahedron].stand_in = "icosahedron";
    for (const int k : {kOursSphere, kOursIcosahedron}) {
        const StandInShape shape{k == kOursSphere ? StandInKind::sphere : StandInKind::icosahedron, 0};
        c[k].build_ms = time_ms(build_repeats, [&] {
            c[k].ours.reset();
            c[k].ours.emplace(ps, shape, ground_quad(), false);
            c[k].ours->update(ps, glm::vec3(0.0f, 0.0f, 10.0f));
        }).median;
        c[k].depths = std::make_unique<OpticalPathLengths>(ps.size());
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
    return c;
}

}  // namespace smoketrace::bench::optical_depth
