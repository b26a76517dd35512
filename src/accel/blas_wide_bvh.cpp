// Collapsing a mesh BLAS's binary tree into a W-wide one (see blas_wide_bvh.hpp).
#include <smoketrace/accel/blas_wide_bvh.hpp>
#include "wide_cut.hpp"

#include <cstdint>
#include <limits>
#include <memory>
#include <utility>
#include <stdexcept>

namespace smoketrace {

template <unsigned W>
void BlasWideBvh<W>::collapse(const Bvh& binary, std::span<const std::uint32_t> leaf_refs) {
    nodes_.clear();
    if (binary.nodes.empty()) return;
    if (leaf_refs.size() != binary.nodes.size())
        throw std::invalid_argument("BlasWideBvh: one leaf reference per binary node expected");
    const WideCut<W> cut(binary);
    lay_out_wide_tree(
        binary, cut,
        [&](std::size_t count) {
            if (count > std::size_t(std::numeric_limits<std::int32_t>::max() / W))
                throw std::length_error("BlasWideBvh: too many nodes");
            nodes_.resize(count);
        },
        [&](std::uint32_t wide, const std::uint32_t* slot, unsigned n, int axis, const std::uint32_t* child) {
            Node w{};
            w.axis = static_cast<std::uint8_t>(axis);
            w.used = static_cast<std::uint8_t>(n);
            const Aabb empty;  // lo = +∞, hi = −∞
            for (unsigned i = 0; i < W; ++i) {
                const float* p = planes(i < n ? binary.nodes[slot[i]].bounds : empty);
                for (int k = 0; k < 6; ++k) w.bounds[k][i] = p[k];
            }
            for (unsigned i = 0; i < n; ++i) {
                const BvhNode& c = binary.nodes[slot[i]];
                if (c.is_leaf()) {
                    if (c.count > 255) throw std::length_error("BlasWideBvh: a leaf of more than 255 primitives");
                    w.child[i] = leaf_refs[slot[i]];
                    w.count[i] = static_cast<std::uint8_t>(c.count);
                    w.leaves |= std::uint8_t(1u << i);
                } else {
                    w.child[i] = child[i];
                }
            }
            nodes_[wide] = w;
        });
}

template class BlasWideBvh<4>;
template class BlasWideBvh<8>;

}  // namespace smoketrace
