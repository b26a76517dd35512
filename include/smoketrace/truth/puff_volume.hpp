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
#include <cstdint>
#include <span>
#include <vector>

namespace smoketrace {

class PuffVolume {
public:
    enum class Kind { grid, uniform_ball, uniform_cube };

    // The baker's voxels of flipbook frame `frame` (puff_density.hpp's layout and values).
    static PuffVolume baked(const SixwayBakeSettings& settings, int frame);
    // Given voxel values (finite, >= 0), n x n x nz in PuffVoxels' layout and cube (tests: small grids).
    static PuffVolume voxels(int n, int nz, std::vector<float> values);
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
    // ∫ density(q0 + t·dq) dt over [t0, t1] (finite; 0 if t1 <= t0), exact up to rounding. The grid's
    // interpolant is a cubic in t between the planes through voxel centres (and 0 beyond the outermost
    // centres' cells), so the segment is cut at every such plane it crosses and each piece integrated by
    // two-point Gauss–Legendre, exact for cubics; the test shapes give value · chord length in closed form.
    // In double: for the grid, while q0 and the segment lie in the cube, the error is below
    // 10⁻¹² · V · (t1 − t0), V the largest voxel value (puff_volume.cpp derives it).
    [[nodiscard]] double integrate(const glm::dvec3& q0, const glm::dvec3& dq, double t0, double t1) const;
    // The same integral cut into bins of `spacing` from `origin`: adds its part in [origin + m·spacing,
    // origin + (m + 1)·spacing] to bins[m], dropping what lies outside them; one walk for many consecutive
    // spans (the light volume's node-to-node segments), each bin within the bound above for its share.
    void integrate_bins(const glm::dvec3& q0, const glm::dvec3& dq, double t0, double t1, double origin, double spacing,
                        std::span<double> bins) const;
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
    void integrate_grid(const glm::dvec3& q0, const glm::dvec3& dq, double t0, double t1, double origin, double spacing,
                        std::span<double> bins) const;
    // The test shapes' [in, out] along the line (infinite for a line standing inside); false if it misses.
    bool chord(const glm::dvec3& q0, const glm::dvec3& dq, double& in, double& out) const;
    // The bin holding t, clamped to [0, count).
    static std::size_t bin_of(double t, double origin, double spacing, std::size_t count);
    [[nodiscard]] double integrate_cell(const double a[3], const double b[3], const int cell[3], double ta,
                                        double tb) const;
    // Cell (i, j, k) spans voxels i … i + 1 (and so on), i from −1 (half outside the grid) to n − 1.
    [[nodiscard]] std::size_t cell_index(int i, int j, int k) const {
        const std::size_t side = std::size_t(n_) + 1;
        return (std::size_t(k + 1) * side + std::size_t(j + 1)) * side + std::size_t(i + 1);
    }

    Kind kind_ = Kind::grid;
    float size_ = 0.0f, value_ = 0.0f, voxel_ = 1.0f;
    int n_ = 0, nz_ = 0;  // voxels along x and y, along z
    float dxy_ = 0.0f, dz_ = 0.0f;
    std::vector<float> grid_;  // [k][j][i]: k along -z (front to back), j along -y (top row first), i along x
    // One bit per cell (cell_index): set if some corner is nonzero. Most of a puff's cube is empty, and a
    // segment skips those cells without reading the grid.
    std::vector<std::uint64_t> occupied_;
};

}  // namespace smoketrace
