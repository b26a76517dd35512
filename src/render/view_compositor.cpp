// The view pass (thesis 4.3.5), see view_compositor.hpp: the image split into 16×16 blocks of pixels, the
// blocks shared among the threads, each block drawn by the chosen compositor. A kernel source, compiled
// once per kernel level (core/simd/dispatch.hpp); render_view() chooses the level in
// view_compositor_dispatch.cpp.
#include <smoketrace/render/pixel_samples.hpp>
#include <smoketrace/render/view_compositor.hpp>

#include "per_ray_view.hpp"
#include "pixel_shading.hpp"
#include "tiled_view.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <memory>
#include <vector>

namespace smoketrace {
namespace {

// A block of pixels: the tiled compositor's ray tile, and the unit of work shared among threads. The smoke
// covers part of the image and its blocks cost many times a block of sky; TBB's work stealing hands the
// blocks out a few at a time, so no thread waits on another's expensive region.
constexpr int kBlockColumns = int(kTileColumns), kBlockRows = int(kTileRows);
static_assert(kBlockColumns <= int(kTileColumns) && kBlockRows <= int(kTileRows));

struct Scratch {
    std::vector<view::Layer> layers;                        // the per-ray compositor's
    std::unique_ptr<view::TiledViewScratch> tiled;          // made by the first tiled block a thread draws
};

}  // namespace

template <simd::Level L>
void detail::render_view_at_level(const SmokeScene& scene, std::span<const Particle> particles,
                                  std::span<const float> lengths, const SixwayTexture& texture,
                                  const Camera& camera, const ViewSettings& settings, ImageRgba& image) {
    static_assert(L == simd::kCompiledLevel);
    const PixelSamples samples(settings.spp);
    const view::PixelShader shader(scene, particles, lengths, texture, settings);
    tbb::enumerable_thread_specific<Scratch> scratch;
    const int blocks_x = (camera.width() + kBlockColumns - 1) / kBlockColumns;
    const int blocks_y = (camera.height() + kBlockRows - 1) / kBlockRows;
    if (settings.progress) settings.progress->begin("view", std::uint64_t(camera.width()) * camera.height());
    tbb::parallel_for(0, blocks_x * blocks_y, [&](int block) {
        Scratch& local = scratch.local();
        const int x0 = (block % blocks_x) * kBlockColumns, y0 = (block / blocks_x) * kBlockRows;
        const int x1 = std::min(x0 + kBlockColumns, camera.width()), y1 = std::min(y0 + kBlockRows, camera.height());
        // Counted as the block begins, once per block of 16x16 pixels: the count is for a display.
        if (settings.progress) settings.progress->add(std::uint64_t(x1 - x0) * std::uint64_t(y1 - y0));
        if (settings.compositor == CompositorKind::tiled) {
            if (!local.tiled) local.tiled = std::make_unique<view::TiledViewScratch>();
            view::render_tile(shader, camera, samples, x0, y0, x1 - x0, y1 - y0, image, *local.tiled);
            return;
        }
        for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x) {
                // Summed in sample order and divided once: the same bits on any thread. With one sample the
                // offset is (0.5, 0.5), the ray is camera.ray(x, y) and 0 + c, c / 1 leave its colour as it is.
                // x + offset rounds by at most 2^-11 (x < 2^14) and the offsets keep 1/(2·spp) >= 2^-7 from
                // the pixel's sides, so a sample never leaves its pixel.
                glm::vec3 sum(0.0f);
                for (int i = 0; i < samples.count(); ++i) {
                    const glm::vec2 o = samples[i];
                    const Ray ray = camera.ray_through(float(x) + o.x, float(y) + o.y, kViewRayTmin);
                    sum += settings.compositor == CompositorKind::one_traversal
                               ? view::one_traversal_sample(shader, ray, local.layers)
                               : view::retrace_sample(shader, ray);
                }
                image.at(x, y) = glm::vec4(sum / float(samples.count()), 1.0f);
            }
    });
}

// This copy's kernel (core/simd/dispatch.hpp); render_view() is in view_compositor_dispatch.cpp.
template void detail::render_view_at_level<simd::kCompiledLevel>(const SmokeScene&, std::span<const Particle>,
                                                                 std::span<const float>, const SixwayTexture&,
                                                                 const Camera&, const ViewSettings&, ImageRgba&);

}  // namespace smoketrace
