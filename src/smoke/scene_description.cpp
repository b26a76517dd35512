// The scene description's own behaviour: the light's turn per frame, and names of the settings.
#include <smoketrace/smoke/scene_description.hpp>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <stdexcept>

namespace smoketrace {

glm::vec3 LightDescription::direction_at_frame(std::int64_t frame) const {
    if (rotation_per_frame_deg == 0.0f || frame == 0) return direction;
    // Reduce in degrees first (exact for fmod) so that large frame numbers keep full precision.
    const double degrees = std::fmod(static_cast<double>(rotation_per_frame_deg) * static_cast<double>(frame), 360.0);
    const double radians = degrees * (3.14159265358979323846 / 180.0);
    const double c = std::cos(radians), s = std::sin(radians);
    const glm::dvec3 d(direction);
    return glm::vec3(glm::dvec3(c * d.x - s * d.y, s * d.x + c * d.y, d.z));
}

void validate_camera(const glm::vec3& position, const glm::vec3& look_at, const glm::vec3& up, float fov_deg,
                     int width, int height) {
    if (width < 1 || height < 1) throw std::invalid_argument("camera: image size must be at least 1x1");
    if (!(fov_deg > 0.0f && fov_deg < 180.0f)) throw std::invalid_argument("camera: fov_deg must be in (0, 180)");
    // In double: in float, |look_at − position|² underflows to 0 for points closer than ~1e-19 (a scene of
    // subnormal coordinates) and overflows beyond ~1e19, and so does |up|² for an up vector that short or long.
    const glm::dvec3 f = glm::dvec3(look_at) - glm::dvec3(position);
    if (!(glm::length(f) > 0.0)) throw std::invalid_argument("camera: position and look_at coincide");
    const double up_length = glm::length(glm::dvec3(up));
    if (!(up_length > 0.0 && glm::length(glm::cross(glm::normalize(f), glm::dvec3(up) / up_length)) >= 1e-6))
        throw std::invalid_argument("camera: up is parallel to the view direction");
}

const char* to_string(RenderMode m) {
    switch (m) {
        case RenderMode::basic: return "basic";
        case RenderMode::simple_shadow: return "simple-shadow";
        case RenderMode::full: return "full";
    }
    return "?";
}

const char* to_string(Compositing c) {
    switch (c) {
        case Compositing::over: return "over";
        case Compositing::thesis: return "thesis";
    }
    return "?";
}

}  // namespace smoketrace
