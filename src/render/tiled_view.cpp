// The tiled compositor, see tiled_view.hpp and view_compositor.hpp.
//
// Per sample position, four steps over the tile's rays, each the one_traversal compositor's step for every
// ray of the tile at once:
//  1. the opaque surface: trace_tile() with the opaque view mask, closest hit;
//  2. the billboards strictly in front of it: trace_tile() with one LayerCollector per ray, near to far, so
//     that a pixel gone opaque stops meeting the billboards behind;
//  3. each pixel's layers sorted and composited, colours looked up only for the layers reached;
//  4. the ground seen through what is left: its shadow rays all go toward the one light, so they are
//     parallel and go to trace_bundle() thirty-two at a time (under a smooth kernel each bundle's exits
//     are integrated together after its walk, BundleKernelSums).
// trace_tile() and trace_bundle() give each ray exactly what trace() gives it alone, so every sample is
// bit for bit the per-ray compositor's (tests/test_view_compositor.cpp).
#include "tiled_view.hpp"

#include <smoketrace/trace/trace_bundle.hpp>

#include <array>
#include <cmath>
#include <limits>
#include <span>

namespace smoketrace::view {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

struct AcceptEvery {
    AnyHitDecision operator()(unsigned, const TraceHit&) const { return AnyHitDecision::accept; }
};

}  // namespace

void render_tile(const PixelShader& shader, const Camera& camera, const PixelSamples& samples, int x0, int y0,
                 int columns, int rows, ImageRgba& image, TiledViewScratch& scratch) {
    const ViewSettings& s = shader.settings();
    const AccelScene& scene = shader.scene().scene();
    const std::span<const Particle> particles = shader.particles();
    glm::vec3 sum[kTileRays];
    for (int i = 0; i < samples.count(); ++i) {
        RayTile tile = camera.tile(x0, y0, columns, rows, samples[i], kViewRayTmin);
        // 1. The opaque surface.
        trace_tile(scene, tile, ray_flag_force_opaque, kOpaqueViewMask, AcceptEvery{}, scratch.results, scratch.trace);
        float t_opaque[kTileRays];
        for (unsigned lane = 0; lane < kTileRays; ++lane) {
            const bool hit = scratch.results.hit(lane);
            t_opaque[lane] = hit ? scratch.results.t(lane) : kInf;
            tile.set_tmax(lane, hit ? std::nextafter(t_opaque[lane], 0.0f) : kInf);  // layers strictly in front
        }
        // 2. The billboards in front of it.
        LayerCollector collectors[kTileRays];
        for (unsigned lane = 0; lane < kTileRays; ++lane)
            collectors[lane] = LayerCollector(shader, scratch.layers[lane], t_opaque[lane]);
        trace_tile(scene, tile, ray_flag_force_non_opaque, kBillboardMask,
                   [&](unsigned lane, const TraceHit& h) { return collectors[lane](h); }, scratch.results,
                   scratch.trace);
        // 3. The layers, front to back; 4. the ground behind them, its shadow rays in bundles.
        PixelCompositor comps[kTileRays];
        float shadow[kTileRays];
        unsigned shadow_lane[kBundleWidth];
        RayBundle bundle(s.to_light);
        auto flush = [&] {
            if (shader.shadow_sums_kernel()) {
                // Every stand-in each ray leaves, summed (pixel_shading.hpp, kernel_bundle_sums.hpp).
                BundleKernelSums& sums = scratch.shadow_sums;
                sums.clear();
                trace_bundle(scene, bundle, shader.shadow_ray_flags(), kStandInMask,
                             [&](unsigned b, const TraceHit& h) {
                                 if (!h.front_face()) sums.add_exit(b, h.instance_id, particles);
                                 return AnyHitDecision::ignore;
                             });
                std::array<double, kBundleWidth> l;
                sums.integrate(s.kernel, shader.light_unit(), bundle, particles, bundle.lanes(), l);
                for (unsigned b = 0; b < bundle.count; ++b) shadow[shadow_lane[b]] = shader.kernel_shadow(float(l[b]));
            } else {
                const BundleResults r =
                    trace_bundle(scene, bundle, shader.shadow_ray_flags(), kStandInMask, AcceptEvery{});
                for (unsigned b = 0; b < bundle.count; ++b) shadow[shadow_lane[b]] = shader.shadow(r[b]);
            }
            bundle = RayBundle(s.to_light);
        };
        bool sees_background[kTileRays];
        for (int r = 0; r < rows; ++r)
            for (int c = 0; c < columns; ++c) {
                const unsigned lane = RayTile::lane(unsigned(c), unsigned(r));
                comps[lane] = PixelCompositor(s);
                sees_background[lane] = composite_layers(shader, scratch.layers[lane], comps[lane]);
                shadow[lane] = 1.0f;
                if (sees_background[lane] && t_opaque[lane] < kInf && shader.ground_needs_shadow_ray()) {
                    // The per-ray compositor's shadow ray origin: ray.origin + t·ray.direction.
                    shadow_lane[bundle.count] = lane;
                    bundle.add(tile.origin() + t_opaque[lane] * tile.direction(lane), kShadowRayTmin);
                    if (bundle.full()) flush();
                }
            }
        if (bundle.count != 0) flush();
        for (int r = 0; r < rows; ++r)
            for (int c = 0; c < columns; ++c) {
                const unsigned lane = RayTile::lane(unsigned(c), unsigned(r));
                const glm::vec3 background = t_opaque[lane] < kInf ? shader.ground_color(shadow[lane]) : s.background;
                const glm::vec3 color = comps[lane].finish(sees_background[lane] ? background : glm::vec3(0.0f));
                // Summed in sample order and divided once, as the per-ray loop does (view_compositor.cpp).
                sum[lane] = i == 0 ? color : sum[lane] + color;
            }
    }
    for (int r = 0; r < rows; ++r)
        for (int c = 0; c < columns; ++c)
            image.at(x0 + c, y0 + r) =
                glm::vec4(sum[RayTile::lane(unsigned(c), unsigned(r))] / float(samples.count()), 1.0f);
}

}  // namespace smoketrace::view
