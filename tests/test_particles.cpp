// The PRNG, the particle system's motion and the thesis's two-tube generator (4.1.1).
#include <smoketrace/smoke/particle_system.hpp>
#include <smoketrace/core/prng.hpp>
#include <smoketrace/smoke/tube_generator.hpp>

#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <vector>

using namespace smoketrace;

namespace {

// Bitwise equality: "deterministic" means the same bits, not merely close values.
bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }
bool same_bits(const glm::vec3& a, const glm::vec3& b) {
    return same_bits(a.x, b.x) && same_bits(a.y, b.y) && same_bits(a.z, b.z);
}
bool same_particles(const std::vector<Particle>& a, const std::vector<Particle>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i) {
        if (!same_bits(a[i].center, b[i].center) || !same_bits(a[i].radius, b[i].radius) ||
            !same_bits(a[i].velocity, b[i].velocity) || !same_bits(a[i].spin, b[i].spin) ||
            !same_bits(a[i].growth, b[i].growth) || !same_bits(a[i].rotation, b[i].rotation))
            return false;
    }
    return true;
}

// A particle centre is the float sum y ± separation of two floats: off the exact value by at most half an
// ulp of |y ± separation| <= 2.35, i.e. 2^-22·0.5 ≈ 1.2e-7. 1e-6 covers that with room.
constexpr double kCentreRoundingTolerance = 1e-6;
constexpr double kTwoPi = 6.283185307179586476925;

}  // namespace

// ---- PRNG --------------------------------------------------------------------------------------------

TEST_CASE("Pcg32 reproduces the reference pcg32 demo sequence", "[particles][prng]") {
    // pcg-c-basic's pcg32-demo, pcg32_srandom_r(&rng, 42u, 54u), "Round 1 / 32bit:" (published output).
    Pcg32 rng(42u, 54u);
    const std::uint32_t expected[] = {0xa15c02b7u, 0x7b47f409u, 0xba1d3330u, 0x83d2f293u, 0xbfa4784bu, 0xcbed606eu};
    for (std::uint32_t e : expected) CHECK(rng.next_u32() == e);
}

TEST_CASE("Pcg32 uniform01 takes the top 24 bits times 2^-24", "[particles][prng]") {
    Pcg32 rng(42u, 54u);
    // 0xa15c02b7 >> 8 = 0xa15c02 = 10574850; the float value is exactly 10574850 / 2^24.
    CHECK(rng.uniform01() == static_cast<float>(10574850.0 / 16777216.0));
    // 0x7b47f409 >> 8 = 0x7b47f4 = 8079348.
    CHECK(rng.uniform01() == static_cast<float>(8079348.0 / 16777216.0));
    // uniform(−1, 1) of 0xba1d3330: −1 + 2·(0xba1d33 / 2^24); both float steps are exact here (2u is a
    // power-of-two scale, and 2u − 1 with 2u in [1, 2) is exact by Sterbenz's lemma).
    CHECK(rng.uniform(-1.0f, 1.0f) == static_cast<float>(-1.0 + 2.0 * (12197171.0 / 16777216.0)));
}

TEST_CASE("Pcg32 uniform01 stays in 0 <= u < 1 and is unbiased", "[particles][prng]") {
    Pcg32 rng(7u);
    constexpr int n = 200000;
    double sum = 0.0;
    float lo = 1.0f, hi = 0.0f;
    for (int i = 0; i < n; ++i) {
        const float u = rng.uniform01();
        lo = std::min(lo, u);
        hi = std::max(hi, u);
        sum += u;
    }
    CHECK(lo >= 0.0f);
    CHECK(hi < 1.0f);
    // Mean of U[0,1) is 1/2 with standard error 1/sqrt(12 n) ≈ 6.5e-4; 5 standard errors.
    CHECK(std::abs(sum / n - 0.5) < 5.0 / std::sqrt(12.0 * n));
}

TEST_CASE("Pcg32 streams and seeds give different sequences", "[particles][prng]") {
    Pcg32 a(1u, 0u), b(1u, 1u), c(2u, 0u), a2(1u, 0u);
    const std::uint32_t va = a.next_u32();
    CHECK(va != b.next_u32());
    CHECK(va != c.next_u32());
    CHECK(va == a2.next_u32());
}

