// Float image files: EXR and PFM hold the linear radiance the renderer computed, bit for bit. Written and read
// back exactly (EXR also through OpenEXR's own reader, PFM's bytes checked against the format by hand),
// including the values a careless writer loses (negative zero, subnormals, values above half's range); every
// bad file refused with a message naming the file; and the command line's -o x.pfm / x.exr equal to the
// image the library renders, its PNG the sRGB of the same floats.
#include "support/cli_runner.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

#include <smoketrace/core/image.hpp>
#include <smoketrace/io/exr_io.hpp>
#include <smoketrace/io/image_files.hpp>
#include <smoketrace/io/output_path.hpp>
#include <smoketrace/io/pfm_io.hpp>
#include <smoketrace/io/png_io.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>
#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/render/sixway_texture.hpp>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <sys/stat.h>

using namespace smoketrace;
using smoketrace::test::CliRun;
using smoketrace::test::file_bytes;
using smoketrace::test::message_of;
using smoketrace::test::run_cli;
using smoketrace::test::TempDir;
namespace fs = std::filesystem;

namespace {

std::uint32_t bits(float v) { return std::bit_cast<std::uint32_t>(v); }

// An image whose channels hold every kind of finite float: zero and negative zero, the smallest and a larger
// subnormal, ordinary radiance, values half cannot hold (above 65504, below its subnormals, more than 11
// significant bits), the largest float, and negative values. Each pixel's channels differ, so that a
// swapped channel or a flipped row shows.
ImageRgba awkward_image(int width, int height) {
    const float values[] = {0.0f,
                            -0.0f,
                            std::numeric_limits<float>::denorm_min(),
                            1.0e-40f,
                            0.18f,
                            1.0f / 3.0f,
                            65505.0f,
                            1.0e-9f,
                            std::numeric_limits<float>::max(),
                            -2.5f,
                            std::nextafter(1.0f, 2.0f),
                            std::numeric_limits<float>::min()};
    constexpr int n = int(sizeof values / sizeof values[0]);
    ImageRgba image(width, height);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            const int i = 3 * (y * width + x);
            image.at(x, y) = glm::vec4(values[i % n], values[(i + 1) % n], values[(i + 2) % n], 1.0f);
        }
    return image;
}

// Every RGB channel equal bit for bit, alpha 1 (the files hold no alpha).
void check_same_bits(const ImageRgba& read, const ImageRgba& written) {
    REQUIRE(read.width == written.width);
    REQUIRE(read.height == written.height);
    for (int y = 0; y < written.height; ++y)
        for (int x = 0; x < written.width; ++x)
            for (int c = 0; c < 3; ++c) {
                INFO("pixel (" << x << ", " << y << ") channel " << c);
                CHECK(bits(read.at(x, y)[c]) == bits(written.at(x, y)[c]));
            }
    for (const glm::vec4& p : read.pixels) CHECK(p.w == 1.0f);
}

std::string as_string(const std::vector<std::uint8_t>& bytes) { return {bytes.begin(), bytes.end()}; }

std::vector<std::uint8_t> bytes_of(const fs::path& path) {
    const std::string text = file_bytes(path);
    return {text.begin(), text.end()};
}

}  // namespace

