// The six-way flipbook baker (see sixway_baker.hpp for the model).
#include <smoketrace/render/sixway_baker.hpp>
#include <smoketrace/render/puff_density.hpp>

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

// ---- Light transport ------------------------------------------------------------------------------

// Channel order of the per-texel accumulators: positive R, G, B, then negative R, G, B.
enum Light : int { kRight, kTop, kFront, kLeft, kBottom, kBack, kLights };

// Bakes one frame into its tile of both atlases. Scratch grids are reused across frames.
void bake_frame(const SixwayBakeSettings& s, const PuffVoxels& g, int frame, SixwayAtlasGrid atlas,
                std::vector<float>& density, std::vector<float>& up, std::vector<float>& down, SixwayBake& out) {
    // 1. Density at voxel centres.
    sample_puff_density(s, g, frame, density);

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
    const OctaveTransmittance transmittance(s);
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

    const PuffVoxels g(settings);
    const std::size_t voxels = g.count();
    std::vector<float> density(voxels), up(voxels), down(voxels);
    for (int f = 0; f < settings.frames; ++f) bake_frame(settings, g, f, bake.grid, density, up, down, bake);
    return bake;
}

}  // namespace smoketrace
