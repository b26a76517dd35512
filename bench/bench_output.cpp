// Section "output": writing a rendered frame, the step after the compositor (docs/performance-log.md,
// "Writing the frames").
// A 1024×1024 `full` frame of the animated two-tube scene (bench_util.hpp), then, side by side in
// interleaved rounds:
//   * sRGB encoding: to_srgb8() (exact decision thresholds, one comparison per channel, parallel over
//     pixels) on one thread and on all, against the textbook per-channel float formula
//     round(255 · (1.055 · v^(1/2.4) − 0.055)) with powf, on one thread, both into buffers kept from
//     round to round; the codes on which the formula differs from the exact rounding are counted
//     (information, not a failure: the formula's own rounding is why the library does not use it);
//   * PNG files of the same RGBA8 pixels: a PngWriter kept from round to round (our encoder over zlib,
//     png_io.cpp) against stbi_write_png() (stb_image_write, which the library used before), both writing
//     a file; each file is read back and must hold exactly the pixels written (a check that both did the
//     job, not a test);
//   * the whole step of the command line (finite check, sRGB encoding, RGB, encoder, atomic file): a
//     sequence's frame, through the sequence's PngWriter, and a single frame, write_png_srgb() with fresh
//     memory. The difference is the first touch of fresh pages, which PngWriter exists to avoid.
#include "bench_registry.hpp"
#include "bench_util.hpp"
#include "timing.hpp"

#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/core/image.hpp>
#include <smoketrace/io/png_io.hpp>
#include <smoketrace/render/sixway_texture.hpp>
#include <smoketrace/io/sixway_files.hpp>

#include <stb_image_write.h>
#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <unistd.h>
#include <vector>

