#include <smoketrace/render/camera.hpp>
#include <smoketrace/smoke/scene_description.hpp>

#include <glm/geometric.hpp>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace smoketrace {

Camera::Camera(const glm::vec3& position, const glm::vec3& look_at, const glm::vec3& up, float fov_deg, int width,
               int height)
    : position_(position), width_(width), height_(height) {
    validate_camera(position, look_at, up, fov_deg, width, height);
    // The frame in double, as validate_camera() checks it: in float, |look_at − position|² underflows or
    // overflows for coordinates far from 1, and so does |up|².
    const glm::dvec3 forward = glm::normalize(glm::dvec3(look_at) - glm::dvec3(position));
    const glm::dvec3 r = glm::cross(forward, glm::dvec3(up) / glm::length(glm::dvec3(up)));
    forward_ = glm::vec3(forward);
    right_ = glm::vec3(glm::normalize(r));
    up_ = glm::cross(right_, forward_);
    half_height_ = std::tan(0.5f * fov_deg * 3.14159265358979f / 180.0f);
    half_width_ = half_height_ * float(width) / float(height);
}

Ray Camera::ray_through(float image_x, float image_y, float tmin) const {
    // 2·x/width − 1, in this order: the shipped images and the tests' hashes are made of these roundings,
    // and another order moves the pixel centres by a rounding step.
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
