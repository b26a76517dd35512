#pragma once
// The camera rays of the smoke scene, ours against Embree 3 on the same quads (sections "view_rays" and
// "threads"): our scenes and Embree's, the passes over the rays (closest hit; every billboard layer in front
// of the ground), one ray at a time, in Embree's 4x4 packets and in our 16x16 tiles, and the contenders of
// each measure. bench_view_rays.cpp says what each does and why it is the same work.
#include "support/embree_reference.hpp"

#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/render/camera.hpp>
#include <smoketrace/render/view_compositor.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/trace/trace.hpp>
#include <smoketrace/trace/trace_tile.hpp>

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace smoketrace::bench::view_rays {

namespace er = embree_reference;

// Layers per ray kept in the fixed per-ray buffer (beyond this they are only counted).
inline constexpr std::uint32_t kLayerCapacity = 512;
// Embree's packets: a kTile x kTile tile of pixels per rtcIntersect16.
inline constexpr int kTile = 4;
inline constexpr int kPacket = kTile * kTile;
// Two answers for one ray are the same when their t differ by at most this, relative (at least 1): the
// same tolerance as the closest-hit check against ours.
inline constexpr float kSameT = 1e-4f;

inline bool same_t(float a, float b) {
    return (std::isinf(a) && std::isinf(b)) || std::abs(a - b) <= kSameT * std::max(1.0f, std::abs(a));
}

// Bit for bit: trace_tile() promises each ray the t trace() gives it.
inline bool same_bits(float a, float b) { return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b); }
inline bool same_bits(const glm::vec3& a, const glm::vec3& b) {
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
inline bool same_layers(const LayerRecord& a, float ground_a, const LayerRecord& b, float ground_b) {
    if (!same_t(ground_a, ground_b)) return false;
    const std::vector<float> x = a.sorted_in_front(ground_a), y = b.sorted_in_front(ground_b);
    if (x.size() != y.size()) return false;
    for (std::size_t i = 0; i < x.size(); ++i)
        if (!same_t(x[i], y[i])) return false;
    return true;
}

// The rays of tile `tile` of a width-pixel-wide image (rays in row order): lane l is pixel
// (kTile·tx + l % kTile, kTile·ty + l / kTile).
inline std::array<const Ray*, kPacket> tile_rays(const std::vector<Ray>& rays, int width, std::size_t tile) {
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

inline TriangleMesh unit_quad() {
    TriangleMesh q;
    q.vertices = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    q.triangles = {{0, 1, 2}, {0, 2, 3}};  // as smoke_scene.cpp's billboards
    return q;
}

inline TriangleMesh ground_mesh(const GroundQuad& g) {
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
inline Work run_pass(bool parallel, std::size_t items, std::size_t grain, const RangePass& pass) {
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
inline RangePass closest_packet_pass(const std::vector<Ray>& rays, int width, const EmbreeBillboards* e) {
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
inline RangePass layers_packet_pass(const std::vector<Ray>& rays, int width, const EmbreeBillboards* e) {
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
inline std::size_t tile_pixel(int width, std::size_t tile, unsigned lane) {
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
inline RangePass closest_tile_pass(const std::vector<RayTile>& tiles, const AccelScene& scene, std::uint8_t mask) {
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
inline RangePass layers_tile_pass(const std::vector<RayTile>& tiles, const AccelScene& scene, std::uint8_t mask) {
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

// One pass of `c` over `rays` rays, on this thread or on the threads of the arena it runs in: about 1024 rays
// per task whatever the item. Returns its work (also kept in c.work).
inline Work run_once(Contender& c, bool parallel, std::size_t rays) {
    c.work = run_pass(parallel, rays / c.item_rays, std::max(1u, 1024 / c.item_rays), c.pass);
    return c.work;
}

// Round-robin: repeat r of every contender before repeat r + 1, then medians. n: rays.
inline void time_round_robin(std::vector<Contender>& cs, int repeats, bool parallel, std::size_t n) {
    for (int r = 0; r < repeats; ++r)
        for (Contender& c : cs) {
            const auto t0 = std::chrono::steady_clock::now();
            run_once(c, parallel, n);
            c.ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        }
}

// --- the scene's camera rays and the contenders ----------------------------------------------------------

// One ray per pixel centre of a size² image in row order, and the same rays as our kTileColumns x kTileRows
// tiles in row order (the lanes of tile k: tile_pixel()). Camera::tile() promises each lane bit for bit its
// pixel's ray; the comparisons rest on it, so it is checked (std::runtime_error otherwise).
struct CameraRays {
    std::vector<Ray> rays;
    std::vector<RayTile> tiles;
};

// The scene file's camera at size² pixels.
inline Camera scene_camera(const SceneDescription& d, int size) {
    return Camera(d.camera.position, d.camera.look_at, d.camera.up, d.camera.fov_deg, size, size);
}

inline CameraRays camera_rays(const Camera& camera, int size) {
    if (size % kTile != 0 || size % int(kTileColumns) != 0 || size % int(kTileRows) != 0)
        throw std::logic_error("view_rays: the image must be cut into whole tiles, Embree's and ours");
    CameraRays c;
    c.rays.reserve(std::size_t(size) * std::size_t(size));
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) c.rays.push_back(camera.ray(x, y, kViewRayTmin));
    for (int y0 = 0; y0 < size; y0 += int(kTileRows))
        for (int x0 = 0; x0 < size; x0 += int(kTileColumns))
            c.tiles.push_back(camera.tile(x0, y0, int(kTileColumns), int(kTileRows), glm::vec2(0.5f), kViewRayTmin));
    for (std::size_t k = 0; k < c.tiles.size(); ++k)
        for (unsigned lane = 0; lane < kTileRays; ++lane) {
            const Ray a = c.tiles[k].ray(lane), &b = c.rays[tile_pixel(size, k, lane)];
            if (!same_bits(a.origin, b.origin) || !same_bits(a.direction, b.direction) || a.tmin != b.tmin ||
                a.tmax != b.tmax)
                throw std::runtime_error("view_rays: a tile's ray is not its pixel's camera ray");
        }
    return c;
}

// One Embree configuration: a layout, robust mode or not, and its two scenes (closest hits: without the
// context-filter flag, Embree's leanest; layers: with it).
struct EmbreeVariant {
    std::string name;
    Layout layout;
    bool robust;
    std::unique_ptr<EmbreeBillboards> closest, layers;
};

// Flattened and instanced, each without and with robust mode; the scenes not made yet.
inline std::vector<EmbreeVariant> embree_variants() {
    std::vector<EmbreeVariant> out;
    for (Layout layout : {Layout::flattened, Layout::instanced})
        for (bool robust : {false, true})
            out.push_back({std::string(layout == Layout::flattened ? "embree_flattened" : "embree_instanced") +
                               (robust ? "_robust" : ""),
                           layout, robust, nullptr, nullptr});
    return out;
}

// Makes and commits both scenes of `v` (untimed).
inline void build_scenes(EmbreeVariant& v, const embree_reference::Device& device, const std::vector<Particle>& ps,
                         const glm::vec3& eye, const GroundQuad& ground) {
    v.closest = std::make_unique<EmbreeBillboards>(device, ps, eye, ground, v.layout, v.robust, false);
    v.closest->commit();
    v.layers = std::make_unique<EmbreeBillboards>(device, ps, eye, ground, v.layout, v.robust, true);
    v.layers->commit();
}

// The contenders of one measure, closest hits or every layer in front of the ground, in this order: ours on
// the smoke scene one ray at a time (trace()), on the billboards-only scene if given, the same two tiled
// (trace_tile()), then each Embree variant's single rays and its packets (_x16).
inline std::vector<Contender> measure_contenders(bool closest, const CameraRays& cam, int size,
                                                 const AccelScene& smoke, const AccelScene* billboards,
                                                 const std::vector<EmbreeVariant>& embree) {
    const std::vector<Ray>& rays = cam.rays;
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
    struct Ours {
        const char* name;
        const AccelScene* scene;
        std::uint8_t mask;
    };
    std::vector<Ours> ours = {{"smoketrace_smoke_scene", &smoke, kViewRayMask}};
    if (billboards) ours.push_back({"smoketrace_billboards", billboards, 0xFF});
    std::vector<Contender> cs;
    for (const Ours& o : ours)
        cs.push_back({o.name, true, true,
                      closest ? closest_pass(rays, ours_closest(*o.scene, o.mask))
                              : layers_pass(rays, ours_layers(*o.scene, o.mask))});
    for (const Ours& o : ours)
        cs.push_back({std::string(o.name) + "_tiled", true, true,
                      closest ? closest_tile_pass(cam.tiles, *o.scene, o.mask)
                              : layers_tile_pass(cam.tiles, *o.scene, o.mask),
                      false, kTileRays});
    for (const EmbreeVariant& v : embree) {
        if (closest) {
            const EmbreeBillboards* e = v.closest.get();
            cs.push_back({v.name, v.robust, false,
                          closest_pass(rays, [e](const Ray& r, float& t) { return e->closest(r, t); })});
            cs.push_back({v.name + "_x16", v.robust, false, closest_packet_pass(rays, size, e), true, kPacket});
        } else {
            const EmbreeBillboards* e = v.layers.get();
            cs.push_back({v.name, v.robust, false,
                          layers_pass(rays, [e](const Ray& r, LayerRecord& rec) { return e->layers(r, rec); })});
            cs.push_back({v.name + "_x16", v.robust, false, layers_packet_pass(rays, size, e), true, kPacket});
        }
    }
    return cs;
}


}  // namespace smoketrace::bench::view_rays
