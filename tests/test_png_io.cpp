// PNG in and out, and the sRGB transfer function: exact values, round trips, and every failure a user can
// cause (missing, not a PNG, truncated, corrupt, wrong size, unwritable destination) giving a message that
// names the file and leaving no output behind; animated PNGs read back by an independent decoder.
#include "support/apng_reader.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

#include <smoketrace/core/image.hpp>
#include <smoketrace/io/output_path.hpp>
#include <smoketrace/io/png_io.hpp>

#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>
#include <unistd.h>

using namespace smoketrace;
using namespace smoketrace::test;
namespace fs = std::filesystem;

namespace {

// A fresh empty folder per test, removed afterwards.
struct TempDir {
    fs::path path;
    TempDir() {
        static std::atomic<int> counter{0};
        path = fs::temp_directory_path() /
               ("smoketrace_png_" + std::to_string(::getpid()) + "_" + std::to_string(counter.fetch_add(1)));
        fs::remove_all(path);
        fs::create_directories(path);
    }
    ~TempDir() { fs::remove_all(path); }
    std::vector<fs::path> entries() const {
        std::vector<fs::path> out;
        for (const auto& e : fs::directory_iterator(path)) out.push_back(e.path());
        return out;
    }
};

std::vector<std::uint8_t> read_bytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const fs::path& p, const std::vector<std::uint8_t>& bytes) {
    std::ofstream out(p, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

// Deterministic test pattern: every byte value occurs, neighbours differ (exercises PNG filters).
Rgba8Image pattern(int w, int h) {
    Rgba8Image im(w, h);
    for (std::size_t i = 0; i < im.pixels.size(); ++i) im.pixels[i] = std::uint8_t((i * 2654435761u) >> 13);
    return im;
}

// Reference sRGB encoding (IEC 61966-2-1) in double precision, independent of the threshold table.
double srgb_encode(double x) { return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055; }

// A value whose scaled encoding lies this close to a half-integer is a rounding tie that float input
// cannot resolve either way; the reference's own pow() error is ~1e-16, so 1e-9 is generous and still
// excludes no sample of the sweep in practice.
constexpr double kTieMargin = 1e-9;

}  // namespace

TEST_CASE("sRGB: known values of the transfer function", "[png]") {
    CHECK(linear_to_srgb8(0.0f) == 0);
    CHECK(linear_to_srgb8(1.0f) == 255);
    CHECK(linear_to_srgb8(0.5f) == 188);  // 1.055·0.5^(1/2.4) − 0.055 = 0.73536 → 187.52
    // Code 128 starts at decode(127.5 / 255) = (0.555 / 1.055)^2.4 = 0.2140411: either side of it.
    CHECK(linear_to_srgb8(0.2141f) == 128);  // 255 · encode = 127.516
    CHECK(linear_to_srgb8(0.2139f) == 127);  // 255 · encode = 127.461
    CHECK(linear_to_srgb8(0.001f) == 3);     // linear segment: 12.92·0.001·255 = 3.29
    CHECK(linear_to_srgb8(-0.25f) == 0);
    CHECK(linear_to_srgb8(-0.0f) == 0);  // sign bit set: must not be taken for a large value
    CHECK(linear_to_srgb8(-std::numeric_limits<float>::denorm_min()) == 0);
    CHECK(linear_to_srgb8(std::numeric_limits<float>::denorm_min()) == 0);
    CHECK(linear_to_srgb8(-std::numeric_limits<float>::max()) == 0);
    CHECK(linear_to_srgb8(std::numeric_limits<float>::max()) == 255);
    CHECK(linear_to_srgb8(7.0f) == 255);
    CHECK(linear_to_srgb8(std::numeric_limits<float>::quiet_NaN()) == 0);
    CHECK(linear_to_srgb8(std::numeric_limits<float>::infinity()) == 255);
    CHECK(linear_to_srgb8(-std::numeric_limits<float>::infinity()) == 0);
}

TEST_CASE("sRGB: matches round(255 · encode(x)) over a dense sweep and at every code boundary", "[png]") {
    auto check = [](float x) {
        const double scaled = 255.0 * srgb_encode(std::min(std::max(double(x), 0.0), 1.0));
        if (std::fabs(scaled - std::floor(scaled) - 0.5) < kTieMargin) return;
        INFO("x = " << x);
        REQUIRE(int(linear_to_srgb8(x)) == int(std::floor(scaled + 0.5)));
    };
    constexpr int kSweep = 200000;
    for (int i = 0; i <= kSweep; ++i) check(float(i) / kSweep);
    // Around each decision threshold: the floats just below and above decode((k - 0.5) / 255).
    for (int k = 1; k <= 255; ++k) {
        const double s = (k - 0.5) / 255.0;
        const double t = s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4);
        float x = float(t);
        for (int step = 0; step < 3; ++step) x = std::nextafter(x, 0.0f);
        for (int step = 0; step < 6; ++step, x = std::nextafter(x, 2.0f)) check(x);
    }
}

