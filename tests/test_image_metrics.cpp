// The benchmark's image metrics (bench/image_metrics.hpp, bench/error_metrics.hpp), on images small enough to
// work out by hand: PSNR, RMSE inside a mask, SSIM with the Gaussian and with a box window, luma of the sRGB
// codes, and the per-particle transmittance error. Values are dyadic where an image holds them, so that the
// float pixels are the numbers written here; the tolerances are a few roundings of double arithmetic.
#include "../bench/image_metrics.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

using namespace smoketrace;
using namespace smoketrace::bench;

namespace {
constexpr double kRounding = 1e-12;  // double sums of at most a few hundred terms of size <= 1

ImageRgba filled(int w, int h, glm::vec4 value) { return ImageRgba(w, h, value); }
}  // namespace

TEST_CASE("image metrics: PSNR and RMSE of a uniform difference", "[image_metrics]") {
    const ImageRgba a = filled(5, 3, {0.5f, 0.25f, 0.75f, 1.0f});
    const ImageRgba b = filled(5, 3, {0.625f, 0.125f, 0.875f, 0.0f});  // every channel 1/8 off, alpha ignored
    const ImageError e = image_error(a, b);
    CHECK(e.rmse == 0.125);
    CHECK(e.psnr_db == Approx(10.0 * std::log10(64.0)).margin(kRounding));  // MSE 1/64: 18.06 dB
    CHECK(e.max_abs == 0.125);
    const ImageError same = image_error(a, a);
    CHECK(same.rmse == 0.0);
    CHECK(std::isinf(same.psnr_db));
}

TEST_CASE("image metrics: RMSE and PSNR inside a mask count only the masked pixels", "[image_metrics]") {
    const ImageRgba ref = filled(4, 4, {0.5f, 0.5f, 0.5f, 1.0f});
    ImageRgba img = ref;
    img.at(0, 0) = {0.625f, 0.625f, 0.625f, 1.0f};  // masked: 1/8 off in each channel
    img.at(1, 1) = {0.75f, 0.5f, 0.5f, 1.0f};       // masked: 1/4 off in red
    img.at(2, 2) = {1.5f, 1.5f, 1.5f, 1.0f};        // not masked: 1 off, must not count
    std::vector<std::uint8_t> mask(16, 0);
    mask[0] = 1;
    mask[5] = 1;
    mask[15] = 1;  // masked, equal to the reference
    const MaskedImageError m = masked_image_error(img, ref, mask);
    // MSE over 3 pixels × 3 channels: (3/64 + 1/16 + 0) / 9 = 7/576.
    CHECK(m.pixels == 3);
    CHECK(m.error.rmse == Approx(std::sqrt(7.0 / 576.0)).margin(kRounding));
    CHECK(m.error.psnr_db == Approx(10.0 * std::log10(576.0 / 7.0)).margin(kRounding));
    CHECK(m.error.max_abs == 0.25);

    const std::vector<std::uint8_t> none(16, 0);
    const MaskedImageError empty = masked_image_error(img, ref, none);
    CHECK(empty.pixels == 0);
    CHECK(std::isinf(empty.error.psnr_db));
    CHECK_THROWS_AS(masked_image_error(img, ref, std::vector<std::uint8_t>(15, 1)), std::invalid_argument);
}

TEST_CASE("image metrics: SSIM of identical images is 1", "[image_metrics]") {
    ImageRgba a(24, 20);
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            a.at(x, y) = {float((x * 7 + y * 3) % 11) / 10.0f, float((x + y) % 2), float(x) / 23.0f, 1.0f};
    CHECK(ssim_srgb(a, a) == 1.0);
    const ImageRgba copy = a;
    CHECK(ssim_srgb(a, copy) == 1.0);
}

TEST_CASE("image metrics: SSIM of flat images is the luminance term alone", "[image_metrics]") {
    // No variance anywhere: SSIM = (2ab + C1) / (a² + b² + C1) in every window.
    const double a = 0.5, b = 0.25;
    const std::vector<double> x(12 * 12, a), y(12 * 12, b);
    const double expected = (2 * a * b + kSsimC1) / (a * a + b * b + kSsimC1);  // 0.80006…
    CHECK(ssim(x, y, 12, 12, ssim_gaussian_window()) == Approx(expected).margin(kRounding));
}

