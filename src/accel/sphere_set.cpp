// Sphere BLAS construction (see sphere_set.hpp).
#include <smoketrace/accel/sphere_set.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

namespace smoketrace {

SphereBlas::SphereBlas(const std::vector<Sphere>& spheres, const BvhBuildSettings& settings) {
    std::vector<Aabb> boxes(spheres.size());
    for (std::size_t i = 0; i < spheres.size(); ++i) {
        const Sphere& s = spheres[i];
        if (!(s.radius > 0.0f) || !std::isfinite(s.radius) || !std::isfinite(s.center.x) ||
            !std::isfinite(s.center.y) || !std::isfinite(s.center.z))
            throw std::invalid_argument("SphereBlas: sphere " + std::to_string(i) + " needs a finite centre and radius > 0");
        // Round the box outward by a relative ulp-scale margin: the box must contain the float sphere.
        const glm::vec3 r(s.radius * (1.0f + 1e-6f));
        boxes[i].grow(s.center - r - glm::abs(s.center) * 1e-7f);
        boxes[i].grow(s.center + r + glm::abs(s.center) * 1e-7f);
    }
    bvh_ = build_bvh(boxes, settings);
    spheres_.resize(bvh_.prim_indices.size());
    for (std::size_t k = 0; k < spheres_.size(); ++k) spheres_[k] = spheres[bvh_.prim_indices[k]];
}

}  // namespace smoketrace
