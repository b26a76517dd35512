// The density kernels' fit (render/kernel_fit.hpp): the fitter recovers a profile's own kernel, and a refit
// from the shipped six-way bake's settings gives the defaults of smoke/density_kernel.hpp.
#include <smoketrace/io/sixway_files.hpp>
#include <smoketrace/render/kernel_fit.hpp>
#include <smoketrace/smoke/density_kernel.hpp>

#include <catch2/catch.hpp>

#include <cmath>
#include <string>

using namespace smoketrace;

namespace {

// The defaults are the fit's numbers written with four decimals: half a unit of the fourth, plus the float
// the constant is stored in (2^-24 relative, below 10^-7 for numbers under 2).
constexpr double kStatedDigits = 0.5e-4 + 1e-7;

}  // namespace

TEST_CASE("kernel fit: the fit recovers the kernel a profile was sampled from", "[kernel]") {
    for (const DensityKernelKind kind : {DensityKernelKind::gaussian, DensityKernelKind::poly1, DensityKernelKind::poly2}) {
        const double support = 0.6125, peak = 1.3;  // off the scan's grid of 1/1000
        RadialProfile p;
        for (int i = 0; i < 2000; ++i) {
            p.q.push_back((i + 0.5) / 2000);
            p.density.push_back(peak * kernel_profile(kind, p.q.back() / support));
        }
        const KernelFit fit = fit_density_kernel(kind, p);
        INFO(fit.kernel.name() << ": support " << fit.kernel.support << ", peak " << fit.kernel.peak);
        // The Gaussian's jump at its support (1.1 % of the peak) lets the error change only where the support
        // crosses a shell's middle: its support is known to within a shell (1/2000). The polynomials vanish at
        // the rim, so theirs is found to the search's 10^-7 (as floats, 10^-6 leaves room).
        const double support_tolerance = kind == DensityKernelKind::gaussian ? 1.0 / 2000 : 1e-6;
        CHECK(std::abs(fit.kernel.support - support) <= support_tolerance);
        CHECK(std::abs(fit.kernel.peak - peak) <= (kind == DensityKernelKind::gaussian ? 1e-3 : 1e-6));
        CHECK(fit.residual <= (kind == DensityKernelKind::gaussian ? 1e-2 : 1e-6));
    }
    CHECK_THROWS_AS(fit_density_kernel(DensityKernelKind::uniform, RadialProfile{}), std::invalid_argument);
}

TEST_CASE("kernel fit: refitting the shipped bake's puff gives the kernels' defaults", "[kernel]") {
    const SixwayBakeSettings puff = read_sixway_bake_settings(std::string(SMOKETRACE_ASSET_DIR) + "/sixway.json");
    const RadialProfile profile = puff_radial_profile(puff);
    // The profile's own shape, as docs/design.md shows it: full density at the centre, none at the puff's edge
    // (radius · (1 + noise_amplitude) bounds it, sixway_baker.hpp).
    CHECK(profile.density.front() == 1.0);
    const double extent = double(puff.radius) * (1.0 + double(puff.noise_amplitude));
    for (std::size_t i = 0; i < profile.q.size(); ++i)
        if (profile.q[i] >= extent) CHECK(profile.density[i] == 0.0);
    // The thesis's ball against the same profile: every fitted kernel must do far better.
    double ball = 0, norm = 0;
    for (std::size_t i = 0; i < profile.q.size(); ++i) {
        const double w = profile.q[i] * profile.q[i];
        ball += w * (1.0 - profile.density[i]) * (1.0 - profile.density[i]);
        norm += w * profile.density[i] * profile.density[i];
    }
    const double ball_residual = std::sqrt(ball / norm);
    for (const DensityKernelKind kind : {DensityKernelKind::gaussian, DensityKernelKind::poly1, DensityKernelKind::poly2}) {
        const KernelFit fit = fit_density_kernel(kind, profile);
        const DensityKernel stated = density_kernel(kind);
        INFO(fit.kernel.name() << ": fitted support " << fit.kernel.support << ", peak " << fit.kernel.peak
                               << ", residual " << fit.residual << "; stated " << stated.support << ", " << stated.peak
                               << "; the ball's residual " << ball_residual);
        CHECK(std::abs(double(fit.kernel.support) - double(stated.support)) <= kStatedDigits);
        CHECK(std::abs(double(fit.kernel.peak) - double(stated.peak)) <= kStatedDigits);
        CHECK(fit.residual < ball_residual / 10);
    }
}
