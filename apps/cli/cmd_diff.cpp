// smoketrace diff: where two float images differ (a frame and its ground truth, docs/explain.md), as an
// image and two numbers.
#include "arguments.hpp"
#include "command.hpp"
#include "output_arg.hpp"

#include <smoketrace/io/image_files.hpp>
#include <smoketrace/io/output_path.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

namespace smoketrace::cli {
namespace {

int run_diff(const Args& args) {
    ArgReader in(args);
    const auto out_arg = in.string("-o");
    const auto scale_arg = in.number("--scale", 1e-30, 1e30);
    const std::string a_path = in.positional("first image (smoketrace diff A.exr B.exr -o D.png)");
    const std::string b_path = in.positional("second image (smoketrace diff A.exr B.exr -o D.png)");
    in.finish();
    if (!out_arg) throw CliError("missing -o D.png");
    const std::filesystem::path out(*out_arg);
    ImageFileKind kind;
    try {
        kind = output_image_kind(out);
    } catch (const OutputPathError& e) {
        throw CliError(std::string("-o: ") + e.what());
    }
    const OutputTarget target = checked_output(out, {a_path, b_path});
    const ImageRgba a = read_float_image(a_path);
    const ImageRgba b = read_float_image(b_path);
    if (a.width != b.width || a.height != b.height)
        throw CliError(quoted_arg(a_path) + " is " + std::to_string(a.width) + "x" + std::to_string(a.height) + ", " +
                       quoted_arg(b_path) + " " + std::to_string(b.width) + "x" + std::to_string(b.height) +
                       ": the images must be of one size");

    // A − B per channel; the pixel's difference d is the mean of its three (what the PNG shows).
    ImageRgba difference(a.width, a.height);
    double squares = 0.0, largest_channel = 0.0, largest_pixel = 0.0;
    for (std::size_t i = 0; i < a.pixels.size(); ++i) {
        const glm::vec3 d = glm::vec3(a.pixels[i]) - glm::vec3(b.pixels[i]);
        for (int c = 0; c < 3; ++c) {
            squares += double(d[c]) * double(d[c]);
            largest_channel = std::max(largest_channel, double(std::abs(d[c])));
        }
        largest_pixel = std::max(largest_pixel, std::abs((double(d.x) + d.y + d.z) / 3.0));
        difference.pixels[i] = glm::vec4(d, 1.0f);
    }
    const double rmse = std::sqrt(squares / (3.0 * double(a.pixels.size())));
    // The PNG: red where A is brighter, blue where B is, black where they agree; |d| times the scale, the
    // largest difference full strength unless --scale says otherwise.
    const double scale = scale_arg ? *scale_arg : largest_pixel > 0.0 ? 1.0 / largest_pixel : 1.0;
    if (kind == ImageFileKind::png)
        for (glm::vec4& p : difference.pixels) {
            const float d = float(scale * ((double(p.x) + p.y + p.z) / 3.0));
            p = glm::vec4(std::clamp(d, 0.0f, 1.0f), 0.0f, std::clamp(-d, 0.0f, 1.0f), 1.0f);
        }
    write_image(out, difference);
    // The numbers on standard output, unless the image is there.
    std::ostream& report = target.kind == OutputKind::standard_output ? std::cerr : std::cout;
    char line[160];
    std::snprintf(line, sizeof line, "rmse=%.6g max_abs=%.6g (linear radiance, RGB channels of %dx%d pixels)\n",
                  rmse, largest_channel, a.width, a.height);
    report << line;
    if (kind == ImageFileKind::png) {
        std::snprintf(line, sizeof line, "scale=%.6g (full red or blue: a pixel's mean difference of %.6g)\n", scale,
                      1.0 / scale);
        report << line;
    }
    std::cerr << (target.kind == OutputKind::standard_output
                      ? std::string("wrote the difference to standard output")
                      : "wrote " + shown_text(out.string(), kMaxShownPathBytes))
              << "\n";
    return 0;
}

constexpr OptionHelp kOptions[] = {
    {"-o", "D.png|D.exr|D.pfm|-", "",
     "the difference A - B: .png red where A is brighter, blue where B is (a pixel's mean over R, G, B, times "
     "--scale, in sRGB); .exr or .pfm the signed A - B per channel, linear float"},
    {"--scale", "S", "1 / the largest difference", "what the PNG multiplies the differences by before clamping to 1"},
};

const RegisterCommand registration{
    {"diff", "diff A.exr|A.pfm B.exr|B.pfm -o D.png|D.exr|D.pfm|- [--scale S]",
     "the difference of two float images of one size (a frame and its truth): an image, and the RMSE and "
     "largest difference of their linear RGB on standard output",
     &run_diff, kOptions}};

}  // namespace
}  // namespace smoketrace::cli
