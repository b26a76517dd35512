#pragma once
// The ground truth of a frame (docs/ground-truth.md): the smoke the frame depicts, rendered as a volume and
// converged to a stated tolerance, so that every approximation of the thesis can be measured against it.
//
// The volume: every particle is the six-way baker's puff (render/puff_density.hpp) as a 3D density, sampled
// at the bake's voxel centres and interpolated trilinearly, placed in its billboard's tangent frame (half-side
// = radius, spin included) at its billboard's flipbook frame; σ(x) = σt · Σ_i ρ_i(x).
// The light transport is the baker's, over the whole field: emission–absorption plus single scattering of the
// directional light (isotropic, albedo 1), the baker's multiple-scattering octaves T_ms(τ) for the light that
// reaches a sample, the scene's ambient term, and the ground lit by the light the field lets through:
//     L = ∫ T_view(s) σ(s) [c_light T_ms(τ_light(s)) + c_amb] ds + T_view(end) · B.
// Puffs are found with the project's TLAS (their sphere stand-ins bound them). τ_light comes from a light
// optical-depth volume (a deep shadow map along the one light direction) whose interpolation error is
// estimated per sample against its every-other-node subgrid; where a pixel's estimates add up to more than
// its share of the tolerance, its largest ones are replaced by exact light rays. Camera rays halve their
// step until the pixel settles.
#include <smoketrace/core/image.hpp>
#include <smoketrace/core/simd/level.hpp>
#include <smoketrace/core/work_progress.hpp>
#include <smoketrace/smoke/scene_description.hpp>
#include <smoketrace/render/sixway_baker.hpp>
#include <smoketrace/truth/puff_volume.hpp>

#include <glm/vec3.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace smoketrace {

struct TruthSettings {
    // Per pixel and channel, linear radiance: half an 8-bit step of a linear image (1/255 · 1/2), so a
    // converged truth and the exact one round to the same or adjacent bytes; error studies measure RMSE
    // of the order of 1/100 and above, far above it.
    float tolerance = 1.0f / 512.0f;
    // Pixel footprint samples at the points of pixel_samples.hpp: the truth of a frame is its pixel's box-filtered
    // mean, so a frame rendered with spp N is measured against an anti-aliased image.
    int spp = 16;
    // Halvings of the camera rays' step beyond the first (step_voxels voxels): 7 reach 1/64 of a voxel, where
    // the piecewise-trilinear density is integrated far below any tolerance worth asking.
    int max_view_levels = 7;
    // The camera rays' first step, in voxels of the smallest puff (the density's own scale).
    float step_voxels = 2.0f;
    // The light volume's node spacing, in voxels of the smallest puff. Exact light rays mop up where its
    // interpolation is not good enough, so this trades the volume's build against the rays taken; 2 voxels
    // is the fastest at 256² on the shipped scenes (docs/ground-truth.md).
    float light_spacing_voxels = 2.0f;
    // The ladder's own light volumes (render_ladder(): one per puff, its density alone): their node spacing in
    // voxels of the puff.
    float own_light_spacing_voxels = 4.0f;
    // The most memory the light volume may take (floats of τ); above it the spacing is doubled until it fits,
    // and more samples take exact light rays.
    std::size_t light_volume_max_bytes = std::size_t(1) << 30;
};

struct TruthReport {
    double seconds = 0;                    // wall time of render()
    double light_seconds = 0;              // of which building the light volume
    float max_error_estimate = 0;          // the largest per-pixel error estimate (view steps + light)
    std::uint64_t unconverged_pixels = 0;  // pixels that hit the step-level limit above their share
    float view_error_estimate = 0;         // the largest step-halving change of a pixel at its last level
    float light_error_estimate = 0;        // the largest light estimate of a pixel (volume + exact rays)
    float light_volume_error_estimate = 0; // the largest a pixel's light estimate would be with the volume alone
    int view_levels_used = 0;              // the deepest step level any pixel needed (0 = the first step)
    int light_columns_u = 0, light_columns_v = 0, light_nodes_w = 0;  // the light volume's grid
    float light_spacing = 0;               // its node spacing, world units
    std::uint64_t camera_samples = 0;      // density samples taken along camera rays, all levels
    std::uint64_t light_samples = 0;       // of those (and ground points) lit, at each pixel's last level
    std::uint64_t exact_light_samples = 0; // of those, shaded with an exact light ray instead of the volume
    std::uint64_t exact_light_pixels = 0;  // pixels with at least one exact light ray
    // Per pixel (width*height, row 0 at the top): its error estimate (view steps + light), and whether it hit
    // the step-level limit with the estimate above its share of the tolerance. An error map for the error
    // study, and what tests hold the bound to.
    std::vector<float> pixel_error_estimate;
    std::vector<std::uint8_t> pixel_unconverged;
};

// The thesis's approximations of the light, put into the volume one at a time: each rung keeps the volume
// (the same puffs, camera rays and opacities as the truth) and every approximation of the rungs before it,
// and adds one more (docs/ground-truth.md, "The ladder"). What an approximation costs is the difference
// between its rung and the one before; the frame drawn with the true optical depths (billboards instead of the
// volume) is the next rung, the frame itself (the stand-ins' optical depths) the last. Per puff i and sample x:
enum class TruthRung : std::uint8_t {
    // (b) One transmittance per particle: the light the other puffs let through is taken once per particle,
    // at its centre: T_ms(τ_own(x) + τ_others(c_i)); the ground's shadow is the nearest particle's e^{-τ(c)}
    // (eq. 4.3 with the true τ), as the frame shades both.
    one_transmittance,
    // Eq. 4.2's form: the puff's own light map times the particle's one transmittance from its centre,
    // T_ms(τ_own(x)) · e^{-τ(c_i)} (the own puff's near half counted in both, as the frame counts it).
    light_map,
    // (d) Six axis lights: the own light map lit from the six axis directions of the billboard's tangent frame
    // and blended as the six-way texture is (h·lx² + v·ly² + d·lz², eq. 4.2's light map), still at σt.
    six_axis,
    // The six-way bake's density: the same light map with the self-shadow of the bake's extinction (7 per
    // half-width in the shipped textures) instead of σt·radius: the light map the textures carry.
    bake_extinction,
};
inline constexpr int kTruthRungs = 4;
[[nodiscard]] const char* to_string(TruthRung r);

