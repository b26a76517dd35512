#pragma once
// What a float image file (EXR, PFM) may hold, checked alike by their writers and readers: an image whose
// pixel count matches its size, and finite radiance (a NaN or an infinity in a frame or a truth is a fault
// upstream, and any error measured against it would be meaningless). The messages name the file and the
// first offending pixel, row by row. Internal to the io layer (src/io/), not installed.
#include <smoketrace/core/image.hpp>

#include <cmath>
#include <cstddef>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace smoketrace::float_image {

[[noreturn]] inline void write_error(const std::filesystem::path& path, const std::string& problem) {
    throw std::runtime_error("cannot write '" + path.string() + "': " + problem);
}

[[noreturn]] inline void read_error(const std::filesystem::path& path, const std::string& problem) {
    throw std::runtime_error("cannot read '" + path.string() + "': " + problem);
}

inline std::string pixel_name(std::size_t x, std::size_t y) {
    return "pixel (" + std::to_string(x) + ", " + std::to_string(y) + ")";
}

// Before writing `image` as a file of `kind` ("EXR", "PFM"): throws write_error() unless its size is that of
// its pixels and its colour channels are finite (alpha is not written).
inline void check_writable(const std::filesystem::path& path, const ImageRgba& image, const char* kind) {
    if (image.width < 1 || image.height < 1 ||
        image.pixels.size() != std::size_t(image.width) * std::size_t(image.height))
        write_error(path, "image size " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                              " with " + std::to_string(image.pixels.size()) + " pixels is not " + kind + " image");
    const std::size_t width = std::size_t(image.width);
    for (std::size_t i = 0; i < image.pixels.size(); ++i) {
        const glm::vec4 p = image.pixels[i];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
            write_error(path, pixel_name(i % width, i / width) + " is not finite");
    }
}

}  // namespace smoketrace::float_image
