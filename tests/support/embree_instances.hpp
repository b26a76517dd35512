#pragma once
// Embree 3 with real instancing (RTC_GEOMETRY_TYPE_INSTANCE) as the reference for smoketrace's two-level
// scene: bottom levels are embree_reference::Scene objects (one committed Embree scene per mesh), placed
// by instance geometries with a float 3×4 transform and an instance mask in one top-level scene.
//
// Embree takes the transform in float, smoketrace in double: float_rounded() gives the transform both
// sides then use, so that the two place the very same geometry (Embree still inverts it in float, which
// the comparing test's tolerance covers).
//
// Hits inside an instance come back in the instance's object space: Embree 3 reports the geometric normal
// Ng untransformed (checked: a mirrored instance of a +z-facing triangle still reports Ng = +z), so the
// facing is decided as smoketrace decides it, from the object-space direction, which this class keeps
// per instance (world_to_object_linear, from the same double inverse smoketrace uses).
#include "support/embree_reference.hpp"

#include <smoketrace/accel/instance.hpp>

#include <embree3/rtcore.h>
#include <glm/mat3x3.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <stdexcept>
#include <type_traits>
#include <vector>

namespace smoketrace::embree_reference {

// A hit of the instanced scene. object_normal: Embree's Ng (object space, unnormalised, pointing out of
// the counter-clockwise side); front_face: smoketrace's convention (the ray meets the counter-clockwise
// side), from Ng and the object-space direction.
struct InstancedHit {
    float t = 0.0f;
    std::uint32_t instance = RTC_INVALID_GEOMETRY_ID;   // geometry id of the instance in the top scene
    std::uint32_t primitive = RTC_INVALID_GEOMETRY_ID;  // triangle index in the instanced mesh
    glm::vec2 barycentrics{0.0f};
    glm::vec3 object_normal{0.0f};
    bool front_face = false;
};

class InstancedScene {
public:
    explicit InstancedScene(const Device& device) : device_(&device), scene_(rtcNewScene(device.handle())) {
        if (!scene_) throw std::runtime_error("embree: rtcNewScene failed");
        rtcSetSceneFlags(scene_, RTCSceneFlags(RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION | RTC_SCENE_FLAG_ROBUST));
    }
    ~InstancedScene() { rtcReleaseScene(scene_); }
    InstancedScene(const InstancedScene&) = delete;
    InstancedScene& operator=(const InstancedScene&) = delete;

    // Each matrix entry and translation component rounded to float: the transform Embree will apply.
    static AffineTransform float_rounded(const AffineTransform& m) {
        AffineTransform r;
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 3; ++k) r.linear[c][k] = double(float(m.linear[c][k]));
        for (int k = 0; k < 3; ++k) r.translation[k] = double(float(m.translation[k]));
        return r;
    }

    // Instances a committed bottom-level scene with object_to_world (use float_rounded() values) and an
    // instance mask; returns the instance's id, which Embree reports as instID[0]. Ids are 0, 1, 2, …
    // in attach order, like smoketrace's instance indices.
    std::uint32_t attach_instance(const Scene& blas, const AffineTransform& object_to_world, std::uint32_t mask) {
        RTCGeometry g = rtcNewGeometry(device_->handle(), RTC_GEOMETRY_TYPE_INSTANCE);
        rtcSetGeometryInstancedScene(g, blas.handle());
        rtcSetGeometryTimeStepCount(g, 1);
        float m[12];  // RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR: the three linear columns, then the translation
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 3; ++k) m[3 * c + k] = float(object_to_world.linear[c][k]);
        for (int k = 0; k < 3; ++k) m[9 + k] = float(object_to_world.translation[k]);
        rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, m);
        rtcSetGeometryMask(g, mask);
        rtcCommitGeometry(g);
        const std::uint32_t id = rtcAttachGeometry(scene_, g);
        rtcReleaseGeometry(g);
        device_->check("attach_instance");
        if (id != world_to_object_.size()) throw std::logic_error("embree: instance ids are not dense");
        world_to_object_.push_back(object_to_world.inverse().linear);
        return id;
    }

    void commit() {
        rtcCommitScene(scene_);
        device_->check("rtcCommitScene (instances)");
    }

    // Closest hit in [tmin, tmax] among instances with (instance mask & ray_mask) != 0.
    bool closest_hit(const Ray& ray, std::uint32_t ray_mask, InstancedHit& hit) const {
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        RTCRayHit rh = to_rtc_ray_hit(ray, ray_mask);
        rtcIntersect1(scene_, &context, &rh);
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
        hit = make_hit(rh.ray.tfar, rh.hit.instID[0], rh.hit.primID, {rh.hit.u, rh.hit.v},
                       {rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z}, ray.direction);
        return true;
    }

    // Every candidate in [tmin, tmax] (visible instances only), each rejected so the search never narrows.
    // Embree's robust mode may report a crossing of a shared edge or vertex more than once.
    template <class OnHit>
    void all_hits(const Ray& ray, std::uint32_t ray_mask, OnHit&& on_hit) const {
        using Fn = std::remove_reference_t<OnHit>;
        FilterContext context;
        rtcInitIntersectContext(&context.base);
        context.base.filter = &FilterContext::reject_and_report<Fn>;
        context.self = this;
        context.on_hit = const_cast<void*>(static_cast<const void*>(&on_hit));
        context.direction = ray.direction;
        RTCRayHit rh = to_rtc_ray_hit(ray, ray_mask);
        rtcIntersect1(scene_, &context.base, &rh);
    }

private:
    struct FilterContext {
        RTCIntersectContext base;  // first member: Embree passes &base back to the filter
        const InstancedScene* self;
        void* on_hit;
        glm::vec3 direction;

        template <class Fn>
        static void reject_and_report(const RTCFilterFunctionNArguments* args) {
            const auto* ctx = reinterpret_cast<const FilterContext*>(args->context);
            Fn& on_hit = *static_cast<Fn*>(ctx->on_hit);
            const unsigned n = args->N;
            for (unsigned i = 0; i < n; ++i) {
                if (args->valid[i] != -1) continue;
                const InstancedHit h = ctx->self->make_hit(
                    RTCRayN_tfar(args->ray, n, i), RTCHitN_instID(args->hit, n, i, 0), RTCHitN_primID(args->hit, n, i),
                    {RTCHitN_u(args->hit, n, i), RTCHitN_v(args->hit, n, i)},
                    {RTCHitN_Ng_x(args->hit, n, i), RTCHitN_Ng_y(args->hit, n, i), RTCHitN_Ng_z(args->hit, n, i)},
                    ctx->direction);
                on_hit(h);
                args->valid[i] = 0;
            }
        }
    };

    InstancedHit make_hit(float t, std::uint32_t instance, std::uint32_t primitive, glm::vec2 uv, glm::vec3 ng,
                          const glm::vec3& world_direction) const {
        InstancedHit h;
        h.t = t;
        h.instance = instance;
        h.primitive = primitive;
        h.barycentrics = uv;
        h.object_normal = ng;
        const glm::dvec3 d = world_to_object_[instance] * glm::dvec3(world_direction);
        h.front_face = double(ng.x) * d.x + double(ng.y) * d.y + double(ng.z) * d.z < 0.0;
        return h;
    }

    const Device* device_;
    RTCScene scene_;
    std::vector<glm::dmat3> world_to_object_;  // per instance, for the object-space facing
};

}  // namespace smoketrace::embree_reference