namespace smoketrace::bench {
namespace {

namespace fs = std::filesystem;

constexpr int kSize = 1024;

// The textbook conversion (IEC 61966-2-1's formula in float, rounded half up), as renderers commonly write
// it; the reference for to_srgb8's speed.
std::uint8_t textbook_srgb8(float v) {
    const float c = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f;
    const float encoded = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
    return static_cast<std::uint8_t>(encoded * 255.0f + 0.5f);
}

void textbook_to_srgb8(const ImageRgba& image, std::vector<std::uint8_t>& out) {
    out.resize(image.pixels.size() * 4);
    for (std::size_t i = 0; i < image.pixels.size(); ++i) {
        const glm::vec4 p = image.pixels[i];
        std::uint8_t* o = out.data() + 4 * i;
        o[0] = textbook_srgb8(p.x);
        o[1] = textbook_srgb8(p.y);
        o[2] = textbook_srgb8(p.z);
        o[3] = unorm8(p.w);
    }
}

// A scratch folder for the files, removed at the end.
struct ScratchDir {
    fs::path path = fs::temp_directory_path() / ("smoketrace_bench_output_" + std::to_string(::getpid()));
    ScratchDir() { fs::create_directories(path); }
    ~ScratchDir() {
        std::error_code ignored;
        fs::remove_all(path, ignored);
    }
};

// Read back: must be exactly the pixels written.
void check_round_trip(const fs::path& file, const Rgba8Image& expected) {
    const Rgba8Image back = read_png_rgba8(file, expected.width, expected.height);
    if (back.pixels != expected.pixels)
        throw std::runtime_error("bench output: " + file.string() + " does not read back as the pixels written");
}

void run_output(const BenchOptions& options) {
    // The frame: the 750-particle animated scene, full mode, its second frame (the first warms the caches).
    const SceneDescription scene = animated_scene(options, 750, kSize);
    RenderOptions o = RenderOptions::from_scene(scene);
    o.render.mode = RenderMode::full;
    o.width = o.height = kSize;
    const SixwayTexture& texture = bench_texture(options);
    FrameRenderer renderer(scene, o, texture);
    ImageRgba frame;
    renderer.render(0, frame);
    renderer.render(1, frame);

    const int all_threads = tbb::info::default_concurrency();
    tbb::task_arena one_thread(1);
    tbb::task_arena every_thread(all_threads);
    const ScratchDir dir;
    const fs::path ours_file = dir.path / "ours.png", stb_file = dir.path / "stb.png", cli_file = dir.path / "cli.png";

    // Every contender once per round, in the same order, so that the shared machine's load hits them alike;
    // a first round warms up and is not counted.
    const Rgba8Image pixels = to_srgb8(frame);
    std::vector<std::uint8_t> a, b, c;  // kept from round to round, as a frame sequence would
    PngWriter writer, sequence;
    std::vector<double> srgb_one, srgb_all, textbook_one, png_ours, png_stb, seq_frame, single_frame;
    // At least 9 counted rounds, quick mode too: a round takes ~0.2 s, and with 3 the medians of these
    // short steps were at the mercy of the shared machine.
    const int counted = std::max(options.repeats, 9);
    const int rounds = counted + 1;
    for (int r = 0; r < rounds; ++r) {
        const double t_one = time_once_ms([&] { one_thread.execute([&] { to_srgb8(frame, 4, a); }); });
        const double t_all = time_once_ms([&] { every_thread.execute([&] { to_srgb8(frame, 4, b); }); });
        const double t_text = time_once_ms([&] { textbook_to_srgb8(frame, c); });
        const double t_ours = time_once_ms([&] { writer.write_rgba8(ours_file, pixels); });
        const double t_stb = time_once_ms([&] {
            if (stbi_write_png(stb_file.c_str(), pixels.width, pixels.height, 4, pixels.pixels.data(), pixels.width * 4) == 0)
                throw std::runtime_error("bench output: stbi_write_png failed on " + stb_file.string());
        });
        const double t_seq = time_once_ms([&] { every_thread.execute([&] { sequence.write_srgb(cli_file, frame); }); });
        const double t_single = time_once_ms([&] { every_thread.execute([&] { write_png_srgb(cli_file, frame); }); });
        if (a != pixels.pixels || b != pixels.pixels)
            throw std::runtime_error("bench output: to_srgb8 differs between thread counts");
        if (r == 0) continue;  // the first round pays the kept buffers' first touch
        srgb_one.push_back(t_one);
        srgb_all.push_back(t_all);
        textbook_one.push_back(t_text);
        png_ours.push_back(t_ours);
        png_stb.push_back(t_stb);
        seq_frame.push_back(t_seq);
        single_frame.push_back(t_single);
    }
    check_round_trip(ours_file, pixels);
    check_round_trip(stb_file, pixels);

    std::size_t differing = 0;
    for (std::size_t i = 0; i < pixels.pixels.size(); ++i) differing += c[i] != pixels.pixels[i];

    const double srgb1 = stats_of(srgb_one).median, srgbN = stats_of(srgb_all).median;
    const double text1 = stats_of(textbook_one).median;
    const double ours = stats_of(png_ours).median, stb = stats_of(png_stb).median;
    const double seq = stats_of(seq_frame).median, single = stats_of(single_frame).median;
    const auto ours_bytes = double(fs::file_size(ours_file)), stb_bytes = double(fs::file_size(stb_file));

    std::printf("output: one %d×%d full frame (750 particles), medians of %d interleaved rounds\n", kSize, kSize,
                counted);
    std::printf("  sRGB encoding   to_srgb8 %7.2f ms (1 thread) %7.2f ms (%d threads) | textbook powf %7.2f ms (1 thread): "
                "%.1fx; the formula differs on %zu of %zu channel values\n",
                srgb1, srgbN, all_threads, text1, text1 / srgb1, differing, pixels.pixels.size());
    std::printf("  PNG file (RGBA) ours     %7.2f ms %9.0f bytes | stb_image_write %7.2f ms %9.0f bytes: %.1fx faster, "
                "%.2f of stb's size; both read back exactly\n",
                ours, ours_bytes, stb, stb_bytes, stb / ours, ours_bytes / stb_bytes);
    std::printf("  the command line's step (check, sRGB, RGB, encode, file): %7.2f ms per frame of a sequence (one PngWriter), "
                "%7.2f ms for a single frame (write_png_srgb, fresh memory)\n",
                seq, single);

    CsvFile file("stage,implementation,threads,median_ms,bytes");
    file.row("srgb", "to_srgb8", 1, srgb1, 0);
    file.row("srgb", "to_srgb8", all_threads, srgbN, 0);
    file.row("srgb", "textbook_powf", 1, text1, 0);
    file.row("png_rgba", "ours_zlib", 1, ours, ours_bytes);
    file.row("png_rgba", "stb_image_write", 1, stb, stb_bytes);
    file.row("frame_to_png", "sequence_writer", all_threads, seq, double(fs::file_size(cli_file)));
    file.row("frame_to_png", "write_png_srgb", all_threads, single, double(fs::file_size(cli_file)));
    file.write(fs::path(options.results_dir) / "output.csv");

    report("output_srgb_ms", srgbN);
    report("output_srgb_speedup_vs_textbook", text1 / srgb1);
    report("output_png_ms", ours);
    report("output_png_speedup_vs_stb", stb / ours);
    report("output_png_size_vs_stb", ours_bytes / stb_bytes);
    report("output_sequence_frame_ms", seq);
    report("output_single_frame_ms", single);
}

const RegisterSection kOutputSection{{"output",
                                      "writing a 1024x1024 frame: sRGB encoding (vs the textbook formula) and PNG "
                                      "files (ours over zlib vs stb_image_write)",
                                      &run_output, true}};

}  // namespace
}  // namespace smoketrace::bench
