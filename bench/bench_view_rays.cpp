// Bench section "view_rays": the view pass's rays (thesis 4.3.5) on the smoke scene, smoketrace's trace()
// against Embree 3 on the same triangles and the same camera rays, in one run:
//   * build: our billboards-only scene (quad BLAS, n+1 instances, TLAS; everything timed) against Embree's
//     commit of the same billboard quads and ground (its vertex and instance set-up untimed; also written
//     with the set-up timed); our whole SmokeScene (stand-ins too, 2n+1 instances) printed beside;
//   * closest hit: one ray per pixel, billboards taken as opaque (ours: ray_flag_force_opaque, mask ~1 in
//     the SmokeScene, whose stand-ins the masks skip), the nearest billboard or the ground;
//   * layers: what the one-traversal compositor really asks, every billboard in front of the ground
//     (ours: any-hit that records and ignores, the ground opaque; Embree: a context filter that records and
//     rejects billboard hits and accepts the ground's).
// Embree runs with its default build quality (medium), in two layouts (flattened: one mesh of world-space
// quads; instanced: one quad, an instance per particle, like ours), without and with RTC_SCENE_FLAG_ROBUST,
// and with two kinds of query: one ray per rtcIntersect1 (x1), or a 4x4 tile of pixels per rtcIntersect16
// with the coherent context flag (x16: Embree's packets, made for camera rays; the layers through the same
// context filter, per lane). The fastest of these is the reference of each ratio ("Embree at its best for
// speed"), and its name is printed. Every packet contender's answers are checked against the same scene's
// single rays: per ray the nearest t, or the layers in front of the ground and the ground's t. Closest-hit
// scenes carry no filter flag (Embree's leanest). Ratios are time ours / time Embree: above 1 means we are
// slower. Headline figures are single-threaded (the stable ones on a shared machine); all-thread rows are
// printed and written too. From 10k particles on (the full run) the particle radius shrinks with the count
// (bench_util.hpp), so that a ray meets about as many billboards as at 750; layers per ray are printed.
// Ours also runs tiled, as the tiled compositor does: the same rays 16x16 pixels at a time through trace_tile()
// (trace_tile.hpp), the same flags, masks and any-hit work as our single rays, timed in the same rounds. Each
// tile is made from the camera before timing, as the rays are, and copied per trace (trace_tile() lowers its
// tmax), as Embree's packets are loaded from the rays. Its answers are checked against our single rays: per
// ray the closest hit's t (bit for bit) and instance, the ground's t and the layers in front of it.
// view_rays.csv's ours_over_this is our single rays' time over the row's, tiled_over_this our tiled time.
#include "bench_registry.hpp"
#include "bench_util.hpp"
#include "embree_device.hpp"
#include "support/embree_reference.hpp"
#include "timing.hpp"

