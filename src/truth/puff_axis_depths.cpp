// A puff's optical depth toward the six axis lights (see puff_axis_depths.hpp).
#include <smoketrace/truth/puff_axis_depths.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>

namespace smoketrace {

namespace {

// ∫ of the indicator of [lo, hi] from x toward +∞ (toward = +1) or −∞ (toward = −1).
float chord_from(float x, float lo, float hi, int toward) {
    if (!(hi > lo)) return 0.0f;
    return toward > 0 ? std::max(0.0f, hi - std::max(x, lo)) : std::max(0.0f, std::min(x, hi) - lo);
}

}  // namespace

PuffAxisDepths::PuffAxisDepths(const PuffVolume& puff, unsigned lights) : puff_(&puff) {
    if (puff.kind() != PuffVolume::Kind::grid) return;
    const int n = puff.columns(), nz = puff.layers();
    const double dxy = puff.side_xy(), dz = puff.side_z();
    const std::vector<float>& rho = puff.voxel_values();
    auto at = [&](int k, int j, int i) { return (std::size_t(k) * std::size_t(n) + std::size_t(j)) * std::size_t(n) + std::size_t(i); };
    for (int l = 0; l < 6; ++l)
        if (lights & (1u << l)) depths_[std::size_t(l)].assign(rho.size(), 0.0f);
    // One axis line of `count` centres, `step` apart in the array and `h` in tangent units: from each centre
    // to the far end, the trapezoid sum of the linear pieces plus the last centre's half cell, where the
    // interpolant falls to 0 over one cell (puff_volume.cpp); in double, stored as float.
    auto line = [&](std::vector<float>& out, std::size_t first, std::ptrdiff_t step, int count, double h) {
        if (out.empty()) return;  // a light not asked for
        const auto idx = [&](int m) { return std::size_t(std::ptrdiff_t(first) + std::ptrdiff_t(m) * step); };
        double sum = 0.5 * h * double(rho[idx(count - 1)]);
        out[idx(count - 1)] = float(sum);
        for (int m = count - 2; m >= 0; --m) {
            sum += 0.5 * h * (double(rho[idx(m)]) + double(rho[idx(m + 1)]));
            out[idx(m)] = float(sum);
        }
    };
    const auto sn = std::ptrdiff_t(n), snn = std::ptrdiff_t(n) * std::ptrdiff_t(n);
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < n; ++j) {
            line(depths_[0], at(k, j, 0), 1, n, dxy);            // +x: i increasing
            line(depths_[3], at(k, j, n - 1), -1, n, dxy);       // -x
        }
    for (int k = 0; k < nz; ++k)
        for (int i = 0; i < n; ++i) {
            line(depths_[1], at(k, n - 1, i), -sn, n, dxy);      // +y: toward row 0 (the top)
            line(depths_[4], at(k, 0, i), sn, n, dxy);           // -y
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            line(depths_[2], at(nz - 1, j, i), -snn, nz, dz);    // +z: toward layer 0 (the front)
            line(depths_[5], at(0, j, i), snn, nz, dz);          // -z
        }
}

float PuffAxisDepths::operator()(int light, glm::vec3 p) const {
    const PuffVolume& v = *puff_;
    const int axis = light % 3, toward = light < 3 ? 1 : -1;
    const int u = (axis + 1) % 3, w = (axis + 2) % 3;  // the other two axes
    switch (v.kind()) {
        case PuffVolume::Kind::grid: {
            const std::vector<float>& d = depths_[std::size_t(light)];
            if (d.empty()) throw std::logic_error("PuffAxisDepths: light " + std::to_string(light) + " was not built");
            return v.interpolate(d, p);
        }
        case PuffVolume::Kind::uniform_ball: {
            const float r2 = v.size() * v.size() - p[u] * p[u] - p[w] * p[w];
            if (!(r2 > 0.0f)) return 0.0f;
            const float h = std::sqrt(r2);
            return v.value() * chord_from(p[axis], -h, h, toward);
        }
        case PuffVolume::Kind::uniform_cube: {
            const float s = v.size();
            if (!(std::abs(p[u]) < s && std::abs(p[w]) < s)) return 0.0f;
            return v.value() * chord_from(p[axis], -s, s, toward);
        }
    }
    return 0.0f;
}

}  // namespace smoketrace
