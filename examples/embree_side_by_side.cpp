// The same rays through smoketrace and through Embree 3, side by side: one mesh (an icosphere) placed four
// times by instances in both libraries, 4096 rays, and the closest hits compared. Built only when CMake
// finds Embree 3; the library itself never links it.
#include <smoketrace/core/prng.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/trace/trace.hpp>

#include <embree3/rtcore.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>

using namespace smoketrace;

int main() {
    const TriangleMesh mesh = make_icosphere(/*level=*/2);
    struct Placement { double x, y, z, scale; };
    const Placement placements[] = {{0, 0, 0, 1}, {2.5, 0.5, 0, 0.75}, {-2, 1, 1, 0.5}, {0.5, -2, 0.5, 1.25}};

    // smoketrace: the mesh as one bottom level (opaque: closest hits need no any-hit), four instances.
    AccelScene scene;
    const auto blas = scene.add_bottom_level(BottomLevel::from_mesh(mesh, /*opaque=*/true));
    for (const Placement& p : placements)
        scene.add_instance({blas, AffineTransform::translate_scale({p.x, p.y, p.z}, p.scale)});
    scene.commit();

    // Embree: the mesh in a scene of its own, instanced four times into the world scene (robust mode, which
    // like smoketrace's triangle test leaves no gaps at shared edges).
    RTCDevice device = rtcNewDevice(nullptr);
    RTCScene object = rtcNewScene(device), world = rtcNewScene(device);
    rtcSetSceneFlags(object, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneFlags(world, RTC_SCENE_FLAG_ROBUST);
    RTCGeometry triangles = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(triangles, RTC_BUFFER_TYPE_VERTEX, 0,
        RTC_FORMAT_FLOAT3, 3 * sizeof(float), mesh.vertices.size()));
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
        for (int k = 0; k < 3; ++k) vertices[3 * i + k] = mesh.vertices[i][k];
    auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(triangles, RTC_BUFFER_TYPE_INDEX, 0,
        RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh.triangles.size()));
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
        for (int k = 0; k < 3; ++k) indices[3 * i + k] = mesh.triangles[i][k];
    rtcCommitGeometry(triangles);
    rtcAttachGeometry(object, triangles);
    rtcReleaseGeometry(triangles);
    rtcCommitScene(object);
    for (unsigned i = 0; i < 4; ++i) {
        const Placement& p = placements[i];
        const float s = float(p.scale), x = float(p.x), y = float(p.y), z = float(p.z);
        const float transform[12] = {s, 0, 0, 0, s, 0, 0, 0, s, x, y, z};  // 3x4, column-major
        RTCGeometry instance = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
        rtcSetGeometryInstancedScene(instance, object);
        rtcSetGeometryTransform(instance, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, transform);
        rtcCommitGeometry(instance);
        rtcAttachGeometryByID(world, instance, i);  // Embree's instID = smoketrace's instance index
        rtcReleaseGeometry(instance);
    }
    rtcCommitScene(world);

    // Rays from a sphere of radius 8 toward random points around the instances: hits and misses.
    Pcg32 rng(2026);
    int hits = 0, disagreements = 0;
    for (int r = 0; r < 4096; ++r) {
        const glm::vec3 from(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        const glm::vec3 to(rng.uniform(-3, 3.5f), rng.uniform(-3.5f, 2), rng.uniform(-1.5f, 2));
        const Ray ray{8.0f * glm::normalize(from), 0.0f, to - 8.0f * glm::normalize(from)};

        const TraceResult ours = trace(scene, ray, ray_flag_none, 0xFF);

        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        RTCRayHit theirs{};
        theirs.ray = {ray.origin.x, ray.origin.y, ray.origin.z, ray.tmin, ray.direction.x, ray.direction.y,
                      ray.direction.z, 0.0f, ray.tmax, ~0u, 0, 0};
        theirs.hit.geomID = theirs.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(world, &context, &theirs);
        const bool embree_hit = theirs.hit.geomID != RTC_INVALID_GEOMETRY_ID;

        // Agree: both miss, or both hit the same instance at the same distance. Tolerance: both intersect in
        // float, smoketrace in object space from a double transform, Embree from a float one; distances of
        // 5-12 then differ by a few float steps (1e-6 each), and 1e-4 relative is far from the gap to any
        // other surface. At a shared edge the two may name different triangles of one mesh: not compared.
        const bool agree = ours.hit == embree_hit &&
            (!ours.hit || (ours.committed.instance_index == theirs.hit.instID[0] &&
                           std::abs(ours.committed.t - theirs.ray.tfar) <= 1e-4f * theirs.ray.tfar));
        hits += ours.hit;
        if (!agree && ++disagreements <= 5)
            std::printf("ray %d: smoketrace %s t=%g, Embree %s t=%g\n", r, ours.hit ? "hit" : "miss", ours.committed.t,
                        embree_hit ? "hit" : "miss", theirs.ray.tfar);
    }
    rtcReleaseScene(world);
    rtcReleaseScene(object);
    rtcReleaseDevice(device);
    std::printf("4096 rays, %d hits: smoketrace and Embree %s\n", hits,
                disagreements == 0 ? "agree on every ray" : "DISAGREE");
    return disagreements == 0 && hits > 0 && hits < 4096 ? 0 : 1;
}