#include <smoketrace/render/camera.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/trace/trace.hpp>
#include <smoketrace/trace/trace_tile.hpp>
#include <smoketrace/render/view_compositor.hpp>

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace smoketrace::bench {
namespace {

namespace er = embree_reference;

// Layers per ray kept in the fixed per-ray buffer (beyond this they are only counted).
constexpr std::uint32_t kLayerCapacity = 512;
// Embree's packets: a kTile x kTile tile of pixels per rtcIntersect16.
constexpr int kTile = 4;
constexpr int kPacket = kTile * kTile;
// Two answers for one ray are the same when their t differ by at most this, relative (at least 1): the
// same tolerance as the closest-hit check against ours.
constexpr float kSameT = 1e-4f;

bool same_t(float a, float b) {
    return (std::isinf(a) && std::isinf(b)) || std::abs(a - b) <= kSameT * std::max(1.0f, std::abs(a));
}

// Bit for bit: trace_tile() promises each ray the t trace() gives it.
bool same_bits(float a, float b) { return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b); }
bool same_bits(const glm::vec3& a, const glm::vec3& b) {
    return same_bits(a.x, b.x) && same_bits(a.y, b.y) && same_bits(a.z, b.z);
}

struct LayerRecord {
    std::array<float, kLayerCapacity> t;
    std::uint32_t count = 0;
    void add(float x) {
        if (count < kLayerCapacity) t[count] = x;
        ++count;
    }
    // Layers in front of the opaque surface at t_opaque (those the compositor keeps).
    [[nodiscard]] std::uint32_t in_front(float t_opaque) const {
        std::uint32_t n = 0;
        for (std::uint32_t i = 0; i < std::min(count, kLayerCapacity); ++i) n += t[i] < t_opaque;
        return n;
    }
    // The kept layers in front of t_opaque, nearest first (for the same-answers check, untimed).
    [[nodiscard]] std::vector<float> sorted_in_front(float t_opaque) const {
        std::vector<float> v;
        for (std::uint32_t i = 0; i < std::min(count, kLayerCapacity); ++i)
            if (t[i] < t_opaque) v.push_back(t[i]);
        std::sort(v.begin(), v.end());
        return v;
    }
};

// The same layers for one ray from two queries: the ground's t, and every layer in front of it. (Layers
// behind the ground are not compared: which of them a query meets before it accepts the ground depends on
// its traversal order.)
bool same_layers(const LayerRecord& a, float ground_a, const LayerRecord& b, float ground_b) {
    if (!same_t(ground_a, ground_b)) return false;
    const std::vector<float> x = a.sorted_in_front(ground_a), y = b.sorted_in_front(ground_b);
    if (x.size() != y.size()) return false;
    for (std::size_t i = 0; i < x.size(); ++i)
        if (!same_t(x[i], y[i])) return false;
    return true;
}

// The rays of tile `tile` of a width-pixel-wide image (rays in row order): lane l is pixel
// (kTile·tx + l % kTile, kTile·ty + l / kTile).
std::array<const Ray*, kPacket> tile_rays(const std::vector<Ray>& rays, int width, std::size_t tile) {
    const std::size_t tiles_x = std::size_t(width / kTile);
    const std::size_t x0 = (tile % tiles_x) * kTile, y0 = (tile / tiles_x) * kTile;
    std::array<const Ray*, kPacket> out;
    for (int l = 0; l < kPacket; ++l)
        out[std::size_t(l)] =
            &rays[(y0 + std::size_t(l / kTile)) * std::size_t(width) + x0 + std::size_t(l % kTile)];
    return out;
}

// What one pass over the rays returns: its work, so the two tracers can be seen to do the same job.
struct Work {
    std::uint64_t hits = 0;    // closest: rays that hit something; layers: layers in front of the ground
    double t_sum = 0;          // closest: summed t of the hits
    Work& operator+=(const Work& o) {
        hits += o.hits;
        t_sum += o.t_sum;
        return *this;
    }
};

TriangleMesh unit_quad() {
    TriangleMesh q;
    q.vertices = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    q.triangles = {{0, 1, 2}, {0, 2, 3}};  // as smoke_scene.cpp's billboards
    return q;
}

TriangleMesh ground_mesh(const GroundQuad& g) {
    TriangleMesh m;
    m.vertices.assign(g.corners.begin(), g.corners.end());
    m.triangles = {{0, 1, 2}, {0, 2, 3}};
    return m;
}

// Our billboards-only scene: exactly what Embree gets (quads and ground), as a two-level scene.
struct OursBillboards {
    AccelScene scene;
    OursBillboards(const std::vector<Particle>& ps, const glm::vec3& eye, const GroundQuad& ground) {
        const auto quad = scene.add_bottom_level(BottomLevel::from_mesh(unit_quad(), false));
        for (std::size_t i = 0; i < ps.size(); ++i)
            scene.add_instance(Instance{quad, SmokeScene::billboard_transform(ps[i], eye), kBillboardMask, std::uint32_t(i)});
        const auto g = scene.add_bottom_level(BottomLevel::from_mesh(ground_mesh(ground), true));
        scene.add_instance(Instance{g, AffineTransform{}, kGroundMask, SmokeScene::kGroundUserId});
        scene.commit();
    }
};

enum class Layout { flattened, instanced };

// Embree's scene of the billboards and the ground.
class EmbreeBillboards {
public:
    EmbreeBillboards(const er::Device& device, const std::vector<Particle>& ps, const glm::vec3& eye,
                     const GroundQuad& ground, Layout layout, bool robust, bool filter)
        : scene_(device, er::SceneOptions{RTC_BUILD_QUALITY_MEDIUM, robust, filter}) {
        ground_geometry_ = scene_.attach_mesh(ground_mesh(ground));
        const TriangleMesh quad = unit_quad();
        if (layout == Layout::flattened) {
            TriangleMesh world;
            for (const Particle& p : ps) {
                const AffineTransform m = SmokeScene::billboard_transform(p, eye);
                const auto base = std::uint32_t(world.vertices.size());
                for (const glm::vec3& v : quad.vertices) world.vertices.push_back(glm::vec3(m.point(glm::dvec3(v))));
                for (const glm::uvec3& t : quad.triangles) world.triangles.push_back(t + base);
            }
            scene_.attach_mesh(world);
        } else {
            child_ = std::make_unique<er::Scene>(device, er::SceneOptions{RTC_BUILD_QUALITY_MEDIUM, robust, filter});
            child_->attach_mesh(quad);
            child_->commit();
            for (const Particle& p : ps) {
                const AffineTransform m = SmokeScene::billboard_transform(p, eye);
                float xfm[12];
                for (int c = 0; c < 3; ++c)
                    for (int r = 0; r < 3; ++r) xfm[3 * c + r] = float(m.linear[c][r]);
                for (int r = 0; r < 3; ++r) xfm[9 + r] = float(m.translation[r]);
                RTCGeometry g = rtcNewGeometry(device.handle(), RTC_GEOMETRY_TYPE_INSTANCE);
                rtcSetGeometryInstancedScene(g, child_->handle());
                rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm);
                rtcCommitGeometry(g);
                rtcAttachGeometry(scene_.handle(), g);
                rtcReleaseGeometry(g);
            }
            device.check("instances");
        }
    }
    void commit() { scene_.commit(); }

    [[nodiscard]] bool closest(const Ray& r, float& t) const {
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        RTCRayHit rh = er::to_rtc_ray_hit(r);
        rtcIntersect1(scene_.handle(), &context, &rh);
        t = rh.ray.tfar;
        return rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }

    // Every billboard hit recorded and rejected; the ground accepted. Returns the ground's t (or +inf).
    float layers(const Ray& r, LayerRecord& record) const {
        LayerContext ctx;
        rtcInitIntersectContext(&ctx.base);
        ctx.base.filter = &LayerContext::filter;
        ctx.ground = ground_geometry_;
        ctx.records = &record;
        RTCRayHit rh = er::to_rtc_ray_hit(r);
        rtcIntersect1(scene_.handle(), &ctx.base, &rh);
        return rh.hit.geomID != RTC_INVALID_GEOMETRY_ID ? rh.ray.tfar : std::numeric_limits<float>::infinity();
    }

    // closest() for the kPacket rays of a tile as one coherent packet: t[l] the nearest hit's t, +inf on a
    // miss.
    void closest16(const std::array<const Ray*, kPacket>& rays, std::array<float, kPacket>& t) const {
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        RTCRayHit16 packet;
        load(packet, rays);
        rtcIntersect16(kAllValid.data(), scene_.handle(), &context, &packet);
        for (int l = 0; l < kPacket; ++l)
            t[std::size_t(l)] = packet.hit.geomID[l] != RTC_INVALID_GEOMETRY_ID
                                    ? packet.ray.tfar[l]
                                    : std::numeric_limits<float>::infinity();
    }

    // layers() for the kPacket rays of a tile as one coherent packet: records[l] gets lane l's billboards;
    // ground_t[l] the ground's t (or +inf).
    void layers16(const std::array<const Ray*, kPacket>& rays, LayerRecord* records,
                  std::array<float, kPacket>& ground_t) const {
        LayerContext ctx;
        rtcInitIntersectContext(&ctx.base);
        ctx.base.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        ctx.base.filter = &LayerContext::filter;
        ctx.ground = ground_geometry_;
        ctx.records = records;
        RTCRayHit16 packet;
        load(packet, rays);
        rtcIntersect16(kAllValid.data(), scene_.handle(), &ctx.base, &packet);
        for (int l = 0; l < kPacket; ++l)
            ground_t[std::size_t(l)] = packet.hit.geomID[l] != RTC_INVALID_GEOMETRY_ID
                                           ? packet.ray.tfar[l]
                                           : std::numeric_limits<float>::infinity();
    }

private:
    alignas(64) static constexpr std::array<int, kPacket> kAllValid = [] {
        std::array<int, kPacket> v{};
        v.fill(-1);
        return v;
    }();

    // Lane l of the packet: ray l of the tile, with id l (the filter's index into the lanes' records).
    static void load(RTCRayHit16& packet, const std::array<const Ray*, kPacket>& rays) {
        for (int l = 0; l < kPacket; ++l) {
            const RTCRayHit one = er::to_rtc_ray_hit(*rays[std::size_t(l)]);
            packet.ray.org_x[l] = one.ray.org_x;
            packet.ray.org_y[l] = one.ray.org_y;
            packet.ray.org_z[l] = one.ray.org_z;
            packet.ray.tnear[l] = one.ray.tnear;
            packet.ray.dir_x[l] = one.ray.dir_x;
            packet.ray.dir_y[l] = one.ray.dir_y;
            packet.ray.dir_z[l] = one.ray.dir_z;
            packet.ray.time[l] = one.ray.time;
            packet.ray.tfar[l] = one.ray.tfar;
            packet.ray.mask[l] = one.ray.mask;
            packet.ray.id[l] = unsigned(l);
            packet.ray.flags[l] = one.ray.flags;
            packet.hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;
            packet.hit.primID[l] = RTC_INVALID_GEOMETRY_ID;
            for (unsigned k = 0; k < RTC_MAX_INSTANCE_LEVEL_COUNT; ++k)
                packet.hit.instID[k][l] = RTC_INVALID_GEOMETRY_ID;
        }
    }

    // A single ray has id 0 and one record; a packet's lane l has id l and records[l].
    struct LayerContext {
        RTCIntersectContext base;
        std::uint32_t ground;
        LayerRecord* records;
        static void filter(const RTCFilterFunctionNArguments* args) {
            auto* self = reinterpret_cast<LayerContext*>(args->context);
            for (unsigned i = 0; i < args->N; ++i) {
                if (args->valid[i] != -1) continue;
                const bool ground = RTCHitN_instID(args->hit, args->N, i, 0) == RTC_INVALID_GEOMETRY_ID &&
                                    RTCHitN_geomID(args->hit, args->N, i) == self->ground;
                if (ground) continue;  // opaque: accepted
                self->records[RTCRayN_id(args->ray, args->N, i)].add(RTCRayN_tfar(args->ray, args->N, i));
                args->valid[i] = 0;
            }
        }
    };

    er::Scene scene_;
    std::unique_ptr<er::Scene> child_;
    std::uint32_t ground_geometry_ = RTC_INVALID_GEOMETRY_ID;
};

