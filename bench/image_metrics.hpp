#pragma once
// Error of a frame against the ground truth (bench section "truth"): the metrics beside those of
// error_metrics.hpp that a comparison with a converged volume render needs.
//
//  * image error inside a mask (the ground pixels the smoke shadows): RMSE and PSNR over those pixels
//    alone, on linear RGB, as image_error() computes them over the whole image;
//  * SSIM (Wang, Bovik, Sheikh & Simoncelli 2004, "Image quality assessment: from error visibility to
//    structural similarity") on the luma of the 8-bit sRGB images a viewer sees: an 11-tap Gaussian window
//    of standard deviation 1.5 pixels, C1 = (0.01·L)², C2 = (0.03·L)² with L = 1, averaged over every
//    window that lies wholly inside the image (no padding: a border would invent structure);
//  * per-particle transmittance toward the light, the frame's exp(−σt·l) against the truth's exp(−τ):
//    mean, maximum and RMS of the absolute difference over every particle (l = +∞ gives 0).
#include "error_metrics.hpp"

#include <smoketrace/core/image.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <stdexcept>
#include <vector>

namespace smoketrace::bench {

// RMSE and PSNR (peak 1) over the pixels where mask is non-zero, on linear RGB, alpha ignored; max_abs is
// the largest channel difference there. An empty mask gives rmse 0 and PSNR +inf; `pixels` says how many.
struct MaskedImageError {
    ImageError error;
    std::size_t pixels = 0;
};

inline MaskedImageError masked_image_error(const ImageRgba& image, const ImageRgba& ref,
                                           std::span<const std::uint8_t> mask) {
    if (mask.size() != image.pixels.size()) throw std::invalid_argument("masked_image_error: mask size differs");
    MaskedImageError e;
    e.error = image_error_where(image, ref, [&](std::size_t i) { return mask[i] != 0; }, &e.pixels);
    return e;
}

// The luma Y' = 0.2126 R' + 0.7152 G' + 0.0722 B' (ITU-R BT.709) of the 8-bit sRGB codes the PNG holds,
// in [0, 1]: what SSIM is conventionally computed on. Row-major, top row first.
inline std::vector<double> srgb_luma(const ImageRgba& image) {
    std::vector<double> y(image.pixels.size());
    for (std::size_t i = 0; i < y.size(); ++i) {
        const glm::vec4& p = image.pixels[i];
        y[i] = (0.2126 * linear_to_srgb8(p.x) + 0.7152 * linear_to_srgb8(p.y) + 0.0722 * linear_to_srgb8(p.z)) / 255.0;
    }
    return y;
}

// The normalised 11-tap Gaussian of standard deviation 1.5 (the SSIM paper's window, separable).
inline std::vector<double> ssim_gaussian_window() {
    std::vector<double> w(11);
    double sum = 0;
    for (int i = 0; i < 11; ++i) {
        const double x = i - 5;
        w[std::size_t(i)] = std::exp(-x * x / (2.0 * 1.5 * 1.5));
        sum += w[std::size_t(i)];
    }
    for (double& v : w) v /= sum;
    return w;
}

inline constexpr double kSsimC1 = 0.01 * 0.01;  // (K1·L)², K1 = 0.01, L = 1
inline constexpr double kSsimC2 = 0.03 * 0.03;  // (K2·L)², K2 = 0.03

// Mean SSIM of two planes of values in [0, 1] (width × height, row-major) under the separable window
// `window` (odd length n, weights summing to 1, the same along x and y): per window position
//     SSIM = (2·μx·μy + C1)(2·σxy + C2) / ((μx² + μy² + C1)(σx² + σy² + C2)),
// the moments weighted by the window; the mean over the (width − n + 1)·(height − n + 1) positions where the
// window fits. Throws std::invalid_argument when the planes differ in size or the window does not fit.
inline double ssim(std::span<const double> x, std::span<const double> y, int width, int height,
                   std::span<const double> window) {
    const int n = int(window.size());
    if (x.size() != y.size() || x.size() != std::size_t(width) * std::size_t(height))
        throw std::invalid_argument("ssim: plane sizes differ");
    if (n % 2 == 0 || n > width || n > height) throw std::invalid_argument("ssim: the window does not fit the image");
    const int ow = width - n + 1, oh = height - n + 1;
    // Five weighted moments, filtered along x into the valid columns, then along y.
    auto filter = [&](auto&& value) {
        std::vector<double> rows(std::size_t(ow) * std::size_t(height)), out(std::size_t(ow) * std::size_t(oh));
        for (int r = 0; r < height; ++r)
            for (int c = 0; c < ow; ++c) {
                double s = 0;
                for (int k = 0; k < n; ++k) s += window[std::size_t(k)] * value(std::size_t(r) * std::size_t(width) + std::size_t(c + k));
                rows[std::size_t(r) * std::size_t(ow) + std::size_t(c)] = s;
            }
        for (int r = 0; r < oh; ++r)
            for (int c = 0; c < ow; ++c) {
                double s = 0;
                for (int k = 0; k < n; ++k) s += window[std::size_t(k)] * rows[std::size_t(r + k) * std::size_t(ow) + std::size_t(c)];
                out[std::size_t(r) * std::size_t(ow) + std::size_t(c)] = s;
            }
        return out;
    };
    const auto mx = filter([&](std::size_t i) { return x[i]; });
    const auto my = filter([&](std::size_t i) { return y[i]; });
    const auto xx = filter([&](std::size_t i) { return x[i] * x[i]; });
    const auto yy = filter([&](std::size_t i) { return y[i] * y[i]; });
    const auto xy = filter([&](std::size_t i) { return x[i] * y[i]; });
    double sum = 0;
    for (std::size_t i = 0; i < mx.size(); ++i) {
        // Moments as E[xy] − μx·μy. Not clamped: a flat window may give −1e-17, which C2 absorbs, and the
        // same expression for σx², σy² and σxy makes SSIM(x, x) exactly 1.
        const double vx = xx[i] - mx[i] * mx[i], vy = yy[i] - my[i] * my[i], cxy = xy[i] - mx[i] * my[i];
        sum += (2.0 * mx[i] * my[i] + kSsimC1) * (2.0 * cxy + kSsimC2) /
               ((mx[i] * mx[i] + my[i] * my[i] + kSsimC1) * (vx + vy + kSsimC2));
    }
    return sum / double(mx.size());
}

// Mean SSIM of two frames: the Gaussian window on their sRGB luma.
inline double ssim_srgb(const ImageRgba& image, const ImageRgba& ref) {
    if (image.width != ref.width || image.height != ref.height) throw std::invalid_argument("ssim_srgb: sizes differ");
    const std::vector<double> a = srgb_luma(image), b = srgb_luma(ref), w = ssim_gaussian_window();
    return ssim(a, b, image.width, image.height, w);
}

// |exp(−σt·l_i) − exp(−τ_i)| over every particle: the frame's transmittance toward the light (its optical
// path length l, +∞ when dark) against the truth's (optical depth τ).
struct TransmittanceError {
    double mean = 0, max = 0, rms = 0;
};

inline TransmittanceError transmittance_error(std::span<const float> lengths, float sigma_t,
                                              std::span<const double> true_tau) {
    if (lengths.size() != true_tau.size()) throw std::invalid_argument("transmittance_error: sizes differ");
    TransmittanceError e;
    double sum = 0, sum_sq = 0;
    for (std::size_t i = 0; i < lengths.size(); ++i) {
        const double t = std::isinf(lengths[i]) ? 0.0 : std::exp(-double(sigma_t) * double(lengths[i]));
        const double d = std::abs(t - std::exp(-true_tau[i]));
        sum += d;
        sum_sq += d * d;
        e.max = std::max(e.max, d);
    }
    if (!lengths.empty()) {
        e.mean = sum / double(lengths.size());
        e.rms = std::sqrt(sum_sq / double(lengths.size()));
    }
    return e;
}

}  // namespace smoketrace::bench
