// The scene description's own behaviour: the light's turn per frame, and names of the settings.
#include <smoketrace/smoke/scene_description.hpp>

#include <glm/vec3.hpp>

#include <cmath>

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