TEST_CASE("sRGB: every float from 2^-14 to 2 gets the code of the double-precision thresholds", "[png]") {
    // Exhaustive over the range where codes change (126M floats, walked in increasing order): the
    // expected code is the number of thresholds decode((k - 0.5) / 255) at or below double(x), kept
    // incrementally since it only grows with x. linear_to_srgb8 searches float bit patterns through a
    // bucket table instead; this holds the two to the same answer for every input, not a sample.
    std::vector<double> thresholds;
    for (int k = 1; k <= 255; ++k) {
        const double s = (k - 0.5) / 255.0;
        thresholds.push_back(s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4));
    }
    thresholds.push_back(std::numeric_limits<double>::infinity());
    const std::uint32_t first = std::bit_cast<std::uint32_t>(0x1p-14f), last = std::bit_cast<std::uint32_t>(2.0f);
    unsigned expected = 0;
    std::uint64_t wrong = 0;
    std::uint32_t first_wrong = 0;
    for (std::uint32_t bits = first; bits < last; ++bits) {
        const float x = std::bit_cast<float>(bits);
        while (double(x) >= thresholds[expected]) ++expected;
        if (linear_to_srgb8(x) != expected) {
            if (wrong++ == 0) first_wrong = bits;
        }
    }
    INFO("first wrong input " << std::bit_cast<float>(first_wrong));
    CHECK(wrong == 0);
    CHECK(expected == 255);
}

TEST_CASE("sRGB: decoding then encoding every code gives the code back", "[png]") {
    for (int k = 0; k < 256; ++k) {
        INFO("code " << k);
        CHECK(int(linear_to_srgb8(float(srgb8_to_linear(std::uint8_t(k))))) == k);
    }
}

TEST_CASE("unorm8: linear data rounds to nearest, clamps, NaN to 0", "[png]") {
    CHECK(unorm8(0.0f) == 0);
    CHECK(unorm8(1.0f) == 255);
    CHECK(unorm8(0.5f) == 128);  // 127.5 rounds half up
    CHECK(unorm8(1.0f / 255.0f) == 1);
    CHECK(unorm8(0.4f / 255.0f) == 0);
    CHECK(unorm8(-1.0f) == 0);
    CHECK(unorm8(2.0f) == 255);
    CHECK(unorm8(std::numeric_limits<float>::quiet_NaN()) == 0);
}

TEST_CASE("PNG: RGBA8 round trip is byte-exact", "[png]") {
    TempDir dir;
    const Rgba8Image im = pattern(37, 23);
    const fs::path p = dir.path / "a.png";
    write_png_rgba8(p, im);
    const Rgba8Image back = read_png_rgba8(p);
    REQUIRE(back.width == 37);
    REQUIRE(back.height == 23);
    CHECK(back.pixels == im.pixels);
    CHECK(dir.entries().size() == 1);  // no temporary file left beside it
}

