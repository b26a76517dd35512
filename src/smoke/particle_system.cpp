// Particle motion (see particle_system.hpp).
#include <smoketrace/smoke/particle_system.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace smoketrace {

namespace {
constexpr float kTwoPi = 6.28318530717958647692f;

// Keeps the angle in [0, 2π) so that a long spin does not lose precision as the angle grows; fmod is exact.
float wrap_angle(float a) {
    a = std::fmod(a, kTwoPi);
    if (a < 0.0f) a += kTwoPi;
    return a < kTwoPi ? a : 0.0f;  // a tiny negative angle plus 2π can round up to 2π itself
}
}  // namespace

void ParticleSystem::advance(int frames) {
    if (frames < 0) throw std::invalid_argument("ParticleSystem::advance: frames must be >= 0");
    for (Particle& p : particles_) {
        if (p.velocity == glm::vec3(0.0f) && p.spin == 0.0f && p.growth == 0.0f) continue;
        for (int f = 0; f < frames; ++f) {
            p.center += p.velocity;
            if (p.spin != 0.0f) p.rotation = wrap_angle(p.rotation + p.spin);
            p.radius = std::max(p.radius * (1.0f + p.growth), kMinParticleRadius);
        }
    }
}

bool ParticleSystem::moving() const {
    return std::any_of(particles_.begin(), particles_.end(), [](const Particle& p) {
        return p.velocity != glm::vec3(0.0f) || p.spin != 0.0f || p.growth != 0.0f;
    });
}

}  // namespace smoketrace
