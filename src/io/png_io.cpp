// PNG reading and writing, and all-or-nothing file writes (see png_io.hpp).
#include <smoketrace/io/png_io.hpp>

#include <smoketrace/core/simd/dispatch.hpp>
#include <smoketrace/io/file_bytes.hpp>
#include <smoketrace/io/output_path.hpp>

#include <stb_image.h>
#include <zlib.h>

#include "png_filter.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <memory>
#include <ostream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace smoketrace {

namespace fs = std::filesystem;

namespace {

// Files larger than this are refused before reading: stb takes the length as an int, and no texture or
// render smoketrace deals with comes near it.
constexpr std::size_t kMaxPngFileBytes = std::size_t(1) << 30;

[[noreturn]] void write_error(const fs::path& path, const std::string& problem) {
    throw std::runtime_error("cannot write '" + path.string() + "': " + problem);
}

[[noreturn]] void read_error(const fs::path& path, const std::string& problem) {
    throw std::runtime_error("cannot read '" + path.string() + "': " + problem);
}

void check_png_size(const fs::path& path, int width, int height) {
    if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide)
        write_error(path, "image size " + std::to_string(width) + "x" + std::to_string(height) +
                              " is outside [1, " + std::to_string(kMaxImageSide) + "]");
}

// --- PNG structure check -------------------------------------------------------------------------------
// stb_image reads past the end of a truncated file as zeros and reports whatever that leads to, and it
// ignores chunk CRCs. Walking the chunk list first turns "truncated" and "corrupt" into plain messages.

constexpr std::array<std::uint8_t, 8> kPngSignature{137, 80, 78, 71, 13, 10, 26, 10};

// A chunk's CRC (PNG specification 5.5: ISO 3309 / ITU-T V.42, reflected polynomial 0xEDB88320, over the
// chunk's type and data): zlib's crc32(), the library the writer deflates with.
std::uint32_t chunk_crc(const std::uint8_t* data, std::size_t size) {
    uLong crc = crc32(0, nullptr, 0);
    for (std::size_t done = 0; done < size;) {  // zlib counts in uInt
        const uInt n = uInt(std::min<std::size_t>(size - done, std::size_t(1) << 30));
        crc = crc32(crc, data + done, n);
        done += n;
    }
    return std::uint32_t(crc);
}

std::uint32_t read_be32(const std::uint8_t* p) {
    return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | std::uint32_t(p[3]);
}