TEST_CASE("PNG: our encoder round-trips single rows, single columns, noise and flat runs", "[png]") {
    // The Paeth filter's edge cases (first row: no row above; first column: no left neighbour), bytes
    // zlib cannot shorten (noise) and long runs (flat colour), each read back through stb_image.
    TempDir dir;
    std::uint32_t state = 12345u;
    for (const auto& [w, h] : {std::pair{1, 1}, {1, 9}, {11, 1}, {300, 200}}) {
        for (const bool flat : {false, true}) {
            Rgba8Image im(w, h);
            for (std::uint8_t& b : im.pixels) {
                state = state * 1664525u + 1013904223u;
                b = flat ? std::uint8_t(200) : std::uint8_t(state >> 24);
            }
            const fs::path p = dir.path / (std::to_string(w) + "x" + std::to_string(h) + (flat ? "f.png" : "n.png"));
            write_png_rgba8(p, im);
            const Rgba8Image back = read_png_rgba8(p);
            INFO(w << "x" << h << (flat ? " flat" : " noise"));
            REQUIRE(back.width == w);
            REQUIRE(back.height == h);
            CHECK(back.pixels == im.pixels);
        }
    }
}

TEST_CASE("PNG: sRGB writer encodes RGB and keeps alpha linear", "[png]") {
    TempDir dir;
    ImageRgba im(3, 2);
    im.at(0, 0) = {0.5f, 0.0f, 1.0f, 0.5f};
    im.at(1, 0) = {0.2141f, 2.0f, -1.0f, 1.0f};
    im.at(2, 1) = {0.001f, 0.5f, 0.5f, 0.0f};
    for (const PngChannels channels : {PngChannels::rgb, PngChannels::rgba}) {
        const fs::path p = dir.path / "s.png";
        write_png_srgb(p, im, channels);
        const Rgba8Image back = read_png_rgba8(p, 3, 2);
        for (int y = 0; y < 2; ++y)
            for (int x = 0; x < 3; ++x) {
                const glm::vec4 v = im.at(x, y);
                const std::uint8_t* t = back.texel(x, y);
                INFO("pixel " << x << "," << y);
                CHECK(t[0] == linear_to_srgb8(v.x));
                CHECK(t[1] == linear_to_srgb8(v.y));
                CHECK(t[2] == linear_to_srgb8(v.z));
                CHECK(t[3] == (channels == PngChannels::rgba ? unorm8(v.w) : 255));  // stb gives RGB opaque alpha
            }
    }
}

TEST_CASE("PNG: a reused PngWriter writes the bytes of a fresh one, whatever it wrote before", "[png]") {
    // The writer keeps its buffers and zlib's stream (deflateReset) from image to image: a smaller image
    // after a larger one must not pick up the larger one's leftovers, a larger one must grow the buffers,
    // and RGB, RGBA and sRGB images must interleave freely. Each file is compared byte for byte with the
    // file a fresh writer (the free functions) makes of the same image, and read back.
    TempDir dir;
    std::uint32_t state = 777u;
    auto linear = [&](int w, int h) {
        ImageRgba im(w, h);
        for (glm::vec4& p : im.pixels) {
            auto next = [&] {
                state = state * 1664525u + 1013904223u;
                return float(state >> 8) / float(1u << 24);
            };
            p = {next(), next(), next(), next()};
        }
        return im;
    };
    PngWriter writer;
    int k = 0;
    for (const auto& [w, h] : {std::pair{64, 48}, {3, 5}, {200, 7}, {1, 1}, {64, 48}, {129, 130}}) {
        const Rgba8Image bytes = pattern(w, h);
        const ImageRgba light = linear(w, h);
        INFO(w << "x" << h);
        const fs::path reused = dir.path / ("reused" + std::to_string(k) + ".png");
        const fs::path fresh = dir.path / ("fresh" + std::to_string(k++) + ".png");
        writer.write_rgba8(reused, bytes);
        write_png_rgba8(fresh, bytes);
        CHECK(read_bytes(reused) == read_bytes(fresh));
        CHECK(read_png_rgba8(reused, w, h).pixels == bytes.pixels);
        for (const PngChannels channels : {PngChannels::rgb, PngChannels::rgba}) {
            writer.write_srgb(reused, light, channels);
            write_png_srgb(fresh, light, channels);
            CHECK(read_bytes(reused) == read_bytes(fresh));
        }
    }
    // A moved-from writer starts over and still writes the same bytes.
    PngWriter moved = std::move(writer);
    const Rgba8Image small = pattern(9, 4);
    writer.write_rgba8(dir.path / "after_move.png", small);  // NOLINT(bugprone-use-after-move): tested on purpose
    moved.write_rgba8(dir.path / "moved.png", small);
    write_png_rgba8(dir.path / "fresh_small.png", small);
    CHECK(read_bytes(dir.path / "after_move.png") == read_bytes(dir.path / "fresh_small.png"));
    CHECK(read_bytes(dir.path / "moved.png") == read_bytes(dir.path / "fresh_small.png"));
}