TEST_CASE("float images: EXR and PFM read back bit for bit, 1x1 and 3x5", "[float_image]") {
    TempDir dir;
    for (const auto& [w, h] : {std::pair{1, 1}, std::pair{3, 5}}) {
        const ImageRgba image = awkward_image(w, h);
        const fs::path stem = dir.path / std::to_string(w);
        const fs::path exr = fs::path(stem).replace_extension(".exr");
        const fs::path pfm = fs::path(stem).replace_extension(".pfm");
        write_image(exr, image);
        write_image(pfm, image);
        check_same_bits(read_float_image(exr), image);
        check_same_bits(read_float_image(pfm), image);

        // OpenEXR's own reader: three float channels R, G, B, no alpha, the data window the image.
        Imf::InputFile file(exr.c_str());
        const Imf::ChannelList& channels = file.header().channels();
        int count = 0;
        for (auto c = channels.begin(); c != channels.end(); ++c, ++count) CHECK(c.channel().type == Imf::FLOAT);
        CHECK(count == 3);
        CHECK(channels.findChannel("A") == nullptr);
        const Imath::Box2i window = file.header().dataWindow();
        REQUIRE(window.min == Imath::V2i(0, 0));
        REQUIRE(window.max == Imath::V2i(w - 1, h - 1));
        std::vector<float> rgb(std::size_t(w * h) * 3);
        Imf::FrameBuffer frame;
        const char* names[3] = {"R", "G", "B"};
        for (int c = 0; c < 3; ++c)
            frame.insert(names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(rgb.data() + c), 3 * sizeof(float),
                                              3 * sizeof(float) * std::size_t(w)));
        file.setFrameBuffer(frame);
        file.readPixels(0, h - 1);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                for (int c = 0; c < 3; ++c)
                    CHECK(bits(rgb[std::size_t(3 * (y * w + x) + c)]) == bits(image.at(x, y)[c]));

        // The PFM by hand: the header, then little-endian floats from the bottom row up.
        const std::string bytes = file_bytes(pfm);
        const std::string header = "PF\n" + std::to_string(w) + " " + std::to_string(h) + "\n-1\n";
        REQUIRE(bytes.size() == header.size() + std::size_t(w * h) * 12);
        CHECK(bytes.compare(0, header.size(), header) == 0);
        for (int row = 0; row < h; ++row)
            for (int x = 0; x < w; ++x)
                for (int c = 0; c < 3; ++c) {
                    const auto* p = reinterpret_cast<const unsigned char*>(bytes.data()) + header.size() +
                                    std::size_t(12 * (row * w + x) + 4 * c);
                    const std::uint32_t le = std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 |
                                             std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
                    CHECK(le == bits(image.at(x, h - 1 - row)[c]));
                }
    }
}

TEST_CASE("float images: PFM variants other programs write are read", "[float_image]") {
    // A big-endian "PF" (positive scale, whose magnitude is no part of the values) and a one-channel "Pf",
    // with a Windows line end: 2x1 images, bottom row first (one row here).
    TempDir dir;
    std::string big = "PF\r\n2 1\r\n4.0\n";
    for (float v : {1.5f, -0.0f, 2.0f, 1.0e-40f, 0.25f, 3.0f}) {
        const std::uint32_t b = bits(v);
        for (int shift = 24; shift >= 0; shift -= 8) big.push_back(char((b >> shift) & 0xFF));
    }
    const ImageRgba a = read_pfm(dir.write("big.pfm", big));
    REQUIRE((a.width == 2 && a.height == 1));
    CHECK(a.at(0, 0) == glm::vec4(1.5f, -0.0f, 2.0f, 1.0f));
    CHECK(std::signbit(a.at(0, 0).y));
    CHECK(bits(a.at(1, 0).x) == bits(1.0e-40f));
    std::string grey = "Pf 1 2 -1 ";
    for (float v : {0.5f, 7.0f}) grey.append(reinterpret_cast<const char*>(&v), 4);  // little-endian machine
    const ImageRgba g = read_pfm(dir.write("grey.pfm", grey));
    CHECK(g.at(0, 0) == glm::vec4(7.0f, 7.0f, 7.0f, 1.0f));  // the top row is the file's last
    CHECK(g.at(0, 1) == glm::vec4(0.5f, 0.5f, 0.5f, 1.0f));
}

TEST_CASE("float images: EXR of half channels and with alpha is read", "[float_image]") {
    // Written by OpenEXR directly, as other programs write: half R, G, B and a float A, 2x2.
    TempDir dir;
    const fs::path path = dir.path / "half.exr";
    const half h[4][3] = {{half(0.5f), half(-0.0f), half(65504.0f)},
                          {half(1.0f), half(2.0f), half(3.0f)},
                          {half(0.25f), half(0.125f), half(6.0e-8f)},
                          {half(4.0f), half(5.0f), half(6.0f)}};
    const float alpha[4] = {1.0f, 0.5f, 0.0f, 0.25f};
    {
        Imf::Header header(2, 2);
        const char* names[3] = {"R", "G", "B"};
        Imf::FrameBuffer frame;
        for (int c = 0; c < 3; ++c) {
            header.channels().insert(names[c], Imf::Channel(Imf::HALF));
            frame.insert(names[c], Imf::Slice(Imf::HALF, (char*)&h[0][c], 3 * sizeof(half), 6 * sizeof(half)));
        }
        header.channels().insert("A", Imf::Channel(Imf::FLOAT));
        frame.insert("A", Imf::Slice(Imf::FLOAT, (char*)alpha, sizeof(float), 2 * sizeof(float)));
        Imf::OutputFile file(path.c_str(), header);
        file.setFrameBuffer(frame);
        file.writePixels(2);
    }
    const ImageRgba image = read_exr(path);
    REQUIRE((image.width == 2 && image.height == 2));
    for (int i = 0; i < 4; ++i)
        for (int c = 0; c < 3; ++c) CHECK(bits(image.pixels[std::size_t(i)][c]) == bits(float(h[i][c])));
    for (int i = 0; i < 4; ++i) CHECK(image.pixels[std::size_t(i)].w == alpha[i]);
}

