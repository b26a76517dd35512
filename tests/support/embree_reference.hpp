#pragma once
// Embree 3 as the reference that smoketrace's BVH is checked and timed against (tests/embree_*.cpp,
// bench/). RAII wrappers only: a device, and a scene built from smoketrace meshes, queried with
//  * closest_hit: rtcIntersect1, no filter;
//  * all_hits: rtcIntersect1 with a context filter function that hands every candidate to a callback
//    and rejects it (valid = 0), so that Embree's traversal goes on and eventually reports every
//    triangle the ray crosses in [tmin, tmax] (DXR's "ignore every hit" any-hit shader).
// The scene carries RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION (unless asked not to), so the filter is per
// query (set in the intersect context), not per geometry: closest-hit queries run without any filter call. A context
// filter is also what Embree calls for hits inside instanced geometry, so an instance geometry
// (RTC_GEOMETRY_TYPE_INSTANCE, an attach_instance() next to attach_mesh()) needs no change here: its
// hits arrive with EmbreeHit::instance set from the hit's instID.
#include <smoketrace/geometry/ray.hpp>
#include <smoketrace/smoke/particle_system.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/accel/triangle_mesh.hpp>

#include <embree3/rtcore.h>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace smoketrace::embree_reference {

// A ray in Embree's layout, with no hit yet: the one conversion every Embree query here goes through.
inline RTCRayHit to_rtc_ray_hit(const Ray& ray, unsigned mask = ~0u) {
    RTCRayHit rh;
    rh.ray.org_x = ray.origin.x;
    rh.ray.org_y = ray.origin.y;
    rh.ray.org_z = ray.origin.z;
    rh.ray.tnear = ray.tmin;
    rh.ray.dir_x = ray.direction.x;
    rh.ray.dir_y = ray.direction.y;
    rh.ray.dir_z = ray.direction.z;
    rh.ray.time = 0.0f;
    rh.ray.tfar = ray.tmax;
    rh.ray.mask = mask;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    for (unsigned& id : rh.hit.instID) id = RTC_INVALID_GEOMETRY_ID;
    return rh;
}

// A hit as Embree reports it. front_face follows smoketrace's convention (ray_triangle.hpp): Embree's
// geometric normal points out of the counter-clockwise (front) side, so the ray meets the front face
// when the normal faces against it.
struct EmbreeHit {
    float t = 0.0f;
    std::uint32_t primitive = RTC_INVALID_GEOMETRY_ID;
    std::uint32_t geometry = RTC_INVALID_GEOMETRY_ID;
    std::uint32_t instance = RTC_INVALID_GEOMETRY_ID;  // instID[0]; invalid for a hit outside instances
    glm::vec2 barycentrics{0.0f};                       // Embree's (u, v): weights of v1, v2
    glm::vec3 geometric_normal{0.0f};                   // unnormalised, as Embree reports it
    bool front_face = false;
};

// Embree's name for an error code, for messages.
inline const char* error_name(RTCError code) {
    switch (code) {
    case RTC_ERROR_NONE: return "RTC_ERROR_NONE";
    case RTC_ERROR_UNKNOWN: return "RTC_ERROR_UNKNOWN";
    case RTC_ERROR_INVALID_ARGUMENT: return "RTC_ERROR_INVALID_ARGUMENT";
    case RTC_ERROR_INVALID_OPERATION: return "RTC_ERROR_INVALID_OPERATION";
    case RTC_ERROR_OUT_OF_MEMORY: return "RTC_ERROR_OUT_OF_MEMORY";
    case RTC_ERROR_UNSUPPORTED_CPU: return "RTC_ERROR_UNSUPPORTED_CPU";
    case RTC_ERROR_CANCELLED: return "RTC_ERROR_CANCELLED";
    }
    return "an unknown error code";
}

class Device {
public:
    // config: Embree's device string, e.g. "threads=1" (nullptr: Embree's defaults, all threads). Throws
    // naming the string and Embree's error when Embree makes no device of it (a value it cannot parse, such
    // as "threads=x"; it ignores keys it does not know).
    explicit Device(const char* config = nullptr) : device_(rtcNewDevice(config)) {
        if (!device_)
            throw std::runtime_error(std::string("embree: rtcNewDevice(") +
                                     (config ? "\"" + std::string(config) + "\"" : std::string("nullptr")) +
                                     ") failed: " + error_name(rtcGetDeviceError(nullptr)));
        rtcSetDeviceErrorFunction(device_, &Device::on_error, this);
    }
    ~Device() { rtcReleaseDevice(device_); }
    Device(const Device&) = delete;
    Device& operator=(const Device&) = delete;

    [[nodiscard]] RTCDevice handle() const { return device_; }

