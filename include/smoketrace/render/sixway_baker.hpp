#pragma once
// Bakes the six-way lighting flipbook (thesis 4.2.2; the thesis's own textures were a studio's and are not
// available): a procedural smoke puff, rendered orthographically along -z (the billboard faces the viewer
// at +z) and lit in turn by six lights, +x, +y, +z into the positive atlas's R, G, B and -x, -y, -z into
// the negative atlas's; alpha is the puff's coverage along the view ray, A = 1 - T.
//
// The puff lives in the cube [-1, 1]³ of tangent space (x right, y up, z toward the viewer), the tile
// spanning x, y in [-1, 1]. Its density is a ball whose radius is displaced by fractal gradient noise:
//     inside(p) = 1 - |p| / radius + noise_amplitude · fbm(p · noise_frequency - frame · drift · dir)
//     density(p) = smoothstep(0, edge_softness, inside(p))         (0 outside, 1 in the core)
// fbm is "billowy" (each octave 2·|noise| - 1, creased between rounded lobes) and clamped to [-1, 1],
// so density is exactly zero beyond radius · (1 + noise_amplitude), which must stay inside the tile:
// alpha is then 0 along the whole tile border and a billboard's edge never shows. Successive frames
// slide the noise field along dir (up and toward the viewer), so the puff churns slowly.
//
// Radiative transfer: the cube is sampled on a tile x tile x depth_samples grid of voxels, one column per
// texel. Along each column the view ray is marched front to back with Beer–Lambert attenuation
// (thesis eq. 2.10); each voxel scatters light toward the viewer in proportion to its opacity
// 1 - exp(-σ·ρ·Δz) and to the light's transmittance from that voxel. The six lights are axis-aligned, so
// the optical depth toward each is a running sum along one grid axis (exact for this grid, no secondary
// ray march). Multiple scattering is approximated by summing octaves of the transmittance with ever
// smaller extinction (e^{-τ} + g·e^{-τ/2} + g²·e^{-τ/4} + ..., normalised; Wrenninge 2013): real
// smoke's far side is dim, not pitch black.
//
// Stored values (linear 8-bit DATA, not sRGB; see sixway_texture.hpp): light map = scattered light /
// alpha, the opacity-weighted mean transmittance of the light along the texel's column, so that shading
// with light_map · light colour · alpha (thesis 4.3.5) gives back the scattered light. Texels whose
// alpha rounds to 0 store light map 0 (no smoke, no light): the atlases then view as the puff on black.
// Bilinear filtering blends that 0 into the colour only next to such texels, where the filtered alpha is
// itself a few 1/255 steps at most, so the darkening is invisible.
//
// Deterministic: own integer-hashed noise (no std random), every texel computed by the same sequence of
// float operations whatever thread runs it (TBB over rows), so the bytes do not depend on thread count.
#include <smoketrace/core/image.hpp>
#include <smoketrace/render/sixway_texture.hpp>

#include <cstdint>
#include <filesystem>

namespace smoketrace {

// radius · (1 + noise_amplitude) may be at most this (tile half-widths). The border texels' centres lie
// at 1 - 1/tile or further from the centre, outside the puff for tiles of 21 texels or more, so their
// alpha is exactly 0 and a billboard's edge (where sampling clamps to them) never shows.
inline constexpr float kSixwayMaxPuffExtent = 0.95f;
inline constexpr int kSixwayMaxBakeTile = 256;     // three float grids of tile²·depth voxels: 200 MB at 256
inline constexpr int kSixwayMaxBakeFrames = 256;   // twice the thesis's 128
inline constexpr int kSixwayMaxScatteringOctaves = 4;

struct SixwayBakeSettings {
    int frames = 16;                  // flipbook frames (laid out by sixway_grid_for_frames: 16 -> 4x4)
    int tile = 128;                   // tile side in texels; the atlas is columns·tile x rows·tile
    int depth_samples = 0;            // voxels along the view ray; 0 = tile (cubic voxels)
    std::uint32_t seed = 1;           // noise seed: a different seed gives a different puff
    float radius = 0.68f;             // ball radius before displacement, in tile half-widths
    float noise_amplitude = 0.39f;    // radius displacement by fbm in [-1, 1], relative to radius
    float noise_frequency = 1.8f;     // lattice cells per tile half-width at the first octave
    int noise_octaves = 4;            // fbm octaves, each at twice the frequency and half the amplitude
    float edge_softness = 0.3f;       // density ramps 0 -> 1 over this much of "inside" (relative radius)
    float extinction = 7.0f;          // σt at full density, per tile half-width: alpha ~0.999 at the centre
    float drift = 0.05f;              // noise-space distance the field slides per frame
    int scattering_octaves = 3;       // 1 = single scattering only
    float scattering_octave_weight = 0.5f;  // g: weight of each further octave
};

// Throws std::invalid_argument naming the field and the problem.
void validate(const SixwayBakeSettings& settings);

struct SixwayBake {
    SixwayBakeSettings settings;
    SixwayAtlasGrid grid;
    Rgba8Image positive;  // R: +x, G: +y, B: +z, A: alpha
    Rgba8Image negative;  // R: -x, G: -y, B: -z, A: alpha
};

[[nodiscard]] SixwayBake bake_sixway(const SixwayBakeSettings& settings);

// Files: write_sixway_bake() (io/sixway_files.hpp).

}  // namespace smoketrace
