// One particle's density for the ground truth (see puff_volume.hpp).
#include <smoketrace/truth/puff_volume.hpp>

#include <smoketrace/render/puff_density.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

namespace smoketrace {

PuffVolume PuffVolume::baked(const SixwayBakeSettings& settings, int frame) {
    validate(settings);
    const PuffVoxels g(settings);
    std::vector<float> values;
    sample_puff_density(settings, g, frame, values);  // the very values the baker marched
    return voxels(g.n, g.nz, std::move(values));
}

PuffVolume PuffVolume::voxels(int n, int nz, std::vector<float> values) {
    if (n < 1 || nz < 1 || n > kSixwayMaxBakeTile || nz > kSixwayMaxBakeTile)
        throw std::invalid_argument("PuffVolume: voxel counts must be in [1, " + std::to_string(kSixwayMaxBakeTile) +
                                    "]");
    if (values.size() != std::size_t(n) * std::size_t(n) * std::size_t(nz))
        throw std::invalid_argument("PuffVolume: " + std::to_string(values.size()) + " voxel values for a " +
                                    std::to_string(n) + "x" + std::to_string(n) + "x" + std::to_string(nz) + " grid");
    for (const float x : values)
        if (!(x >= 0.0f && x <= std::numeric_limits<float>::max()))
            throw std::invalid_argument("PuffVolume: voxel values must be finite densities >= 0");
    SixwayBakeSettings layout;
    layout.tile = n;
    layout.depth_samples = nz;
    const PuffVoxels g(layout);
    PuffVolume v;
    v.kind_ = Kind::grid;
    v.n_ = g.n;
    v.nz_ = g.nz;
    v.dxy_ = g.dxy;
    v.dz_ = g.dz;
    v.voxel_ = std::min(g.dxy, g.dz);
    v.grid_ = std::move(values);
    // A cell is occupied if any of its 8 corner voxels is nonzero: mark the 8 cells around each such voxel.
    const std::size_t side = std::size_t(v.n_) + 1;
    v.occupied_.assign((side * side * (std::size_t(v.nz_) + 1) + 63) / 64, 0);
    for (int k = 0; k < v.nz_; ++k)
        for (int j = 0; j < v.n_; ++j)
            for (int i = 0; i < v.n_; ++i) {
                if (v.grid_[g.index(k, j, i)] == 0.0f) continue;
                for (int dk = 0; dk < 2; ++dk)
                    for (int dj = 0; dj < 2; ++dj)
                        for (int di = 0; di < 2; ++di) {
                            const std::size_t cell = v.cell_index(i - 1 + di, j - 1 + dj, k - 1 + dk);
                            v.occupied_[cell / 64] |= std::uint64_t(1) << (cell % 64);
                        }
            }
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

double PuffVolume::integrate(const glm::dvec3& q0, const glm::dvec3& dq, double t0, double t1) const {
    double sum = 0.0;
    integrate_bins(q0, dq, t0, t1, t0, std::numeric_limits<double>::infinity(), {&sum, 1});
    return sum;
}

void PuffVolume::integrate_bins(const glm::dvec3& q0, const glm::dvec3& dq, double t0, double t1, double origin,
                                double spacing, std::span<double> bins) const {
    if (bins.empty()) return;
    // Only the bins' span counts.
    const double lo = std::max(t0, origin), hi = std::min(t1, origin + double(bins.size()) * spacing);
    if (!(hi > lo)) return;
    if (kind_ == Kind::grid) {
        integrate_grid(q0, dq, lo, hi, origin, spacing, bins);
        return;
    }
    double in, out;
    if (!chord(q0, dq, in, out)) return;
    in = std::max(in, lo);
    out = std::min(out, hi);
    // value · the chord's overlap with each bin it meets.
    const double value = value_;
    for (std::size_t m = bin_of(in, origin, spacing, bins.size()); m < bins.size(); ++m) {
        const double a = std::max(in, origin + double(m) * spacing);
        const double b = std::min(out, origin + double(m + 1) * spacing);
        if (b > a) bins[m] += value * (b - a);
        if (b >= out) break;
    }
}

std::size_t PuffVolume::bin_of(double t, double origin, double spacing, std::size_t count) {
    const double m = std::floor((t - origin) / spacing);  // 0 for an infinite spacing
    return m <= 0.0 ? 0 : std::min(std::size_t(m), count - 1);
}

bool PuffVolume::chord(const glm::dvec3& q0, const glm::dvec3& dq, double& in, double& out) const {
    const double size = size_;
    in = -std::numeric_limits<double>::infinity();
    out = std::numeric_limits<double>::infinity();
    if (kind_ == Kind::uniform_ball) {
        // About the line's point nearest the centre, q_c at t_c: half the chord is √((size² − |q_c|²) / |dq|²),
        // without the cancellation of the quadratic's discriminant.
        const double dd = glm::dot(dq, dq);
        if (dd == 0.0) return glm::dot(q0, q0) < size * size;
        const double tc = -glm::dot(q0, dq) / dd;
        const glm::dvec3 qc = q0 + tc * dq;
        const double half_squared = (size * size - glm::dot(qc, qc)) / dd;
        if (!(half_squared > 0.0)) return false;
        const double half = std::sqrt(half_squared);
        in = tc - half;
        out = tc + half;
        return true;
    }
    for (int c = 0; c < 3; ++c) {  // the cube: the slabs' intersection
        if (dq[c] == 0.0) {
            if (!(std::abs(q0[c]) < size)) return false;
            continue;
        }
        const double ta = (-size - q0[c]) / dq[c], tb = (size - q0[c]) / dq[c];
        in = std::max(in, std::min(ta, tb));
        out = std::min(out, std::max(ta, tb));
    }
    return out > in;
}

// In grid coordinates (voxel centre m of an axis at f = m, x to the right, y and z flipped as the layout has
// them) each coordinate along the segment is f = a + t·b. Between consecutive integer planes of the three
// axes the interpolant is a product of three linear functions of t, a cubic, and it is 0 wherever some f is
// outside (−1, size): the nodes beyond the grid are 0, so the outermost cells fall to 0 continuously.
//
// Rounding: every cut and every Gauss node comes from a, b and t in a few operations, so while q0 and the
// segment lie in the cube the grid coordinates (at most size + 1 in magnitude) are off by at most
// 8·(size + 1)·2⁻⁵³; the density moves by at most V (the largest voxel value) per unit of each coordinate.
// A misplaced cut costs nothing to first order (the cubics on either side agree on the plane), and summing
// a bin's N ≤ 3·(size + 2) + 1 pieces adds N·2⁻⁵³ relative. Together, with 20 units for the trilinear's own
// operations: below (27·(size + 2) + 21)·2⁻⁵³·V·length < 10⁻¹²·V·length for size ≤ 256, length being the
// bin's share of the segment.
void PuffVolume::integrate_grid(const glm::dvec3& q0, const glm::dvec3& dq, double t0, double t1, double origin,
                                double spacing, std::span<double> bins) const {
    if (grid_.empty()) return;  // a default-constructed volume: no voxels
    const double dxy = dxy_, dz = dz_;
    const double a[3] = {(q0.x + 1.0) / dxy - 0.5, (1.0 - q0.y) / dxy - 0.5, (1.0 - q0.z) / dz - 0.5};
    const double b[3] = {dq.x / dxy, -dq.y / dxy, -dq.z / dz};
    const int size[3] = {n_, n_, nz_};

    // The support (−1, size) on every axis: an axis the segment does not move along holds it inside or
    // leaves nothing (a segment on a boundary plane sees density 0).
    double lo = t0, hi = t1;
    for (int c = 0; c < 3; ++c) {
        if (b[c] == 0.0) {
            if (!(a[c] > -1.0 && a[c] < double(size[c]))) return;
            continue;
        }
        const double ta = (-1.0 - a[c]) / b[c], tb = (double(size[c]) - a[c]) / b[c];
        lo = std::max(lo, std::min(ta, tb));
        hi = std::min(hi, std::max(ta, tb));
    }
    if (!(hi > lo)) return;

    // A 3D DDA, the bins' ends a fourth sequence of cuts: each moving axis's next integer plane after lo and
    // the t where the segment crosses it. The segment is cut at the nearest crossing, and every sequence
    // crossing there moves on to its next one, so each turn advances one: at most 3·(size + 2) + 1 turns
    // plus the bins, whatever rounding does to the t's (rounded division is monotone, so an axis's crossings
    // never go back).
    double next[3];
    int plane[3], step[3];
    for (int c = 0; c < 3; ++c) {
        if (b[c] == 0.0) {
            next[c] = std::numeric_limits<double>::infinity();
            plane[c] = step[c] = 0;
            continue;
        }
        const double f = a[c] + lo * b[c];
        step[c] = b[c] > 0.0 ? 1 : -1;
        plane[c] = b[c] > 0.0 ? int(std::floor(f)) + 1 : int(std::ceil(f)) - 1;
        next[c] = (double(plane[c]) - a[c]) / b[c];
    }
    std::size_t bin = bin_of(lo, origin, spacing, bins.size());
    double bin_end = origin + double(bin + 1) * spacing;
    double t = lo;
    for (;;) {
        const double end = std::min({hi, next[0], next[1], next[2], bin_end});
        if (end > t) {
            // The piece's cell: the one holding its midpoint, clamped to the support's cells, so that a piece
            // cut short by rounding still takes a cell it touches (whose cubic agrees with its neighbour's on
            // the plane between them, to the rounding of the cut).
            const double mid = 0.5 * (t + end);
            int cell[3];
            for (int c = 0; c < 3; ++c) cell[c] = std::clamp(int(std::floor(a[c] + mid * b[c])), -1, size[c] - 1);
            const std::size_t index = cell_index(cell[0], cell[1], cell[2]);
            if ((occupied_[index / 64] >> (index % 64)) & 1u) bins[bin] += integrate_cell(a, b, cell, t, end);
            t = end;
        }
        if (end >= hi) break;
        for (int c = 0; c < 3; ++c)
            if (next[c] <= end) {
                plane[c] += step[c];
                next[c] = (double(plane[c]) - a[c]) / b[c];
            }
        if (bin_end <= end) {
            if (bin + 1 == bins.size()) break;  // hi is the last bin's end; rounding put it a hair beyond
            ++bin;
            bin_end = origin + double(bin + 1) * spacing;
        }
    }
}

// One piece of the segment, inside one cell: two-point Gauss–Legendre on the cell's cubic.
double PuffVolume::integrate_cell(const double a[3], const double b[3], const int cell[3], double ta, double tb) const {
    const double mid = 0.5 * (ta + tb), h = tb - ta;
    double v[2][2][2];  // [dk][dj][di]: the cell's corners, 0 beyond the grid
    for (int dk = 0; dk < 2; ++dk)
        for (int dj = 0; dj < 2; ++dj)
            for (int di = 0; di < 2; ++di) {
                const int i = cell[0] + di, j = cell[1] + dj, k = cell[2] + dk;
                const bool inside = i >= 0 && i < n_ && j >= 0 && j < n_ && k >= 0 && k < nz_;
                const std::size_t at = (std::size_t(k) * std::size_t(n_) + std::size_t(j)) * std::size_t(n_) + std::size_t(i);
                v[dk][dj][di] = inside ? double(grid_[at]) : 0.0;
            }
    // The Gauss nodes at the midpoint ± h/(2√3).
    const double offset = h * 0.28867513459481288225;
    double sum = 0.0;
    for (const double t : {mid - offset, mid + offset}) {
        const double u = a[0] + t * b[0] - double(cell[0]);
        const double w = a[1] + t * b[1] - double(cell[1]);
        const double s = a[2] + t * b[2] - double(cell[2]);
        const double c00 = v[0][0][0] + u * (v[0][0][1] - v[0][0][0]);
        const double c01 = v[0][1][0] + u * (v[0][1][1] - v[0][1][0]);
        const double c10 = v[1][0][0] + u * (v[1][0][1] - v[1][0][0]);
        const double c11 = v[1][1][0] + u * (v[1][1][1] - v[1][1][0]);
        const double c0 = c00 + w * (c01 - c00);
        const double c1 = c10 + w * (c11 - c10);
        sum += c0 + s * (c1 - c0);
    }
    return 0.5 * h * sum;
}

}  // namespace smoketrace
