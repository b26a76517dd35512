#include <smoketrace/textbook/trace.hpp>

namespace smoketrace::textbook {

bool admits(const Instance& inst, const BottomLevel& blas, std::uint32_t flags, std::uint8_t inclusion_mask,
            bool& opaque) {
    if ((inst.mask & inclusion_mask) == 0) return false;  // rule 1
    // Rule 2: the geometry's opacity, overridden by the instance's FORCE_OPAQUE and then FORCE_NON_OPAQUE,
    // and those by the ray's FORCE_OPAQUE and then FORCE_NON_OPAQUE.
    opaque = blas.opaque;
    if (inst.flags & instance_flag_force_opaque) opaque = true;
    if (inst.flags & instance_flag_force_non_opaque) opaque = false;
    if (flags & ray_flag_force_opaque) opaque = true;
    if (flags & ray_flag_force_non_opaque) opaque = false;
    return !(opaque ? (flags & ray_flag_cull_opaque) : (flags & ray_flag_cull_non_opaque));  // rule 3
}

ObjectRay object_ray(const Instance& inst, const BottomLevel& blas, const Ray& world_ray, std::uint32_t flags) {
    // x_object = L⁻¹·(x_world − translation): the translation is subtracted first, in double, so that a small
    // particle far from the world origin keeps its precision.
    const glm::dmat3 to_object = inst.object_to_world.inverse().linear;
    ObjectRay o;
    o.origin = to_object * (glm::dvec3(world_ray.origin) - inst.object_to_world.translation);
    o.direction = to_object * glm::dvec3(world_ray.direction);
    o.ray = Ray{glm::vec3(o.origin), world_ray.tmin, glm::vec3(o.direction), world_ray.tmax};
    o.triangle_ray = TriangleRay(o.ray);
    // Rule 4: facing culls apply to triangles only, and not in an instance flagged TRIANGLE_CULL_DISABLE.
    // Facing is decided in object space, so a mirroring transform does not flip it.
    const bool facing_cull = blas.kind == GeometryKind::triangles && !(inst.flags & instance_flag_triangle_cull_disable);
    o.cull_back = facing_cull && (flags & ray_flag_cull_back_facing_triangles);
    o.cull_front = facing_cull && (flags & ray_flag_cull_front_facing_triangles);
    o.front_clockwise = (inst.flags & instance_flag_triangle_front_clockwise) != 0;
    return o;
}

}  // namespace smoketrace::textbook
