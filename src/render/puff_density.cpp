// The six-way baker's procedural puff (see sixway_baker.hpp for the model).
#include <smoketrace/render/puff_density.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <glm/geometric.hpp>

#include <array>
#include <cmath>
#include <cstdint>

namespace smoketrace {

namespace {

// ---- Noise: gradient (Perlin-style) noise on an integer lattice, hashed, no tables to seed ------------

// MurmurHash3's 32-bit finaliser: a bijection whose output bits each depend on every input bit.
constexpr std::uint32_t mix32(std::uint32_t h) {
    h ^= h >> 16;
    h *= 0x85EB'CA6Bu;
    h ^= h >> 13;
    h *= 0xC2B2'AE35u;
    h ^= h >> 16;
    return h;
}

// Golden-ratio increment (2^32 / φ): spreads consecutive seeds and octaves far apart in hash space.
constexpr std::uint32_t kSeedStep = 0x9E37'79B9u;

std::uint32_t lattice_hash(std::int32_t x, std::int32_t y, std::int32_t z, std::uint32_t seed) {
    std::uint32_t h = mix32(seed + kSeedStep);
    h = mix32(h ^ std::uint32_t(x));
    h = mix32(h ^ std::uint32_t(y));
    return mix32(h ^ std::uint32_t(z));
}

// The twelve cube-edge directions, four of them repeated to make sixteen so the top four hash bits pick
// one without a modulo (the gradient set of Perlin's "improved noise", 2002).
constexpr std::array<std::array<float, 3>, 16> kGradients{{{1, 1, 0}, {-1, 1, 0}, {1, -1, 0}, {-1, -1, 0},
                                                          {1, 0, 1}, {-1, 0, 1}, {1, 0, -1}, {-1, 0, -1},
                                                          {0, 1, 1}, {0, -1, 1}, {0, 1, -1}, {0, -1, -1},
                                                          {1, 1, 0}, {-1, 1, 0}, {0, -1, 1}, {0, -1, -1}}};

float corner(std::int32_t ix, std::int32_t iy, std::int32_t iz, float dx, float dy, float dz, std::uint32_t seed) {
    const auto& g = kGradients[lattice_hash(ix, iy, iz, seed) >> 28];
    return g[0] * dx + g[1] * dy + g[2] * dz;
}

float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }  // C2 quintic: no lattice creases
float lerp(float a, float b, float t) { return a + t * (b - a); }

// Gradient noise, zero at lattice points, roughly in [-1, 1].
float gradient_noise(glm::vec3 q, std::uint32_t seed) {
    const float fx = std::floor(q.x), fy = std::floor(q.y), fz = std::floor(q.z);
    const auto ix = std::int32_t(fx), iy = std::int32_t(fy), iz = std::int32_t(fz);
    const float tx = q.x - fx, ty = q.y - fy, tz = q.z - fz;
    const float u = fade(tx), v = fade(ty), w = fade(tz);
    const float c000 = corner(ix, iy, iz, tx, ty, tz, seed);
    const float c100 = corner(ix + 1, iy, iz, tx - 1, ty, tz, seed);
    const float c010 = corner(ix, iy + 1, iz, tx, ty - 1, tz, seed);
    const float c110 = corner(ix + 1, iy + 1, iz, tx - 1, ty - 1, tz, seed);
    const float c001 = corner(ix, iy, iz + 1, tx, ty, tz - 1, seed);
    const float c101 = corner(ix + 1, iy, iz + 1, tx - 1, ty, tz - 1, seed);
    const float c011 = corner(ix, iy + 1, iz + 1, tx, ty - 1, tz - 1, seed);
    const float c111 = corner(ix + 1, iy + 1, iz + 1, tx - 1, ty - 1, tz - 1, seed);
    return lerp(lerp(lerp(c000, c100, u), lerp(c010, c110, u), v), lerp(lerp(c001, c101, u), lerp(c011, c111, u), v), w);
}

// Fractal sum of octaves (frequency x2, amplitude x1/2), normalised by the amplitude sum and clamped to
// [-1, 1], so the puff's support bound radius·(1 + noise_amplitude) holds exactly.
float fbm(glm::vec3 q, int octaves, std::uint32_t seed) {
    float sum = 0.0f, amplitude = 1.0f, total = 0.0f;
    for (int o = 0; o < octaves; ++o) {
        // Billow: |noise| folds each octave at its zero set into creases between rounded lobes, the
        // cauliflower look of a smoke puff; 2|n| - 1 recentres it on [-1, 1].
        sum += amplitude * (2.0f * std::fabs(gradient_noise(q, seed + std::uint32_t(o) * kSeedStep)) - 1.0f);
        total += amplitude;
        amplitude *= 0.5f;
        q *= 2.0f;
    }
    const float n = sum / total;
    return n > -1.0f ? (n < 1.0f ? n : 1.0f) : -1.0f;
}

// The direction the noise field slides per frame, in tangent space: mostly up (smoke rises), partly
// toward the viewer (features appear and fade in depth rather than only translating on screen).
const glm::vec3 kDriftDirection = glm::normalize(glm::vec3(0.0f, 0.8f, 0.6f));

}  // namespace

PuffDensity::PuffDensity(const SixwayBakeSettings& settings, int frame)
    : s_(settings), noise_offset_(-float(frame) * settings.drift * kDriftDirection) {
    const float support = settings.radius * (1.0f + settings.noise_amplitude);
    support_squared_ = support * support;
}

float PuffDensity::operator()(glm::vec3 p) const {
    const float r2 = glm::dot(p, p);
    if (r2 >= support_squared_) return 0.0f;
    const float n = fbm(p * s_.noise_frequency + noise_offset_, s_.noise_octaves, s_.seed);
    const float inside = 1.0f - std::sqrt(r2) / s_.radius + s_.noise_amplitude * n;
    const float t = inside > 0.0f ? (inside < s_.edge_softness ? inside / s_.edge_softness : 1.0f) : 0.0f;
    return t * t * (3.0f - 2.0f * t);  // smoothstep
}

void sample_puff_density(const SixwayBakeSettings& settings, const PuffVoxels& g, int frame,
                         std::vector<float>& density) {
    density.resize(g.count());
    const PuffDensity puff(settings, frame);
    tbb::parallel_for(tbb::blocked_range<int>(0, g.nz * g.n), [&](const tbb::blocked_range<int>& rows) {
        for (int r = rows.begin(); r != rows.end(); ++r) {
            const int k = r / g.n, j = r % g.n;
            for (int i = 0; i < g.n; ++i) density[g.index(k, j, i)] = puff(g.centre(k, j, i));
        }
    });
}

}  // namespace smoketrace
