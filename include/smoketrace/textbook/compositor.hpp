#pragma once
// The textbook frame, compositor: the colour one camera ray sees (thesis 4.3.5, eq. 4.1; method.md "View
// pass"). The ray finds the opaque surface (the ground) or the sky, then every billboard in front of it; the
// layers are sorted front to back and composited, and the ground behind them is shaded with its shadow ray
// toward the light (eq. 4.3). Colours come from shading.hpp; every ray goes through textbook::trace.
#include <smoketrace/geometry/ray.hpp>
#include <smoketrace/textbook/shading.hpp>

#include <glm/vec3.hpp>

namespace smoketrace::textbook {

// TMin of camera rays (4.3.5): clear of the camera's own position, in scene units.
inline constexpr float kCameraRayTmin = 1e-3f;

// The colour (linear RGB) of the camera ray `ray`.
[[nodiscard]] glm::dvec3 camera_ray_color(const Shading& shading, const Ray& ray);

// The shadow on the ground point `point` (eq. 4.3): the fraction of the light that reaches it through the
// smoke. simple-shadow: 0 if any particle is in the way, else 1; full: exp(−l·σt) of the nearest particle
// toward the light (uniform kernel, the thesis), or exp(−σt·Σ shares) of every particle the shadow ray passes
// through (a smooth kernel, density_kernel.hpp).
[[nodiscard]] double ground_shadow(const Shading& shading, const glm::vec3& point);

}  // namespace smoketrace::textbook
