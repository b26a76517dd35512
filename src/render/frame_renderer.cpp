#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/render/pixel_samples.hpp>
#include <smoketrace/smoke/particle_groups.hpp>

#include <stdexcept>
#include <string>
#include <vector>

namespace smoketrace {

RenderOptions RenderOptions::from_scene(const SceneDescription& scene) {
    RenderOptions o;
    o.render = scene.render;
    o.shape = scene.smoke.shape;
    o.kernel = scene.smoke.kernel;
    o.width = int(scene.camera.width);
    o.height = int(scene.camera.height);
    return o;
}

namespace {
std::optional<GroundQuad> ground_of(const SceneDescription& d) {
    if (!d.ground) return std::nullopt;
    return GroundQuad{d.ground->corners};
}
}  // namespace

FrameRenderer::FrameRenderer(const SceneDescription& scene, const RenderOptions& options, const SixwayTexture& texture)
    : desc_(scene), options_(options), texture_(texture), particles_(scene.smoke.particles),
      smoke_(particles_.particles(), options.shape, ground_of(scene), /*billboards=*/true),
      camera_(scene.camera.position, scene.camera.look_at, scene.camera.up, scene.camera.fov_deg, options.width,
              options.height),
      depths_(particles_.size()) {
    if (options.render.groups < 1) throw std::invalid_argument("render: groups must be >= 1");
    if (options.render.spp < 1 || options.render.spp > std::uint32_t(kMaxSpp))
        throw std::invalid_argument("render: spp must be in [1, " + std::to_string(kMaxSpp) + "]");
}

ViewSettings FrameRenderer::view_settings(std::uint64_t frame) const {
    ViewSettings v;
    v.mode = options_.render.mode;
    v.kernel = options_.kernel;
    v.compositing = options_.render.compositing;
    v.compositor = options_.compositor;
    v.sigma_t = desc_.smoke.sigma_t;
    v.alpha = desc_.smoke.alpha;
    v.softness = options_.render.softness;
    v.transmittance_threshold = options_.render.transmittance_threshold;
    v.to_light = desc_.light.direction_at_frame(std::int64_t(frame));
    v.light_color = desc_.light.color;
    v.ambient = desc_.ambient;
    v.background = desc_.background;
    if (desc_.ground) v.ground_color = desc_.ground->color;
    v.flipbook_frame = int(frame % std::uint64_t(texture_.frame_count()));
    v.spp = int(options_.render.spp);
    v.progress = progress_;
    return v;
}

bool FrameRenderer::still_at(std::uint64_t frame) const {
    if (frame == 0 || particles_.moving()) return false;
    return desc_.light.direction_at_frame(std::int64_t(frame)) ==
           desc_.light.direction_at_frame(std::int64_t(frame) - 1);
}

bool FrameRenderer::advance_to(std::uint64_t frame, bool trace_depths, FrameReport& report) {
    FrameTimings& t = report.timings;
    StageClock clock;
    const bool first = frame == 0;
    const bool moved = !first && particles_.moving();
    if (moved) particles_.advance(1);
    const glm::vec3 light = desc_.light.direction_at_frame(std::int64_t(frame));
    const bool light_turned = first || light != last_light_;
    last_frame_ = std::int64_t(frame);
    last_light_ = light;
    const bool still = !first && !moved && !light_turned;
    if (still) return true;

    if (progress_) progress_->begin("TLAS update", 0);
    report.tlas = smoke_.update(particles_.particles(), camera_.position());
    t.tlas_update = clock.lap_ms(t.usage.tlas_update);
    if (trace_depths && options_.render.mode != RenderMode::basic) {
        // The first frame traces every particle so that none starts without a value; after that, one
        // group per frame (thesis 4.4.2).
        const std::uint32_t groups = first ? 1 : options_.render.groups;
        const auto which = particle_group(particles_.size(), groups, frame);
        OpticalDepthSettings ods;
        ods.cutoff = options_.render.cutoff;
        ods.progress = progress_;
        ods.kernel = options_.kernel;
        depths_.update(smoke_, particles_.particles(), which, light, ods, options_.sort, t);
        report.depths_updated = which.size();
    }
    return false;
}

void FrameRenderer::skip_to(std::uint64_t frame) {
    const auto from = std::uint64_t(last_frame_ + 1);
    if (frame < from) throw std::logic_error("FrameRenderer: cannot skip back to an earlier frame");
    // Which skipped frames' optical depths are still in use at `frame`: walking back from frame - 1, a
    // frame that traces (not a still one) sets its group's values unless a later one already has; frame 0
    // sets every group's. Only those frames trace; the others advance the particles and the TLAS alone,
    // so the TLAS's refit-or-rebuild history is the full run's too.
    const std::uint32_t groups = options_.render.groups;
    std::vector<bool> traces(frame - from, false), covered(groups, false);
    std::uint32_t uncovered = groups;
    for (std::uint64_t f = frame; f-- > from && uncovered > 0;) {
        if (still_at(f)) continue;
        if (f == 0) {
            traces[0] = true;
            break;
        }
        const auto g = std::uint32_t(f % groups);
        if (covered[g]) continue;
        covered[g] = true;
        --uncovered;
        traces[f - from] = true;
    }
    for (std::uint64_t f = from; f < frame; ++f) {
        FrameReport ignored;
        advance_to(f, traces[f - from], ignored);
    }
}

FrameReport FrameRenderer::render(std::uint64_t frame, ImageRgba& image) {
    if (std::int64_t(frame) != last_frame_ + 1) throw std::logic_error("FrameRenderer: frames must be rendered in order");
    FrameReport report;
    FrameTimings& t = report.timings;
    StageClock total;

    // Work is skipped only where its inputs did not change. Still particles and a still light leave the
    // TLAS and the optical depths as they were; the view is redrawn unless its flipbook frame is also the
    // one already in `image` (the billboards animate even when nothing moves).
    const bool still = advance_to(frame, true, report);
    const int flipbook_frame = int(frame % std::uint64_t(texture_.frame_count()));
    if (still && flipbook_frame == last_flipbook_frame_ && image.width == options_.width &&
        image.height == options_.height) {
        report.reused_previous = true;
        t.total = total.lap_ms(t.usage.total);
        return report;
    }
    StageClock clock;

    const ViewSettings v = view_settings(frame);
    render_view(smoke_, particles_.particles(), depths_.lengths(), texture_, camera_, v, image);
    t.view = clock.lap_ms(t.usage.view);
    last_flipbook_frame_ = flipbook_frame;
    t.total = total.lap_ms(t.usage.total);
    return report;
}

}  // namespace smoketrace
