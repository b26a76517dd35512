#pragma once
// A ray tile: up to kTileColumns × kTileRows rays from one point through a grid of points on an image plane,
// the camera rays of a block of pixels (one sample each). trace_tile() traces them together (trace_tile.hpp),
// as trace_bundle() does for rays that share a direction.
//
// Ray (c, r) has the pinhole camera's direction (render/camera.hpp)
//     normalize(forward + x[c]·right + y[r]·up),
// x[c] and y[r] being the image-plane coordinates of its column and row. Every ray of the tile lies on that
// plane's grid, so what a box can show the tile is decided on the plane: the box's shadow there (the range
// of its corners' (q·right)/(q·forward), (q·up)/(q·forward), q relative to the origin) covers every ray
// that can meet anything inside the box, and only the rows and columns under it need testing
// (shadow_lanes()). For a box that is also behind the eye the shadow is unbounded and the whole tile is
// kept. The top-level walk culls nodes with the tile's frustum: the four planes through the origin along
// the grid's outer rows and columns (outside()).
//
// Margins: the directions are rounded floats and forward, right, up orthonormal only to rounding, so a ray's
// own shadow coordinates differ from x[c], y[r] by a few units in the 7th digit of 1 + |x| + |y|. Every
// test here widens the grid by kTileMargin times that, four hundred times the error and a fifth of a pixel
// of a 1024-pixel image at 45°: a ray is never culled from a box it meets, and few rays are tested in vain.
#include <smoketrace/core/simd/lanes.hpp>
#include <smoketrace/geometry/aabb.hpp>
#include <smoketrace/geometry/ray.hpp>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>

namespace smoketrace {

inline constexpr unsigned kTileColumns = 16;  // a row of lanes is one AVX-512 register of floats
inline constexpr unsigned kTileRows = 16;
inline constexpr unsigned kTileRays = kTileColumns * kTileRows;
inline constexpr float kTileMargin = 1e-4f;  // relative to 1 + |x| + |y|: see above

// A set of the tile's rows or columns: bit i for row (column) i.
using TileLineSet = std::uint32_t;
static_assert(kTileColumns <= 32 && kTileRows <= 32);

class RayTile {
public:
    // The grid: `columns` × `rows` rays (each ≥ 1, ≤ kTileColumns / kTileRows) from `origin`, with the
    // image-plane coordinates x[0 … columns), y[0 … rows) and the frame forward, right, up (unit and
    // orthogonal, as a camera's). Lane r·kTileColumns + c is ray (c, r); its interval is [tmin, +∞) until
    // set_tmax().
    RayTile(const glm::vec3& origin, const glm::vec3& forward, const glm::vec3& right, const glm::vec3& up,
            const float* x, unsigned columns, const float* y, unsigned rows, float tmin)
        : origin_(origin), columns_(columns), rows_(rows), tmin_(tmin) {
        assert(columns >= 1 && columns <= kTileColumns && rows >= 1 && rows <= kTileRows);
        float x_lo = x[0], x_hi = x[0], y_lo = y[0], y_hi = y[0], reach = 0.0f;
        for (unsigned c = 0; c < columns; ++c) {
            x_[c] = x[c];
            x_lo = std::min(x_lo, x[c]);
            x_hi = std::max(x_hi, x[c]);
            reach = std::max(reach, std::abs(x[c]));
        }
        float reach_y = 0.0f;
        for (unsigned r = 0; r < rows; ++r) {
            y_[r] = y[r];
            y_lo = std::min(y_lo, y[r]);
            y_hi = std::max(y_hi, y[r]);
            reach_y = std::max(reach_y, std::abs(y[r]));
        }
        margin_ = kTileMargin * (1.0f + reach + reach_y);
        x_lo_ = x_lo - margin_;
        x_hi_ = x_hi + margin_;
        y_lo_ = y_lo - margin_;
        y_hi_ = y_hi + margin_;
        // A point q (relative to the origin) is outside the frustum when n·q > 0 for one of these.
        const glm::dvec3 f(forward), rt(right), u(up);
        forward_d_ = f;
        right_d_ = rt;
        up_d_ = u;
        planes_[0] = rt - double(x_hi_) * f;
        planes_[1] = double(x_lo_) * f - rt;
        planes_[2] = u - double(y_hi_) * f;
        planes_[3] = double(y_lo_) * f - u;
        for (unsigned r = 0; r < kTileRows; ++r)
            for (unsigned c = 0; c < kTileColumns; ++c) {
                const unsigned lane = r * kTileColumns + c;
                // Lanes outside the grid repeat its first ray, so that every lane is a valid ray for the
                // SIMD kernels; they are never reported.
                const unsigned cc = c < columns ? c : 0, rr = r < rows ? r : 0;
                const glm::vec3 d = glm::normalize(forward + x[cc] * right + y[rr] * up);
                dx_[lane] = d.x;
                dy_[lane] = d.y;
                dz_[lane] = d.z;
                tmax_[lane] = std::numeric_limits<float>::infinity();
            }
        all_columns_ = columns == 32 ? ~0u : (1u << columns) - 1u;
        all_rows_ = rows == 32 ? ~0u : (1u << rows) - 1u;
    }