TEST_CASE("float images: NaN and infinity are refused by writer and reader, naming the pixel", "[float_image]") {
    TempDir dir;
    ImageRgba image = awkward_image(3, 5);
    for (const float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
        image.at(2, 4).y = bad;
        for (const char* name : {"bad.exr", "bad.pfm"}) {
            INFO(name);
            const std::string message = message_of([&] { write_image(dir.path / name, image); });
            CHECK_THAT(message, Catch::Contains(name) && Catch::Contains("pixel (2, 4) is not finite"));
            CHECK_FALSE(fs::exists(dir.path / name));
        }
    }
    // A PFM holding a NaN in the top-left pixel: the file's last row.
    std::string pfm = "PF\n1 2\n-1\n";
    const float values[6] = {1.0f, 2.0f, 3.0f, 4.0f, std::numeric_limits<float>::quiet_NaN(), 6.0f};
    pfm.append(reinterpret_cast<const char*>(values), sizeof values);
    CHECK_THAT(message_of([&] { (void)read_pfm(dir.write("nan.pfm", pfm)); }),
               Catch::Contains("nan.pfm") && Catch::Contains("pixel (0, 0) is not finite"));
    // An existing file is kept whole when the new image is refused, and nothing is left beside it.
    write_image(dir.path / "keep.pfm", awkward_image(1, 1));
    const std::string before = file_bytes(dir.path / "keep.pfm");
    CHECK_THROWS(write_image(dir.path / "keep.pfm", image));
    CHECK(file_bytes(dir.path / "keep.pfm") == before);
    CHECK(std::distance(fs::directory_iterator(dir.path), fs::directory_iterator()) == 2);  // nan.pfm, keep.pfm
}

TEST_CASE("float images: bad PFM files are refused with a message naming the file", "[float_image]") {
    TempDir dir;
    write_pfm(dir.path / "good.pfm", awkward_image(3, 5));
    const std::string good = file_bytes(dir.path / "good.pfm");
    const auto refused = [&](const std::string& name, const std::string& bytes, const std::string& problem) {
        INFO(name);
        const fs::path path = dir.write(name, bytes);
        CHECK_THAT(message_of([&] { (void)read_float_image(path); }),
                   Catch::Contains(path.string()) && Catch::Contains(problem));
    };
    refused("magic.pfm", "P6\n3 5\n255\n", "not a PFM file");
    refused("empty.pfm", "", "not a PFM file");
    refused("truncated.pfm", good.substr(0, good.size() - 5), "truncated PFM");
    refused("header.pfm", "PF\n3", "truncated PFM header");
    refused("longer.pfm", good + "x", "longer than its header says");
    refused("width.pfm", "PF\nthree 5\n-1\n", "the width 'three' is not a whole number");
    refused("height.pfm", "PF\n3 0\n-1\n", "the height '0' is not a whole number in [1, 16384]");
    refused("side.pfm", "PF\n16385 1\n-1\n", "the width '16385' is not a whole number in [1, 16384]");
    // 16384² is a legal side each way but four times the pixel limit: refused before any data is read.
    refused("pixels.pfm", "PF\n16384 16384\n-1\n", "is more than 67108864 pixels");
    refused("scale.pfm", "PF\n3 5\n0\n", "the scale '0' is not a non-zero finite number");
    refused("missing.png", "", "a PNG holds 8-bit sRGB");
    CHECK_THAT(message_of([&] { (void)read_float_image(dir.path / "absent.pfm"); }),
               Catch::Contains("absent.pfm") && Catch::Contains("No such file"));
}

