// libFuzzer target for the texture reader: read_png_rgba8() and its bounded forms (png_io.hpp), and a
// six-way texture built from what they read (load_sixway_texture(), sixway_files.hpp).
//
// Contract checked on every input:
//  * each reader either returns an image or throws std::runtime_error naming the file; any other exception
//    escapes and libFuzzer reports it as a crash, as are sanitizer findings;
//  * an image read has a size within [1, kMaxImageSide] and exactly width·height·4 bytes; the bounded form
//    returns only images within its bound, and the same pixels as the unbounded one;
//  * the six-way texture of the image as both atlases, one frame, either loads or fails naming the file.
//
// Most mutations of a PNG break a chunk's CRC, which the reader checks first; so that the fuzzer also reaches
// the decoder, an input of odd length has every complete chunk's CRC recomputed before it is written.
// Build and run: scripts/fuzz.sh (clang, -DSMOKETRACE_FUZZ=ON, build-fuzz/); seed corpus: tests/fuzz/corpus_png/.
#include <smoketrace/io/png_io.hpp>
#include <smoketrace/io/sixway_files.hpp>

#include <zlib.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <unistd.h>

using namespace smoketrace;

namespace {

// Small enough that the bound is met by inputs of a few kilobytes (a deflate stream expands ~1000:1).
constexpr int kFuzzBound = 512;

[[noreturn]] void violated(const char* what, const std::string& detail = {}) {
    std::fprintf(stderr, "fuzz_png_texture: %s %s\n", what, detail.c_str());
    std::abort();
}

const std::filesystem::path& texture_path() {
    static const std::filesystem::path path = [] {
        auto folder = std::filesystem::temp_directory_path() / ("smoketrace_fuzz_png_" + std::to_string(::getpid()));
        std::filesystem::create_directories(folder);
        return folder / "texture.png";
    }();
    return path;
}

std::uint32_t read_be32(const std::uint8_t* p) {
    return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | std::uint32_t(p[3]);
}

// Every complete chunk after the signature gets the CRC of its type and data.
void fix_crcs(std::vector<std::uint8_t>& png) {
    for (std::size_t at = 8; at <= png.size() && png.size() - at >= 12;) {
        const std::uint64_t length = read_be32(&png[at]);
        if (length > png.size() - at - 12) return;
        const auto crc = std::uint32_t(crc32(0, &png[at + 4], uInt(4 + length)));
        for (int i = 0; i < 4; ++i) png[at + 8 + length + std::size_t(i)] = std::uint8_t(crc >> (24 - 8 * i));
        at += 12 + std::size_t(length);
    }
}

void check_image(const Rgba8Image& image, int max_width, int max_height) {
    if (image.width < 1 || image.height < 1 || image.width > max_width || image.height > max_height)
        violated("image size outside the bound:", std::to_string(image.width) + "x" + std::to_string(image.height));
    if (image.pixels.size() != std::size_t(image.width) * std::size_t(image.height) * 4)
        violated("pixel buffer size does not match the image size");
}

void check_message(const std::runtime_error& e, const std::filesystem::path& path) {
    if (std::string_view(e.what()).find(path.string()) == std::string_view::npos)
        violated("error message without the file name:", e.what());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    std::vector<std::uint8_t> bytes(data, data + size);
    if (size % 2 == 1) fix_crcs(bytes);
    const std::filesystem::path& path = texture_path();
    std::ofstream(path, std::ios::binary | std::ios::trunc)
        .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    std::optional<Rgba8Image> whole;
    try {
        whole = read_png_rgba8(path);
        check_image(*whole, kMaxImageSide, kMaxImageSide);
    } catch (const std::runtime_error& e) {
        check_message(e, path);
    }
    try {
        const Rgba8Image bounded = read_png_rgba8_at_most(path, kFuzzBound, kFuzzBound);
        check_image(bounded, kFuzzBound, kFuzzBound);
        if (!whole || bounded.pixels != whole->pixels) violated("the bounded reader reads other pixels");
    } catch (const std::runtime_error& e) {
        check_message(e, path);
        if (whole && whole->width <= kFuzzBound && whole->height <= kFuzzBound)
            violated("the bounded reader refuses an image within its bound:", e.what());
    }
    if (whole) {
        try {
            const Rgba8Image same = read_png_rgba8(path, whole->width, whole->height);
            if (same.pixels != whole->pixels) violated("the expected-size reader reads other pixels");
        } catch (const std::runtime_error& e) {
            violated("the expected-size reader refuses the image's own size:", e.what());
        }
    }
    try {
        (void)load_sixway_texture(path, path, SixwayAtlasGrid{1, 1, 1});
    } catch (const std::runtime_error& e) {
        check_message(e, path);
    }
    return 0;
}
