// The density kernels' fit to the baker's puff (see kernel_fit.hpp).
#include <smoketrace/render/kernel_fit.hpp>
#include <smoketrace/render/puff_density.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <glm/vec3.hpp>

#include <cmath>
#include <stdexcept>
#include <utility>

namespace smoketrace {

RadialProfile puff_radial_profile(const SixwayBakeSettings& puff, const RadialProfileSampling& sampling) {
    if (sampling.bins < 1 || sampling.directions < 1)
        throw std::invalid_argument("puff_radial_profile: bins and directions must be >= 1");
    validate(puff);
    // A Fibonacci sphere: direction k at height 1 − (2k + 1)/n, turned by the golden angle from the last.
    const double golden_angle = 3.14159265358979323846 * (3.0 - std::sqrt(5.0));
    std::vector<glm::vec3> dirs(std::size_t(sampling.directions));
    for (int k = 0; k < sampling.directions; ++k) {
        const double z = 1.0 - (2.0 * k + 1.0) / sampling.directions, ring = std::sqrt(1.0 - z * z);
        dirs[std::size_t(k)] = glm::vec3(float(ring * std::cos(golden_angle * k)), float(ring * std::sin(golden_angle * k)),
                                         float(z));
    }
    std::vector<PuffDensity> frames;
    for (int f = 0; f < puff.frames; ++f) frames.emplace_back(puff, f);
    RadialProfile p;
    p.q.resize(std::size_t(sampling.bins));
    p.density.resize(std::size_t(sampling.bins));
    tbb::parallel_for(tbb::blocked_range<int>(0, sampling.bins), [&](const tbb::blocked_range<int>& r) {
        for (int i = r.begin(); i != r.end(); ++i) {
            const double q = (i + 0.5) / sampling.bins;
            double sum = 0.0;
            for (const PuffDensity& density : frames)
                for (const glm::vec3& d : dirs) sum += density(float(q) * d);
            p.q[std::size_t(i)] = q;
            p.density[std::size_t(i)] = sum / (double(frames.size()) * double(dirs.size()));
        }
    });
    return p;
}

double kernel_profile(DensityKernelKind kind, double q) {
    if (q >= 1.0) return 0.0;
    switch (kind) {
        case DensityKernelKind::uniform: return 1.0;
        case DensityKernelKind::gaussian: return std::exp(-q * q * kGaussianSupportSigmas * kGaussianSupportSigmas / 2);
        case DensityKernelKind::poly1: return 1.0 - q * q;
        case DensityKernelKind::poly2: return (1.0 - q * q) * (1.0 - q * q);
    }
    return 0.0;
}

namespace {

// For one support: the best peak (linear least squares) and the weighted squared error it leaves.
std::pair<double, double> best_peak(DensityKernelKind kind, const RadialProfile& p, double support) {
    double fr = 0, ff = 0;
    for (std::size_t i = 0; i < p.q.size(); ++i) {
        const double w = p.q[i] * p.q[i], f = kernel_profile(kind, p.q[i] / support);
        fr += w * f * p.density[i];
        ff += w * f * f;
    }
    const double peak = ff > 0 ? fr / ff : 0.0;
    double error = 0;
    for (std::size_t i = 0; i < p.q.size(); ++i) {
        const double e = peak * kernel_profile(kind, p.q[i] / support) - p.density[i];
        error += p.q[i] * p.q[i] * e * e;
    }
    return {peak, error};
}

}  // namespace

KernelFit fit_density_kernel(DensityKernelKind kind, const RadialProfile& p) {
    if (kind == DensityKernelKind::uniform)
        throw std::invalid_argument("fit_density_kernel: the uniform kernel has the thesis's scale, not a fitted one");
    constexpr int kScanSteps = 1000;
    int best = kScanSteps;
    double best_error = best_peak(kind, p, 1.0).second;
    for (int s = 1; s < kScanSteps; ++s) {
        const double e = best_peak(kind, p, double(s) / kScanSteps).second;
        if (e < best_error) best_error = e, best = s;
    }
    // Golden-section search over the scan's best step and its two neighbours.
    double lo = double(best - 1) / kScanSteps, hi = std::min(1.0, double(best + 1) / kScanSteps);
    const double ratio = (std::sqrt(5.0) - 1.0) / 2.0;
    double x1 = hi - ratio * (hi - lo), x2 = lo + ratio * (hi - lo);
    double e1 = best_peak(kind, p, x1).second, e2 = best_peak(kind, p, x2).second;
    while (hi - lo > 1e-7) {
        if (e1 <= e2) {
            hi = x2, x2 = x1, e2 = e1;
            x1 = hi - ratio * (hi - lo);
            e1 = best_peak(kind, p, x1).second;
        } else {
            lo = x1, x1 = x2, e1 = e2;
            x2 = lo + ratio * (hi - lo);
            e2 = best_peak(kind, p, x2).second;
        }
    }
    const double support = std::min(1.0, (lo + hi) / 2);
    const auto [peak, error] = best_peak(kind, p, support);
    double norm = 0;
    for (std::size_t i = 0; i < p.q.size(); ++i) norm += p.q[i] * p.q[i] * p.density[i] * p.density[i];
    return {DensityKernel{kind, float(support), float(peak)}, std::sqrt(error / norm)};
}

}  // namespace smoketrace
