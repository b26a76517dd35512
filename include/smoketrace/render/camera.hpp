#pragma once
// A pinhole camera: a ray through any point of the image, by default through each pixel's centre as in the
// thesis's view pass (4.3.5).
#include <smoketrace/geometry/ray.hpp>
#include <smoketrace/geometry/ray_tile.hpp>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace smoketrace {

class Camera {
public:
    // fov_deg is the vertical field of view. Throws std::invalid_argument when position == look_at, up is
    // parallel to the view direction, or the size or field of view is out of range.
    Camera(const glm::vec3& position, const glm::vec3& look_at, const glm::vec3& up, float fov_deg, int width,
           int height);

    // Ray through the point (image_x, image_y) of the image in continuous pixel coordinates: pixel (x, y)
    // covers [x, x + 1) × [y, y + 1), y = 0 the top row, so (0, 0) is the image's top-left corner and
    // (width, height) its bottom-right one. Unit direction, so t is distance.
    [[nodiscard]] Ray ray_through(float image_x, float image_y, float tmin) const;
    // Ray through the centre of pixel (x, y): ray_through(x + 0.5, y + 0.5), bit for bit.
    [[nodiscard]] Ray ray(int x, int y, float tmin) const;

    // The rays of pixels [x0, x0 + columns) × [y0, y0 + rows) as a tile (at most kTileColumns × kTileRows),
    // each through the point `offset` of its pixel ((0.5, 0.5): the centre; x right, y down), with
    // unbounded tmax: lane (c, r) is bit for bit the ray of pixel (x0 + c, y0 + r) through that point.
    [[nodiscard]] RayTile tile(int x0, int y0, int columns, int rows, glm::vec2 offset, float tmin) const;

    [[nodiscard]] const glm::vec3& position() const { return position_; }
    [[nodiscard]] int width() const { return width_; }
    [[nodiscard]] int height() const { return height_; }

private:
    glm::vec3 position_, forward_, right_, up_;
    float half_height_, half_width_;  // tan(fov/2) and that times the aspect ratio
    int width_, height_;
};

}  // namespace smoketrace
