#pragma once
// The PNG writer's row filter (png_io.cpp): a kernel, compiled in png_filter.cpp once per kernel level
// (core/simd/dispatch.hpp); the writer runs it at the process's level.
#include <smoketrace/core/simd/level.hpp>

#include <cstddef>
#include <cstdint>

namespace smoketrace::detail {

// Rows top to bottom of `channels` 8-bit samples per pixel, `stride` = width · channels bytes each, into
// `out`: each row as the PNG specification's filter type 4 (Paeth) stores it, its filter-type byte first,
// height · (stride + 1) bytes in all.
template <simd::Level L>
void paeth_filter_rows_at_level(const std::uint8_t* data, std::size_t stride, std::size_t height,
                                std::size_t channels, std::uint8_t* out);

}  // namespace smoketrace::detail