std::string chunk_name(const std::uint8_t* type) {
    std::string name;
    for (int i = 0; i < 4; ++i) {
        const char c = char(type[i]);
        name += (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') ? std::string(1, c) : "?";
    }
    return name;
}

// Throws (naming the file) unless `bytes` is a PNG whose chunks are complete, whose CRCs match, which
// starts with IHDR and reaches IEND, and whose size is within kMaxImageSide.
void check_png_structure(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
    if (bytes.size() < kPngSignature.size() || std::memcmp(bytes.data(), kPngSignature.data(), kPngSignature.size()) != 0)
        read_error(path, "not a PNG file (the PNG signature is missing)");
    std::size_t at = kPngSignature.size();
    bool first = true;
    while (true) {
        if (bytes.size() - at < 8)
            read_error(path, "truncated PNG: the file ends at byte " + std::to_string(bytes.size()) +
                                 " before the IEND chunk");
        const std::uint32_t length = read_be32(&bytes[at]);
        const std::uint8_t* type = &bytes[at + 4];
        const std::string name = chunk_name(type);
        if (length > 0x7FFF'FFFFu)  // the PNG specification's limit on a chunk length
            read_error(path, "corrupt PNG: chunk '" + name + "' at byte " + std::to_string(at) + " has an invalid length");
        const std::size_t needed = 12 + std::size_t(length);  // length, type, data, CRC
        if (bytes.size() - at < needed)
            read_error(path, "truncated PNG: chunk '" + name + "' at byte " + std::to_string(at) + " needs " +
                                 std::to_string(needed) + " bytes, the file has " + std::to_string(bytes.size() - at) + " left");
        const std::uint32_t stored = read_be32(&bytes[at + 8 + length]);
        const std::uint32_t computed = chunk_crc(type, 4 + std::size_t(length));
        if (stored != computed)
            read_error(path, "corrupt PNG: CRC mismatch in chunk '" + name + "' at byte " + std::to_string(at));
        if (first) {
            if (name != "IHDR" || length < 8) read_error(path, "corrupt PNG: the first chunk is not a valid IHDR");
            const std::uint32_t w = read_be32(type + 4), h = read_be32(type + 8);
            if (w < 1 || h < 1 || w > std::uint32_t(kMaxImageSide) || h > std::uint32_t(kMaxImageSide))
                read_error(path, "PNG size " + std::to_string(w) + "x" + std::to_string(h) + " is outside [1, " +
                                     std::to_string(kMaxImageSide) + "]");
            first = false;
        }
        at += needed;
        if (name == "IEND") return;
    }
}

// --- PNG encoding -------------------------------------------------------------------------------------
// A PNG is the signature, then chunks: IHDR (size and pixel format), one IDAT (the zlib stream of the
// filtered rows), IEND. Each row is Paeth-filtered (png_filter.cpp; filter type 4: every byte minus the
// prediction from its left, upper and upper-left neighbours), which on rendered smoke and sky leaves long
// runs of small values; zlib's run-length strategy compresses those well and several times faster than its
// default strategy (bench section "output").

// The inverse of read_be32(): PNG stores every number big-endian.
void store_be32(std::uint8_t* p, std::uint32_t v) {
    for (int k = 0; k < 4; ++k) p[k] = std::uint8_t(v >> (24 - 8 * k));
}

void append_be32(std::string& out, std::uint32_t v) {
    for (int shift = 24; shift >= 0; shift -= 8) out.push_back(char((v >> shift) & 0xFFu));
}

void append_chunk(std::string& out, const char (&type)[5], const std::uint8_t* data, std::size_t size) {
    append_be32(out, std::uint32_t(size));
    const std::size_t type_at = out.size();
    out.append(type, 4);
    if (size > 0) out.append(reinterpret_cast<const char*>(data), size);
    const auto* typed = reinterpret_cast<const std::uint8_t*>(out.data() + type_at);
    append_be32(out, chunk_crc(typed, 4 + size));
}

// The signature and the IHDR chunk of a `width` x `height` image of `channels` 8-bit samples per pixel.
void append_png_start(std::string& out, int width, int height, int channels) {
    static constexpr std::uint8_t kColourType[5] = {0, 0, 4, 2, 6};  // by channel count
    out.append(reinterpret_cast<const char*>(kPngSignature.data()), kPngSignature.size());
    std::array<std::uint8_t, 13> header{};
    store_be32(&header[0], std::uint32_t(width));
    store_be32(&header[4], std::uint32_t(height));
    header[8] = 8;  // bits per sample
    header[9] = kColourType[channels];
    // [10..12]: compression 0 (zlib), filter method 0 (the five adaptive filters), no interlace
    append_chunk(out, "IHDR", header.data(), header.size());
}

void check_finite(const fs::path& path, const ImageRgba& image) {
    for (std::size_t i = 0; i < image.pixels.size(); ++i) {
        const glm::vec4 p = image.pixels[i];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(p.w))
            write_error(path, "pixel (" + std::to_string(i % std::size_t(image.width)) + ", " +
                                  std::to_string(i / std::size_t(image.width)) + ") is not finite");
    }
}

}  // namespace

// The writer's working memory (see PngWriter): reused from one image to the next, grown when an image
// needs more. The filter and deflate buffers are left uninitialised (plain new[]): every byte is written
// before it is read, and zeroing them would cost a third of the encoding time.
struct PngWriter::Buffers {
    struct Bytes {
        std::unique_ptr<std::uint8_t[]> data;
        std::size_t capacity = 0;
        std::uint8_t* reserve(std::size_t n) {
            if (n > capacity) {
                data.reset(new std::uint8_t[n]);
                capacity = n;
            }
            return data.get();
        }
    };
    std::vector<std::uint8_t> samples;  // write_srgb's 8-bit samples
    Bytes filtered, compressed;
    std::string png;  // the file's bytes
    // zlib's stream, made at the first image and reset for the next (its state is ~270 KiB of zlib's).
    // zlib's state points back at `z`, so Buffers never moves: PngWriter holds it by pointer.
    z_stream z{};
    bool z_ready = false;

