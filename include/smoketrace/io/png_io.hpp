#pragma once
// PNG files in (stb_image) and out (our encoder over zlib, png_io.cpp).
//
// The PNG is encoded in memory, then handed to write_output() (output_path.hpp): a regular file is
// replaced whole or not at all (temporary file beside it, renamed over it), a symbolic link is followed,
// an existing FIFO or device is written as it is, and the path "-" is standard output. Every failure
// throws std::runtime_error whose message names the path and the problem.
#include <smoketrace/core/image.hpp>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

namespace smoketrace {

enum class PngChannels { rgb = 3, rgba = 4 };

// Writes PNG files (the functions below), keeping its working memory from one image to the next: the
// 8-bit samples, the filtered rows, zlib's stream and the file's bytes, ~2.5x the image in 8-bit. Fresh
// memory costs a page fault per 4 KiB on first touch, about as much as the encoding itself (bench section
// "output"); a frame sequence written through one writer pays that once. The free functions use a
// writer of their own. One writer per thread; a moved-from writer starts over with fresh memory.
class PngWriter {
public:
    PngWriter();
    ~PngWriter();
    PngWriter(PngWriter&&) noexcept;
    PngWriter& operator=(PngWriter&&) noexcept;

    void write_srgb(const std::filesystem::path& path, const ImageRgba& image, PngChannels channels = PngChannels::rgb);
    void write_rgba8(const std::filesystem::path& path, int width, int height, const std::uint8_t* rgba);
    void write_rgba8(const std::filesystem::path& path, const Rgba8Image& image);
    // The PNG file's bytes, for a caller that writes them with others (write_outputs_together()); valid
    // until the writer's next call. `path` names the file in messages.
    [[nodiscard]] const std::string& encode_rgba8(const std::filesystem::path& path, const Rgba8Image& image);

private:
    struct Buffers;
    Buffers& buffers();
    std::unique_ptr<Buffers> buffers_;
};

// Linear image -> 8-bit sRGB PNG (RGB through the sRGB transfer function, alpha stored linearly when
// kept). Throws, naming the path and the first offending pixel, if any pixel is NaN or infinite: a
// non-finite pixel is a renderer bug and must not be hidden by the clamp to [0, 1].
void write_png_srgb(const std::filesystem::path& path, const ImageRgba& image,
                    PngChannels channels = PngChannels::rgb);

// Raw RGBA8 bytes (width·height·4, top row first) -> RGBA PNG, written as given (no colour conversion).
void write_png_rgba8(const std::filesystem::path& path, int width, int height, const std::uint8_t* rgba);
void write_png_rgba8(const std::filesystem::path& path, const Rgba8Image& image);

// Reads any 8- or 16-bit PNG as RGBA8 (grey and RGB gain opaque alpha; 16-bit is rounded to 8).
// Throws std::runtime_error naming the file and the problem: cannot be read (errno text), not a PNG
// (signature), truncated or corrupt (chunk structure and CRCs are checked before decoding), not
// decodable (stb's failure reason), or, with the second overload, not of the expected size. Sizes are
// checked against the header before the pixels are decoded: a file of a few megabytes can decode to
// gigabytes.
[[nodiscard]] Rgba8Image read_png_rgba8(const std::filesystem::path& path);
[[nodiscard]] Rgba8Image read_png_rgba8(const std::filesystem::path& path, int expected_width, int expected_height);
// As the first overload, but an image wider than `max_width` or taller than `max_height` is refused (a
// texture's limits: the whole-image limit kMaxImageSide holds 16384x16384, 1 GB decoded).
[[nodiscard]] Rgba8Image read_png_rgba8_at_most(const std::filesystem::path& path, int max_width, int max_height);

}  // namespace smoketrace
