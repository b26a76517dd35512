#pragma once
// A density kernel's light by quadrature, in double: the density the stand-ins stand for (density_kernel.hpp's
// ρ = peak·f(|x − c| / R), summed over the particles) evaluated point by point from its definition and
// integrated along a ray with Simpson's rule between the supports' boundaries, never through the closed
// forms. The reference the view's kernel shadows and the kernel's optical depths are held to in
// tests/test_render_by_hand.cpp.
#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/particle_system.hpp>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <span>
#include <vector>

namespace smoketrace::test {

// f(q) of density_kernel.hpp's file comment, q = distance / R: 0 <= q < 1 inside the support.
inline double kernel_profile(DensityKernelKind kind, double q) {
    switch (kind) {
        case DensityKernelKind::uniform: return 1.0;
        case DensityKernelKind::poly1: return 1.0 - q * q;
        case DensityKernelKind::poly2: return (1.0 - q * q) * (1.0 - q * q);
        case DensityKernelKind::gaussian: {
            const double k = kGaussianSupportSigmas;  // σ = R / k
            return std::exp(-0.5 * q * q * k * k);
        }
    }
    return 0.0;
}

// peak·f at x of particle p's kernel, f continued past the support's rim (q > 1) by its formula: the
// quadrature below decides which particles cover a stretch once, at its middle, so that a node on a rim
// counts the particle the stretch is inside of, whichever way the rounding of q falls there.
inline double kernel_density(const DensityKernel& k, const Particle& p, const glm::dvec3& x) {
    const double q = glm::length(x - glm::dvec3(p.center)) / (double(k.support) * double(p.radius));
    return double(k.peak) * kernel_profile(k.kind, q);
}

// Simpson panels per stretch between two neighbouring support boundaries. Inside one stretch the summed
// density is smooth in t: per particle a quadratic (poly1), which Simpson integrates exactly, a quartic
// (poly2), with an error of (stretch)·h⁴/180 times its fourth derivative 24·peak/R⁴, at most 10^-9·peak·R
// for a whole chord, or a Gaussian, whose error at this step is smaller still (against 2048 panels, at most
// 3·10^-10·peak·R over random chords). Far below a float's rounding of the result.
inline constexpr int kSimpsonPanels = 256;

// ∫ over t >= 0 of the summed density along o + t·d (d: unit length), and in `rim_distance` (when given) the
// least |b − R| over the particles, b the ray's distance from the centre: how close the ray grazes a support's
// rim, where a kernel with f(1) > 0 makes the integral a square-root function of the ray's position.
inline double density_integral(const DensityKernel& k, std::span<const Particle> ps, const glm::dvec3& o,
                               const glm::dvec3& d, double* rim_distance = nullptr) {
    std::vector<double> cuts{0.0};
    double rim = INFINITY;
    for (const Particle& p : ps) {
        const glm::dvec3 v = glm::dvec3(p.center) - o;
        const double s0 = glm::dot(v, d);
        const double b = glm::length(glm::cross(v, d));  // the distance of the line from the centre
        const double support = double(k.support) * double(p.radius);
        rim = std::min(rim, std::abs(b - support));
        if (b >= support) continue;
        const double a = std::sqrt(support * support - b * b);
        if (s0 - a > 0.0) cuts.push_back(s0 - a);
        if (s0 + a > 0.0) cuts.push_back(s0 + a);
    }
    if (rim_distance) *rim_distance = rim;
    std::sort(cuts.begin(), cuts.end());
    double integral = 0.0;
    std::vector<const Particle*> inside;
    for (std::size_t c = 0; c + 1 < cuts.size(); ++c) {
        const double t0 = cuts[c], t1 = cuts[c + 1], h = (t1 - t0) / kSimpsonPanels;
        if (!(h > 0.0)) continue;
        inside.clear();
        const glm::dvec3 middle = o + 0.5 * (t0 + t1) * d;
        for (const Particle& p : ps)
            if (glm::length(middle - glm::dvec3(p.center)) < double(k.support) * double(p.radius)) inside.push_back(&p);
        auto rho = [&](double t) {
            double sum = 0.0;
            for (const Particle* p : inside) sum += kernel_density(k, *p, o + t * d);
            return sum;
        };
        double sum = rho(t0) + rho(t1);
        for (int i = 1; i < kSimpsonPanels; ++i) sum += (i % 2 == 1 ? 4.0 : 2.0) * rho(t0 + i * h);
        integral += sum * h / 3.0;
    }
    return integral;
}

}  // namespace smoketrace::test
