#pragma once
// Density kernels: the density a particle's stand-in stands for when light crosses it (docs/design.md,
// "Density kernels"). The thesis's stand-in is a ball of uniform density (eq. 3.1), whose optical depth has an
// infinite slope at every silhouette: hard-edged disc shadows. The puffs the billboards show fade toward their
// rims; a smooth radial profile lets the light see them so.
//
// A particle of centre c and radius r has the density ρ(x) = peak · f(|x − c| / R) inside its support sphere
// |x − c| < R = support · r, and 0 outside. support <= 1, so the stand-in's sphere bounds the support:
//   uniform   f = 1, support 1, peak 1: the thesis's ball. The optical-depth pass keeps eq. 3.1 for it, the
//             length inside the UNION of the balls, through the radix resolver's walk (hit_resolver.hpp).
//   gaussian  f(q) = exp(−q² k² / 2): a Gaussian of σ = R / k truncated at k = kGaussianSupportSigmas σ;
//   poly1     f(q) = 1 − q²;
//   poly2     f(q) = (1 − q²)².
// The smooth kernels add where particles overlap: the density field is the sum of the particles' densities
// (the union model of eq. 3.1 counts an overlap once), and a ray o + t·d (|d| = 1) has the density-weighted
// length, and optical depth,
//     l = Σ_i ∫ ρ_i(o + t·d) dt over t >= 0,     τ = σt · l   (eq. 2.12, as for the uniform kernel's l).
//
// One particle's share, in the ray parameter. s0 = (c − o)·d is the ray parameter of the closest approach,
// b² = |(c − o) × d|² its squared distance; the ray meets the support where b < R, over the half-chord
// a = √(R² − b²) either side. With s = t − s0 measured from the closest point, the stretch of the ray inside
// the support and ahead of its origin is s ∈ [s_begin, a], s_begin = max(−a, −s0) (−s0 when the origin is
// inside), of length L = a − s_begin (empty when the support lies behind the origin), and
//     ∫ f ds over [s_begin, a] =
//       uniform:   L
//       poly1:     L² (a − L/3) / R²                   (∫_0^L u (2a − u) du, u = a − s: no cancellation)
//       poly2:     L³ (4a²/3 − a L + L²/5) / R⁴         (∫_0^L u² (2a − u)² du)
//       gaussian:  e^{−b²/2σ²} σ √(π/2) [erf(a / σ√2) − erf(s_begin / σ√2)]   (erf: core/simd/special_functions.hpp)
// times peak. These are computed in double from the float centre, radius and ray origin (the direction
// normalised in double), over Doubles<N> lanes (stretch_integrals(); width 1 is the scalar twin, the same bits).
// Error: double rounding, a few ulps of R, except the Gaussian's erf, whose kErfMaxError (1.5·10^-7) is
// absolute: the Gaussian's share is within 2·kErfMaxError · peak·σ√(π/2) of the exact integral.
//
// In the optical-depth pass (optical_depth_pass.hpp) entry hits add nothing and each EXIT hit (a back face)
// adds its particle's whole stretch. A ray meets a convex stand-in's surface at most once on the way out
// (an edge or a vertex counts once, ray_triangle.hpp), and leaves every stand-in it enters or starts in, so
// the exits name each particle the ray meets exactly once: the sum needs no sort and no pairing of entries
// with exits. The stand-in only decides WHICH particles the ray meets; the integral is the support sphere's.
// For the sphere stand-in that is exact (the support lies inside it). The icosahedron's inradius is
// kIcosahedronInradius·r: a support up to that lies inside it, and every ray that meets the support meets
// the icosahedron; a larger support sticks out through the faces' middles, and a ray through that part alone
// misses the particle (its share is lost), while a ray through a corner beyond the support adds 0.
#include <smoketrace/core/aligned_allocator.hpp>
#include <smoketrace/core/simd/lanes.hpp>
#include <smoketrace/core/simd/special_functions.hpp>

#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace smoketrace {

enum class DensityKernelKind : std::uint8_t { uniform, gaussian, poly1, poly2 };

