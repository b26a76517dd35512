#pragma once
// Image files by kind: the one place where an image file's name decides what it holds. A rendered frame is
// written as 8-bit sRGB (PNG, png_io.hpp, for viewing) or as the linear radiance the renderer computed, in
// 32-bit floats (OpenEXR, exr_io.hpp, or Portable Float Map, pfm_io.hpp, for measuring); the extension of
// the output's name says which, in any case (out.EXR is an EXR).
#include <smoketrace/core/image.hpp>
#include <smoketrace/io/png_io.hpp>

#include <filesystem>
#include <optional>
#include <string_view>

namespace smoketrace {

enum class ImageFileKind { png, exr, pfm };

// "PNG", "EXR", "PFM": the kind as messages name it.
[[nodiscard]] std::string_view to_string(ImageFileKind kind);

// The kinds a name may end in, for messages.
inline constexpr std::string_view kImageFileKindsText =
    ".png (8-bit sRGB), .exr (OpenEXR, linear float) or .pfm (Portable Float Map, linear float)";

// The kind `path`'s extension names (.png, .exr, .pfm, in any case); nothing for any other or none.
[[nodiscard]] std::optional<ImageFileKind> image_file_kind(const std::filesystem::path& path);

// The kind write_image() writes at `path`: its extension's; PNG for standard output ("-") and for an existing
// file that is neither a regular file nor a folder (a FIFO, a device: a stream may have any name). Throws
// OutputPathError (output_path.hpp) naming the path and listing the kinds for any other name.
[[nodiscard]] ImageFileKind output_image_kind(const std::filesystem::path& path);

// Writes frames in the kind each path names (output_image_kind()); the PNG encoder's memory is kept from one
// frame to the next (PngWriter). PNG frames are opaque RGB, as write_png_srgb() writes them. Throws what the
// kind's writer throws: std::runtime_error naming the path and the problem (a non-finite pixel among them),
// with nothing written.
class ImageFileWriter {
public:
    void write(const std::filesystem::path& path, const ImageRgba& image);

private:
    PngWriter png_;
};

// ImageFileWriter().write(path, image): one frame.
void write_image(const std::filesystem::path& path, const ImageRgba& image);

// Reads a linear float image, EXR or PFM as the extension says (read_exr(), read_pfm()). A PNG, or any other
// name, is refused with std::runtime_error naming the file: a PNG holds 8-bit sRGB, not the radiance.
[[nodiscard]] ImageRgba read_float_image(const std::filesystem::path& path);

}  // namespace smoketrace
