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
// With `true_depths` (smoketrace depths --truth), a fifth column "true_optical_depth": the ground truth's τ
// from the particle's centre to the light (GroundTruth::particle_optical_depths(), shortest round-trip text
// of the double); compare it with optical_path_length × the scene's sigma_t.
// Precondition: the spans have the same size (true_depths: that size or empty).
[[nodiscard]] std::vector<std::string> format_depths_csv(std::span<const float> lengths,
                                                         std::span<const std::uint32_t> hit_counts,
                                                         std::span<const DepthStatus> status,
                                                         std::span<const double> true_depths = {});

}  // namespace smoketrace
