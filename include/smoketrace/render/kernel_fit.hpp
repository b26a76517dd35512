#pragma once
// The fit of the smooth density kernels (smoke/density_kernel.hpp) to the six-way baker's puff
// (puff_density.hpp): each kernel's scale, its support R and its peak, chosen so that its radial profile is
// closest to the puff's mean radial density, and a particle's optical depth approximates the puff volume's
// (docs/design.md, "Density kernels"). Here, not in smoke/, because the puff is the render layer's; the fitted
// numbers live in density_kernel.hpp as its defaults, and tests/test_kernel_fit.cpp refits them.
#include <smoketrace/render/sixway_baker.hpp>
#include <smoketrace/smoke/density_kernel.hpp>

#include <vector>

namespace smoketrace {

// How finely the puff's mean radial density is sampled: the fit of the defaults used these.
struct RadialProfileSampling {
    int bins = 200;         // shells of equal width over q ∈ [0, 1] (tangent units: 1 = the particle's radius)
    int directions = 2000;  // points of a Fibonacci sphere on each shell
};

// The puff's density averaged over each shell's directions and over the flipbook's frames, at the shells'
// middle radii q[i] = (i + 1/2) / bins. Deterministic (shells in parallel, each summed in a fixed order).
struct RadialProfile {
    std::vector<double> q, density;
};
[[nodiscard]] RadialProfile puff_radial_profile(const SixwayBakeSettings& puff, const RadialProfileSampling& sampling = {});

// The profile f(q) of a kernel of `kind` (density_kernel.hpp), 0 for q >= 1.
[[nodiscard]] double kernel_profile(DensityKernelKind kind, double q);

struct KernelFit {
    DensityKernel kernel;  // the fitted support and peak, rounded to float
    // The least-squares error over the volume, relative: √(Σ q² (ρ_kernel − ρ̄)² / Σ q² ρ̄²).
    double residual = 0;
};

// Least squares over the volume of the averaged puff: minimises Σ_i q_i² (peak · f(q_i / support) − ρ̄_i)²
// (each shell weighted by its volume) over peak (in closed form for each support) and support ∈ (0, 1] (a
// scan at steps of 1/1000, then golden-section search in the best step's neighbourhood to 10^-7). `kind`
// smooth (std::invalid_argument for uniform, whose scale is the thesis's).
[[nodiscard]] KernelFit fit_density_kernel(DensityKernelKind kind, const RadialProfile& profile);

}  // namespace smoketrace
