#pragma once
// A random scene of every instance kind trace() distinguishes, for tests that hold a multi-ray trace
// (trace_bundle(), trace_tile()) to trace() ray by ray, and the key that compares their candidates.
#include <smoketrace/accel/accel_scene.hpp>
#include <smoketrace/core/prng.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/accel/trace_types.hpp>

#include <glm/geometric.hpp>

#include <bit>
#include <cstdint>
#include <tuple>

namespace smoketrace::test {

inline glm::vec3 random_unit(Pcg32& rng) {
    glm::vec3 v;
    do v = glm::vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)); while (glm::length(v) < 0.1f);
    return glm::normalize(v);
}

// A random affine map (rotation, non-uniform scale, some mirrored), or a similarity (rotation, uniform
// scale: world-sphere instances), translated by up to ±15.
inline AffineTransform random_transform(Pcg32& rng, bool similarity, int i) {
    const glm::dvec3 x(random_unit(rng));
    glm::dvec3 y;
    do y = glm::dvec3(random_unit(rng)); while (glm::length(glm::cross(x, y)) < 0.1);
    y = glm::normalize(y - glm::dot(y, x) * x);
    const glm::dmat3 rot(x, y, glm::cross(x, y));
    const double s = 0.3 + 2.7 * rng.uniform01();
    const glm::dvec3 sc = similarity ? glm::dvec3(s)
                                     : glm::dvec3(0.2 + 4.8 * rng.uniform01(), 0.2 + 4.8 * rng.uniform01(),
                                                  (i % 3 == 0 ? -1.0 : 1.0) * (0.2 + 4.8 * rng.uniform01()));
    AffineTransform m;
    m.linear = rot * glm::dmat3(glm::dvec3(sc.x, 0, 0), glm::dvec3(0, sc.y, 0), glm::dvec3(0, 0, sc.z));
    m.translation = glm::dvec3(rng.uniform(-15, 15), rng.uniform(-15, 15), rng.uniform(-15, 15));
    return m;
}

inline TriangleMesh quad() {
    TriangleMesh m;
    m.vertices = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    m.triangles = {{0, 1, 2}, {0, 2, 3}};
    return m;
}

// 400 instances of six kinds: world spheres (similarity transforms), object-space spheres (non-uniform
// scale), icospheres (object-space meshes), world-space quads, opaque quads, opaque world spheres; masks
// 1, 2 or 4. `paths`: object_space_only takes every instance through trace()'s general path.
inline AccelScene mixed_scene(Pcg32& rng, InstancePaths paths = InstancePaths::fastest) {
    AccelScene s(paths);
    const std::uint32_t sphere = s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1.0f}}, false));
    const std::uint32_t ico = s.add_bottom_level(BottomLevel::from_mesh(make_icosphere(1, 1.0f), false));
    const std::uint32_t glass = s.add_bottom_level(BottomLevel::from_mesh(quad(), false));
    const std::uint32_t wall = s.add_bottom_level(BottomLevel::from_mesh(quad(), true));
    const std::uint32_t ball = s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0.1f, 0, 0}, 0.5f}}, true));
    for (int i = 0; i < 400; ++i) {
        const int kind = i % 6;
        const std::uint32_t blas[] = {sphere, sphere, ico, glass, wall, ball};
        const std::uint8_t flags = i % 11 == 0 ? instance_flag_triangle_front_clockwise
                                 : i % 13 == 0 ? instance_flag_triangle_cull_disable : instance_flag_none;
        s.add_instance(Instance{blas[kind], random_transform(rng, kind == 0 || kind == 5, i),
                                std::uint8_t(1u << (i % 3)), std::uint32_t(i), flags});
    }
    s.commit();
    return s;
}

using HitKey = std::tuple<std::uint32_t, std::uint32_t, HitKind, std::uint32_t>;  // instance, primitive, kind, t bits
inline HitKey key_of(const TraceHit& h) {
    return {h.instance_index, h.primitive_index, h.kind, std::bit_cast<std::uint32_t>(h.t)};
}

}  // namespace smoketrace::test