struct DensityKernel {
    DensityKernelKind kind = DensityKernelKind::uniform;
    float support = 1.0f;  // R / r, in (0, 1]
    float peak = 1.0f;     // ρ at the centre; the uniform ball's density is 1

    // Everything but uniform: integrated in closed form and summed (the uniform kernel: eq. 3.1's union walk).
    [[nodiscard]] bool smooth() const { return kind != DensityKernelKind::uniform; }
    [[nodiscard]] std::string name() const;  // "uniform", "gaussian", "poly1", "poly2"
    bool operator==(const DensityKernel&) const = default;
};

// The Gaussian's truncation, in standard deviations, and its profile at the support, f(1) = e^{−k²/2}: the
// density falls to 1.1 % of its peak there, and jumps to 0.
inline constexpr double kGaussianSupportSigmas = 3.0;
inline constexpr double kGaussianRimDensity = 0.011108996538242306;  // e^{−4.5}
// The inradius of the thesis's icosahedron over its circumradius r (make_icosahedron(): vertices on the
// sphere): √((5 + 2√5) / 15).
inline constexpr double kIcosahedronInradius = 0.79465447229176611;

// The kernels with their fitted scale (support, peak): fitted to the six-way baker's puff, the shipped
// assets/sixway.json's bake, by render/kernel_fit.hpp (docs/design.md, "Density kernels": the method, the
// residual, the profile); tests/test_kernel_fit.cpp refits and checks these.
inline constexpr DensityKernel kUniformKernel{DensityKernelKind::uniform, 1.0f, 1.0f};
inline constexpr DensityKernel kGaussianKernel{DensityKernelKind::gaussian, 0.7575f, 1.6181f};
inline constexpr DensityKernel kPoly1Kernel{DensityKernelKind::poly1, 0.5407f, 1.2854f};
inline constexpr DensityKernel kPoly2Kernel{DensityKernelKind::poly2, 0.6399f, 1.4236f};

// The fitted kernel of `kind` (one of the four above).
[[nodiscard]] DensityKernel density_kernel(DensityKernelKind kind);
// "uniform", "gaussian", "poly1" or "poly2": that kernel with its fitted scale; nullopt for anything else.
[[nodiscard]] std::optional<DensityKernel> parse_density_kernel(std::string_view name);
// The names parse_density_kernel() accepts, for messages.
inline constexpr std::string_view kDensityKernelNames = "uniform, gaussian, poly1, poly2";

// Throws std::invalid_argument unless 0 < support <= 1 and peak is finite and > 0, and both are 1 for uniform.
void validate(const DensityKernel& kernel);

namespace detail {

// The closed forms of the file comment, over lanes: for each lane the particle's share peak·∫ f ds, from
// s0 (the closest approach's ray parameter), b2 (its squared distance) and radius (R, the support's radius,
// > 0), 0 where the ray does not meet the support ahead of its origin. Written once; width 1 is the scalar
// twin, and every width gives its bits (tests/test_density_kernel.cpp).
template <DensityKernelKind Kind, unsigned N>
[[gnu::always_inline]] inline simd::Doubles<N> stretch_integrals(const simd::Doubles<N>& s0, const simd::Doubles<N>& b2,
                                                                 const simd::Doubles<N>& radius, double peak) {
    using D = simd::Doubles<N>;
    const D zero = D::broadcast(0.0);
    const D a2 = radius * radius - b2;
    const D a = sqrt(max(a2, zero));
    const D s_begin = max(-a, -s0);
    const D length = a - s_begin;
    const auto meets = (a2 > zero) & (length > zero);
    D share;
    if constexpr (Kind == DensityKernelKind::uniform) {
        share = length;
    } else if constexpr (Kind == DensityKernelKind::poly1) {
        const D inv_r = D::broadcast(1.0) / radius;
        share = length * length * (a - length * D::broadcast(1.0 / 3.0)) * (inv_r * inv_r);
    } else if constexpr (Kind == DensityKernelKind::poly2) {
        const D inv_r = D::broadcast(1.0) / radius;
        const D inv_r2 = inv_r * inv_r;
        const D bracket =
            D::broadcast(4.0 / 3.0) * a2 - a * length + length * length * D::broadcast(1.0 / 5.0);
        share = length * length * length * bracket * (inv_r2 * inv_r2);
    } else {
        // σ = R/k: the erf argument s/(σ√2) = s·k/(R√2), and b²/(2σ²) is the square of b·k/(R√2). With
        // erf(x) = 1 − P(x)·e^{−x²} (special_functions.hpp), e^{−b²/2σ²}·erf(x) needs no third exponential:
        // at x = a/(σ√2) the product of the two is e^{−R²/2σ²} = e^{−k²/2}, and at s_begin it is e^{−q²k²/2},
        // q the start's distance from the centre over R (<= 1). So, E = e^{−b²/2σ²},
        //     share = σ√(π/2) [(E − P(a)·e^{−k²/2}) − sign(s_begin)·(E − P(s_begin)·e^{−q²k²/2})].
        const D scale = D::broadcast(kGaussianSupportSigmas / 1.4142135623730951) / radius;
        const D scale2 = scale * scale;
        const D e = simd::exp_negative(b2 * scale2);
        const D rim = D::broadcast(kGaussianRimDensity);
        const D end = e - simd::erf_tail_polynomial(a * scale) * rim;
        const D begin = copysign(e - simd::erf_tail_polynomial(s_begin * scale) *
                                         simd::exp_negative((b2 + s_begin * s_begin) * scale2),
                                 s_begin);
        const D sigma_root_half_pi = radius * D::broadcast(1.2533141373155003 / kGaussianSupportSigmas);  // σ√(π/2)
        share = sigma_root_half_pi * (end - begin);
    }
    return select(meets, share * D::broadcast(peak), zero);
}

}  // namespace detail

