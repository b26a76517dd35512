#pragma once
// Contract: every sample bit for bit one_traversal_sample()'s (per_ray_view.hpp), and so within
// kFastVsTextbookTolerance of textbook::camera_ray_color() (tests/test_textbook_frame.cpp).
//
// The tiled compositor (view_compositor.hpp): a block of pixels' camera rays traced together, one sample
// position at a time. Internal to the render layer.
#include "pixel_shading.hpp"

#include <smoketrace/core/image.hpp>
#include <smoketrace/render/camera.hpp>
#include <smoketrace/render/pixel_samples.hpp>
#include <smoketrace/smoke/kernel_bundle_sums.hpp>
#include <smoketrace/trace/trace_tile.hpp>

#include <array>
#include <vector>

namespace smoketrace::view {

// What a thread keeps from tile to tile, so that a tile allocates nothing once the lists have grown.
struct TiledViewScratch {
    TileScratch trace;
    TileResults results;
    std::array<std::vector<Layer>, kTileRays> layers;
    BundleKernelSums shadow_sums;  // a smooth kernel's shadow rays, a bundle at a time
};

// Pixels [x0, x0 + columns) × [y0, y0 + rows) of `image` (at most kTileColumns × kTileRows): every sample
// of `samples` traced as a ray tile, the pixel the mean of its samples, each sample bit for bit the colour
// one_traversal_sample() gives its ray.
void render_tile(const PixelShader& shader, const Camera& camera, const PixelSamples& samples, int x0, int y0,
                 int columns, int rows, ImageRgba& image, TiledViewScratch& scratch);

}  // namespace smoketrace::view