    Buffers() = default;
    Buffers(const Buffers&) = delete;
    Buffers& operator=(const Buffers&) = delete;
    ~Buffers() {
        if (z_ready) deflateEnd(&z);
    }

    // The zlib stream of `data`'s filtered rows (rows top to bottom, `channels` 8-bit samples per pixel: 1
    // grey, 2 grey and alpha, 3 RGB, 4 RGBA) into `compressed`; returns its size. The same bytes for the
    // same pixels on every run, whatever the writer encoded before.
    std::size_t deflate_rows(const fs::path& path, int width, int height, int channels, const std::uint8_t* data);
    // The PNG file of `data` (as above) into `png`.
    void encode(const fs::path& path, int width, int height, int channels, const std::uint8_t* data);
    void write(const fs::path& path, int width, int height, int channels, const std::uint8_t* data) {
        encode(path, width, height, channels, data);
        write_output(path, [&](std::ostream& out) { out.write(png.data(), std::streamsize(png.size())); });
    }
};

std::size_t PngWriter::Buffers::deflate_rows(const fs::path& path, int width, int height, int channels,
                                             const std::uint8_t* data) {
    // zlib counts in 32 bits: the largest image, with its filter bytes, must fit (1 GiB does).
    static_assert(std::uint64_t(kMaxImageSide) * (std::uint64_t(kMaxImageSide) * 4 + 1) < (std::uint64_t(1) << 31));
    const std::size_t stride = std::size_t(width) * std::size_t(channels);
    const std::size_t filtered_size = std::size_t(height) * (stride + 1);
    std::uint8_t* const rows = filtered.reserve(filtered_size);
    simd::at_active_level([&]<simd::Level L> {
        detail::paeth_filter_rows_at_level<L>(data, stride, std::size_t(height), std::size_t(channels), rows);
    });

    // deflateReset() starts a stream exactly as a fresh deflateInit2() with the same settings would: the
    // same bytes as a writer of its own.
    const int started = z_ready ? deflateReset(&z) : deflateInit2(&z, Z_DEFAULT_COMPRESSION, Z_DEFLATED, 15, 8, Z_RLE);
    if (started != Z_OK) write_error(path, "PNG encoding failed: zlib could not start");
    z_ready = true;
    const uLong bound = deflateBound(&z, uLong(filtered_size));
    std::uint8_t* const stream = compressed.reserve(bound);
    z.next_in = rows;
    z.avail_in = uInt(filtered_size);
    z.next_out = stream;
    z.avail_out = uInt(bound);
    const int status = deflate(&z, Z_FINISH);  // one call: the output has deflateBound's room
    if (status != Z_STREAM_END) write_error(path, "PNG encoding failed: zlib status " + std::to_string(status));
    return z.total_out;
}

void PngWriter::Buffers::encode(const fs::path& path, int width, int height, int channels, const std::uint8_t* data) {
    const std::size_t compressed_size = deflate_rows(path, width, height, channels, data);
    png.clear();
    append_png_start(png, width, height, channels);
    append_chunk(png, "IDAT", compressed.data.get(), compressed_size);
    append_chunk(png, "IEND", nullptr, 0);
}


PngWriter::PngWriter() : buffers_(std::make_unique<Buffers>()) {}
PngWriter::~PngWriter() = default;
PngWriter::PngWriter(PngWriter&&) noexcept = default;
PngWriter& PngWriter::operator=(PngWriter&&) noexcept = default;

PngWriter::Buffers& PngWriter::buffers() {
    if (!buffers_) buffers_ = std::make_unique<Buffers>();  // moved from: starts over
    return *buffers_;
}

