#pragma once
// The thesis's smoke: two perpendicular tubes of sphere particles, one slightly above the other
// (thesis 4.1 and 4.1.1).
//
// Positions are sampled uniformly in the cuboid x, y ∈ [−R, R], z ∈ [−L/2, L/2] around the z axis and
// rejected where x² + y² > R². Of the kept samples, the 0th, 2nd, 4th, … are moved +separation in y (the
// upper tube, along z); the 1st, 3rd, … are moved −separation in y and rotated 90° about y, (x, y, z) →
// (z, y, −x), so that the lower tube runs along x; then every particle is moved by `center`. Output order
// is sample order, so the particles alternate upper, lower, upper, …; with an odd count the upper tube has
// one more.
//
// Deterministic on every platform: the own PRNG (prng.hpp), float operations that round exactly once each
// (no FMA contraction, see CMakeLists.txt), and the rotation done by swapping coordinates, not with sin/cos.
//
// Defaults and why (the thesis gives no dimensions; these reproduce what its figures and text show):
// * 750 particles: the thesis's default (4.4.1, figures 5.1 and 5.2).
// * tube_radius 1, tube_length 6: long, slim tubes as in figures 5.1/5.2; the lower one is long enough for
//   light from the right to fade visibly along it (5.2).
// * particle_radius 0.35: with 375 particles per tube a ray along the lower tube's axis crosses about
//   2·375·(0.35/1)² ≈ 92 sphere surfaces and one across the upper tube's diameter about 31. That matches
//   5.2.3: with the cutoff at 20 light does not get through even the upper tube, at 40 it does, and past
//   60–80 hits (where the OD pass time flattens, table B.4) almost nothing changes.
// * separation 1.35 = tube_radius + particle_radius: the outermost spheres of the two tubes just touch at
//   y = 0, so the tubes read as two bodies ("one tube is slightly above ... the other", 4.1) and the upper
//   one casts a distinct shadow on the lower (5.1).
#include <smoketrace/smoke/particle_system.hpp>

#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace smoketrace {

struct TubeSettings {
    std::uint32_t particles = 750;      // total over both tubes
    float tube_radius = 1.0f;           // R
    float tube_length = 6.0f;           // L
    float separation = 1.35f;           // each tube's axis is this far from y = 0 (upper +, lower −)
    float particle_radius = 0.35f;
    std::uint64_t seed = 2022;          // the thesis's year; any value
    glm::vec3 center{0.0f};             // where the tubes cross (the point above is moved here)

    // Optional motion (thesis 4.1.1), all zero by default: a still scene.
    glm::vec3 drift{0.0f};              // common velocity, world units per frame
    float jitter_speed = 0.0f;          // plus a per-particle velocity, each component uniform in [−j, j]
    float spin_speed = 0.0f;            // per-particle spin uniform in [−s, s] radians per frame
    float growth = 0.0f;                // common radius scale per frame (see Particle::growth)
    bool random_rotation = true;        // start each billboard at a random angle so the puffs do not repeat
};

// PRNG streams: positions, motion and initial rotation draw from separate streams of the same seed, so
// switching motion on or off never moves a particle's starting position.
inline constexpr std::uint64_t kTubePositionStream = 0;
inline constexpr std::uint64_t kTubeMotionStream = 1;
inline constexpr std::uint64_t kTubeRotationStream = 2;

// Exactly settings.particles particles, in sample order (see above). Preconditions (the scene file checks
// them, this function asserts them with std::invalid_argument): radii and length > 0 and finite,
// separation, speeds finite, growth > −1.
[[nodiscard]] std::vector<Particle> generate_tubes(const TubeSettings& settings);

}  // namespace smoketrace
