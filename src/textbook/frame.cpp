// The textbook frame, the loop (thesis 4.3): see frame.hpp.
#include <smoketrace/textbook/frame.hpp>

#include <smoketrace/render/pixel_samples.hpp>
#include <smoketrace/smoke/particle_groups.hpp>
#include <smoketrace/textbook/compositor.hpp>
#include <smoketrace/textbook/optical_depth.hpp>

#include <tbb/parallel_for.h>

#include <optional>
#include <stdexcept>
#include <string>

namespace smoketrace::textbook {
namespace {

std::optional<GroundQuad> ground_of(const SceneDescription& d) {
    if (!d.ground) return std::nullopt;
    return GroundQuad{d.ground->corners};
}

}  // namespace

FrameOptions FrameOptions::from_scene(const SceneDescription& scene) {
    FrameOptions o;
    o.render = scene.render;
    o.shape = scene.smoke.shape;
    o.kernel = scene.smoke.kernel;
    o.width = int(scene.camera.width);
    o.height = int(scene.camera.height);
    return o;
}

FrameLoop::FrameLoop(const SceneDescription& scene, const FrameOptions& options, const SixwayTexture& texture)
    : desc_(scene), options_(options), texture_(texture), particles_(scene.smoke.particles),
      scene_(particles_.particles(), options.shape, ground_of(scene), /*billboards=*/true),
      camera_(scene.camera.position, scene.camera.look_at, scene.camera.up, scene.camera.fov_deg, options.width,
              options.height),
      lengths_(particles_.size(), 0.0f) {
    if (options.render.groups < 1) throw std::invalid_argument("render: groups must be >= 1");
    if (options.render.spp < 1 || options.render.spp > std::uint32_t(kMaxSpp))
        throw std::invalid_argument("render: spp must be in [1, " + std::to_string(kMaxSpp) + "]");
    validate(options.kernel);
}

ViewParameters FrameLoop::view_parameters(std::uint64_t frame) const {
    ViewParameters v;
    v.mode = options_.render.mode;
    v.kernel = options_.kernel;
    v.compositing = options_.render.compositing;
    v.sigma_t = desc_.smoke.sigma_t;
    v.alpha = desc_.smoke.alpha;
    v.softness = options_.render.softness;
    v.transmittance_threshold = options_.render.transmittance_threshold;
    v.to_light = glm::dvec3(desc_.light.direction_at_frame(std::int64_t(frame)));
    v.light_color = glm::dvec3(desc_.light.color);
    v.ambient = glm::dvec3(desc_.ambient);
    v.background = glm::dvec3(desc_.background);
    if (desc_.ground) v.ground_color = glm::dvec3(desc_.ground->color);
    v.flipbook_frame = int(frame % std::uint64_t(texture_.frame_count()));
    v.spp = int(options_.render.spp);
    return v;
}

void FrameLoop::advance_to(std::uint64_t frame) {
    while (frame_ < std::int64_t(frame)) {
        const std::uint64_t f = std::uint64_t(++frame_);
        if (f > 0) particles_.advance(1);
        // The instances follow the particles, the billboards turn to face the camera (4.3, "TLAS update").
        scene_.update(particles_.particles(), camera_.position());
        if (options_.render.mode == RenderMode::basic) continue;  // no optical depth at all
        // The first frame gives every particle its value; after that one group per frame (4.4.2), the
        // others keeping theirs.
        const auto group = particle_group(particles_.size(), f == 0 ? 1 : options_.render.groups, f);
        const OpticalDepths d = optical_depths(scene_, particles_.particles(), group,
                                               desc_.light.direction_at_frame(std::int64_t(f)),
                                               options_.render.cutoff, options_.kernel);
        for (std::size_t k = 0; k < group.size(); ++k) lengths_[group[k]] = d.lengths[k];
    }
}

void FrameLoop::render(std::uint64_t frame, ImageRgba& image) {
    if (std::int64_t(frame) <= frame_) throw std::logic_error("textbook::FrameLoop: frames must come in order");
    advance_to(frame);
    const ViewParameters view = view_parameters(frame);
    const Shading shading(scene_, particles_.particles(), lengths_, texture_, view);
    const PixelSamples samples(view.spp);
    image = ImageRgba(camera_.width(), camera_.height());
    // Rows in parallel: each pixel depends on its own rays alone, so any split gives the same image.
    tbb::parallel_for(0, camera_.height(), [&](int y) {
        for (int x = 0; x < camera_.width(); ++x) {
            // The pixel: the plain mean of its samples (a box filter), at the points of pixel_samples.hpp.
            glm::dvec3 sum(0.0);
            for (int i = 0; i < samples.count(); ++i) {
                const glm::vec2 o = samples[i];
                sum += camera_ray_color(shading, camera_.ray_through(float(x) + o.x, float(y) + o.y, kCameraRayTmin));
            }
            image.at(x, y) = glm::vec4(glm::vec3(sum / double(samples.count())), 1.0f);
        }
    });
}

}  // namespace smoketrace::textbook
