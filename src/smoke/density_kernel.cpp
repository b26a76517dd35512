// Density kernels and their closed-form stretch integrals (see density_kernel.hpp).
#include <smoketrace/smoke/density_kernel.hpp>

#include <glm/geometric.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

namespace smoketrace {

std::string DensityKernel::name() const {
    switch (kind) {
        case DensityKernelKind::uniform: return "uniform";
        case DensityKernelKind::gaussian: return "gaussian";
        case DensityKernelKind::poly1: return "poly1";
        case DensityKernelKind::poly2: return "poly2";
    }
    return "?";
}

DensityKernel density_kernel(DensityKernelKind kind) {
    switch (kind) {
        case DensityKernelKind::uniform: return kUniformKernel;
        case DensityKernelKind::gaussian: return kGaussianKernel;
        case DensityKernelKind::poly1: return kPoly1Kernel;
        case DensityKernelKind::poly2: return kPoly2Kernel;
    }
    return kUniformKernel;
}

std::optional<DensityKernel> parse_density_kernel(std::string_view name) {
    for (const DensityKernelKind kind : {DensityKernelKind::uniform, DensityKernelKind::gaussian,
                                         DensityKernelKind::poly1, DensityKernelKind::poly2}) {
        const DensityKernel k = density_kernel(kind);
        if (name == k.name()) return k;
    }
    return std::nullopt;
}

void validate(const DensityKernel& k) {
    if (k.kind == DensityKernelKind::uniform && !(k.support == 1.0f && k.peak == 1.0f))
        throw std::invalid_argument("density kernel uniform: the thesis's ball has support 1 and peak 1 (eq. 3.1 "
                                    "measures lengths, not densities), not " + std::to_string(k.support) + " and " +
                                    std::to_string(k.peak));
    if (!(k.support > 0.0f && k.support <= 1.0f))
        throw std::invalid_argument("density kernel " + k.name() + ": support " + std::to_string(k.support) +
                                    " is not in (0, 1] (the stand-in's sphere must bound the support)");
    if (!(k.peak > 0.0f && std::isfinite(k.peak)))
        throw std::invalid_argument("density kernel " + k.name() + ": peak " + std::to_string(k.peak) +
                                    " is not a finite number > 0");
}

namespace {

// The kernel's kind as a template argument: one loop per kind, no branch per lane.
template <class F>
decltype(auto) with_kind(DensityKernelKind kind, F&& f) {
    switch (kind) {
        case DensityKernelKind::gaussian: return f.template operator()<DensityKernelKind::gaussian>();
        case DensityKernelKind::poly1: return f.template operator()<DensityKernelKind::poly1>();
        case DensityKernelKind::poly2: return f.template operator()<DensityKernelKind::poly2>();
        case DensityKernelKind::uniform: break;
    }
    return f.template operator()<DensityKernelKind::uniform>();
}

// s0, b² and R of a block of N stretches from the float inputs at p[k] (N of each, aligned for widen()), then
// their shares: the geometry of particle_stretch_integral(), over lanes.
template <DensityKernelKind Kind, unsigned N>
[[gnu::always_inline]] inline simd::Doubles<N> block_integrals(const float* const ox, const float* const oy,
                                                               const float* const oz, const float* const cx,
                                                               const float* const cy, const float* const cz,
                                                               const float* const r, const glm::dvec3& d,
                                                               const DensityKernel& kernel) {
    using D = simd::Doubles<N>;
    const D vx = D::widen(cx) - D::widen(ox), vy = D::widen(cy) - D::widen(oy), vz = D::widen(cz) - D::widen(oz);
    const D dx = D::broadcast(d.x), dy = D::broadcast(d.y), dz = D::broadcast(d.z);
    const D s0 = vx * dx + vy * dy + vz * dz;
    const D wx = vy * dz - vz * dy, wy = vz * dx - vx * dz, wz = vx * dy - vy * dx;
    const D b2 = wx * wx + wy * wy + wz * wz;
    const D radius = D::broadcast(double(kernel.support)) * D::widen(r);
    return detail::stretch_integrals<Kind, N>(s0, b2, radius, double(kernel.peak));
}

}  // namespace

double kernel_stretch_integral(const DensityKernel& kernel, double s0, double b2, double radius) {
    return with_kind(kernel.kind, [&]<DensityKernelKind Kind>() {
        using D = simd::Doubles<1>;
        return detail::stretch_integrals<Kind, 1>(D::broadcast(s0), D::broadcast(b2), D::broadcast(radius),
                                                  double(kernel.peak))
            .lane[0];
    });
}

double particle_stretch_integral(const DensityKernel& kernel, const glm::vec3& origin, const glm::dvec3& unit_direction,
                                 const glm::vec3& centre, float radius) {
    return with_kind(kernel.kind, [&]<DensityKernelKind Kind>() {
        alignas(64) const float in[7] = {origin.x, origin.y, origin.z, centre.x, centre.y, centre.z, radius};
        return block_integrals<Kind, 1>(in, in + 1, in + 2, in + 3, in + 4, in + 5, in + 6, unit_direction, kernel)
            .lane[0];
    });
}

void KernelStretches::resize(std::size_t n) {
    for (Floats* v : {&ox_, &oy_, &oz_, &cx_, &cy_, &cz_, &r_}) v->resize(n);
}

void integrate_stretches(const DensityKernel& kernel, const glm::dvec3& d, const KernelStretches& s,
                         std::span<double> out) {
    const std::size_t n = s.size();
    if (out.size() != n) {
        throw std::invalid_argument("integrate_stretches: " + std::to_string(n) + " stretches but " +
                                    std::to_string(out.size()) + " outputs");
    }
    with_kind(kernel.kind, [&]<DensityKernelKind Kind>() {
        constexpr unsigned N = simd::kDoubleLanes;
        std::size_t i = 0;
        alignas(64) double block[N];
        for (; i + N <= n; i += N) {
            store(block, block_integrals<Kind, N>(s.ox_.data() + i, s.oy_.data() + i, s.oz_.data() + i, s.cx_.data() + i,
                                                  s.cy_.data() + i, s.cz_.data() + i, s.r_.data() + i, d, kernel));
            for (unsigned k = 0; k < N; ++k) out[i + k] = block[k];
        }
        // The rest one at a time: the width-1 twin gives the same bits.
        for (; i < n; ++i)
            out[i] = block_integrals<Kind, 1>(s.ox_.data() + i, s.oy_.data() + i, s.oz_.data() + i, s.cx_.data() + i,
                                              s.cy_.data() + i, s.cz_.data() + i, s.r_.data() + i, d, kernel)
                         .lane[0];
    });
}

}  // namespace smoketrace