void PngWriter::write_rgba8(const fs::path& path, int width, int height, const std::uint8_t* rgba) {
    check_png_size(path, width, height);
    if (rgba == nullptr) write_error(path, "no pixel data");
    buffers().write(path, width, height, 4, rgba);
}

void PngWriter::write_rgba8(const fs::path& path, const Rgba8Image& image) {
    const std::string& png = encode_rgba8(path, image);
    write_output(path, [&](std::ostream& out) { out.write(png.data(), std::streamsize(png.size())); });
}

const std::string& PngWriter::encode_rgba8(const fs::path& path, const Rgba8Image& image) {
    check_png_size(path, image.width, image.height);
    if (image.pixels.size() != std::size_t(image.width) * std::size_t(image.height) * 4)
        write_error(path, "pixel buffer size does not match " + std::to_string(image.width) + "x" +
                              std::to_string(image.height) + " RGBA");
    Buffers& b = buffers();
    b.encode(path, image.width, image.height, 4, image.pixels.data());
    return b.png;
}

void PngWriter::write_srgb(const fs::path& path, const ImageRgba& image, PngChannels channels) {
    check_png_size(path, image.width, image.height);
    if (image.pixels.size() != std::size_t(image.width) * std::size_t(image.height))
        write_error(path, "pixel buffer size does not match " + std::to_string(image.width) + "x" +
                              std::to_string(image.height));
    check_finite(path, image);
    Buffers& b = buffers();
    to_srgb8(image, int(channels), b.samples);
    b.write(path, image.width, image.height, int(channels), b.samples.data());
}

// APNG specification 1.0 (https://wiki.mozilla.org/APNG_Specification): acTL before the first IDAT; each
// frame an fcTL then its data, the first frame's in IDAT, the others' in fdAT chunks that start with their
// sequence number; sequence numbers count fcTL and fdAT chunks together from 0, with no gap.
ApngWriter::ApngWriter(std::ostream& out, fs::path path, int width, int height, std::uint32_t frames,
                       std::uint32_t fps)
    : out_(out), path_(std::move(path)), width_(width), height_(height), frames_(frames), fps_(fps) {
    check_png_size(path_, width, height);
    if (frames < 1) write_error(path_, "an animated PNG needs at least one frame");
    if (fps < 1 || fps > 0xFFFFu) write_error(path_, "frame rate " + std::to_string(fps) + " is outside [1, 65535]");
    chunks_.clear();
    append_png_start(chunks_, width, height, 3);
    std::array<std::uint8_t, 8> control{};
    store_be32(&control[0], frames);  // num_frames
    // [4..7]: num_plays 0, loop for ever
    append_chunk(chunks_, "acTL", control.data(), control.size());
    put(chunks_);
}

void ApngWriter::put(const std::string& bytes) {
    out_.write(bytes.data(), std::streamsize(bytes.size()));
    if (!out_) write_error(path_, "write failed");
}

void ApngWriter::add_srgb(const ImageRgba& frame) {
    if (added_ == frames_)
        write_error(path_, "more frames than the " + std::to_string(frames_) + " the animated PNG announces");
    if (frame.width != width_ || frame.height != height_ ||
        frame.pixels.size() != std::size_t(frame.width) * std::size_t(frame.height))
        write_error(path_, "frame " + std::to_string(added_) + " is " + std::to_string(frame.width) + "x" +
                               std::to_string(frame.height) + ", the animated PNG " + std::to_string(width_) + "x" +
                               std::to_string(height_));
    check_finite(path_, frame);
    PngWriter::Buffers& b = encoder_.buffers();
    to_srgb8(frame, 3, b.samples);
    const std::size_t size = b.deflate_rows(path_, width_, height_, 3, b.samples.data());

    std::array<std::uint8_t, 26> control{};
    store_be32(&control[0], sequence_++);
    store_be32(&control[4], std::uint32_t(width_));
    store_be32(&control[8], std::uint32_t(height_));
    // [12..19]: x and y offset 0, every frame covers the whole image
    control[21] = 1;  // delay_num 1 over delay_den fps: each frame shows for 1/fps s
    control[22] = std::uint8_t(fps_ >> 8);
    control[23] = std::uint8_t(fps_);
    // [24], [25]: dispose_op none and blend_op source: each frame replaces the whole image
    chunks_.clear();
    append_chunk(chunks_, "fcTL", control.data(), control.size());
    if (added_ == 0) {
        append_chunk(chunks_, "IDAT", b.compressed.data.get(), size);
    } else {
        // fdAT's data is its sequence number, then the frame's zlib stream as an IDAT would hold it.
        std::uint8_t* const stream = b.compressed.data.get();
        b.filtered.reserve(size + 4);  // the rows are compressed: their buffer holds the chunk's data
        std::uint8_t* const data = b.filtered.data.get();
        store_be32(data, sequence_++);
        std::memcpy(data + 4, stream, size);
        append_chunk(chunks_, "fdAT", data, size + 4);
    }
    put(chunks_);
    ++added_;
}

