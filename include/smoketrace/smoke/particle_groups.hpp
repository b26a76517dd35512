#pragma once
// Particle groups (thesis 4.4.2): with G groups, each frame updates the optical depth of only 1/G of the
// particles, round-robin; the others keep the value of their last update.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace smoketrace {

// The particles whose optical depth frame `frame` updates: every i < n with i mod G == frame mod G.
// Interleaved rather than contiguous blocks, so that each frame's group is spread over the whole smoke
// and a stale region never forms.
[[nodiscard]] std::vector<std::uint32_t> particle_group(std::size_t n, std::uint32_t groups, std::uint64_t frame);

}  // namespace smoketrace
