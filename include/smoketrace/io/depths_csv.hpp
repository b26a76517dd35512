#pragma once
// The optical depths as CSV, what `smoketrace depths` writes: a header line, then one row per particle,
// "particle,optical_path_length,hits,status". A length is the shortest text that reads back as the same
// float (std::to_chars: 0.35 for 0.35f) or "inf" for a particle that is occluded or cut off.
#include <smoketrace/smoke/hit_resolver.hpp>

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace smoketrace {

// The CSV's text, in pieces to be written in order (formatted in parallel, a piece per block of rows, so that
// a million rows take a fraction of the optical-depth pass). The bytes do not depend on the thread count.
// Precondition: the three spans have the same size.
[[nodiscard]] std::vector<std::string> format_depths_csv(std::span<const float> lengths,
                                                         std::span<const std::uint32_t> hit_counts,
                                                         std::span<const DepthStatus> status);

}  // namespace smoketrace
