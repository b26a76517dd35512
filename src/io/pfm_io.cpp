// Portable Float Map files in and out (see pfm_io.hpp).
#include <smoketrace/io/pfm_io.hpp>

#include <smoketrace/io/file_bytes.hpp>
#include <smoketrace/io/output_path.hpp>

#include "float_image_rules.hpp"

#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

namespace smoketrace {

namespace fs = std::filesystem;

using float_image::check_writable;
using float_image::pixel_name;
using float_image::read_error;
using float_image::write_error;

namespace {

// The header is a few dozen bytes; its three fields must be found within this many.
constexpr std::size_t kMaxHeaderBytes = 256;
// The largest file: the largest image of three floats per pixel, and its header.
constexpr std::uint64_t kMaxPfmFileBytes = kMaxImagePixels * 12 + kMaxHeaderBytes;

std::uint32_t byte_swapped(std::uint32_t bits) {
    return (bits >> 24) | ((bits >> 8) & 0xFF00u) | ((bits << 8) & 0xFF0000u) | (bits << 24);
}

// A float's bits as a little-endian file holds them, whatever the machine's byte order.
std::uint32_t little_endian(std::uint32_t bits) {
    return std::endian::native == std::endian::little ? bits : byte_swapped(bits);
}

bool is_pfm_space(std::uint8_t c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

// Reads the header's fields from `bytes`, from `at` on: each is preceded by white space (Netpbm's rule; the
// format's own files use one newline or space) and the last is followed by exactly one white-space byte,
// after which the data start.
class HeaderReader {
public:
    HeaderReader(const fs::path& path, const std::vector<std::uint8_t>& bytes, std::size_t at)
        : path_(path), bytes_(bytes), at_(at) {}

    // The next field's text.
    std::string field(const char* name) {
        const std::size_t end = std::min(bytes_.size(), kMaxHeaderBytes);
        const std::size_t spaces_from = at_;
        while (at_ < end && is_pfm_space(bytes_[at_])) ++at_;
        if (at_ == spaces_from) bad(name, "is not preceded by white space");
        const std::size_t from = at_;
        while (at_ < end && !is_pfm_space(bytes_[at_])) ++at_;
        if (at_ == from || at_ == end)
            read_error(path_, "truncated PFM header: the " + std::string(name) + " is missing");
        return std::string(reinterpret_cast<const char*>(bytes_.data()) + from, at_ - from);
    }
    int side(const char* name) {
        const std::string text = field(name);
        int value = 0;
        const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
        if (error != std::errc() || end != text.data() + text.size() || value < 1 || value > kMaxImageSide)
            bad(name, "'" + text + "' is not a whole number in [1, " + std::to_string(kMaxImageSide) + "]");
        return value;
    }
    float scale() {
        const std::string text = field("scale");
        float value = 0.0f;
        const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
        if (error != std::errc() || end != text.data() + text.size() || value == 0.0f || !std::isfinite(value))
            bad("scale", "'" + text + "' is not a non-zero finite number (its sign gives the byte order)");
        return value;
    }
    // Where the data start: after the one white-space byte that ends the header.
    std::size_t data_start() const { return at_ + 1; }

private:
    [[noreturn]] void bad(const char* name, const std::string& problem) {
        read_error(path_, "bad PFM header: the " + std::string(name) + " " + problem);
    }
    const fs::path& path_;
    const std::vector<std::uint8_t>& bytes_;
    std::size_t at_;
};

}  // namespace

void write_pfm(const fs::path& path, const ImageRgba& image) {
    check_writable(path, image, "a PFM");
    const std::size_t width = std::size_t(image.width);
    const std::string header = "PF\n" + std::to_string(image.width) + " " + std::to_string(image.height) + "\n-1\n";
    write_output(path, [&](std::ostream& out) {
        out.write(header.data(), std::streamsize(header.size()));
        std::vector<std::uint32_t> row(width * 3);
        // Bottom row first: the format's order, the opposite of ImageRgba's.
        for (int y = image.height - 1; y >= 0; --y) {
            for (std::size_t x = 0; x < width; ++x) {
                const glm::vec4& p = image.at(int(x), y);
                for (int c = 0; c < 3; ++c)
                    row[x * 3 + std::size_t(c)] = little_endian(std::bit_cast<std::uint32_t>(p[c]));
            }
            out.write(reinterpret_cast<const char*>(row.data()), std::streamsize(row.size() * 4));
        }
    });
}

ImageRgba read_pfm(const fs::path& path) {
    const std::vector<std::uint8_t> bytes = read_file_bytes(path, kMaxPfmFileBytes);
    if (bytes.size() < 2 || bytes[0] != 'P' || (bytes[1] != 'F' && bytes[1] != 'f'))
        read_error(path, "not a PFM file (it does not start with \"PF\" or \"Pf\")");
    const std::size_t channels = bytes[1] == 'F' ? 3 : 1;
    HeaderReader header(path, bytes, 2);
    const int width = header.side("width");
    const int height = header.side("height");
    const bool file_little_endian = header.scale() < 0.0f;
    const std::uint64_t pixels = std::uint64_t(width) * std::uint64_t(height);
    if (pixels > kMaxImagePixels)
        read_error(path, "PFM size " + std::to_string(width) + "x" + std::to_string(height) + " is more than " +
                             std::to_string(kMaxImagePixels) + " pixels");
    const std::size_t start = header.data_start();
    const std::uint64_t data_bytes = pixels * channels * 4;
    const std::uint64_t have = bytes.size() - std::min(bytes.size(), start);
    if (have != data_bytes)
        read_error(path, std::string(have < data_bytes ? "truncated PFM" : "PFM longer than its header says") +
                             ": a " + std::to_string(width) + "x" + std::to_string(height) + " image of " +
                             std::to_string(channels) + " channel" + (channels == 1 ? "" : "s") + " has " +
                             std::to_string(data_bytes) + " bytes of data, the file " + std::to_string(have));

    ImageRgba image(width, height, ImageRgba::Uninitialized{});
    const std::uint8_t* data = bytes.data() + start;
    const bool swap = file_little_endian != (std::endian::native == std::endian::little);
    for (int y = 0; y < height; ++y) {
        // Row y of the file is row height-1-y of the image (bottom to top).
        const std::uint8_t* row = data + std::size_t(y) * std::size_t(width) * channels * 4;
        for (int x = 0; x < width; ++x) {
            float rgb[3];
            for (std::size_t c = 0; c < channels; ++c) {
                std::uint32_t bits;
                std::memcpy(&bits, row + (std::size_t(x) * channels + c) * 4, 4);
                rgb[c] = std::bit_cast<float>(swap ? byte_swapped(bits) : bits);
                if (!std::isfinite(rgb[c]))
                    read_error(path, pixel_name(std::size_t(x), std::size_t(height - 1 - y)) + " is not finite");
            }
            if (channels == 1) rgb[1] = rgb[2] = rgb[0];
            image.at(x, height - 1 - y) = glm::vec4(rgb[0], rgb[1], rgb[2], 1.0f);
        }
    }
    return image;
}

}  // namespace smoketrace