// --- the passes -------------------------------------------------------------------------------------------

using RangePass = std::function<Work(std::size_t, std::size_t)>;

// Items are rays, or tiles of kPacket rays; a task takes about 1024 rays either way.
Work run_pass(bool parallel, std::size_t items, std::size_t grain, const RangePass& pass) {
    if (!parallel) return pass(0, items);
    tbb::combinable<Work> partial;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, items, grain),
                      [&](const tbb::blocked_range<std::size_t>& r) { partial.local() += pass(r.begin(), r.end()); });
    return partial.combine([](Work a, const Work& b) { return a += b; });
}

template <class Trace>
RangePass closest_pass(const std::vector<Ray>& rays, Trace trace_one) {
    return [&rays, trace_one](std::size_t b, std::size_t e) {
        Work w;
        for (std::size_t i = b; i < e; ++i) {
            float t;
            if (trace_one(rays[i], t)) {
                ++w.hits;
                w.t_sum += t;
            }
        }
        return w;
    };
}

template <class Trace>
RangePass layers_pass(const std::vector<Ray>& rays, Trace trace_one) {
    return [&rays, trace_one](std::size_t b, std::size_t e) {
        Work w;
        LayerRecord record;
        for (std::size_t i = b; i < e; ++i) {
            record.count = 0;
            const float t_opaque = trace_one(rays[i], record);
            w.hits += record.in_front(t_opaque);
        }
        return w;
    };
}

