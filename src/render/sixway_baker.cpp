// The six-way flipbook baker (see sixway_baker.hpp for the model).
#include <smoketrace/render/sixway_baker.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

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

// ---- The puff --------------------------------------------------------------------------------------

// The direction the noise field slides per frame, in tangent space: mostly up (smoke rises), partly
// toward the viewer (features appear and fade in depth rather than only translating on screen).
const glm::vec3 kDriftDirection = glm::normalize(glm::vec3(0.0f, 0.8f, 0.6f));

struct Puff {
    const SixwayBakeSettings& s;
    glm::vec3 noise_offset;   // -frame · drift · kDriftDirection
    float support_squared;    // density is zero at |p|² >= this

    float density(glm::vec3 p) const {
        const float r2 = glm::dot(p, p);
        if (r2 >= support_squared) return 0.0f;
        const float n = fbm(p * s.noise_frequency + noise_offset, s.noise_octaves, s.seed);
        const float inside = 1.0f - std::sqrt(r2) / s.radius + s.noise_amplitude * n;
        const float t = inside > 0.0f ? (inside < s.edge_softness ? inside / s.edge_softness : 1.0f) : 0.0f;
        return t * t * (3.0f - 2.0f * t);  // smoothstep
    }
};

// ---- Light transport ------------------------------------------------------------------------------

// Channel order of the per-texel accumulators: positive R, G, B, then negative R, G, B.
enum Light : int { kRight, kTop, kFront, kLeft, kBottom, kBack, kLights };

struct Transmittance {
    int octaves;
    float weight;
    float norm;  // 1 / (1 + g + g² + ...)

    // Octave o has extinction 2^-o: e^{-τ/2^o} by repeated square roots of e^{-τ}, exact to rounding.
    float operator()(float optical_depth) const {
        float e = std::exp(-optical_depth);
        float sum = e, w = 1.0f;
        for (int o = 1; o < octaves; ++o) {
            e = std::sqrt(e);
            w *= weight;
            sum += w * e;
        }
        return sum * norm;
    }
};

struct Grid {
    int n = 0;   // texels per tile side = voxels along x and y
    int nz = 0;  // voxels along z
    float dxy = 0.0f, dz = 0.0f;
    std::size_t index(int k, int j, int i) const {
        return (std::size_t(k) * std::size_t(n) + std::size_t(j)) * std::size_t(n) + std::size_t(i);
    }
    glm::vec3 centre(int k, int j, int i) const {
        return {-1.0f + (float(i) + 0.5f) * dxy, 1.0f - (float(j) + 0.5f) * dxy, 1.0f - (float(k) + 0.5f) * dz};
    }
};

