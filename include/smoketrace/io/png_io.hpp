#pragma once
// PNG files in (stb_image) and out (our encoder over zlib, png_io.cpp), and animated PNGs out.
//
// The PNG is encoded in memory, then handed to write_output() (output_path.hpp): a regular file is
// replaced whole or not at all (temporary file beside it, renamed over it), a symbolic link is followed,
// an existing FIFO or device is written as it is, and the path "-" is standard output. Every failure
// throws std::runtime_error whose message names the path and the problem.
#include <smoketrace/core/image.hpp>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <ostream>
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
    friend class ApngWriter;  // encodes its frames with a writer's buffers
    struct Buffers;
    Buffers& buffers();
    std::unique_ptr<Buffers> buffers_;
};

// An animated PNG (APNG: the acTL, fcTL and fdAT chunks of the PNG extension that browsers play), written
// frame by frame to a stream: each frame is compressed and written as it comes, so a sequence costs one
// frame's memory, not the sequence's. The first frame is also the file's ordinary image (IDAT), which a
// viewer that does not animate shows. Frames are 8-bit sRGB RGB, encoded as write_png_srgb() encodes a
// frame, shown for 1/fps s each and looped for ever. The bytes depend on the frames' pixels only.
// Errors throw std::runtime_error naming `path`; the stream is then incomplete, and write_output()
// (output_path.hpp) discards it.
class ApngWriter {
public:
    // Writes the signature, IHDR and acTL to `out`. Throws unless the size is within [1, kMaxImageSide],
    // frames >= 1 and fps within [1, 65535] (the fcTL's 16-bit delay denominator).
    ApngWriter(std::ostream& out, std::filesystem::path path, int width, int height, std::uint32_t frames,
               std::uint32_t fps);
    // Writes the next frame. Throws on a frame of another size, a non-finite pixel, a frame beyond the
    // count given, or a stream that failed (a full disk stops the sequence at that frame).
    void add_srgb(const ImageRgba& frame);
    // Writes IEND. Throws unless every frame announced was added.
    void finish();

private:
    void put(const std::string& bytes);
    std::ostream& out_;
    std::filesystem::path path_;
    int width_, height_;
    std::uint32_t frames_, fps_;
    std::uint32_t added_ = 0;
    std::uint32_t sequence_ = 0;  // fcTL and fdAT chunks share one count, from 0 (APNG specification)
    PngWriter encoder_;
    std::string chunks_;
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
