#pragma once
// Small helpers that many tests share: a particle from a centre and a radius, the list of every particle
// index, and the message an operation fails with.
#include <smoketrace/smoke/particle_system.hpp>

#include <glm/vec3.hpp>

#include <cstdint>
#include <exception>
#include <numeric>
#include <string>
#include <vector>

namespace smoketrace::test {

inline Particle particle(glm::vec3 center, float radius) {
    Particle p;
    p.center = center;
    p.radius = radius;
    return p;
}

// 0, 1, …, n − 1: the `which` argument that selects every particle.
inline std::vector<std::uint32_t> all_of(std::size_t n) {
    std::vector<std::uint32_t> v(n);
    std::iota(v.begin(), v.end(), 0u);
    return v;
}

// What f() throws (any std::exception), or "(no exception)". A template, not std::function: nothing to
// allocate, and any callable fits.
template <class F>
std::string message_of(F&& f) {
    try {
        f();
    } catch (const std::exception& e) {
        return e.what();
    }
    return "(no exception)";
}

}  // namespace smoketrace::test