struct LadderReport {
    double seconds = 0;
    float view_error_estimate = 0;         // the largest step-halving change of a pixel of any rung, last level
    std::uint64_t unconverged_pixels = 0;  // pixels that hit the step-level limit with a change above half the tolerance
    int view_levels_used = 0;
    std::uint64_t camera_samples = 0;
    // The largest per-pixel estimate of the own light volumes' interpolation error (each lit sample's light change
    // between the grid and its every-other-node subgrid, weighted as it enters the pixel, as render() estimates
    // its light volume's); an estimate, not mended by exact rays.
    float own_light_error_estimate = 0;
};

// render()'s image checked against pixel() (every light ray exact) at a sample of pixels (GroundTruth::check()).
struct TruthCheck {
    std::uint64_t pixels = 0;        // pixels checked
    float largest_difference = 0;    // the largest |render() − pixel()| of a channel
    int x = -1, y = -1;              // where
    float estimate_there = 0;        // render()'s error estimate of that pixel
    std::uint64_t above_tolerance = 0;  // pixels whose difference exceeds the tolerance
    std::uint64_t above_estimate = 0;   // pixels whose difference exceeds their estimate + half the tolerance
    double seconds = 0;
};

class GroundTruth {
public:
    // The smoke of frame `frame` of `scene` (particles advanced as FrameRenderer advances them) seen by the
    // scene's camera at width x height; `puff` = the bake settings of the scene's six-way textures.
    GroundTruth(const SceneDescription& scene, const SixwayBakeSettings& puff, std::uint64_t frame, int width,
                int height, const TruthSettings& settings = {});
    // The same with given densities, one per flipbook frame (tests: a uniform ball, a uniform cube);
    // `scattering` gives the light's multiple-scattering octaves (scattering_octaves 1: plain e^{-τ}).
    GroundTruth(const SceneDescription& scene, const SixwayBakeSettings& scattering, std::vector<PuffVolume> flipbook,
                std::uint64_t frame, int width, int height, const TruthSettings& settings = {});
    ~GroundTruth();
    GroundTruth(const GroundTruth&) = delete;
    GroundTruth& operator=(const GroundTruth&) = delete;

    // The image, linear radiance, alpha 1; rows and pixel centres as the frame renderer's (row 0 at the top).
    TruthReport render(ImageRgba& image, WorkProgress* progress = nullptr) const;
    // The rungs of the ladder (TruthRung), images[r] for rung r, linear radiance like render()'s; camera steps
    // halved per pixel until every rung's pixel changes by less than half the tolerance. The rungs need no
    // light volume of the whole field: their light is the own puff's (a light volume of that puff alone, or its
    // six axis depths) and one exact τ per particle.
    LadderReport render_ladder(std::array<ImageRgba, kTruthRungs>& images, WorkProgress* progress = nullptr) const;
    // One pixel, its light rays traced exactly (no light volume): the reference render() is tested against,
    // and what `explain --pixel` can show beside a frame's pixel.
    [[nodiscard]] glm::vec3 pixel(int x, int y) const;
    // render()'s `image` (and its `report`) against pixel() at the centre pixel of every stride × stride block:
    // a check of the bound on a sample of pixels (pixel() is converged to half the tolerance itself, so a
    // difference up to the estimate plus half the tolerance is within both bounds). Parallel over the pixels.
    [[nodiscard]] TruthCheck check(const ImageRgba& image, const TruthReport& report, int stride,
                                   WorkProgress* progress = nullptr) const;
    // τ from each particle's centre to the light, exact light rays (the thesis's l also starts at the centre
    // and counts its own sphere's exit): each puff's integral exact up to rounding (PuffVolume::integrate).
    [[nodiscard]] std::vector<double> particle_optical_depths() const;
    // 1 where the pixel centre's camera ray reaches the ground and the ground point's light ray meets a puff's
    // sphere (the region the ground-shadow error is measured in), else 0; width*height, row 0 at the top.
    [[nodiscard]] std::vector<std::uint8_t> ground_shadow_mask() const;

    [[nodiscard]] int width() const;
    [[nodiscard]] int height() const;

private:
    // The members above that do the work, at one kernel level (core/simd/dispatch.hpp): ground_truth.cpp,
    // compiled once per level, instantiates each for the level it is compiled for; the public members
    // (ground_truth_dispatch.cpp) run them at the process's level.
    template <simd::Level L>
    TruthReport render_at_level(ImageRgba& image, WorkProgress* progress) const;
    template <simd::Level L>
    LadderReport render_ladder_at_level(std::array<ImageRgba, kTruthRungs>& images, WorkProgress* progress) const;
    template <simd::Level L>
    glm::vec3 pixel_at_level(int x, int y) const;
    template <simd::Level L>
    TruthCheck check_at_level(const ImageRgba& image, const TruthReport& report, int stride,
                              WorkProgress* progress) const;
    template <simd::Level L>
    std::vector<double> particle_optical_depths_at_level() const;
    template <simd::Level L>
    std::vector<std::uint8_t> ground_shadow_mask_at_level() const;

    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace smoketrace