TEST_CASE("Pcg32 below(n) is the top of the 32 bits scaled by n, in range and unbiased", "[particles][prng]") {
    Pcg32 a(7u), b(7u);
    for (std::uint32_t n : {1u, 2u, 5u, 1000u, 0xFFFF'FFFFu}) {
        const std::uint32_t v = a.below(n);
        CHECK(v == std::uint32_t((std::uint64_t{b.next_u32()} * n) >> 32));
        CHECK(v < n);
    }
    // Six values, 60,000 draws: each count is 10,000 ± 91 (binomial standard deviation); 5 deviations.
    Pcg32 rng(3u);
    std::array<int, 6> counts{};
    for (int i = 0; i < 60000; ++i) ++counts[rng.below(6)];
    for (int c : counts) CHECK(std::abs(c - 10000) < 5 * 91);
}

// ---- ParticleSystem ----------------------------------------------------------------------------------

TEST_CASE("advance moves each particle by its velocity per frame", "[particles]") {
    Particle p;
    p.center = {1.0f, 2.0f, 3.0f};
    p.velocity = {0.25f, -0.5f, 0.125f};  // powers of two: every sum below is exact
    Particle still;
    still.center = {-4.0f, 0.0f, 0.0f};
    ParticleSystem system({p, still});
    system.advance(3);
    CHECK(system[0].center == glm::vec3(1.75f, 0.5f, 3.375f));
    CHECK(system[0].radius == 1.0f);
    CHECK(system[1].center == glm::vec3(-4.0f, 0.0f, 0.0f));
    system.advance();
    CHECK(system[0].center == glm::vec3(2.0f, 0.0f, 3.5f));
}

TEST_CASE("advance scales the radius by 1 + growth per frame", "[particles]") {
    Particle p;
    p.radius = 1.0f;
    p.growth = 0.5f;
    ParticleSystem system({p});
    system.advance(2);
    CHECK(system[0].radius == 2.25f);  // 1 · 1.5 · 1.5, exact in float
}

TEST_CASE("advance never shrinks a radius to zero", "[particles]") {
    Particle p;
    p.radius = 1.0f;
    p.growth = -0.5f;  // halves per frame: 2^-200 would underflow to 0 long before frame 200
    ParticleSystem system({p});
    system.advance(200);
    CHECK(system[0].radius == kMinParticleRadius);
    CHECK(system[0].radius > 0.0f);
}

TEST_CASE("advance spins billboards and keeps the angle in 0 <= a < 2pi", "[particles]") {
    Particle forward;
    forward.spin = 1.0f;
    Particle backward;
    backward.spin = -0.75f;
    ParticleSystem system({forward, backward});
    system.advance(10);
    // 10 rad ≡ 10 − 2π; −7.5 rad ≡ −7.5 + 4π. Ten float additions and wraps of values below 2π each round
    // by at most half an ulp of 2π (2.4e-7): 10 · 2.4e-7 ≈ 2.4e-6, so 1e-5.
    constexpr double kSpinAccumulationTolerance = 1e-5;
    CHECK(system[0].rotation == Approx(10.0 - kTwoPi).margin(kSpinAccumulationTolerance));
    CHECK(system[1].rotation == Approx(-7.5 + 2.0 * kTwoPi).margin(kSpinAccumulationTolerance));
    for (const Particle& q : system.particles()) {
        CHECK(q.rotation >= 0.0f);
        CHECK(q.rotation < static_cast<float>(kTwoPi));
    }
}

TEST_CASE("advance(n) equals n single steps bit for bit", "[particles]") {
    std::vector<Particle> particles;
    for (int i = 0; i < 5; ++i) {
        Particle p;
        p.center = {0.1f * i, 0.3f, -0.7f};
        p.radius = 0.3f + 0.01f * i;
        p.velocity = {0.013f, -0.021f * i, 0.007f};
        p.spin = 0.37f - 0.2f * i;
        p.growth = 0.003f * (i - 2);
        particles.push_back(p);
    }
    ParticleSystem batch(particles), stepped(particles);
    batch.advance(17);
    for (int f = 0; f < 17; ++f) stepped.advance(1);
    CHECK(same_particles({batch.particles().begin(), batch.particles().end()},
                         {stepped.particles().begin(), stepped.particles().end()}));
}

TEST_CASE("advance(0) changes nothing and negative frame counts are refused", "[particles]") {
    Particle p;
    p.velocity = {1.0f, 0.0f, 0.0f};
    ParticleSystem system({p});
    system.advance(0);
    CHECK(system[0].center == glm::vec3(0.0f));
    CHECK_THROWS_AS(system.advance(-1), std::invalid_argument);
}

TEST_CASE("moving() is true exactly when some particle has velocity, spin or growth", "[particles]") {
    Particle still;
    still.rotation = 1.0f;  // a rotated but not spinning billboard is still
    CHECK_FALSE(ParticleSystem({still, still}).moving());
    CHECK_FALSE(ParticleSystem().moving());

    Particle moving = still;
    moving.velocity.y = 1e-6f;
    CHECK(ParticleSystem({still, moving}).moving());
    Particle spinning = still;
    spinning.spin = -0.1f;
    CHECK(ParticleSystem({spinning, still}).moving());
    Particle growing = still;
    growing.growth = 0.01f;
    CHECK(ParticleSystem({still, growing}).moving());
}

// ---- Tube generator ----------------------------------------------------------------------------------

TEST_CASE("generate_tubes returns exactly the requested count, alternating the tubes", "[particles][tubes]") {
    for (std::uint32_t count : {0u, 1u, 2u, 750u, 751u}) {
        TubeSettings s;
        s.particles = count;
        const auto particles = generate_tubes(s);
        REQUIRE(particles.size() == count);
        std::uint32_t upper = 0;
        for (std::size_t i = 0; i < particles.size(); ++i) {
            // separation > tube_radius, so the tubes lie on either side of y = 0.
            const bool is_upper = particles[i].center.y > 0.0f;
            CHECK(is_upper == (i % 2 == 0));
            upper += is_upper ? 1u : 0u;
        }
        CHECK(upper == (count + 1) / 2);  // half each; with an odd count the upper tube has one more
    }
}

TEST_CASE("generate_tubes puts every particle inside its tube", "[particles][tubes]") {
    TubeSettings s;
    s.particles = 2000;
    s.tube_radius = 0.8f;
    s.tube_length = 5.0f;
    s.separation = 1.5f;
    s.particle_radius = 0.2f;
    const double r = s.tube_radius, half = 0.5 * s.tube_length, sep = s.separation;
    const auto particles = generate_tubes(s);
    for (std::size_t i = 0; i < particles.size(); ++i) {
        const glm::dvec3 c(particles[i].center);
        INFO("particle " << i << " at " << c.x << ", " << c.y << ", " << c.z);
        CHECK(particles[i].radius == s.particle_radius);
        if (i % 2 == 0) {  // upper tube: axis along z at y = +sep
            CHECK(std::hypot(c.x, c.y - sep) <= r + kCentreRoundingTolerance);
            CHECK(std::abs(c.z) <= half);
        } else {           // lower tube: axis along x at y = −sep
            CHECK(std::hypot(c.z, c.y + sep) <= r + kCentreRoundingTolerance);
            CHECK(std::abs(c.x) <= half);
        }
    }
}

TEST_CASE("generate_tubes follows the thesis's sampling step by step", "[particles][tubes]") {
    // An independent re-statement of 4.1.1 with the same PRNG stream: draw (x, y, z) in the cuboid, reject
    // outside the circle, alternate +y / (−y and rotate 90° about y: (x, y, z) → (z, y, −x)).
    TubeSettings s;
    s.seed = 12345;
    s.particles = 8;
    const auto particles = generate_tubes(s);
    Pcg32 rng(s.seed, kTubePositionStream);
    const float r = s.tube_radius, half = s.tube_length / 2.0f;
    std::size_t kept = 0, rejected = 0;
    while (kept < particles.size()) {
        const float x = rng.uniform(-r, r), y = rng.uniform(-r, r), z = rng.uniform(-half, half);
        if (x * x + y * y > r * r) {
            ++rejected;
            continue;
        }
        const glm::vec3 expected = kept % 2 == 0 ? glm::vec3(x, y + s.separation, z) : glm::vec3(z, y - s.separation, -x);
        CHECK(same_bits(particles[kept].center, expected));
        ++kept;
    }
    INFO("rejected " << rejected);  // not asserted: it depends on the seed
}

TEST_CASE("generate_tubes is deterministic per seed", "[particles][tubes]") {
    TubeSettings s;
    const auto a = generate_tubes(s);
    const auto b = generate_tubes(s);
    CHECK(same_particles(a, b));
    s.seed += 1;
    const auto c = generate_tubes(s);
    REQUIRE(c.size() == a.size());
    std::size_t differing = 0;
    for (std::size_t i = 0; i < a.size(); ++i) differing += same_bits(a[i].center, c[i].center) ? 0 : 1;
    CHECK(differing == a.size());  // a shared float triple between two seeds would be a 2^-70-ish accident
}

TEST_CASE("generate_tubes fills the tube cross-section uniformly", "[particles][tubes]") {
    // For points uniform in a disc of radius R, P(ρ < R/√2) = 1/2 and the mean along the axis is 0.
    TubeSettings s;
    s.particles = 20000;
    const auto particles = generate_tubes(s);
    const double r2 = double(s.tube_radius) * s.tube_radius;
    std::size_t inner = 0;
    double axial = 0.0;
    const std::size_t per_tube = particles.size() / 2;
    for (std::size_t i = 0; i < particles.size(); i += 2) {
        const glm::dvec3 c(particles[i].center);
        const double dy = c.y - s.separation;
        inner += (c.x * c.x + dy * dy < r2 / 2.0) ? 1 : 0;
        axial += c.z;
    }
    // Binomial standard error sqrt(p(1−p)/n) with p = 1/2, and L/sqrt(12 n) for the mean; 5 of each.
    CHECK(std::abs(double(inner) / per_tube - 0.5) < 5.0 * std::sqrt(0.25 / per_tube));
    CHECK(std::abs(axial / per_tube) < 5.0 * s.tube_length / std::sqrt(12.0 * per_tube));
}

TEST_CASE("generate_tubes motion: positions do not depend on it, speeds stay in range", "[particles][tubes]") {
    TubeSettings still;
    still.particles = 300;
    TubeSettings moving = still;
    moving.drift = {0.0f, 0.01f, 0.0f};
    moving.jitter_speed = 0.002f;
    moving.spin_speed = 0.05f;
    moving.growth = 0.001f;
    const auto a = generate_tubes(still);
    const auto b = generate_tubes(moving);
    REQUIRE(a.size() == b.size());
    bool some_spin = false;
    for (std::size_t i = 0; i < a.size(); ++i) {
        CHECK(same_bits(a[i].center, b[i].center));
        CHECK(same_bits(a[i].rotation, b[i].rotation));
        CHECK(a[i].velocity == glm::vec3(0.0f));
        CHECK(a[i].spin == 0.0f);
        CHECK(a[i].growth == 0.0f);
        const glm::vec3 jitter = b[i].velocity - moving.drift;
        // jitter is drawn in [−j, j] and added to the drift; subtracting the drift back rounds by at most
        // an ulp of 0.012 (~1e-9), far below the 1e-7 allowance.
        constexpr float kDriftRoundingTolerance = 1e-7f;
        for (int k = 0; k < 3; ++k) CHECK(std::abs(jitter[k]) <= moving.jitter_speed + kDriftRoundingTolerance);
        CHECK(std::abs(b[i].spin) <= moving.spin_speed);
        CHECK(b[i].growth == moving.growth);
        some_spin = some_spin || b[i].spin != 0.0f;
    }
    CHECK(some_spin);
    CHECK_FALSE(ParticleSystem(a).moving());
    CHECK(ParticleSystem(b).moving());
}

TEST_CASE("generate_tubes random_rotation", "[particles][tubes]") {
    TubeSettings s;
    s.particles = 500;
    s.random_rotation = false;
    for (const Particle& p : generate_tubes(s)) CHECK(p.rotation == 0.0f);
    s.random_rotation = true;
    std::size_t nonzero = 0;
    for (const Particle& p : generate_tubes(s)) {
        CHECK(p.rotation >= 0.0f);
        CHECK(p.rotation < static_cast<float>(kTwoPi));
        nonzero += p.rotation != 0.0f ? 1 : 0;
    }
    CHECK(nonzero > 0);
}

TEST_CASE("generate_tubes rejects invalid settings", "[particles][tubes]") {
    auto with = [](auto change) {
        TubeSettings s;
        change(s);
        return s;
    };
    CHECK_THROWS_AS(generate_tubes(with([](TubeSettings& s) { s.tube_radius = 0.0f; })), std::invalid_argument);
    CHECK_THROWS_AS(generate_tubes(with([](TubeSettings& s) { s.tube_length = -1.0f; })), std::invalid_argument);
    CHECK_THROWS_AS(generate_tubes(with([](TubeSettings& s) { s.particle_radius = NAN; })), std::invalid_argument);
    CHECK_THROWS_AS(generate_tubes(with([](TubeSettings& s) { s.separation = INFINITY; })), std::invalid_argument);
    CHECK_THROWS_AS(generate_tubes(with([](TubeSettings& s) { s.growth = -1.0f; })), std::invalid_argument);
}
