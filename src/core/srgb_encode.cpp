// The image loop of the sRGB encoder (srgb_encode.hpp): a kernel source, compiled once per kernel level; its
// entry point is to_srgb8() in image.cpp.
#include "srgb_encode.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace smoketrace {

template <simd::Level L>
void detail::to_srgb8_at_level(const ImageRgba& image, int channels, std::uint8_t* samples) {
    static_assert(L == simd::kCompiledLevel);
    const SrgbEncodeTable& e = srgb_encode_table();
    const std::size_t c = std::size_t(channels);
    // Each pixel on its own: the same bytes on any number of threads.
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, image.pixels.size(), 1 << 14),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t i = r.begin(); i < r.end(); ++i) {
                              const glm::vec4 p = image.pixels[i];
                              std::uint8_t* o = samples + i * c;
                              o[0] = srgb8_code(e, p.x);
                              o[1] = srgb8_code(e, p.y);
                              o[2] = srgb8_code(e, p.z);
                              if (c == 4) o[3] = unorm8(p.w);
                          }
                      });
}

// This copy's loop (core/simd/dispatch.hpp).
template void detail::to_srgb8_at_level<simd::kCompiledLevel>(const ImageRgba&, int, std::uint8_t*);

}  // namespace smoketrace
