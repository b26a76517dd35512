// One particle's density for the ground truth (see puff_volume.hpp).
#include <smoketrace/truth/puff_volume.hpp>

#include <smoketrace/render/puff_density.hpp>

#include <stdexcept>

namespace smoketrace {

PuffVolume PuffVolume::baked(const SixwayBakeSettings& settings, int frame) {
    validate(settings);
    const PuffVoxels g(settings);
    PuffVolume v;
    v.kind_ = Kind::grid;
    v.n_ = g.n;
    v.nz_ = g.nz;
    v.dxy_ = g.dxy;
    v.dz_ = g.dz;
    v.voxel_ = std::min(g.dxy, g.dz);
    sample_puff_density(settings, g, frame, v.grid_);  // the very values the baker marched
    return v;
}

PuffVolume PuffVolume::uniform_ball(float radius, float value) {
    if (!(radius > 0.0f && radius <= 1.0f)) throw std::invalid_argument("PuffVolume: ball radius must be in (0, 1]");
    PuffVolume v;
    v.kind_ = Kind::uniform_ball;
    v.size_ = radius;
    v.value_ = value;
    v.voxel_ = radius / 64.0f;
    return v;
}

PuffVolume PuffVolume::uniform_cube(float half_side, float value) {
    if (!(half_side > 0.0f && half_side <= 0.5773502f))
        throw std::invalid_argument("PuffVolume: cube half side must be in (0, 1/sqrt(3)]");
    PuffVolume v;
    v.kind_ = Kind::uniform_cube;
    v.size_ = half_side;
    v.value_ = value;
    v.voxel_ = half_side / 64.0f;
    return v;
}

// Trilinear between voxel centres; the nodes beyond the grid count as 0, so the density falls to 0 over the
// half voxel outside the outermost centres (the puff is 0 there anyway: its support ends at 0.95).
float PuffVolume::interpolate(const std::vector<float>& values, glm::vec3 p) const {
    const float fi = (p.x + 1.0f) / dxy_ - 0.5f;
    const float fj = (1.0f - p.y) / dxy_ - 0.5f;
    const float fk = (1.0f - p.z) / dz_ - 0.5f;
    if (!(fi > -1.0f && fi < float(n_) && fj > -1.0f && fj < float(n_) && fk > -1.0f && fk < float(nz_))) return 0.0f;
    const float bi = std::floor(fi), bj = std::floor(fj), bk = std::floor(fk);
    const int i0 = int(bi), j0 = int(bj), k0 = int(bk);
    const float ti = fi - bi, tj = fj - bj, tk = fk - bk;
    if (i0 >= 0 && j0 >= 0 && k0 >= 0 && i0 + 1 < n_ && j0 + 1 < n_ && k0 + 1 < nz_) {
        // A cell inside the grid (nearly every sample): its eight nodes without a bounds check each, the same
        // operations as below.
        const std::size_t row = std::size_t(n_), layer = std::size_t(n_) * std::size_t(n_);
        const float* v = &values[std::size_t(k0) * layer + std::size_t(j0) * row + std::size_t(i0)];
        const float c00 = v[0] + ti * (v[1] - v[0]);
        const float c01 = v[row] + ti * (v[row + 1] - v[row]);
        const float c10 = v[layer] + ti * (v[layer + 1] - v[layer]);
        const float c11 = v[layer + row] + ti * (v[layer + row + 1] - v[layer + row]);
        const float c0 = c00 + tj * (c01 - c00);
        const float c1 = c10 + tj * (c11 - c10);
        return c0 + tk * (c1 - c0);
    }
    auto at = [&](int k, int j, int i) -> float {
        if (i < 0 || i >= n_ || j < 0 || j >= n_ || k < 0 || k >= nz_) return 0.0f;
        return values[(std::size_t(k) * std::size_t(n_) + std::size_t(j)) * std::size_t(n_) + std::size_t(i)];
    };
    const float c00 = at(k0, j0, i0) + ti * (at(k0, j0, i0 + 1) - at(k0, j0, i0));
    const float c01 = at(k0, j0 + 1, i0) + ti * (at(k0, j0 + 1, i0 + 1) - at(k0, j0 + 1, i0));
    const float c10 = at(k0 + 1, j0, i0) + ti * (at(k0 + 1, j0, i0 + 1) - at(k0 + 1, j0, i0));
    const float c11 = at(k0 + 1, j0 + 1, i0) + ti * (at(k0 + 1, j0 + 1, i0 + 1) - at(k0 + 1, j0 + 1, i0));
    const float c0 = c00 + tj * (c01 - c00);
    const float c1 = c10 + tj * (c11 - c10);
    return c0 + tk * (c1 - c0);
}

}  // namespace smoketrace
