#pragma once
// Portable Float Map files: linear RGB radiance as 32-bit floats, bit for bit, in the simplest format that
// holds it (pbrt, Mitsuba, HDR tools and numpy read it in a few lines). The file is a text header
//
//   PF\n<width> <height>\n<scale>\n
//
// then width·height·3 floats, RGB per pixel, rows from the BOTTOM of the image to the top; the sign of
// the scale gives the byte order (negative: little-endian). "Pf" in place of "PF" is a one-channel map.
//
// The writer writes "PF", scale -1 and little-endian floats; the RGB of an ImageRgba exactly as it holds
// them (alpha, which the format has no room for, is dropped: the renderer's frames are opaque). The file goes
// through write_output() (output_path.hpp): whole or not at all. The reader takes "PF" and "Pf" in either
// byte order and ignores the scale's magnitude (it is no part of the values), so a file this writer wrote
// reads back bit for bit.
//
// Only finite values are written or read: a NaN or an infinity in a frame is a renderer bug, and one read
// from a file would poison every error figure computed with it (RMSE, PSNR), so both refuse it, naming the
// pixel. Negative values, negative zero and subnormals pass through unchanged.
#include <smoketrace/core/image.hpp>

#include <filesystem>

namespace smoketrace {

// Writes the RGB of `image` to `path` as a little-endian PFM. Throws std::runtime_error naming the path and
// the problem: an empty image, a non-finite pixel (its coordinates), or the write's failure.
void write_pfm(const std::filesystem::path& path, const ImageRgba& image);

// Reads a PFM file as linear RGB with alpha 1 ("Pf": the one channel in R, G and B). Throws
// std::runtime_error naming the file and the problem: cannot be read, not a PFM (the "PF"/"Pf" magic is
// missing), a header field that is not a number or out of range (width or height outside
// [1, kMaxImageSide], more than kMaxImagePixels pixels, a zero or non-finite scale), data shorter or longer
// than the header says (truncated), or a non-finite value (its pixel).
[[nodiscard]] ImageRgba read_pfm(const std::filesystem::path& path);

}  // namespace smoketrace
