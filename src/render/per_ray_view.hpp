#pragma once
// The per-ray compositors (view_compositor.hpp): every pixel sample's camera ray traced on its own with
// trace(). The reference the tiled compositor is held to, and the thesis's re-trace loop. Internal to the
// render layer.
#include "pixel_shading.hpp"

#include <smoketrace/geometry/ray.hpp>

#include <vector>

namespace smoketrace::view {

// One traversal for the opaque surface, one over the billboards in front of it (LayerCollector).
glm::vec3 one_traversal_sample(const PixelShader& shader, const Ray& ray, std::vector<Layer>& layers);

// The thesis's loop: the closest billboard or the ground, shade, and trace again from just behind it.
glm::vec3 retrace_sample(const PixelShader& shader, const Ray& ray);

}  // namespace smoketrace::view