    // Throws if Embree reported an error since the last check. (Embree's error callback must not
    // throw through Embree's C frames, so errors are recorded there and raised here.)
    void check(const char* what) const {
        if (error_.empty()) return;
        const std::string message = std::string("embree: ") + what + ": " + error_;
        error_.clear();
        throw std::runtime_error(message);
    }

private:
    static void on_error(void* self, RTCError code, const char* text) {
        auto& error = static_cast<Device*>(self)->error_;
        if (error.empty()) error = "error " + std::to_string(int(code)) + " (" + (text ? text : "") + ")";
    }
    RTCDevice device_;
    mutable std::string error_;
};

struct SceneOptions {
    RTCBuildQuality quality = RTC_BUILD_QUALITY_MEDIUM;  // Embree's default; HIGH adds spatial splits
    bool robust = true;                                  // RTC_SCENE_FLAG_ROBUST: watertight triangle test
    // RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION, needed by all_hits(). Off gives Embree's leanest
    // closest-hit configuration (the benchmark measures both).
    bool context_filter = true;
};

class Scene {
public:
    Scene(const Device& device, const SceneOptions& options = {})
        : device_(&device), scene_(rtcNewScene(device.handle())), options_(options) {
        if (!scene_) throw std::runtime_error("embree: rtcNewScene failed");
        int flags = RTC_SCENE_FLAG_NONE;
        if (options.context_filter) flags |= RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION;
        if (options.robust) flags |= RTC_SCENE_FLAG_ROBUST;
        rtcSetSceneFlags(scene_, RTCSceneFlags(flags));
        rtcSetSceneBuildQuality(scene_, options.quality);
    }
    ~Scene() { rtcReleaseScene(scene_); }
    Scene(const Scene&) = delete;
    Scene& operator=(const Scene&) = delete;

    // Adds a triangle mesh; returns its geometry id. The vertices and indices are copied into buffers
    // owned by the scene and shared with Embree (no second copy inside Embree). The vertex buffer is
    // padded because Embree reads each vertex with a 16-byte load.
    std::uint32_t attach_mesh(const TriangleMesh& mesh) {
        auto& buffers = meshes_.emplace_back(std::make_unique<MeshBuffers>());
        buffers->vertices.resize(3 * mesh.vertices.size() + 1, 0.0f);
        for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
            for (int a = 0; a < 3; ++a) buffers->vertices[3 * i + a] = mesh.vertices[i][a];
        buffers->indices.resize(3 * mesh.triangles.size());
        for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
            for (int a = 0; a < 3; ++a) buffers->indices[3 * i + a] = mesh.triangles[i][a];

        RTCGeometry geometry = rtcNewGeometry(device_->handle(), RTC_GEOMETRY_TYPE_TRIANGLE);
        rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, buffers->vertices.data(), 0,
                                   3 * sizeof(float), mesh.vertices.size());
        rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, buffers->indices.data(), 0,
                                   3 * sizeof(std::uint32_t), mesh.triangles.size());
        rtcSetGeometryBuildQuality(geometry, options_.quality);
        rtcCommitGeometry(geometry);
        const std::uint32_t id = rtcAttachGeometry(scene_, geometry);
        rtcReleaseGeometry(geometry);  // the scene holds its own reference
        device_->check("attach_mesh");
        return id;
    }

    // Builds the acceleration structure (this is what the benchmark times as Embree's build).
    void commit() {
        rtcCommitScene(scene_);
        device_->check("rtcCommitScene");
    }

    [[nodiscard]] RTCScene handle() const { return scene_; }

    // Closest hit in [ray.tmin, ray.tmax]; false on a miss.
    bool closest_hit(const Ray& ray, EmbreeHit& hit) const {
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        RTCRayHit rh = to_rtc_ray_hit(ray);
        rtcIntersect1(scene_, &context, &rh);
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
        hit.t = rh.ray.tfar;
        hit.primitive = rh.hit.primID;
        hit.geometry = rh.hit.geomID;
        hit.instance = rh.hit.instID[0];
        hit.barycentrics = {rh.hit.u, rh.hit.v};
        hit.geometric_normal = {rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z};
        hit.front_face = faces_against(hit.geometric_normal, ray.direction);
        return true;
    }

    // Calls on_hit(const EmbreeHit&) for every candidate Embree finds in [ray.tmin, ray.tmax] and
    // rejects each one, so the search never narrows. Order is Embree's traversal order. Embree in
    // robust mode reports a ray through an edge shared by two triangles on BOTH of them (and a ray
    // through a vertex on several): deduplicating is the caller's business.
    template <class OnHit>
    void all_hits(const Ray& ray, OnHit&& on_hit) const {
        if (!options_.context_filter) throw std::logic_error("embree: all_hits() needs SceneOptions::context_filter");
        using Fn = std::remove_reference_t<OnHit>;
        FilterContext context;
        rtcInitIntersectContext(&context.base);
        context.base.filter = &FilterContext::reject_and_report<Fn>;
        context.on_hit = const_cast<void*>(static_cast<const void*>(&on_hit));
        context.direction = ray.direction;
        RTCRayHit rh = to_rtc_ray_hit(ray);
        rtcIntersect1(scene_, &context.base, &rh);
    }

