#pragma once
// A particle's optical-depth ray (thesis 4.3.2): from its centre toward the light, and what it can find.
// Plain constants and the status, shared by the textbook pass (textbook/optical_depth.hpp) and the fast
// one (optical_depth_pass.hpp), so that both cast the same ray and answer in the same terms.
#include <cstdint>
#include <limits>

namespace smoketrace {

// TMin of an optical-depth ray, relative to its particle's radius r. The ray starts at the centre, inside its
// own stand-in. tmin > 0 so that a surface the centre lies on (the ground under a particle resting on it,
// another stand-in through the centre) is not crossed at t = 0. And tmin may be any fraction of r below
// the own exit (>= the inradius, 0.79·r for the icosahedron) without changing l: the ray is in smoke over
// [0, own exit) whatever it meets there, so a surface in [0, tmin) changes only the hit count, and a ground
// within tmin of the centre does not occlude. The thesis's absolute 1e-7 dropped the own exit of every
// particle smaller than that (l = 0, no hits); a fraction of r behaves the same at every scale.
// 2^-22: a power of two, so scaling a scene by 2^k scales every tmin exactly; near the thesis's 1e-7 at the
// default particle radius 0.35 (8.3e-8); and > 0 even for kMinParticleRadius (2^-126 · 2^-22 = 2^-148).
inline constexpr float kOpticalDepthTminPerRadius = 0x1.0p-22f;
[[nodiscard]] constexpr float optical_depth_tmin(float radius) { return kOpticalDepthTminPerRadius * radius; }
// TMax of the thesis's optical-depth rays: effectively unbounded, yet finite.
inline constexpr float kOpticalDepthTmax = 1e38f;

// What the optical-depth ray of a particle found: hits to resolve (ok), something opaque between the
// particle and the light (occluded), or more hits than the cutoff allows (cutoff, thesis 4.4.3).
enum class DepthStatus : std::uint8_t { ok, occluded, cutoff };

// The optical path length of a particle that is occluded or over the cutoff: "fully dark" (thesis 4.3.3
// stores "a very high value"). +infinity makes exp(-l * sigma_t) exactly 0 for any sigma_t > 0.
inline constexpr float kFullyDarkPathLength = std::numeric_limits<float>::infinity();

}  // namespace smoketrace