TEST_CASE("PNG: to_srgb8 into a buffer gives RGBA as to_srgb8() and RGB without alpha", "[png]") {
    ImageRgba im(5, 3);
    float v = -0.1f;
    for (glm::vec4& p : im.pixels) {
        p = {v, v * 0.5f, 1.0f - v, v * 0.25f};
        v += 0.07f;
    }
    const Rgba8Image rgba = to_srgb8(im);
    std::vector<std::uint8_t> samples(3, 99);  // stale contents and size: replaced
    to_srgb8(im, 4, samples);
    CHECK(samples == rgba.pixels);
    to_srgb8(im, 3, samples);
    REQUIRE(samples.size() == im.pixels.size() * 3);
    for (std::size_t i = 0; i < im.pixels.size(); ++i)
        for (std::size_t c = 0; c < 3; ++c) CHECK(samples[3 * i + c] == rgba.pixels[4 * i + c]);
    CHECK_THROWS_AS(to_srgb8(im, 2, samples), std::invalid_argument);
}

TEST_CASE("PNG: a non-finite pixel is refused and nothing is written", "[png]") {
    TempDir dir;
    ImageRgba im(4, 4, glm::vec4(0.5f));
    im.at(2, 3).y = std::numeric_limits<float>::quiet_NaN();
    const fs::path p = dir.path / "nan.png";
    const std::string msg = message_of([&] { write_png_srgb(p, im); });
    CHECK_THAT(msg, Catch::Contains(p.string()) && Catch::Contains("pixel (2, 3)") && Catch::Contains("not finite"));
    CHECK(dir.entries().empty());
}

TEST_CASE("PNG: rewriting a file replaces it whole", "[png]") {
    TempDir dir;
    const fs::path p = dir.path / "r.png";
    write_png_rgba8(p, pattern(8, 8));
    const Rgba8Image second = pattern(5, 9);
    write_png_rgba8(p, second);
    CHECK(read_png_rgba8(p).pixels == second.pixels);
    CHECK(dir.entries().size() == 1);
}

TEST_CASE("PNG errors: missing file names the path and the system's reason", "[png]") {
    TempDir dir;
    const fs::path p = dir.path / "nope.png";
    const std::string msg = message_of([&] { (void)read_png_rgba8(p); });
    CHECK_THAT(msg, Catch::Contains(p.string()) && Catch::Contains("No such file or directory"));
}

TEST_CASE("PNG errors: a file that is not a PNG", "[png]") {
    TempDir dir;
    const fs::path p = dir.path / "text.png";
    std::ofstream(p) << "this is not an image\n";
    CHECK_THAT(message_of([&] { (void)read_png_rgba8(p); }), Catch::Contains(p.string()) && Catch::Contains("not a PNG"));
    const fs::path empty = dir.path / "empty.png";
    std::ofstream{empty};
    CHECK_THAT(message_of([&] { (void)read_png_rgba8(empty); }), Catch::Contains(empty.string()) && Catch::Contains("not a PNG"));
    CHECK_THAT(message_of([&] { (void)read_png_rgba8(dir.path); }), Catch::Contains(dir.path.string()) && Catch::Contains("directory"));
}