void ApngWriter::finish() {
    if (added_ != frames_)
        write_error(path_, "the animated PNG announces " + std::to_string(frames_) + " frames, " +
                               std::to_string(added_) + " were written");
    chunks_.clear();
    append_chunk(chunks_, "IEND", nullptr, 0);
    put(chunks_);
    out_.flush();
    if (!out_) write_error(path_, "write failed");
}

void write_png_rgba8(const fs::path& path, int width, int height, const std::uint8_t* rgba) {
    PngWriter().write_rgba8(path, width, height, rgba);
}

void write_png_rgba8(const fs::path& path, const Rgba8Image& image) { PngWriter().write_rgba8(path, image); }

void write_png_srgb(const fs::path& path, const ImageRgba& image, PngChannels channels) {
    PngWriter().write_srgb(path, image, channels);
}

namespace {

// `bytes` (a whole PNG file) decoded, after check_png_structure() and `size_ok(width, height)` on stb's
// reading of its header, so that a size the caller refuses costs no decoding.
template <class SizeCheck>
Rgba8Image decode_png(const fs::path& path, const std::vector<std::uint8_t>& bytes, SizeCheck&& size_ok) {
    check_png_structure(path, bytes);
    int width = 0, height = 0, channels_in_file = 0;
    if (!stbi_info_from_memory(bytes.data(), int(bytes.size()), &width, &height, &channels_in_file)) {
        const char* reason = stbi_failure_reason();
        read_error(path, std::string("cannot decode PNG: ") + (reason ? reason : "unknown reason"));
    }
    size_ok(width, height);
    const std::unique_ptr<stbi_uc, void (*)(void*)> decoded(
        stbi_load_from_memory(bytes.data(), int(bytes.size()), &width, &height, &channels_in_file, 4), stbi_image_free);
    if (!decoded) {
        const char* reason = stbi_failure_reason();
        read_error(path, std::string("cannot decode PNG: ") + (reason ? reason : "unknown reason"));
    }
    Rgba8Image image(width, height);
    std::memcpy(image.pixels.data(), decoded.get(), image.pixels.size());
    return image;
}

}  // namespace

Rgba8Image read_png_rgba8(const fs::path& path) {
    return decode_png(path, read_file_bytes(path, kMaxPngFileBytes), [](int, int) {});
}

Rgba8Image read_png_rgba8(const fs::path& path, int expected_width, int expected_height) {
    return decode_png(path, read_file_bytes(path, kMaxPngFileBytes), [&](int width, int height) {
        if (width != expected_width || height != expected_height)
            read_error(path, "expected " + std::to_string(expected_width) + "x" + std::to_string(expected_height) +
                                 " pixels, the file has " + std::to_string(width) + "x" + std::to_string(height));
    });
}

Rgba8Image read_png_rgba8_at_most(const fs::path& path, int max_width, int max_height) {
    return decode_png(path, read_file_bytes(path, kMaxPngFileBytes), [&](int width, int height) {
        if (width > max_width || height > max_height)
            read_error(path, "PNG size " + std::to_string(width) + "x" + std::to_string(height) +
                                 " is larger than the limit of " + std::to_string(max_width) + "x" +
                                 std::to_string(max_height) + " for a texture");
    });
}

}  // namespace smoketrace