TEST_CASE("float images: bad EXR files are refused with a message naming the file", "[float_image]") {
    TempDir dir;
    write_exr(dir.path / "good.exr", awkward_image(3, 5));
    const std::vector<std::uint8_t> good = bytes_of(dir.path / "good.exr");
    const auto refused = [&](const std::string& name, const std::vector<std::uint8_t>& bytes,
                             const std::string& problem) {
        INFO(name);
        const fs::path path = dir.write(name, as_string(bytes));
        const std::string message = message_of([&] { (void)read_float_image(path); });
        CHECK_THAT(message, Catch::Contains(path.string()) && Catch::Contains(problem));
    };
    refused("magic.exr", {'P', 'F', '\n', '1'}, "not an OpenEXR file");
    // Cut in the header, and cut in the pixels (after the header and the offset table).
    refused("header.exr", std::vector<std::uint8_t>(good.begin(), good.begin() + 40), "truncated OpenEXR header");
    refused("pixels.exr", std::vector<std::uint8_t>(good.begin(), good.end() - 20), "the file ends before the data");
    // The data window made 16384² (xMax, yMax = 16383): refused on the header, before OpenEXR allocates.
    std::vector<std::uint8_t> huge = good;
    const std::string window = "dataWindow";
    const auto at = std::search(huge.begin(), huge.end(), window.begin(), window.end());
    REQUIRE(at != huge.end());
    const std::size_t value = std::size_t(at - huge.begin()) + window.size() + 1 + 6 + 4;  // "box2i\0", size
    for (std::size_t k : {value + 8, value + 12}) {
        const std::uint32_t v = 16383;
        std::memcpy(&huge[k], &v, 4);
    }
    refused("huge.exr", huge, "EXR size 16384x16384 is more than 67108864 pixels");
    // A file without R, G, B: one luminance channel Y.
    {
        Imf::Header header(1, 1);
        header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
        float y = 0.5f;
        Imf::FrameBuffer frame;
        frame.insert("Y", Imf::Slice(Imf::FLOAT, (char*)&y, sizeof y, sizeof y));
        Imf::OutputFile file((dir.path / "luminance.exr").c_str(), header);
        file.setFrameBuffer(frame);
        file.writePixels(1);
    }
    CHECK_THAT(message_of([&] { (void)read_exr(dir.path / "luminance.exr"); }),
               Catch::Contains("luminance.exr") && Catch::Contains("has no R channel"));
}

TEST_CASE("float images: the output's name chooses its kind", "[float_image]") {
    CHECK(output_image_kind("a.png") == ImageFileKind::png);
    CHECK(output_image_kind("dir/a.EXR") == ImageFileKind::exr);
    CHECK(output_image_kind("a.Pfm") == ImageFileKind::pfm);
    CHECK(output_image_kind("-") == ImageFileKind::png);
    CHECK_THROWS_AS(output_image_kind("a.jpg"), OutputPathError);
    CHECK_THAT(message_of([] { (void)output_image_kind("a.jpg"); }),
               Catch::Contains("'a.jpg'") && Catch::Contains(".png") && Catch::Contains(".exr") &&
                   Catch::Contains(".pfm"));
    CHECK_THROWS_AS(output_image_kind("png"), OutputPathError);
    // A FIFO may have any name: a stream gets a PNG.
    TempDir dir;
    const fs::path fifo = dir.path / "pipe";
    REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
    CHECK(output_image_kind(fifo) == ImageFileKind::png);
}

// The command line writes the frame the library renders: the PFM and the EXR hold its floats bit for bit, the
// PNG their sRGB. A sequence names its EXR files as it names PNGs.
TEST_CASE("float images: render -o x.pfm and x.exr hold the library's frame, x.png its sRGB", "[float_image][cli]") {
    TempDir dir;
    const std::string scene_path = std::string(SMOKETRACE_ASSET_DIR) + "/scenes/minimal.json";
    for (const char* name : {"f.pfm", "f.exr", "f.png"}) {
        const CliRun r = run_cli("render " + scene_path + " -o " + (dir.path / name).string() + " --size 24x16");
        INFO(r.err);
        REQUIRE(r.exit_code == 0);
    }
    const SceneDescription scene = load_scene_file(scene_path);
    const SixwayTexture texture = load_sixway_texture(fs::path(SMOKETRACE_ASSET_DIR) / kSixwayLayoutFile);
    RenderOptions options = RenderOptions::from_scene(scene);
    options.width = 24;
    options.height = 16;
    FrameRenderer renderer(scene, options, texture);
    ImageRgba image;
    renderer.render(0, image);
    check_same_bits(read_float_image(dir.path / "f.pfm"), image);
    check_same_bits(read_float_image(dir.path / "f.exr"), image);
    // The PNG: each RGB channel the sRGB code of the same float.
    const Rgba8Image png = read_png_rgba8(dir.path / "f.png");
    REQUIRE((png.width == 24 && png.height == 16));
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 24; ++x)
            for (int c = 0; c < 3; ++c) CHECK(png.texel(x, y)[c] == linear_to_srgb8(image.at(x, y)[c]));
    // Not all one colour: the smoke is in the frame.
    CHECK(std::any_of(image.pixels.begin(), image.pixels.end(), [&](const glm::vec4& p) { return p != image.pixels[0]; }));

    const CliRun seq = run_cli("render " + scene_path + " -o " + (dir.path / "seq.exr").string() + " --size 8x8 --frames 2");
    INFO(seq.err);
    CHECK(seq.exit_code == 0);
    CHECK(fs::exists(dir.path / "seq_0000.exr"));
    CHECK(fs::exists(dir.path / "seq_0001.exr"));
    const CliRun bad = run_cli("render " + scene_path + " -o " + (dir.path / "f.tiff").string());
    CHECK(bad.exit_code == 2);
    CHECK_THAT(bad.err, Catch::Contains("must end in .png (8-bit sRGB), .exr (OpenEXR, linear float) or .pfm"));
}

