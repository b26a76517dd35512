// The view pass's entry point (view_compositor.hpp): its kernel, compiled in view_compositor.cpp, run at
// the process's kernel level (core/simd/dispatch.hpp).
#include <smoketrace/core/simd/dispatch.hpp>
#include <smoketrace/render/view_compositor.hpp>

#include <stdexcept>

namespace smoketrace {

void render_view(const SmokeScene& scene, std::span<const Particle> particles, std::span<const float> lengths,
                 const SixwayTexture& texture, const Camera& camera, const ViewSettings& settings, ImageRgba& image) {
    if (!scene.has_billboards() && !particles.empty())
        throw std::invalid_argument("render_view: the scene was built without billboards");
    // Every pixel is written by the kernel: a frame of the same size reuses the buffer (no page faults).
    if (image.width != camera.width() || image.height != camera.height())
        image = ImageRgba(camera.width(), camera.height(), ImageRgba::Uninitialized{});
    simd::at_active_level([&]<simd::Level L> {
        detail::render_view_at_level<L>(scene, particles, lengths, texture, camera, settings, image);
    });
}

}  // namespace smoketrace