TEST_CASE("PNG errors: truncated and corrupt files", "[png]") {
    TempDir dir;
    const fs::path good = dir.path / "good.png";
    write_png_rgba8(good, pattern(64, 64));
    const std::vector<std::uint8_t> bytes = read_bytes(good);
    REQUIRE(bytes.size() > 100);

    SECTION("half of a real PNG") {
        const fs::path p = dir.path / "half.png";
        write_bytes(p, std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + std::ptrdiff_t(bytes.size() / 2)));
        CHECK_THAT(message_of([&] { (void)read_png_rgba8(p); }), Catch::Contains(p.string()) && Catch::Contains("truncated"));
    }
    SECTION("all but the last byte (the IEND CRC)") {
        const fs::path p = dir.path / "short.png";
        write_bytes(p, std::vector<std::uint8_t>(bytes.begin(), bytes.end() - 1));
        CHECK_THAT(message_of([&] { (void)read_png_rgba8(p); }),
                   Catch::Contains(p.string()) && Catch::Contains("truncated") && Catch::Contains("IEND"));
    }
    SECTION("the signature alone") {
        const fs::path p = dir.path / "sig.png";
        write_bytes(p, std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + 8));
        CHECK_THAT(message_of([&] { (void)read_png_rgba8(p); }), Catch::Contains(p.string()) && Catch::Contains("truncated"));
    }
    SECTION("one flipped bit in the image data") {
        std::vector<std::uint8_t> bad = bytes;
        bad[bad.size() / 2] ^= 0x10;  // inside IDAT: a 64x64 pattern compresses to one chunk filling the middle
        const fs::path p = dir.path / "flip.png";
        write_bytes(p, bad);
        CHECK_THAT(message_of([&] { (void)read_png_rgba8(p); }),
                   Catch::Contains(p.string()) && Catch::Contains("CRC mismatch") && Catch::Contains("IDAT"));
    }
}

TEST_CASE("PNG errors: wrong size when a size is expected", "[png]") {
    TempDir dir;
    const fs::path p = dir.path / "a.png";
    write_png_rgba8(p, pattern(37, 23));
    CHECK_THAT(message_of([&] { (void)read_png_rgba8(p, 64, 64); }),
               Catch::Contains(p.string()) && Catch::Contains("expected 64x64") && Catch::Contains("37x23"));
    CHECK(read_png_rgba8(p, 37, 23).width == 37);
}

TEST_CASE("PNG errors: a size beyond the caller's limit is refused from the header, before decoding", "[png]") {
    TempDir dir;
    const fs::path p = dir.path / "wide.png";
    write_png_rgba8(p, pattern(9000, 3));
    CHECK_THAT(message_of([&] { (void)read_png_rgba8_at_most(p, 8192, 8192); }),
               Catch::Contains(p.string()) && Catch::Contains("PNG size 9000x3 is larger than the limit of 8192x8192"));
    CHECK_THAT(message_of([&] { (void)read_png_rgba8_at_most(p, 9000, 2); }), Catch::Contains("larger than the limit"));
    CHECK(read_png_rgba8_at_most(p, 9000, 3).pixels == pattern(9000, 3).pixels);
}

TEST_CASE("PNG errors: writing into a missing folder names the path and leaves nothing", "[png]") {
    TempDir dir;
    const fs::path p = dir.path / "missing" / "out.png";
    const std::string msg = message_of([&] { write_png_rgba8(p, pattern(4, 4)); });
    CHECK_THAT(msg, Catch::Contains(p.string()) && Catch::Contains("does not exist"));
    CHECK_FALSE(fs::exists(p));
    CHECK(dir.entries().empty());
}