// Embree's packets over tiles [b, e) of a width-pixel-wide image: the same work as closest_pass.
RangePass closest_packet_pass(const std::vector<Ray>& rays, int width, const EmbreeBillboards* e) {
    return [&rays, width, e](std::size_t b, std::size_t end) {
        Work w;
        std::array<float, kPacket> t;
        for (std::size_t tile = b; tile < end; ++tile) {
            e->closest16(tile_rays(rays, width, tile), t);
            for (const float x : t)
                if (!std::isinf(x)) {
                    ++w.hits;
                    w.t_sum += x;
                }
        }
        return w;
    };
}

// Embree's packets over tiles [b, e): the same work as layers_pass.
RangePass layers_packet_pass(const std::vector<Ray>& rays, int width, const EmbreeBillboards* e) {
    return [&rays, width, e](std::size_t b, std::size_t end) {
        Work w;
        const auto records = std::make_unique<LayerRecord[]>(kPacket);  // once per task, 32 KB: off the stack
        std::array<float, kPacket> ground_t;
        for (std::size_t tile = b; tile < end; ++tile) {
            for (int l = 0; l < kPacket; ++l) records[std::size_t(l)].count = 0;
            e->layers16(tile_rays(rays, width, tile), records.get(), ground_t);
            for (int l = 0; l < kPacket; ++l) w.hits += records[std::size_t(l)].in_front(ground_t[std::size_t(l)]);
        }
        return w;
    };
}

// --- ours, a 16x16 tile at a time (trace_tile()) ---

// The image's kTileColumns x kTileRows tiles in row order: lane (c, r) of tile k is the ray of pixel
// (x0 + c, y0 + r). The index of that pixel's ray in the row-order rays.
std::size_t tile_pixel(int width, std::size_t tile, unsigned lane) {
    const std::size_t tiles_x = std::size_t(width) / kTileColumns;
    const std::size_t x = (tile % tiles_x) * kTileColumns + lane % kTileColumns;
    const std::size_t y = (tile / tiles_x) * kTileRows + lane / kTileColumns;
    return y * std::size_t(width) + x;
}

struct AcceptEvery {
    AnyHitDecision operator()(unsigned, const TraceHit&) const { return AnyHitDecision::accept; }
};

// What a thread keeps from tile to tile, as the tiled compositor does, so that a tile allocates nothing.
struct TileState {
    TileResults results;
    TileScratch scratch;
    std::unique_ptr<LayerRecord[]> records;  // the layers' pass: one per ray of the tile
};
using TileStates = tbb::enumerable_thread_specific<TileState>;

// Our closest hits over tiles [b, e) of `tiles`: the same work as closest_pass with trace() (the same flags,
// the same mask).
RangePass closest_tile_pass(const std::vector<RayTile>& tiles, const AccelScene& scene, std::uint8_t mask) {
    auto states = std::make_shared<TileStates>();
    return [&tiles, &scene, mask, states](std::size_t b, std::size_t e) {
        TileState& st = states->local();
        Work w;
        for (std::size_t k = b; k < e; ++k) {
            RayTile tile = tiles[k];
            trace_tile(scene, tile, ray_flag_force_opaque, mask, AcceptEvery{}, st.results, st.scratch);
            for (unsigned lane = 0; lane < kTileRays; ++lane)
                if (st.results.hit(lane)) {
                    ++w.hits;
                    w.t_sum += st.results.t(lane);
                }
        }
        return w;
    };
}

// Our layers over tiles [b, e): the same work as layers_pass (every billboard recorded and ignored, the
// ground opaque, the layers in front of it counted).
RangePass layers_tile_pass(const std::vector<RayTile>& tiles, const AccelScene& scene, std::uint8_t mask) {
    auto states = std::make_shared<TileStates>();
    return [&tiles, &scene, mask, states](std::size_t b, std::size_t e) {
        TileState& st = states->local();
        if (!st.records) st.records = std::make_unique<LayerRecord[]>(kTileRays);  // 512 KB: once per thread
        LayerRecord* records = st.records.get();
        Work w;
        for (std::size_t k = b; k < e; ++k) {
            RayTile tile = tiles[k];
            for (unsigned lane = 0; lane < kTileRays; ++lane) records[lane].count = 0;
            trace_tile(scene, tile, ray_flag_none, mask,
                       [records](unsigned lane, const TraceHit& h) {
                           records[lane].add(h.t);
                           return AnyHitDecision::ignore;
                       },
                       st.results, st.scratch);
            for (unsigned lane = 0; lane < kTileRays; ++lane)
                w.hits += records[lane].in_front(st.results.hit(lane) ? st.results.t(lane)
                                                                      : std::numeric_limits<float>::infinity());
        }
        return w;
    };
}

struct Contender {
    std::string name;
    bool robust;  // Embree's robust mode (ours: always watertight)
    bool ours;
    RangePass pass;
    bool packets = false;       // Embree's rtcIntersect16 over tiles of kPacket rays
    unsigned item_rays = 1;     // rays per item of the pass: 1, kPacket (Embree's packets), kTileRays (ours tiled)
    std::vector<double> ms{};
    Work work{};
};

// Round-robin: repeat r of every contender before repeat r + 1, then medians. n: rays.
void time_round_robin(std::vector<Contender>& cs, int repeats, bool parallel, std::size_t n) {
    for (int r = 0; r < repeats; ++r)
        for (Contender& c : cs) {
            const auto t0 = std::chrono::steady_clock::now();
            // About 1024 rays per task whatever the item.
            c.work = run_pass(parallel, n / c.item_rays, std::max(1u, 1024 / c.item_rays), c.pass);
            c.ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        }
}

std::string fmt(double v, int precision = 3) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(precision) << v;
    return s.str();
}

