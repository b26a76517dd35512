// Image files by kind (see image_files.hpp).
#include <smoketrace/io/image_files.hpp>

#include <smoketrace/io/exr_io.hpp>
#include <smoketrace/io/output_path.hpp>
#include <smoketrace/io/pfm_io.hpp>

#include <algorithm>
#include <cctype>
#include <stdexcept>
#include <string>

#include <sys/stat.h>

namespace smoketrace {

namespace fs = std::filesystem;

std::string_view to_string(ImageFileKind kind) {
    switch (kind) {
        case ImageFileKind::png: return "PNG";
        case ImageFileKind::exr: return "EXR";
        case ImageFileKind::pfm: return "PFM";
    }
    return "?";
}

std::optional<ImageFileKind> image_file_kind(const fs::path& path) {
    std::string extension = path.extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (extension == ".png") return ImageFileKind::png;
    if (extension == ".exr") return ImageFileKind::exr;
    if (extension == ".pfm") return ImageFileKind::pfm;
    return std::nullopt;
}

ImageFileKind output_image_kind(const fs::path& path) {
    if (const auto kind = image_file_kind(path)) return *kind;
    if (path == kStandardOutputPath) return ImageFileKind::png;
    struct stat st{};
    if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode)) return ImageFileKind::png;
    throw OutputPathError("'" + path.string() + "' names no kind of image: the name must end in " +
                          std::string(kImageFileKindsText));
}

void ImageFileWriter::write(const fs::path& path, const ImageRgba& image) {
    switch (output_image_kind(path)) {
        case ImageFileKind::png: png_.write_srgb(path, image); return;
        case ImageFileKind::exr: write_exr(path, image); return;
        case ImageFileKind::pfm: write_pfm(path, image); return;
    }
}

void write_image(const fs::path& path, const ImageRgba& image) { ImageFileWriter().write(path, image); }

ImageRgba read_float_image(const fs::path& path) {
    const auto kind = image_file_kind(path);
    if (kind == ImageFileKind::exr) return read_exr(path);
    if (kind == ImageFileKind::pfm) return read_pfm(path);
    throw std::runtime_error("cannot read '" + path.string() + "' as a float image: " +
                             (kind ? "a PNG holds 8-bit sRGB, not the linear radiance; " : "") +
                             "the name must end in .exr or .pfm");
}

}  // namespace smoketrace