    [[nodiscard]] unsigned columns() const { return columns_; }
    [[nodiscard]] unsigned rows() const { return rows_; }
    [[nodiscard]] static unsigned lane(unsigned column, unsigned row) { return row * kTileColumns + column; }
    [[nodiscard]] TileLineSet all_columns() const { return all_columns_; }
    [[nodiscard]] TileLineSet all_rows() const { return all_rows_; }

    [[nodiscard]] const glm::vec3& origin() const { return origin_; }
    [[nodiscard]] float tmin() const { return tmin_; }
    [[nodiscard]] glm::vec3 direction(unsigned lane) const { return {dx_[lane], dy_[lane], dz_[lane]}; }
    [[nodiscard]] float tmax(unsigned lane) const { return tmax_[lane]; }
    void set_tmax(unsigned lane, float t) { tmax_[lane] = t; }
    // For a search that lowers its ray's tmax as it commits hits (trace_tile()), and its SIMD reads.
    [[nodiscard]] float& tmax_ref(unsigned lane) { return tmax_[lane]; }
    [[nodiscard]] const float* tmax_data() const { return tmax_; }
    [[nodiscard]] Ray ray(unsigned lane) const { return Ray{origin_, tmin_, direction(lane), tmax_[lane]}; }
    // The directions by component, lane-contiguous (kTileRays each), for the SIMD kernels.
    [[nodiscard]] const float* direction_x() const { return dx_; }
    [[nodiscard]] const float* direction_y() const { return dy_; }
    [[nodiscard]] const float* direction_z() const { return dz_; }

    // True when no ray of the tile can meet anything inside `box`: it lies wholly outside one frustum plane.
    // In double, so that a box far from the origin or much larger than its distance is decided as exactly
    // as a small one near by.
    [[nodiscard]] bool outside(const Aabb& box) const {
        const glm::dvec3 o(origin_);
        const glm::dvec3 lo = glm::dvec3(box.lo) - o, hi = glm::dvec3(box.hi) - o;
        for (const glm::dvec3& n : planes_) {
            // The corner that minimises n·q; the box is out when even that one is outside.
            const double d = n.x * (n.x > 0.0 ? lo.x : hi.x) + n.y * (n.y > 0.0 ? lo.y : hi.y) +
                             n.z * (n.z > 0.0 ? lo.z : hi.z);
            if (d > 0.0) return true;
        }
        return false;
    }

    // The frustum's four planes through the origin (outside() tests n·q > 0, q relative to the origin).
    [[nodiscard]] const glm::dvec3* frustum_planes() const { return planes_; }

