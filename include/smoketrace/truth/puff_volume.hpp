#pragma once
// One particle's density in its billboard's tangent space (x right, y up, z toward the eye; the cube
// [-1, 1]³, half-side = the particle's radius): either the six-way baker's puff sampled at the bake's voxel
// centres and interpolated trilinearly (0 beyond the outermost centres' cells), or a closed-form test density
// (uniform ball, uniform cube) whose integrals are known exactly.
#include <smoketrace/render/sixway_baker.hpp>

#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace smoketrace {

class PuffVolume {
public:
    enum class Kind { grid, uniform_ball, uniform_cube };

    // The baker's voxels of flipbook frame `frame` (puff_density.hpp's layout and values).
    static PuffVolume baked(const SixwayBakeSettings& settings, int frame);
    // Density `value` inside |p| < radius (radius <= 1: the stand-in sphere bounds it).
    static PuffVolume uniform_ball(float radius, float value = 1.0f);
    // Density `value` inside max(|x|, |y|, |z|) < half_side (half_side <= 1/√3 keeps it in the sphere).
    static PuffVolume uniform_cube(float half_side, float value = 1.0f);

    [[nodiscard]] float density(glm::vec3 p) const {
        switch (kind_) {
            case Kind::uniform_ball: return p.x * p.x + p.y * p.y + p.z * p.z < size_ * size_ ? value_ : 0.0f;
            case Kind::uniform_cube:
                return std::max(std::max(std::abs(p.x), std::abs(p.y)), std::abs(p.z)) < size_ ? value_ : 0.0f;
            case Kind::grid: break;
        }
        return interpolate(grid_, p);
    }
    [[nodiscard]] Kind kind() const { return kind_; }
    // The density's scale in tangent units: a voxel's side (the grid), or the test shape's size / 64.
    [[nodiscard]] float voxel() const { return voxel_; }
    // The test shapes' size (ball radius, cube half side) and density.
    [[nodiscard]] float size() const { return size_; }
    [[nodiscard]] float value() const { return value_; }

    // The grid: voxels along x and y, along z, their sides, and the values at their centres ([k][j][i] as above).
    [[nodiscard]] int columns() const { return n_; }
    [[nodiscard]] int layers() const { return nz_; }
    [[nodiscard]] float side_xy() const { return dxy_; }
    [[nodiscard]] float side_z() const { return dz_; }
    [[nodiscard]] const std::vector<float>& voxel_values() const { return grid_; }
    // Trilinear interpolation at p of `values` laid out as this grid's voxel centres (the density itself, or
    // any other field sampled there), 0 beyond the outermost centres' cells.
    [[nodiscard]] float interpolate(const std::vector<float>& values, glm::vec3 p) const;

private:

    Kind kind_ = Kind::grid;
    float size_ = 0.0f, value_ = 0.0f, voxel_ = 1.0f;
    int n_ = 0, nz_ = 0;  // voxels along x and y, along z
    float dxy_ = 0.0f, dz_ = 0.0f;
    std::vector<float> grid_;  // [k][j][i]: k along -z (front to back), j along -y (top row first), i along x
};

}  // namespace smoketrace