TEST_CASE("PNG errors: a destination that cannot be replaced leaves no temporary file", "[png]") {
    // The target is a folder: the temporary file is written in full, the rename fails, the temporary
    // must be removed and the folder left as it was.
    TempDir dir;
    const fs::path p = dir.path / "taken.png";
    fs::create_directory(p);
    const std::string msg = message_of([&] { write_png_rgba8(p, pattern(4, 4)); });
    CHECK_THAT(msg, Catch::Contains(p.string()));
    CHECK(fs::is_directory(p));
    CHECK(dir.entries().size() == 1);
}

TEST_CASE("PNG errors: bad sizes and buffers are refused before writing", "[png]") {
    TempDir dir;
    const fs::path p = dir.path / "z.png";
    const std::vector<std::uint8_t> bytes(16, 0);
    CHECK_THAT(message_of([&] { write_png_rgba8(p, 0, 4, bytes.data()); }), Catch::Contains(p.string()));
    CHECK_THAT(message_of([&] { write_png_rgba8(p, 2, 2, nullptr); }), Catch::Contains(p.string()));
    Rgba8Image wrong(2, 2);
    wrong.pixels.pop_back();
    CHECK_THAT(message_of([&] { write_png_rgba8(p, wrong); }), Catch::Contains(p.string()));
    CHECK(dir.entries().empty());
}

namespace {

// A frame whose every pixel differs from its neighbours and from the same pixel of the other frames, with
// values below 0 and above 1 (clamped) and a ramp through the sRGB curve: frame k of a test sequence.
ImageRgba apng_test_frame(int w, int h, int k) {
    ImageRgba im(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float t = float((x * 7 + y * 13 + k * 29) % 97) / 80.0f - 0.1f;
            im.pixels[std::size_t(y) * std::size_t(w) + std::size_t(x)] = {t, 1.0f - t, float(k) / 3.0f, 1.0f};
        }
    return im;
}

// The 8-bit RGB a frame must decode to: each component through the sRGB transfer function, alpha dropped.
std::vector<std::uint8_t> expected_rgb(const ImageRgba& im) {
    std::vector<std::uint8_t> rgb;
    for (const glm::vec4& p : im.pixels)
        for (int c = 0; c < 3; ++c) rgb.push_back(linear_to_srgb8(p[c]));
    return rgb;
}

}  // namespace

TEST_CASE("APNG: frames written one by one follow the chunk rules and decode to their pixels", "[png][apng]") {
    constexpr int kW = 13, kH = 7;
    for (const std::uint32_t frames : {1u, 2u, 5u}) {
        INFO(frames << " frames");
        std::ostringstream out;
        ApngWriter apng(out, "seq.apng", kW, kH, frames, 30);
        std::vector<ImageRgba> written;
        for (std::uint32_t k = 0; k < frames; ++k) {
            written.push_back(apng_test_frame(kW, kH, int(k)));
            apng.add_srgb(written.back());
        }
        apng.finish();
        const Apng back = read_apng(out.str());  // throws on any broken chunk rule
        CHECK(back.width == std::uint32_t(kW));
        CHECK(back.height == std::uint32_t(kH));
        CHECK(back.num_frames == frames);
        CHECK(back.num_plays == 0u);  // loops for ever
        REQUIRE(back.frames.size() == frames);
        for (std::uint32_t k = 0; k < frames; ++k) {
            INFO("frame " << k);
            const ApngFrame& f = back.frames[k];
            CHECK(f.in_idat == (k == 0));  // the first frame is what a still viewer shows
            CHECK((f.width == std::uint32_t(kW) && f.height == std::uint32_t(kH) && f.x_offset == 0 && f.y_offset == 0));
            CHECK((f.delay_num == 1 && f.delay_den == 30));  // 1/30 s
            CHECK((f.dispose_op == 0 && f.blend_op == 0));   // each frame replaces the image
            CHECK(f.rgb == expected_rgb(written[k]));
        }
        if (frames > 1) CHECK(back.frames[0].rgb != back.frames[1].rgb);
        // The order of the chunks, IDAT carrying the first frame and fdAT the others.
        std::vector<std::string> order{"IHDR", "acTL", "fcTL", "IDAT"};
        for (std::uint32_t k = 1; k < frames; ++k) order.insert(order.end(), {"fcTL", "fdAT"});
        order.push_back("IEND");
        CHECK(back.chunk_types == order);
    }
}

