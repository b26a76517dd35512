#pragma once
// Error of a render configuration against the exact reference (bench section "error").
//
// Optical path length (per particle, the l of eq. 3.1):
//   * particles whose l is finite in both runs: absolute error |l − l_ref| (world units) and relative
//     error |l − l_ref| / l_ref; mean, 99th percentile (nearest rank) and max over those particles.
//     l_ref > 0 always: a particle's ray starts at its centre, inside its own stand-in, so l ≥ its radius.
//   * l = +inf ("fully dark": occluded by the ground, or over the cutoff) cannot enter a difference. It is
//     counted instead: both_dark (both +inf, an exact agreement), false_dark (this run +inf where the
//     reference is finite: what a cutoff does) and false_lit (finite where the reference is +inf).
//   * transmittance error |exp(−σt·l) − exp(−σt·l_ref)| over EVERY particle (+inf gives T = 0): one
//     bounded number that also prices the dark mismatches; mean and max.
// Image (the rendered frame against the reference's render of the same frame): on linear RGB values as
// the renderer computes them (before the sRGB encoding of the PNG), alpha ignored; RMSE over all pixels
// and the three channels, PSNR = 10·log10(1 / MSE) dB with peak 1 (+inf for identical images), and the
// largest absolute channel difference.
#include <smoketrace/core/image.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>
#include <stdexcept>
#include <vector>

namespace smoketrace::bench {

struct PathLengthError {
    std::size_t particles = 0;
    std::size_t compared = 0;  // finite in both runs
    std::size_t both_dark = 0;
    std::size_t false_dark = 0;
    std::size_t false_lit = 0;
    double abs_mean = 0, abs_p99 = 0, abs_max = 0;
    double rel_mean = 0, rel_p99 = 0, rel_max = 0;
    double transmittance_mean = 0, transmittance_max = 0;
    [[nodiscard]] std::size_t dark_mismatch() const { return false_dark + false_lit; }
};

// Nearest-rank percentile (q in (0, 1]) of v; v is sorted in place. 0 for an empty v.
inline double percentile(std::vector<double>& v, double q) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    const auto rank = static_cast<std::size_t>(std::ceil(q * double(v.size())));
    return v[std::clamp<std::size_t>(rank, 1, v.size()) - 1];
}

inline PathLengthError path_length_error(std::span<const float> l, std::span<const float> ref, float sigma_t) {
    if (l.size() != ref.size()) throw std::invalid_argument("path_length_error: sizes differ");
    PathLengthError e;
    e.particles = l.size();
    std::vector<double> abs_err, rel_err;
    abs_err.reserve(l.size());
    rel_err.reserve(l.size());
    double t_sum = 0;
    auto transmittance = [&](float x) { return std::isinf(x) ? 0.0 : std::exp(-double(sigma_t) * double(x)); };
    for (std::size_t i = 0; i < l.size(); ++i) {
        const bool dark = std::isinf(l[i]), ref_dark = std::isinf(ref[i]);
        const double dt = std::abs(transmittance(l[i]) - transmittance(ref[i]));
        t_sum += dt;
        e.transmittance_max = std::max(e.transmittance_max, dt);
        if (dark && ref_dark) {
            ++e.both_dark;
        } else if (dark) {
            ++e.false_dark;
        } else if (ref_dark) {
            ++e.false_lit;
        } else {
            const double a = std::abs(double(l[i]) - double(ref[i]));
            abs_err.push_back(a);
            rel_err.push_back(a / std::max(double(ref[i]), 1e-12));
        }
    }
    e.compared = abs_err.size();
    if (!l.empty()) e.transmittance_mean = t_sum / double(l.size());
    auto summarise = [](std::vector<double>& v, double& mean, double& p99, double& max) {
        if (v.empty()) return;
        double s = 0;
        for (double x : v) s += x;
        mean = s / double(v.size());
        p99 = percentile(v, 0.99);
        max = v.back();  // sorted by percentile()
    };
    summarise(abs_err, e.abs_mean, e.abs_p99, e.abs_max);
    summarise(rel_err, e.rel_mean, e.rel_p99, e.rel_max);
    return e;
}

struct ImageError {
    double rmse = 0;
    double psnr_db = std::numeric_limits<double>::infinity();
    double max_abs = 0;
};

// RMSE, PSNR (peak 1) and the largest channel difference on linear RGB (alpha ignored) over the pixels i for
// which keep(i) holds; `counted` (if given) receives how many. No pixel kept: rmse 0, PSNR +inf.
template <class Keep>
ImageError image_error_where(const ImageRgba& image, const ImageRgba& ref, Keep&& keep, std::size_t* counted = nullptr) {
    if (image.width != ref.width || image.height != ref.height)
        throw std::invalid_argument("image_error: sizes differ");
    double sum = 0, max_abs = 0;
    std::size_t kept = 0;
    for (std::size_t i = 0; i < image.pixels.size(); ++i) {
        if (!keep(i)) continue;
        ++kept;
        for (int c = 0; c < 3; ++c) {
            const double d = double(image.pixels[i][c]) - double(ref.pixels[i][c]);
            sum += d * d;
            max_abs = std::max(max_abs, std::abs(d));
        }
    }
    ImageError e;
    const double mse = kept ? sum / (3.0 * double(kept)) : 0.0;
    e.rmse = std::sqrt(mse);
    e.psnr_db = mse > 0 ? 10.0 * std::log10(1.0 / mse) : std::numeric_limits<double>::infinity();
    e.max_abs = max_abs;
    if (counted) *counted = kept;
    return e;
}

inline ImageError image_error(const ImageRgba& image, const ImageRgba& ref) {
    return image_error_where(image, ref, [](std::size_t) { return true; });
}

// Per-pixel error for a heat map: the RMS over the three channels of the linear difference, row-major,
// top row first (as ImageRgba).
inline std::vector<float> pixel_error_map(const ImageRgba& image, const ImageRgba& ref) {
    if (image.width != ref.width || image.height != ref.height)
        throw std::invalid_argument("pixel_error_map: sizes differ");
    std::vector<float> map(image.pixels.size());
    for (std::size_t i = 0; i < map.size(); ++i) {
        double s = 0;
        for (int c = 0; c < 3; ++c) {
            const double d = double(image.pixels[i][c]) - double(ref.pixels[i][c]);
            s += d * d;
        }
        map[i] = float(std::sqrt(s / 3.0));
    }
    return map;
}

}  // namespace smoketrace::bench