// Bakes one frame into its tile of both atlases. Scratch grids are reused across frames.
void bake_frame(const SixwayBakeSettings& s, const Grid& g, int frame, SixwayAtlasGrid atlas,
                std::vector<float>& density, std::vector<float>& up, std::vector<float>& down, SixwayBake& out) {
    const float support = s.radius * (1.0f + s.noise_amplitude);
    const Puff puff{s, -float(frame) * s.drift * kDriftDirection, support * support};

    // 1. Density at voxel centres.
    tbb::parallel_for(tbb::blocked_range<int>(0, g.nz * g.n), [&](const tbb::blocked_range<int>& rows) {
        for (int r = rows.begin(); r != rows.end(); ++r) {
            const int k = r / g.n, j = r % g.n;
            for (int i = 0; i < g.n; ++i) density[g.index(k, j, i)] = puff.density(g.centre(k, j, i));
        }
    });

    // 2. Optical depth (density x length, midpoint rule) from each voxel centre to the top and bottom
    //    faces: running sums down and up each column of a slice.
    tbb::parallel_for(tbb::blocked_range<int>(0, g.nz), [&](const tbb::blocked_range<int>& slices) {
        for (int k = slices.begin(); k != slices.end(); ++k) {
            for (int i = 0; i < g.n; ++i) up[g.index(k, 0, i)] = 0.5f * g.dxy * density[g.index(k, 0, i)];
            for (int j = 1; j < g.n; ++j)
                for (int i = 0; i < g.n; ++i)
                    up[g.index(k, j, i)] = up[g.index(k, j - 1, i)] +
                                           0.5f * g.dxy * (density[g.index(k, j - 1, i)] + density[g.index(k, j, i)]);
            const int last = g.n - 1;
            for (int i = 0; i < g.n; ++i) down[g.index(k, last, i)] = 0.5f * g.dxy * density[g.index(k, last, i)];
            for (int j = last - 1; j >= 0; --j)
                for (int i = 0; i < g.n; ++i)
                    down[g.index(k, j, i)] = down[g.index(k, j + 1, i)] +
                                             0.5f * g.dxy * (density[g.index(k, j + 1, i)] + density[g.index(k, j, i)]);
        }
    });

    // 3. March each texel's column front to back (parallel over texel rows).
    const float sigma = s.extinction;
    float weight_sum = 0.0f, w = 1.0f;
    for (int o = 0; o < s.scattering_octaves; ++o, w *= s.scattering_octave_weight) weight_sum += w;
    const Transmittance transmittance{s.scattering_octaves, s.scattering_octave_weight, 1.0f / weight_sum};
    const int tile_x0 = (frame % atlas.columns) * g.n, tile_y0 = (frame / atlas.columns) * g.n;

    tbb::parallel_for(tbb::blocked_range<int>(0, g.n), [&](const tbb::blocked_range<int>& rows) {
        // Per texel of one row: view transmittance, optical depth in front, column total, coverage, and per
        // light the accumulated scattering. Allocated per task, not per texel.
        const auto n = std::size_t(g.n);
        std::vector<float> view_t(n), front(n), column(n), alpha(n), left_od(n), right_od(n);
        std::vector<std::array<float, kLights>> scattered(n);
        for (int j = rows.begin(); j != rows.end(); ++j) {
            std::fill(view_t.begin(), view_t.end(), 1.0f);
            std::fill(front.begin(), front.end(), 0.0f);
            std::fill(column.begin(), column.end(), 0.0f);
            std::fill(alpha.begin(), alpha.end(), 0.0f);
            std::fill(scattered.begin(), scattered.end(), std::array<float, kLights>{});
            for (int k = 0; k < g.nz; ++k)
                for (int i = 0; i < g.n; ++i) column[std::size_t(i)] += density[g.index(k, j, i)] * g.dz;

            for (int k = 0; k < g.nz; ++k) {
                const float* row = &density[g.index(k, j, 0)];
                // Optical depth to the left and right faces along this row of voxels.
                left_od[0] = 0.5f * g.dxy * row[0];
                for (int i = 1; i < g.n; ++i) left_od[std::size_t(i)] = left_od[std::size_t(i) - 1] + 0.5f * g.dxy * (row[i - 1] + row[i]);
                right_od[n - 1] = 0.5f * g.dxy * row[n - 1];
                for (int i = g.n - 2; i >= 0; --i) right_od[std::size_t(i)] = right_od[std::size_t(i) + 1] + 0.5f * g.dxy * (row[i + 1] + row[i]);

                for (int i = 0; i < g.n; ++i) {
                    const auto t = std::size_t(i);
                    const float d = row[i];
                    if (d == 0.0f) continue;  // empty voxel: scatters nothing, attenuates nothing
                    const float half = 0.5f * d * g.dz;
                    const float to_front = front[t] + half;
                    const float to_back = std::max(column[t] - front[t] - half, 0.0f);  // rounding can dip below 0
                    std::array<float, kLights> lit;
                    lit[kRight] = transmittance(sigma * right_od[t]);
                    lit[kTop] = transmittance(sigma * up[g.index(k, j, i)]);
                    lit[kFront] = transmittance(sigma * to_front);
                    lit[kLeft] = transmittance(sigma * left_od[t]);
                    lit[kBottom] = transmittance(sigma * down[g.index(k, j, i)]);
                    lit[kBack] = transmittance(sigma * to_back);
                    // Beer–Lambert through this voxel (thesis eq. 2.10): the share of the view ray it stops
                    // is what it scatters toward the viewer.
                    const float pass = std::exp(-sigma * d * g.dz);
                    const float opacity = view_t[t] * (1.0f - pass);
                    for (int l = 0; l < kLights; ++l) scattered[t][std::size_t(l)] += opacity * lit[std::size_t(l)];
                    alpha[t] += opacity;
                    view_t[t] *= pass;
                    front[t] += d * g.dz;
                }
            }

            for (int i = 0; i < g.n; ++i) {
                const auto t = std::size_t(i);
                const std::uint8_t a8 = unorm8(alpha[t]);
                const bool covered = a8 > 0;  // alpha code 0 <=> light map 0 (sixway_baker.hpp)
                std::uint8_t* p = out.positive.texel(tile_x0 + i, tile_y0 + j);
                std::uint8_t* q = out.negative.texel(tile_x0 + i, tile_y0 + j);
                for (int c = 0; c < 3; ++c) {
                    const auto lp = std::size_t(c), ln = std::size_t(c + 3);
                    p[c] = covered ? unorm8(scattered[t][lp] / alpha[t]) : 0;
                    q[c] = covered ? unorm8(scattered[t][ln] / alpha[t]) : 0;
                }
                p[3] = q[3] = a8;
            }
        }
    });
}