TEST_CASE("APNG: a PNG reader that does not animate reads the first frame", "[png][apng]") {
    TempDir dir;
    const fs::path p = dir.path / "seq.apng";
    const ImageRgba first = apng_test_frame(9, 4, 0);
    write_output(p, [&](std::ostream& out) {
        ApngWriter apng(out, p, 9, 4, 3, 24);
        for (int k = 0; k < 3; ++k) apng.add_srgb(apng_test_frame(9, 4, k));
        apng.finish();
    });
    const Rgba8Image still = read_png_rgba8(p, 9, 4);  // stb_image: no APNG support
    const std::vector<std::uint8_t> rgb = expected_rgb(first);
    for (std::size_t i = 0; i < std::size_t(9 * 4); ++i) {
        INFO("pixel " << i);
        REQUIRE((still.pixels[4 * i] == rgb[3 * i] && still.pixels[4 * i + 1] == rgb[3 * i + 1] &&
                 still.pixels[4 * i + 2] == rgb[3 * i + 2] && still.pixels[4 * i + 3] == 255));
    }
}

TEST_CASE("APNG: the same frames give the same bytes, whatever the writer wrote before", "[png][apng]") {
    const auto write = [](int first_frame) {
        std::ostringstream out;
        ApngWriter apng(out, "a.apng", 16, 9, 3, 12);
        for (int k = 0; k < 3; ++k) apng.add_srgb(apng_test_frame(16, 9, first_frame + k));
        apng.finish();
        return out.str();
    };
    CHECK(write(0) == write(0));
    CHECK(write(0) != write(1));
}

TEST_CASE("APNG errors: wrong frames, counts and settings are refused naming the file", "[png][apng]") {
    std::ostringstream out;
    CHECK_THAT(message_of([&] { ApngWriter(out, "a.apng", 0, 4, 2, 24); }), Catch::Contains("a.apng"));
    CHECK_THAT(message_of([&] { ApngWriter(out, "a.apng", 4, 4, 0, 24); }), Catch::Contains("at least one frame"));
    CHECK_THAT(message_of([&] { ApngWriter(out, "a.apng", 4, 4, 2, 0); }), Catch::Contains("outside [1, 65535]"));
    {
        ApngWriter apng(out, "a.apng", 4, 4, 2, 24);
        CHECK_THAT(message_of([&] { apng.add_srgb(apng_test_frame(4, 5, 0)); }), Catch::Contains("frame 0 is 4x5"));
        ImageRgba bad = apng_test_frame(4, 4, 0);
        bad.pixels[5].y = std::numeric_limits<float>::quiet_NaN();
        CHECK_THAT(message_of([&] { apng.add_srgb(bad); }), Catch::Contains("pixel (1, 1) is not finite"));
        apng.add_srgb(apng_test_frame(4, 4, 0));
        CHECK_THAT(message_of([&] { apng.finish(); }), Catch::Contains("announces 2 frames, 1 were written"));
        apng.add_srgb(apng_test_frame(4, 4, 1));
        CHECK_THAT(message_of([&] { apng.add_srgb(apng_test_frame(4, 4, 2)); }),
                   Catch::Contains("more frames than the 2"));
        apng.finish();
    }
    // A stream that fails (a full disk) stops the sequence at the frame that could not be written.
    std::ostream broken(nullptr);
    CHECK_THAT(message_of([&] { ApngWriter(broken, "full.apng", 4, 4, 2, 24); }),
               Catch::Contains("full.apng") && Catch::Contains("write failed"));
}

