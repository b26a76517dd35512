// The thesis's two-tube particle system (see tube_generator.hpp).
#include <smoketrace/smoke/tube_generator.hpp>

#include <smoketrace/core/prng.hpp>

#include <cmath>
#include <stdexcept>

namespace smoketrace {

namespace {
constexpr float kTwoPi = 6.28318530717958647692f;

bool finite(float v) { return std::isfinite(v); }
bool finite(const glm::vec3& v) { return finite(v.x) && finite(v.y) && finite(v.z); }

void check(const TubeSettings& s) {
    auto positive = [](float v) { return finite(v) && v > 0.0f; };
    if (!positive(s.tube_radius) || !positive(s.tube_length) || !positive(s.particle_radius))
        throw std::invalid_argument("generate_tubes: radii and length must be finite and > 0");
    if (!finite(s.center) || !finite(s.separation) || !finite(s.drift) || !finite(s.jitter_speed) ||
        !finite(s.spin_speed) || !finite(s.growth) || s.growth <= -1.0f)
        throw std::invalid_argument("generate_tubes: centre, separation and speeds must be finite, growth > -1");
}
}  // namespace

std::vector<Particle> generate_tubes(const TubeSettings& s) {
    check(s);
    Pcg32 position_rng(s.seed, kTubePositionStream);
    Pcg32 motion_rng(s.seed, kTubeMotionStream);
    Pcg32 rotation_rng(s.seed, kTubeRotationStream);

    const float r = s.tube_radius;
    const float half_length = 0.5f * s.tube_length;  // exact: a power-of-two scale
    const float r2 = r * r;

    std::vector<Particle> particles;
    particles.reserve(s.particles);
    while (particles.size() < s.particles) {
        // Draw order x, y, z is part of the format: changing it changes every scene made from a seed.
        const float x = position_rng.uniform(-r, r);
        const float y = position_rng.uniform(-r, r);
        const float z = position_rng.uniform(-half_length, half_length);
        if (x * x + y * y > r2) continue;  // outside the tube: rejected (acceptance π/4)

        Particle p;
        if (particles.size() % 2 == 0) {
            p.center = {x, y + s.separation, z};            // upper tube, along z
        } else {
            p.center = {z, y - s.separation, -x};           // lower tube: rotated 90° about y, along x
        }
        p.center += s.center;  // exact for the default centre 0: the shipped scenes keep their bits
        p.radius = s.particle_radius;

        const float vx = motion_rng.uniform(-s.jitter_speed, s.jitter_speed);
        const float vy = motion_rng.uniform(-s.jitter_speed, s.jitter_speed);
        const float vz = motion_rng.uniform(-s.jitter_speed, s.jitter_speed);
        p.velocity = s.drift + glm::vec3(vx, vy, vz);
        p.spin = motion_rng.uniform(-s.spin_speed, s.spin_speed);
        p.growth = s.growth;

        if (s.random_rotation) {
            const float a = rotation_rng.uniform01() * kTwoPi;
            p.rotation = a < kTwoPi ? a : 0.0f;  // u·2π can round up to 2π
        }
        particles.push_back(p);
    }
    return particles;
}

}  // namespace smoketrace