[[noreturn]] void settings_error(const std::string& field, const std::string& problem) {
    throw std::invalid_argument("six-way bake settings: " + field + ": " + problem);
}

void check_range(const char* field, double value, double min, double max) {
    if (!std::isfinite(value) || value < min || value > max)
        settings_error(field, std::to_string(value) + " is outside [" + std::to_string(min) + ", " + std::to_string(max) + "]");
}

}  // namespace

void validate(const SixwayBakeSettings& s) {
    check_range("frames", s.frames, 1, kSixwayMaxBakeFrames);
    check_range("tile", s.tile, 4, kSixwayMaxBakeTile);
    check_range("depth_samples", s.depth_samples, 0, kSixwayMaxBakeTile);
    check_range("radius", s.radius, 0.01, kSixwayMaxPuffExtent);
    check_range("noise_amplitude", s.noise_amplitude, 0.0, 0.99);  // < 1 keeps the centre inside the puff
    check_range("noise_frequency", s.noise_frequency, 0.01, 64.0);
    check_range("noise_octaves", s.noise_octaves, 1, 10);
    check_range("edge_softness", s.edge_softness, 1e-3, 1.0);
    check_range("extinction", s.extinction, 1e-3, 1e3);
    check_range("drift", s.drift, 0.0, 10.0);
    check_range("scattering_octaves", s.scattering_octaves, 1, kSixwayMaxScatteringOctaves);
    check_range("scattering_octave_weight", s.scattering_octave_weight, 0.0, 1.0);
    const float extent = s.radius * (1.0f + s.noise_amplitude);
    if (extent > kSixwayMaxPuffExtent)
        settings_error("radius", "radius * (1 + noise_amplitude) = " + std::to_string(extent) +
                                     " reaches beyond " + std::to_string(kSixwayMaxPuffExtent) +
                                     " of the tile: the puff would be cut at the billboard's edge");
    const SixwayAtlasGrid grid = sixway_grid_for_frames(s.frames);
    if (grid.columns * s.tile > kMaxImageSide || grid.rows * s.tile > kMaxImageSide)
        settings_error("tile", "the atlas would exceed " + std::to_string(kMaxImageSide) + " pixels");
}

SixwayBake bake_sixway(const SixwayBakeSettings& settings) {
    validate(settings);
    SixwayBake bake;
    bake.settings = settings;
    bake.grid = sixway_grid_for_frames(settings.frames);
    bake.positive = Rgba8Image(bake.grid.columns * settings.tile, bake.grid.rows * settings.tile);
    bake.negative = Rgba8Image(bake.positive.width, bake.positive.height);

    Grid g;
    g.n = settings.tile;
    g.nz = settings.depth_samples > 0 ? settings.depth_samples : settings.tile;
    g.dxy = 2.0f / float(g.n);
    g.dz = 2.0f / float(g.nz);
    const std::size_t voxels = std::size_t(g.n) * std::size_t(g.n) * std::size_t(g.nz);
    std::vector<float> density(voxels), up(voxels), down(voxels);
    for (int f = 0; f < settings.frames; ++f) bake_frame(settings, g, f, bake.grid, density, up, down, bake);
    return bake;
}

}  // namespace smoketrace
