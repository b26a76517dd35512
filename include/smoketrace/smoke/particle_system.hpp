#pragma once
// Smoke particles and their motion (thesis 4.1.1: "Each particle can also be assigned motion vectors,
// movement speeds, rotation speeds and scale speeds").
//
// Speeds are per frame, not per second: the renderer is judged frame by frame (thesis 5.2.2 compares
// frame 32 of two runs), so a frame number must fix the scene exactly, independent of wall-clock time.
#include <glm/vec3.hpp>

#include <cstddef>
#include <limits>
#include <span>
#include <utility>
#include <vector>

namespace smoketrace {

struct Particle {
    glm::vec3 center{0.0f};
    float radius = 1.0f;       // the sphere stand-in's radius, and half the billboard's side
    // The thesis's "motion vector" and "movement speed" folded into one vector: world units per frame.
    glm::vec3 velocity{0.0f};
    float spin = 0.0f;         // billboard rotation speed about the view axis, radians per frame
    float growth = 0.0f;       // radius scale speed: radius *= 1 + growth each frame (0.01 = +1 %/frame)
    float rotation = 0.0f;     // current billboard rotation, radians in [0, 2π)
};

// A particle never shrinks below the smallest normal float: radius > 0 is an invariant every consumer
// relies on (ray/sphere tests divide by it), and denormals would slow the hot loops to a crawl.
inline constexpr float kMinParticleRadius = std::numeric_limits<float>::min();

class ParticleSystem {
public:
    ParticleSystem() = default;
    explicit ParticleSystem(std::vector<Particle> particles) : particles_(std::move(particles)) {}

    // Moves, rotates and scales every particle by `frames` frame steps (frames >= 0). Each step is
    // applied separately, so advance(n) gives bit for bit the same particles as n calls of advance(1):
    //   center += velocity;  rotation = (rotation + spin) wrapped to [0, 2π);
    //   radius = max(radius · (1 + growth), kMinParticleRadius).
    void advance(int frames = 1);

    // True when some particle has a nonzero velocity, spin or growth, i.e. when advance() would change
    // anything; a renderer skips the acceleration-structure update and the optical-depth pass otherwise.
    [[nodiscard]] bool moving() const;

    [[nodiscard]] std::size_t size() const { return particles_.size(); }
    [[nodiscard]] bool empty() const { return particles_.empty(); }
    [[nodiscard]] std::span<const Particle> particles() const { return particles_; }
    [[nodiscard]] std::span<Particle> particles() { return particles_; }
    [[nodiscard]] const Particle& operator[](std::size_t i) const { return particles_[i]; }
    [[nodiscard]] Particle& operator[](std::size_t i) { return particles_[i]; }

private:
    std::vector<Particle> particles_;
};

}  // namespace smoketrace