// One particle's share for one ray, from its geometry (s0, b², R as in the file comment): the scalar twin of
// the lanes kernel, the same bits.
[[nodiscard]] double kernel_stretch_integral(const DensityKernel& kernel, double s0, double b2, double radius);

// The share of particle (centre, radius) of the ray from `origin` along `unit_direction` (unit length, in
// double): s0 and b² from the float inputs in double (b² from the cross product, which does not cancel),
// R = support · radius. What the optical-depth pass adds for one exit hit, bit for bit, whoever calls it (the
// view's shadow rays, explain --particle, tests).
[[nodiscard]] double particle_stretch_integral(const DensityKernel& kernel, const glm::vec3& origin,
                                               const glm::dvec3& unit_direction, const glm::vec3& centre, float radius);

// Stretches to integrate together (the optical-depth pass collects a bundle's exits here): per entry the
// ray's origin and the particle's centre and radius, structure of arrays, 64-byte aligned, for the lanes.
class KernelStretches {
public:
    // n entries, those past the old size unwritten until set(); the memory is kept for the next resize().
    void resize(std::size_t n);
    void set(std::size_t i, const glm::vec3& origin, const glm::vec3& centre, float radius) {
        ox_[i] = origin.x, oy_[i] = origin.y, oz_[i] = origin.z;
        cx_[i] = centre.x, cy_[i] = centre.y, cz_[i] = centre.z;
        r_[i] = radius;
    }
    void add(const glm::vec3& origin, const glm::vec3& centre, float radius) {
        ox_.push_back(origin.x), oy_.push_back(origin.y), oz_.push_back(origin.z);
        cx_.push_back(centre.x), cy_.push_back(centre.y), cz_.push_back(centre.z);
        r_.push_back(radius);
    }
    void clear() { resize(0); }
    [[nodiscard]] std::size_t size() const { return r_.size(); }

private:
    friend void integrate_stretches(const DensityKernel&, const glm::dvec3&, const KernelStretches&, std::span<double>);
    using Floats = std::vector<float, UnwrittenAllocator<float, 64>>;
    Floats ox_, oy_, oz_, cx_, cy_, cz_, r_;
};

// out[i] = particle_stretch_integral(kernel, origin_i, unit_direction, centre_i, radius_i) for every entry,
// the same bits, in blocks of simd::kDoubleLanes (the rest at width 1). std::invalid_argument unless
// out.size() == stretches.size().
void integrate_stretches(const DensityKernel& kernel, const glm::dvec3& unit_direction, const KernelStretches& stretches,
                         std::span<double> out);

}  // namespace smoketrace