// smoketrace diff: A − B of two float images, as the signed floats (.pfm) and as a red/blue PNG, with the RMSE and
// the largest difference, all checked by hand on three pixels.
TEST_CASE("float images: diff writes A - B and prints its RMSE and largest difference", "[float_image][cli]") {
    TempDir dir;
    ImageRgba a(3, 1), b(3, 1);
    a.at(0, 0) = glm::vec4(0.5f, 0.5f, 0.5f, 1.0f);  // A brighter by 0.25 in every channel
    b.at(0, 0) = glm::vec4(0.25f, 0.25f, 0.25f, 1.0f);
    a.at(1, 0) = glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);  // B brighter by 0.5
    b.at(1, 0) = glm::vec4(0.5f, 0.5f, 0.5f, 1.0f);
    a.at(2, 0) = b.at(2, 0) = glm::vec4(0.75f, 0.125f, 2.0f, 1.0f);  // the same
    write_pfm(dir.path / "a.pfm", a);
    write_exr(dir.path / "b.exr", b);
    const std::string inputs = (dir.path / "a.pfm").string() + " " + (dir.path / "b.exr").string();
    const CliRun floats = smoketrace::test::run_cli_stdout("diff " + inputs + " -o " + (dir.path / "d.pfm").string());
    INFO(floats.err);
    REQUIRE(floats.exit_code == 0);
    // RMSE over the nine channels: sqrt((3 · 0.25² + 3 · 0.5²) / 9) = sqrt(0.9375 / 9).
    CHECK_THAT(floats.out, Catch::StartsWith("rmse=0.322749 max_abs=0.5 (linear radiance, RGB channels of 3x1"));
    const ImageRgba d = read_pfm(dir.path / "d.pfm");
    CHECK(d.at(0, 0) == glm::vec4(0.25f, 0.25f, 0.25f, 1.0f));
    CHECK(d.at(1, 0) == glm::vec4(-0.5f, -0.5f, -0.5f, 1.0f));
    CHECK(d.at(2, 0) == glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
    // The PNG: scale 1 / 0.5, so the first pixel is red at 0.5 (sRGB 188), the second full blue, the third black.
    const CliRun png = smoketrace::test::run_cli_stdout("diff " + inputs + " -o " + (dir.path / "d.png").string());
    REQUIRE(png.exit_code == 0);
    CHECK_THAT(png.out, Catch::Contains("scale=2 "));
    CHECK_THAT(png.err, Catch::Contains("wrote " + (dir.path / "d.png").string()));
    const Rgba8Image shown = read_png_rgba8(dir.path / "d.png");
    const std::uint8_t expected[3][3] = {{188, 0, 0}, {0, 0, 255}, {0, 0, 0}};
    for (int x = 0; x < 3; ++x)
        for (int c = 0; c < 3; ++c) CHECK(shown.texel(x, 0)[c] == expected[x][c]);
    // Images of two sizes, and an output that is an input, are refused; nothing is written.
    write_pfm(dir.path / "small.pfm", ImageRgba(1, 1));
    const CliRun sizes = run_cli("diff " + inputs.substr(0, inputs.find(' ')) + " " + (dir.path / "small.pfm").string() +
                                 " -o " + (dir.path / "e.png").string());
    CHECK(sizes.exit_code == 2);
    CHECK_THAT(sizes.err, Catch::Contains("is 3x1") && Catch::Contains("1x1: the images must be of one size"));
    CHECK(run_cli("diff " + inputs + " -o " + (dir.path / "a.pfm").string()).exit_code == 2);
    CHECK_FALSE(fs::exists(dir.path / "e.png"));
}