TEST_CASE("APNG errors: a sequence that fails half-way leaves no file", "[png][apng]") {
    TempDir dir;
    const fs::path p = dir.path / "seq.apng";
    std::string old = "an older file";
    write_bytes(p, std::vector<std::uint8_t>(old.begin(), old.end()));
    const std::string msg = message_of([&] {
        write_output(p, [&](std::ostream& out) {
            ApngWriter apng(out, p, 4, 4, 3, 24);
            apng.add_srgb(apng_test_frame(4, 4, 0));
            ImageRgba bad = apng_test_frame(4, 4, 1);
            bad.pixels[0].x = std::numeric_limits<float>::infinity();
            apng.add_srgb(bad);
        });
    });
    CHECK_THAT(msg, Catch::Contains(p.string()) && Catch::Contains("not finite"));
    CHECK(read_bytes(p) == std::vector<std::uint8_t>(old.begin(), old.end()));  // the old file, untouched
    CHECK(dir.entries().size() == 1);                                          // no temporary file
}

// The reader above is the only judge of the chunk rules: each rule it holds is broken here once, in a
// file that is otherwise right (CRCs recomputed), and must be caught.
TEST_CASE("APNG: the test's reader catches a bad CRC, a sequence number out of order and a miscount", "[png][apng]") {
    std::ostringstream out;
    ApngWriter apng(out, "a.apng", 6, 3, 3, 24);
    for (int k = 0; k < 3; ++k) apng.add_srgb(apng_test_frame(6, 3, k));
    apng.finish();
    const std::string good = out.str();
    REQUIRE_NOTHROW(read_apng(good));
    // The byte offset of the first chunk of `type`'s data, and its length.
    const auto find_chunk = [&](const std::string& bytes, const std::string& type) {
        std::size_t at = 8;
        while (bytes.compare(at + 4, 4, type) != 0) at += 12 + apng_detail::be32(reinterpret_cast<const std::uint8_t*>(&bytes[at]));
        return std::pair{at + 8, std::size_t(apng_detail::be32(reinterpret_cast<const std::uint8_t*>(&bytes[at])))};
    };
    const auto reseal = [&](std::string& bytes, const std::string& type) {  // a right CRC for the change
        const auto [data, length] = find_chunk(bytes, type);
        const std::uint32_t crc = std::uint32_t(
            crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(&bytes[data - 4]), uInt(length + 4)));
        for (int k = 0; k < 4; ++k) bytes[data + length + std::size_t(k)] = char(crc >> (24 - 8 * k));
    };
    const auto message = [](const std::string& bytes) { return message_of([&] { (void)read_apng(bytes); }); };
    {
        std::string bad = good;
        bad[find_chunk(bad, "fdAT").first + 6] ^= 1;  // a data byte, CRC left as it was
        CHECK_THAT(message(bad), Catch::Contains("CRC mismatch in chunk fdAT"));
    }
    {
        std::string bad = good;
        bad[find_chunk(bad, "fdAT").first + 3] += 1;  // the first fdAT's sequence number, 2 → 3
        reseal(bad, "fdAT");
        CHECK_THAT(message(bad), Catch::Contains("fdAT sequence number out of order"));
    }
    {
        std::string bad = good;
        bad[find_chunk(bad, "acTL").first + 3] = 4;  // num_frames 3 → 4
        reseal(bad, "acTL");
        CHECK_THAT(message(bad), Catch::Contains("acTL announces 4 frames, the file has 3"));
    }
    {
        std::string bad = good;
        bad[find_chunk(bad, "IDAT").first + 5] ^= 0x40;  // the first frame's zlib data
        reseal(bad, "IDAT");
        CHECK_THAT(message(bad), Catch::Contains("zlib stream"));
    }
}