    // The columns and rows whose rays can meet anything inside `box` (see above); false when none can.
    bool shadow_lanes(const Aabb& box, TileLineSet& columns, TileLineSet& rows) const {
        // In double (see outside()); then the shadow itself carries no error worth a margin. The eight corners
        // in lanes (corner k takes hi on axis a where bit a of k is set): two divisions per block of lanes
        // rather than sixteen one by one.
        using Doubles = simd::Doubles<simd::kDoubleLanes>;
        constexpr unsigned D = simd::kDoubleLanes;
        alignas(64) static constexpr double kCornerBits[3][8] = {
            {0, 1, 0, 1, 0, 1, 0, 1}, {0, 0, 1, 1, 0, 0, 1, 1}, {0, 0, 0, 0, 1, 1, 1, 1}};
        const Doubles zero = Doubles::broadcast(0.0);
        alignas(64) double sx[8], sy[8];
        for (unsigned k = 0; k < 8; k += D) {
            Doubles q[3];
            for (int a = 0; a < 3; ++a)
                q[a] = select(Doubles::load(kCornerBits[a] + k) > zero, Doubles::broadcast(double(box.hi[a])),
                              Doubles::broadcast(double(box.lo[a]))) -
                       Doubles::broadcast(double(origin_[a]));
            const Doubles depth = q[0] * Doubles::broadcast(forward_d_.x) + q[1] * Doubles::broadcast(forward_d_.y) +
                                  q[2] * Doubles::broadcast(forward_d_.z);
            // At or behind the eye's plane the shadow is unbounded (or the corner is the eye itself).
            if (bits(depth > zero) != (D == 32 ? ~0u : (1u << D) - 1u)) {
                columns = all_columns_;
                rows = all_rows_;
                return true;
            }
            store(sx + k, (q[0] * Doubles::broadcast(right_d_.x) + q[1] * Doubles::broadcast(right_d_.y) +
                           q[2] * Doubles::broadcast(right_d_.z)) / depth);
            store(sy + k, (q[0] * Doubles::broadcast(up_d_.x) + q[1] * Doubles::broadcast(up_d_.y) +
                           q[2] * Doubles::broadcast(up_d_.z)) / depth);
        }
        double sx_lo = sx[0], sx_hi = sx[0], sy_lo = sy[0], sy_hi = sy[0];
        for (unsigned k = 1; k < 8; ++k) {
            sx_lo = std::min(sx_lo, sx[k]);
            sx_hi = std::max(sx_hi, sx[k]);
            sy_lo = std::min(sy_lo, sy[k]);
            sy_hi = std::max(sy_hi, sy[k]);
        }
        // The grid lines inside [lo − margin, hi + margin], in lanes (a NaN bound, from a box at infinity,
        // keeps them all).
        auto inside = [&](const float* coords, double lo, double hi) {
            const Doubles l = Doubles::broadcast(lo - margin_), h = Doubles::broadcast(hi + margin_);
            TileLineSet set = 0;
            for (unsigned i = 0; i < kTileColumns; i += D) {
                const Doubles c = Doubles::widen(coords + i);
                set |= TileLineSet(~bits((c < l) | (c > h)) & ((1u << D) - 1u)) << i;
            }
            return set;
        };
        static_assert(kTileColumns == kTileRows);
        columns = inside(x_, sx_lo, sx_hi) & all_columns_;
        rows = inside(y_, sy_lo, sy_hi) & all_rows_;
        return columns != 0 && rows != 0;
    }

private:
    glm::vec3 origin_;
    unsigned columns_, rows_;
    float tmin_;
    alignas(64) float x_[kTileColumns] = {}, y_[kTileRows] = {};
    float margin_, x_lo_, x_hi_, y_lo_, y_hi_;
    glm::dvec3 planes_[4];
    glm::dvec3 forward_d_, right_d_, up_d_;
    TileLineSet all_columns_, all_rows_;
    alignas(64) float dx_[kTileRays];
    alignas(64) float dy_[kTileRays];
    alignas(64) float dz_[kTileRays];
    alignas(64) float tmax_[kTileRays];
};

}  // namespace smoketrace
