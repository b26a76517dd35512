#pragma once
// OpenEXR files (ILM's high-dynamic-range format, what pbrt, Mitsuba and compositing tools read), through
// the OpenEXR library.
//
// The writer stores the R, G and B of an ImageRgba as 32-bit float channels, ZIP-compressed (lossless), one
// part, scan lines top to bottom. Float, not half: half keeps 11 significant bits (a relative step of 2^-11,
// ~5e-4) and nothing above 65504, so a frame written as half would not be the frame the renderer computed,
// and the error of a method measured against a truth read back from half would include the rounding of
// both. In float the round trip is exact, bit for bit. Alpha is not written: the renderer's frames are
// opaque (alpha 1 everywhere), and a constant channel says nothing. The file is encoded in memory and handed
// to write_output() (output_path.hpp): whole or not at all.
//
// The reader takes any scan-line or tiled single-part EXR with R, G and B channels (half, float or uint:
// converted to float by OpenEXR; A read when present, else 1), its data window as the image.
//
// As for PFM (pfm_io.hpp), only finite values are written or read; negative values, negative zero and
// subnormals pass through unchanged.
#include <smoketrace/core/image.hpp>

#include <filesystem>

namespace smoketrace {

// Writes the RGB of `image` to `path` as an OpenEXR file of float channels. Throws std::runtime_error
// naming the path and the problem: an empty image, a non-finite pixel (its coordinates), OpenEXR's
// failure to encode, or the write's failure.
void write_exr(const std::filesystem::path& path, const ImageRgba& image);

// Reads an OpenEXR file as linear RGBA. Throws std::runtime_error naming the file and the problem: cannot be
// read, not an EXR (magic number), a multi-part or deep file, a data window outside [1, kMaxImageSide] a
// side or over kMaxImagePixels pixels (checked on the header before OpenEXR allocates anything), a missing
// R, G or B channel, truncated (pixels missing), OpenEXR's reason for refusing it, or a non-finite value
// (its pixel).
[[nodiscard]] ImageRgba read_exr(const std::filesystem::path& path);

}  // namespace smoketrace