void run_view_rays(const BenchOptions& options) {
    const int size = 512;
    static_assert(512 % kTile == 0 && 512 % kTileColumns == 0 && 512 % kTileRows == 0,
                  "the image is cut into whole tiles, Embree's and ours");
    const std::vector<std::uint32_t> counts = options.quick ? std::vector<std::uint32_t>{750}
                                                            : std::vector<std::uint32_t>{750, 1500, 10'000};
    const int repeats = std::max(options.repeats, 3);
    const int all_threads = tbb::info::default_concurrency();
    const er::Device device = bench_embree_device();
    CsvFile csv("particles,measure,implementation,robust,threads,rays,median_ms,min_ms,max_ms,ours_over_this,work,"
                "tiled_over_this");
    // Headline figures (750 particles, one thread): ours / the best Embree contender, over every one, over
    // the robust ones, over single rays only; whether the best one is a packet query; layers per ray. Ours
    // tiled: its time over the best Embree contender's, its rays per second (millions); at one thread and
    // at all threads (_mt).
    struct Headline {
        double ratio = 0, ratio_robust = 0, ratio_x1 = 0, best_is_packet = 0;
        double tiled_ratio = 0, tiled_mrays = 0, tiled_ratio_mt = 0, tiled_mrays_mt = 0;
    } headline_closest, headline_layers;
    double headline_build = 0, headline_layers_per_ray = 0;
    std::size_t disagreements_total = 0, packet_disagreements_total = 0, tiled_disagreements_total = 0,
                tiled_ties_total = 0;
    // The contenders' order: ours first (per ray, then tiled; the smoke scene, then billboards only).
    constexpr std::size_t kOurs = 0, kOursBillboards = 1, kOursTiled = 2, kOursBillboardsTiled = 3;

    for (const std::uint32_t n : counts) {
        const SceneDescription desc = animated_scene(options, n, size);
        const std::vector<Particle>& ps = desc.smoke.particles;
        const GroundQuad ground{desc.ground->corners};
        const Camera camera(desc.camera.position, desc.camera.look_at, desc.camera.up, desc.camera.fov_deg, size, size);
        const glm::vec3 eye = camera.position();
        std::vector<Ray> rays;
        rays.reserve(std::size_t(size) * size);
        for (int y = 0; y < size; ++y)
            for (int x = 0; x < size; ++x) rays.push_back(camera.ray(x, y, kViewRayTmin));
        // Our tiles of the same rays (Camera::tile() promises each lane bit for bit its pixel's ray; the
        // comparison rests on it, so it is checked).
        std::vector<RayTile> ray_tiles;
        for (int y0 = 0; y0 < size; y0 += int(kTileRows))
            for (int x0 = 0; x0 < size; x0 += int(kTileColumns))
                ray_tiles.push_back(
                    camera.tile(x0, y0, int(kTileColumns), int(kTileRows), glm::vec2(0.5f), kViewRayTmin));
        for (std::size_t k = 0; k < ray_tiles.size(); ++k)
            for (unsigned lane = 0; lane < kTileRays; ++lane) {
                const Ray a = ray_tiles[k].ray(lane), &b = rays[tile_pixel(size, k, lane)];
                if (!same_bits(a.origin, b.origin) || !same_bits(a.direction, b.direction) || a.tmin != b.tmin ||
                    a.tmax != b.tmax)
                    throw std::runtime_error("view_rays: a tile's ray is not its pixel's camera ray");
            }
        std::cout << "  " << n << " particles, " << rays.size() << " camera rays (" << size << "x" << size
                  << ", two_tubes_right.json's camera); ms, medians of " << repeats << " round-robin repeats\n";

        // ---- builds (all threads) ----
        std::optional<SmokeScene> smoke;
        std::unique_ptr<OursBillboards> billboards;
        struct EmbreeVariant {
            std::string name;
            Layout layout;
            bool robust;
            std::unique_ptr<EmbreeBillboards> closest, layers;  // without / with the context-filter flag
        };
        std::vector<EmbreeVariant> embree;
        for (Layout layout : {Layout::flattened, Layout::instanced})
            for (bool robust : {false, true})
                embree.push_back({std::string(layout == Layout::flattened ? "embree_flattened" : "embree_instanced") +
                                      (robust ? "_robust" : ""),
                                  layout, robust, nullptr, nullptr});
        // build_ms[0]: our SmokeScene, [1]: our billboards-only scene, [2 + k]: Embree variant k's commit,
        // setup_ms[k]: the same with its set-up (world vertices or instance geometries, then the commit).
        std::vector<std::vector<double>> build_ms(2 + embree.size()), setup_ms(embree.size());
        for (int r = 0; r < repeats; ++r) {
            build_ms[0].push_back(time_ms(1, [&] {
                smoke.reset();
                smoke.emplace(ps, StandInShape{StandInKind::sphere, 0}, ground, true);
                smoke->update(ps, eye);
            }).median);
            build_ms[1].push_back(time_ms(1, [&] {
                billboards.reset();
                billboards = std::make_unique<OursBillboards>(ps, eye, ground);
            }).median);
            for (std::size_t k = 0; k < embree.size(); ++k) {
                EmbreeVariant& v = embree[k];
                const auto t0 = std::chrono::steady_clock::now();
                v.closest.reset();
                v.closest = std::make_unique<EmbreeBillboards>(device, ps, eye, ground, v.layout, v.robust, false);
                const auto t1 = std::chrono::steady_clock::now();
                v.closest->commit();
                const auto t2 = std::chrono::steady_clock::now();
                build_ms[2 + k].push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
                setup_ms[k].push_back(std::chrono::duration<double, std::milli>(t2 - t0).count());
            }
        }
        for (EmbreeVariant& v : embree) {
            v.layers = std::make_unique<EmbreeBillboards>(device, ps, eye, ground, v.layout, v.robust, true);
            v.layers->commit();
        }
        const double ours_build = stats_of(build_ms[0]).median, ours_bb_build = stats_of(build_ms[1]).median;
        double best_embree_build = std::numeric_limits<double>::infinity();
        std::cout << "    build, all threads (ms): smoketrace smoke scene (stand-ins, billboards, ground) " << fmt(ours_build)
                  << ", billboards and ground only " << fmt(ours_bb_build) << "; Embree commit (with set-up):";
        csv.row(n, "build", "smoketrace_smoke_scene", 0, all_threads, 0, ours_build, stats_of(build_ms[0]).min,
                stats_of(build_ms[0]).max, 1.0, 0);
        csv.row(n, "build", "smoketrace_billboards", 0, all_threads, 0, ours_bb_build, stats_of(build_ms[1]).min,
                stats_of(build_ms[1]).max, 1.0, 0);
        for (std::size_t k = 0; k < embree.size(); ++k) {
            const Stats s = stats_of(build_ms[2 + k]), w = stats_of(setup_ms[k]);
            std::cout << " " << embree[k].name << " " << fmt(s.median) << " (" << fmt(w.median) << ")";
            csv.row(n, "build", embree[k].name, int(embree[k].robust), all_threads, 0, s.median, s.min, s.max,
                    ours_bb_build / s.median, 0);
            csv.row(n, "build_with_setup", embree[k].name, int(embree[k].robust), all_threads, 0, w.median, w.min,
                    w.max, ours_bb_build / w.median, 0);
            best_embree_build = std::min(best_embree_build, s.median);
        }
        std::cout << "\n    billboards-only build / fastest Embree commit: " << fmt(ours_bb_build / best_embree_build, 2)
                  << "\n";

        // ---- the same answers? untimed. Closest hit per ray: each Embree variant's single rays against
        // ours, and its packets against its single rays; all layers: its packets against its single rays.
        std::vector<float> ours_t(rays.size()), other_t(rays.size());
        for (std::size_t i = 0; i < rays.size(); ++i) {
            const TraceResult r = trace(smoke->scene(), rays[i], ray_flag_force_opaque, kViewRayMask);
            ours_t[i] = r.hit ? r.committed.t : std::numeric_limits<float>::infinity();
        }
        const std::size_t tiles = rays.size() / kPacket;
        std::vector<std::size_t> differ(embree.size(), 0), packet_differ(embree.size(), 0);
        for (std::size_t k = 0; k < embree.size(); ++k) {
            for (std::size_t i = 0; i < rays.size(); ++i) {
                float t;
                other_t[i] = embree[k].closest->closest(rays[i], t) ? t : std::numeric_limits<float>::infinity();
                differ[k] += !same_t(ours_t[i], other_t[i]);
            }
            disagreements_total += differ[k];
            const auto records = std::make_unique<LayerRecord[]>(kPacket);
            LayerRecord single;
            std::array<float, kPacket> packet_t, ground_t;
            for (std::size_t tile = 0; tile < tiles; ++tile) {
                const std::array<const Ray*, kPacket> lanes = tile_rays(rays, size, tile);
                embree[k].closest->closest16(lanes, packet_t);
                for (int l = 0; l < kPacket; ++l) {
                    const std::size_t i = std::size_t(lanes[std::size_t(l)] - rays.data());
                    packet_differ[k] += !same_t(other_t[i], packet_t[std::size_t(l)]);
                }
                for (int l = 0; l < kPacket; ++l) records[std::size_t(l)].count = 0;
                embree[k].layers->layers16(lanes, records.get(), ground_t);
                for (int l = 0; l < kPacket; ++l) {
                    single.count = 0;
                    const float ground = embree[k].layers->layers(*lanes[std::size_t(l)], single);
                    packet_differ[k] += !same_layers(single, ground, records[std::size_t(l)], ground_t[std::size_t(l)]);
                }
            }
            packet_disagreements_total += packet_differ[k];
        }
        // Ours tiled against our single rays, on both our scenes: the closest hit bit for bit, and its
        // instance (the same t on another instance is a tie at exactly that t, which trace_tile() may commit
        // in another order: counted apart); the ground's t and every layer in front of it, t bit for bit
        // (which layers behind the ground a ray meets before it commits the ground depends on the order).
        struct TiledCheck {
            std::size_t closest = 0, ties = 0, layers = 0;
        } tiled_check;
        {
            TileState st;
            st.records = std::make_unique<LayerRecord[]>(kTileRays);
            LayerRecord single;
            for (const auto& [s, mask] : {std::pair<const AccelScene*, std::uint8_t>{&smoke->scene(), kViewRayMask},
                                          {&billboards->scene, std::uint8_t(0xFF)}})
                for (std::size_t k = 0; k < ray_tiles.size(); ++k) {
                    RayTile tile = ray_tiles[k];
                    trace_tile(*s, tile, ray_flag_force_opaque, mask, AcceptEvery{}, st.results, st.scratch);
                    for (unsigned lane = 0; lane < kTileRays; ++lane) {
                        const TraceResult alone =
                            trace(*s, rays[tile_pixel(size, k, lane)], ray_flag_force_opaque, mask);
                        const TraceResult tiled = st.results[lane];
                        if (tiled.hit != alone.hit || (alone.hit && !same_bits(tiled.committed.t, alone.committed.t)))
                            ++tiled_check.closest;
                        else if (alone.hit && tiled.committed.instance_index != alone.committed.instance_index)
                            ++tiled_check.ties;
                    }
                    tile = ray_tiles[k];
                    LayerRecord* records = st.records.get();
                    for (unsigned lane = 0; lane < kTileRays; ++lane) records[lane].count = 0;
                    trace_tile(*s, tile, ray_flag_none, mask,
                               [records](unsigned lane, const TraceHit& h) {
                                   records[lane].add(h.t);
                                   return AnyHitDecision::ignore;
                               },
                               st.results, st.scratch);
                    for (unsigned lane = 0; lane < kTileRays; ++lane) {
                        single.count = 0;
                        const TraceResult alone = trace(*s, rays[tile_pixel(size, k, lane)], ray_flag_none, mask,
                                                        [&single](const TraceHit& h) {
                                                            single.add(h.t);
                                                            return AnyHitDecision::ignore;
                                                        });
                        const TraceResult tiled = st.results[lane];
                        const float ground = alone.hit ? alone.committed.t : std::numeric_limits<float>::infinity();
                        const std::vector<float> a = single.sorted_in_front(ground),
                                                 b = records[lane].sorted_in_front(ground);
                        bool same = tiled.hit == alone.hit && (!alone.hit || same_bits(tiled.committed.t, ground)) &&
                                    a.size() == b.size();
                        for (std::size_t i = 0; same && i < a.size(); ++i) same = same_bits(a[i], b[i]);
                        tiled_check.layers += !same;
                    }
                }
            tiled_disagreements_total += tiled_check.closest + tiled_check.layers;
            tiled_ties_total += tiled_check.ties;
        }

        // ---- traversal: closest and layers, 1 thread and all threads ----
        const AccelScene& smoke_scene = smoke->scene();
        const AccelScene& bb_scene = billboards->scene;
        auto ours_closest = [](const AccelScene& s, std::uint8_t mask) {
            return [&s, mask](const Ray& r, float& t) {
                const TraceResult res = trace(s, r, ray_flag_force_opaque, mask);
                t = res.committed.t;
                return res.hit;
            };
        };
        auto ours_layers = [](const AccelScene& s, std::uint8_t mask) {
            return [&s, mask](const Ray& r, LayerRecord& rec) {
                const TraceResult res = trace(s, r, ray_flag_none, mask, [&rec](const TraceHit& h) {
                    rec.add(h.t);
                    return AnyHitDecision::ignore;
                });
                return res.hit ? res.committed.t : std::numeric_limits<float>::infinity();
            };
        };
        for (const char* measure : {"closest", "layers"}) {
            const bool closest = std::string(measure) == "closest";
            for (int threads : {1, all_threads}) {
                if (threads == all_threads && all_threads == 1) break;
                std::vector<Contender> cs;
                if (closest) {
                    cs.push_back({"smoketrace_smoke_scene", true, true, closest_pass(rays, ours_closest(smoke_scene, kViewRayMask))});
                    cs.push_back({"smoketrace_billboards", true, true, closest_pass(rays, ours_closest(bb_scene, 0xFF))});
                    cs.push_back({"smoketrace_smoke_scene_tiled", true, true,
                                  closest_tile_pass(ray_tiles, smoke_scene, kViewRayMask), false, kTileRays});
                    cs.push_back({"smoketrace_billboards_tiled", true, true,
                                  closest_tile_pass(ray_tiles, bb_scene, 0xFF), false, kTileRays});
                    for (const EmbreeVariant& v : embree) {
                        const EmbreeBillboards* e = v.closest.get();
                        cs.push_back({v.name, v.robust, false, closest_pass(rays, [e](const Ray& r, float& t) { return e->closest(r, t); })});
                        cs.push_back(
                            {v.name + "_x16", v.robust, false, closest_packet_pass(rays, size, e), true, kPacket});
                    }
                } else {
                    cs.push_back({"smoketrace_smoke_scene", true, true, layers_pass(rays, ours_layers(smoke_scene, kViewRayMask))});
                    cs.push_back({"smoketrace_billboards", true, true, layers_pass(rays, ours_layers(bb_scene, 0xFF))});
                    cs.push_back({"smoketrace_smoke_scene_tiled", true, true,
                                  layers_tile_pass(ray_tiles, smoke_scene, kViewRayMask), false, kTileRays});
                    cs.push_back({"smoketrace_billboards_tiled", true, true,
                                  layers_tile_pass(ray_tiles, bb_scene, 0xFF), false, kTileRays});
                    for (const EmbreeVariant& v : embree) {
                        const EmbreeBillboards* e = v.layers.get();
                        cs.push_back({v.name, v.robust, false, layers_pass(rays, [e](const Ray& r, LayerRecord& rec) { return e->layers(r, rec); })});
                        cs.push_back(
                            {v.name + "_x16", v.robust, false, layers_packet_pass(rays, size, e), true, kPacket});
                    }
                }
                tbb::task_arena arena(threads);
                arena.execute([&] { time_round_robin(cs, repeats, threads > 1, rays.size()); });
                const double ours = stats_of(cs[kOurs].ms).median, tiled = stats_of(cs[kOursTiled].ms).median;
                double best = std::numeric_limits<double>::infinity(), best_robust = best, best_x1 = best;
                const Contender* best_one = nullptr;
                std::ostringstream line;
                line << "    " << std::left << std::setw(8) << measure << std::right << std::setw(2) << threads
                     << " thr:";
                for (std::size_t k = 0; k < cs.size(); ++k) {
                    const Stats s = stats_of(cs[k].ms);
                    line << (k > 0 && k % 4 == 0 ? "\n       " : "") << "  " << cs[k].name << " " << fmt(s.median, 2);
                    csv.row(n, measure, cs[k].name, int(cs[k].robust && !cs[k].ours), threads, rays.size(), s.median,
                            s.min, s.max, ours / s.median, cs[k].work.hits, tiled / s.median);
                    if (!cs[k].ours) {
                        if (s.median < best) best_one = &cs[k];
                        best = std::min(best, s.median);
                        if (cs[k].robust) best_robust = std::min(best_robust, s.median);
                        if (!cs[k].packets) best_x1 = std::min(best_x1, s.median);
                    }
                }
                line << "\n      ours/best Embree " << fmt(ours / best, 2) << " (best: " << best_one->name
                     << "; robust " << fmt(ours / best_robust, 2) << ", single rays " << fmt(ours / best_x1, 2)
                     << "), billboards-only ours/best " << fmt(stats_of(cs[kOursBillboards].ms).median / best, 2)
                     << "\n      tiled ours/best Embree " << fmt(tiled / best, 2) << " (" << best_one->name << "; "
                     << fmt(double(rays.size()) / tiled / 1e3, 1) << " Mrays/s, " << fmt(ours / tiled, 2)
                     << "x our single rays), billboards-only tiled ours/best "
                     << fmt(stats_of(cs[kOursBillboardsTiled].ms).median / best, 2) << "; work:";
                for (const Contender& c : cs) line << " " << c.work.hits;
                if (!closest)
                    line << " (" << fmt(double(cs[kOurs].work.hits) / double(rays.size()), 2) << " layers per ray)";
                std::cout << line.str() << "\n" << std::flush;
                if (n == 750) {
                    Headline& h = closest ? headline_closest : headline_layers;
                    const double mrays = double(rays.size()) / tiled / 1e3;
                    if (threads == 1) {
                        h.ratio = ours / best;
                        h.ratio_robust = ours / best_robust;
                        h.ratio_x1 = ours / best_x1;
                        h.best_is_packet = best_one->packets ? 1.0 : 0.0;
                        h.tiled_ratio = tiled / best;
                        h.tiled_mrays = mrays;
                        if (!closest) headline_layers_per_ray = double(cs[kOurs].work.hits) / double(rays.size());
                    } else {
                        h.tiled_ratio_mt = tiled / best;
                        h.tiled_mrays_mt = mrays;
                    }
                }
            }
        }
        std::cout << "    closest-hit answers differing from ours (|dt| > 1e-4 relative):";
        for (std::size_t k = 0; k < embree.size(); ++k) std::cout << " " << embree[k].name << " " << differ[k];
        std::cout << " of " << rays.size() << "\n    packet answers differing from the same scene's single rays "
                  << "(closest t, or layers and ground t):";
        for (std::size_t k = 0; k < embree.size(); ++k) std::cout << " " << embree[k].name << " " << packet_differ[k];
        std::cout << " of " << 2 * rays.size() << "\n    tiled answers differing from our single rays (both our scenes;"
                  << " t bit for bit): closest hit " << tiled_check.closest << " (and " << tiled_check.ties
                  << " ties: another instance at the same t), layers " << tiled_check.layers << ", of "
                  << 2 * rays.size() << " each\n";
        if (n == 750) headline_build = ours_bb_build / best_embree_build;
    }
    csv.write(std::filesystem::path(options.results_dir) / "view_rays.csv");
    report("view_rays_ratio_vs_embree", headline_closest.ratio);
    report("view_rays_ratio_vs_embree_robust", headline_closest.ratio_robust);
    report("view_rays_ratio_vs_embree_x1", headline_closest.ratio_x1);
    report("view_rays_embree_best_is_packet", headline_closest.best_is_packet);
    report("view_layers_ratio_vs_embree", headline_layers.ratio);
    report("view_layers_ratio_vs_embree_x1", headline_layers.ratio_x1);
    report("view_layers_embree_best_is_packet", headline_layers.best_is_packet);
    report("view_layers_per_ray", headline_layers_per_ray);
    report("smoke_build_ratio_vs_embree", headline_build);
    report("view_rays_embree_disagreements", double(disagreements_total));
    report("view_rays_embree_packet_disagreements", double(packet_disagreements_total));
    report("view_rays_tiled_ratio_vs_embree", headline_closest.tiled_ratio);
    report("view_rays_tiled_mrays_per_s", headline_closest.tiled_mrays);
    report("view_layers_tiled_ratio_vs_embree", headline_layers.tiled_ratio);
    report("view_layers_tiled_mrays_per_s", headline_layers.tiled_mrays);
    if (all_threads > 1) {
        // Named by the thread count: _2t on a two-core machine.
        const std::string t = "_" + std::to_string(all_threads) + "t";
        report("view_rays_tiled_ratio_vs_embree" + t, headline_closest.tiled_ratio_mt);
        report("view_rays_tiled_mrays_per_s" + t, headline_closest.tiled_mrays_mt);
        report("view_layers_tiled_ratio_vs_embree" + t, headline_layers.tiled_ratio_mt);
        report("view_layers_tiled_mrays_per_s" + t, headline_layers.tiled_mrays_mt);
    }
    report("view_rays_tiled_disagreements", double(tiled_disagreements_total));
    report("view_rays_tiled_ties", double(tiled_ties_total));
}

const RegisterSection kViewRaysSection{{"view_rays",
                                        "view-pass rays on the smoke scene vs Embree 3 on the same quads (single "
                                        "rays and 4x4 packets): build, closest hit, all layers in front of the ground",
                                        &run_view_rays, true}};

}  // namespace
}  // namespace smoketrace::bench
