#include <smoketrace/render/camera.hpp>

#include <glm/geometric.hpp>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace smoketrace {

Camera::Camera(const glm::vec3& position, const glm::vec3& look_at, const glm::vec3& up, float fov_deg, int width,
               int height)
    : position_(position), width_(width), height_(height) {
    if (width < 1 || height < 1) throw std::invalid_argument("camera: image size must be at least 1x1");
    if (!(fov_deg > 0.0f && fov_deg < 180.0f)) throw std::invalid_argument("camera: fov_deg must be in (0, 180)");
    // The frame in double: in float, |look_at − position|² underflows to 0 for points closer than ~1e-19
    // (a scene of subnormal coordinates) and overflows beyond ~1e19, and so does |up|² for an up vector
    // that short or long. The sine of the angle between up and the view must be at least 1e-6, as the scene
    // reader checks (kMinUpViewSine).
    const glm::dvec3 f = glm::dvec3(look_at) - glm::dvec3(position);
    if (!(glm::length(f) > 0.0)) throw std::invalid_argument("camera: position and look_at coincide");
    const glm::dvec3 forward = glm::normalize(f);
    const double up_length = glm::length(glm::dvec3(up));
    const glm::dvec3 r = glm::cross(forward, glm::dvec3(up) / up_length);
    if (!(up_length > 0.0 && glm::length(r) >= 1e-6))
        throw std::invalid_argument("camera: up is parallel to the view direction");
    forward_ = glm::vec3(forward);
    right_ = glm::vec3(glm::normalize(r));
    up_ = glm::cross(right_, forward_);
    half_height_ = std::tan(0.5f * fov_deg * 3.14159265358979f / 180.0f);
    half_width_ = half_height_ * float(width) / float(height);
}

Ray Camera::ray_through(float image_x, float image_y, float tmin) const {
    // 2·x/width − 1, in this order: ray() has always computed its pixel centres so, and any other order
    // would move the default images by a rounding step.
    const float sx = (2.0f * image_x / float(width_) - 1.0f) * half_width_;
    const float sy = (1.0f - 2.0f * image_y / float(height_)) * half_height_;
    return Ray{position_, tmin, glm::normalize(forward_ + sx * right_ + sy * up_), std::numeric_limits<float>::infinity()};
}

RayTile Camera::tile(int x0, int y0, int columns, int rows, glm::vec2 offset, float tmin) const {
    // ray_through()'s image-plane coordinates, for the point `offset` of each pixel.
    float x[kTileColumns], y[kTileRows];
    for (int c = 0; c < columns; ++c) x[c] = (2.0f * (float(x0 + c) + offset.x) / float(width_) - 1.0f) * half_width_;
    for (int r = 0; r < rows; ++r) y[r] = (1.0f - 2.0f * (float(y0 + r) + offset.y) / float(height_)) * half_height_;
    return RayTile(position_, forward_, right_, up_, x, unsigned(columns), y, unsigned(rows), tmin);
}

Ray Camera::ray(int x, int y, float tmin) const { return ray_through(float(x) + 0.5f, float(y) + 0.5f, tmin); }

}  // namespace smoketrace