private:
    struct MeshBuffers {
        std::vector<float> vertices;
        std::vector<std::uint32_t> indices;
    };

    // The intersect context extended with the callback: Embree hands the filter the pointer to the
    // context it was given, so the first member's address is the whole struct's.
    struct FilterContext {
        RTCIntersectContext base;
        void* on_hit;
        glm::vec3 direction;

        template <class Fn>
        static void reject_and_report(const RTCFilterFunctionNArguments* args) {
            const auto* self = reinterpret_cast<const FilterContext*>(args->context);
            Fn& on_hit = *static_cast<Fn*>(self->on_hit);
            const unsigned n = args->N;
            for (unsigned i = 0; i < n; ++i) {
                if (args->valid[i] != -1) continue;
                EmbreeHit h;
                h.t = RTCRayN_tfar(args->ray, n, i);
                h.primitive = RTCHitN_primID(args->hit, n, i);
                h.geometry = RTCHitN_geomID(args->hit, n, i);
                h.instance = RTCHitN_instID(args->hit, n, i, 0);
                h.barycentrics = {RTCHitN_u(args->hit, n, i), RTCHitN_v(args->hit, n, i)};
                h.geometric_normal = {RTCHitN_Ng_x(args->hit, n, i), RTCHitN_Ng_y(args->hit, n, i),
                                      RTCHitN_Ng_z(args->hit, n, i)};
                h.front_face = faces_against(h.geometric_normal, self->direction);
                on_hit(static_cast<const EmbreeHit&>(h));
                args->valid[i] = 0;  // reject: the traversal continues with tfar unchanged
            }
        }
    };

    static bool faces_against(const glm::vec3& normal, const glm::vec3& direction) {
        return double(normal.x) * direction.x + double(normal.y) * direction.y + double(normal.z) * direction.z < 0.0;
    }

    const Device* device_;
    RTCScene scene_;
    SceneOptions options_;
    std::vector<std::unique_ptr<MeshBuffers>> meshes_;
};

// The ground quad as Embree's two triangles.
inline TriangleMesh quad_mesh(const GroundQuad& g) {
    TriangleMesh m;
    m.vertices.assign(g.corners.begin(), g.corners.end());
    m.triangles = {{0, 1, 2}, {0, 2, 3}};
    return m;
}

// Every particle's copy of `unit` in one world-space mesh (Embree's flattened layout): the vertices
// translate(centre)·scale(radius)'d in double, rounded to float once.
inline TriangleMesh flattened_stand_ins(std::span<const Particle> ps, const TriangleMesh& unit) {
    TriangleMesh world;
    world.vertices.reserve(ps.size() * unit.vertices.size());
    world.triangles.reserve(ps.size() * unit.triangles.size());
    for (const Particle& p : ps) {
        const auto base = static_cast<std::uint32_t>(world.vertices.size());
        for (const glm::vec3& v : unit.vertices)
            world.vertices.push_back(glm::vec3(glm::dvec3(p.center) + double(p.radius) * glm::dvec3(v)));
        for (const glm::uvec3& t : unit.triangles) world.triangles.push_back(t + base);
    }
    return world;
}

// ---------------------------------------------------------------------------------------------------
// The large reference mesh of the Embree comparisons and of the benchmark: a finely subdivided
// icosphere (radius 1 at the origin, 20·4^level triangles) floating over a displaced height-field
// grid (2·grid² triangles over [−3, 3]², around z = −1.5, never touching the sphere). Both parts are
// connected meshes with shared vertices, the sphere closed; sizes from ~50k (level 5, grid 112) to
// ~1.3M (level 8, grid 256) triangles.
inline TriangleMesh make_sphere_over_terrain(int icosphere_level, int grid) {
    TriangleMesh m = make_icosphere(icosphere_level, 1.0f);
    const auto base = static_cast<std::uint32_t>(m.vertices.size());
    const auto n = static_cast<std::uint32_t>(grid);
    for (std::uint32_t j = 0; j <= n; ++j)
        for (std::uint32_t i = 0; i <= n; ++i) {
            const float x = -3.0f + 6.0f * float(i) / float(n), y = -3.0f + 6.0f * float(j) / float(n);
            const float z = -1.5f + 0.15f * std::sin(2.1f * x) * std::cos(1.7f * y) + 0.05f * std::sin(7.0f * x + 3.0f * y);
            m.vertices.emplace_back(x, y, z);
        }
    for (std::uint32_t j = 0; j < n; ++j)
        for (std::uint32_t i = 0; i < n; ++i) {
            const std::uint32_t a = base + j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
            m.triangles.emplace_back(a, b, c);  // counter-clockwise seen from above (+z)
            m.triangles.emplace_back(a, c, d);
        }
    return m;
}

}  // namespace smoketrace::embree_reference
