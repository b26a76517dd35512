// Optical path lengths from C++ (thesis 4.3.2-4.3.3): how much smoke lies between each particle and the
// light. Three spherical particles stacked under a light straight above; each one's path length is checked
// against the chords worked out by hand below.
//
// What the library does: from each particle's centre a ray goes toward the light and an any-hit callback
// records every particle surface it crosses (+1 entering, -1 leaving); the hit resolver sorts them and sums
// the stretches that lie inside smoke (equation 3.1, which also counts the particle the ray starts in).
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/smoke/particle_groups.hpp>

#include <cmath>
#include <cstdio>
#include <vector>

using namespace smoketrace;

int main() {
    // Particles of radius 1: A at the origin, B three units above it, C six units above, offset 0.5 in x.
    std::vector<Particle> particles(3);
    particles[0].center = {0.0f, 0.0f, 0.0f};
    particles[1].center = {0.0f, 3.0f, 0.0f};
    particles[2].center = {0.5f, 6.0f, 0.0f};
    const glm::vec3 to_light{0.0f, 1.0f, 0.0f};

    // The scene the light rays are traced in: one exact-sphere stand-in per particle, no ground, no
    // billboards (only the view pass needs those). update() places the instances and commits the top level.
    SmokeScene smoke(particles, StandInShape{StandInKind::sphere, 0}, std::nullopt, /*billboards=*/false);
    smoke.update(particles, /*eye=*/glm::vec3(0.0f, 0.0f, 10.0f));

    // Trace and resolve every particle (one group: particle_group(n, 1, frame) is all of them).
    OpticalPathLengths depths(particles.size());
    FrameTimings timings;
    depths.update(smoke, particles, particle_group(particles.size(), 1, 0), to_light, OpticalDepthSettings{},
                  HitSort::adaptive, timings);

    // By hand, along +y: a ray starts inside its own particle (1 unit of smoke to leave it); a particle
    // centred on the ray adds its diameter 2; C, 0.5 off the ray, adds the chord 2·sqrt(1 - 0.5²).
    const double chord_c = 2.0 * std::sqrt(1.0 - 0.25);
    const double expected[] = {1.0 + 2.0 + chord_c, 1.0 + chord_c, 1.0};
    // Tolerance: the hit distances are floats below 10, so each is within ~1e-6 of exact; 1e-4 leaves room
    // for the sum yet is far below any missed or doubled surface (a chord of 1.7 or more).
    constexpr double kTolerance = 1e-4;
    int failures = 0;
    for (std::size_t i = 0; i < particles.size(); ++i) {
        const double l = depths.lengths()[i];
        const bool ok = depths.status()[i] == DepthStatus::ok && std::abs(l - expected[i]) <= kTolerance;
        std::printf("particle %zu: optical path length %.6f (expected %.6f, %u surfaces crossed) %s\n", i, l,
                    expected[i], depths.hit_counts()[i], ok ? "ok" : "WRONG");
        failures += ok ? 0 : 1;
    }
    // Transmittance toward the light for an extinction coefficient sigma_t = 1: exp(-l·sigma_t) (eq. 4.2).
    std::printf("transmittance of particle 0: %.4f\n", std::exp(-double(depths.lengths()[0])));
    std::printf("%s\n", failures == 0 ? "all path lengths within 1e-4 of the chords" : "MISMATCH");
    return failures == 0 ? 0 : 1;
}