TEST_CASE("image metrics: SSIM of one 3x3 box window, by hand", "[image_metrics]") {
    // x: a bright centre on black; y: its negative. With the window 1/3 along each axis every pixel
    // weighs 1/9: μx = 1/9, μy = 8/9, σx² = σy² = 1/9 − 1/81 = 8/81, σxy = E[x·y] − μx·μy = 0 − 8/81.
    const std::vector<double> x = {0, 0, 0, 0, 1, 0, 0, 0, 0};
    std::vector<double> y(9);
    for (std::size_t i = 0; i < 9; ++i) y[i] = 1.0 - x[i];
    const std::vector<double> box = {1.0 / 3, 1.0 / 3, 1.0 / 3};
    const double mx = 1.0 / 9, my = 8.0 / 9, v = 8.0 / 81, cxy = -8.0 / 81;
    const double expected = (2 * mx * my + kSsimC1) * (2 * cxy + kSsimC2) / ((mx * mx + my * my + kSsimC1) * (2 * v + kSsimC2));
    CHECK(expected == Approx(-0.24401).margin(1e-5));  // negatively correlated: below zero
    CHECK(ssim(x, y, 3, 3, box) == Approx(expected).margin(kRounding));
    // Against black: μy = σy = σxy = 0, so SSIM = C1 / (1/81 + C1) · C2 / (8/81 + C2).
    const std::vector<double> black(9, 0.0);
    CHECK(ssim(x, black, 3, 3, box) ==
          Approx(kSsimC1 / (1.0 / 81 + kSsimC1) * kSsimC2 / (8.0 / 81 + kSsimC2)).margin(kRounding));
    CHECK_THROWS_AS(ssim(x, y, 3, 3, ssim_gaussian_window()), std::invalid_argument);  // 11 taps > 3 pixels
}

TEST_CASE("image metrics: luma of the sRGB codes", "[image_metrics]") {
    ImageRgba img(3, 1);
    img.at(0, 0) = {1.0f, 1.0f, 1.0f, 1.0f};
    img.at(1, 0) = {0.0f, 0.0f, 0.0f, 1.0f};
    img.at(2, 0) = {0.0f, 0.5f, 0.0f, 1.0f};
    const std::vector<double> y = srgb_luma(img);
    CHECK(y[0] == Approx(1.0).margin(kRounding));
    CHECK(y[1] == 0.0);
    // Linear 0.5 is sRGB code 188 (1.055·0.5^(1/2.4) − 0.055 = 0.7354, ·255 = 187.5 → 188).
    CHECK(linear_to_srgb8(0.5f) == 188);
    CHECK(y[2] == Approx(0.7152 * 188.0 / 255.0).margin(kRounding));
}

TEST_CASE("image metrics: per-particle transmittance error against true optical depths", "[image_metrics]") {
    const float inf = std::numeric_limits<float>::infinity();
    // σt = 2: l = 0 → T = 1 against τ = 0 (exact); l = +inf → T = 0 against τ = 0 (off by 1);
    // l = 1 → T = e⁻² against τ = 2 (exact); l = 0.5 → T = e⁻¹ against τ = 0 (off by 1 − e⁻¹).
    const std::vector<float> l = {0.0f, inf, 1.0f, 0.5f};
    const std::vector<double> tau = {0.0, 0.0, 2.0, 0.0};
    const TransmittanceError e = transmittance_error(l, 2.0f, tau);
    const double d = 1.0 - std::exp(-1.0);
    CHECK(e.mean == Approx((1.0 + d) / 4).margin(kRounding));
    CHECK(e.max == Approx(1.0).margin(kRounding));
    CHECK(e.rms == Approx(std::sqrt((1.0 + d * d) / 4)).margin(kRounding));
    CHECK_THROWS_AS(transmittance_error(l, 2.0f, std::vector<double>(3, 0.0)), std::invalid_argument);
}
