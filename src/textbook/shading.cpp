// The textbook frame, shading (thesis 4.2.2, 4.3.5, eqs. 4.2–4.4): see shading.hpp.
#include <smoketrace/textbook/shading.hpp>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace smoketrace::textbook {

double transmittance(double l, double sigma_t) { return sigma_t == 0.0 ? 1.0 : std::exp(-l * sigma_t); }

Shading::Shading(const SmokeScene& scene, std::span<const Particle> particles, std::span<const float> lengths,
                 const SixwayTexture& texture, const ViewParameters& view)
    : scene_(scene), particles_(particles), texture_(texture), view_(view) {
    validate(view.kernel);
    // Once per particle and frame: the light in its billboard's tangent space (the columns of the billboard
    // instance's transform are its x, y and z axes, smoke_scene.hpp), its flipbook frame, its darkening.
    const std::size_t n = particles.size();
    billboards_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        const glm::dmat3 axes = scene.scene().transform(std::uint32_t(n + i)).linear;  // billboards: instances n…2n−1
        Billboard& b = billboards_[i];
        for (int k = 0; k < 3; ++k) b.light_tangent[k] = glm::dot(view.to_light, glm::normalize(axes[k]));
        b.frame = (view.flipbook_frame + int(i)) % texture.frame_count();
        b.transmittance = view.mode == RenderMode::basic ? 1.0 : transmittance(lengths[i], view.sigma_t);
    }
    if (scene.has_ground()) n_dot_l_ = std::max(glm::dot(glm::dvec3(scene.ground_normal()), view.to_light), 0.0);
}

double Shading::opacity(std::uint32_t p, glm::dvec2 uv, double t, double t_opaque) const {
    double a = texture_.sample(glm::vec2(uv), billboards_[p].frame).alpha * view_.alpha;
    if (view_.softness > 0.0 && t_opaque < std::numeric_limits<double>::infinity())
        a *= std::clamp((t_opaque - t) / view_.softness, 0.0, 1.0);
    return a;
}

glm::dvec3 Shading::layer_color(std::uint32_t p, glm::dvec2 uv) const {
    const Billboard& b = billboards_[p];
    const SixwaySample s = texture_.sample(glm::vec2(uv), b.frame);
    // Per tangent axis the texture lit from the light's side of it, weighted by the squared direction cosine.
    const glm::dvec3& l = b.light_tangent;
    const double h = l.x > 0.0 ? s.pos.x : s.neg.x;
    const double v = l.y > 0.0 ? s.pos.y : s.neg.y;
    const double d = l.z > 0.0 ? s.pos.z : s.neg.z;
    const double light_map = h * l.x * l.x + v * l.y * l.y + d * l.z * l.z;
    return light_map * view_.light_color * b.transmittance + view_.ambient;
}

glm::dvec3 Shading::ground_color(double shadow) const {
    return view_.ground_color * (view_.light_color * (n_dot_l_ * shadow) + view_.ambient);
}

}  // namespace smoketrace::textbook
