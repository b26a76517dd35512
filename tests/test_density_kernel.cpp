// The density kernels' closed-form stretch integrals (smoke/density_kernel.hpp) against numerical quadrature
// of the density itself in long double, over random chords at every scale: rays that start inside the support,
// that graze it, that pass it by or leave it behind; the sum over overlapping particles against the quadrature
// of the summed density; and the lanes against their scalar twin, bit for bit.
#include <smoketrace/core/prng.hpp>
#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>

#include <catch2/catch.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

using namespace smoketrace;

namespace {

using LongVec = std::array<long double, 3>;

constexpr DensityKernelKind kKinds[] = {DensityKernelKind::uniform, DensityKernelKind::gaussian,
                                        DensityKernelKind::poly1, DensityKernelKind::poly2};

// n-point Gauss–Legendre nodes and weights on [−1, 1], by Newton's method on P_n in long double.
struct GaussLegendre {
    std::vector<long double> x, w;
    explicit GaussLegendre(int n) {
        for (int i = 0; i < n; ++i) {
            long double z = std::cos(3.14159265358979323846L * (i + 0.75L) / (n + 0.5L)), dp = 0;
            for (int iter = 0; iter < 100; ++iter) {
                long double p0 = 1, p1 = z;
                for (int k = 2; k <= n; ++k) {
                    const long double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
                    p0 = p1, p1 = p2;
                }
                dp = n * (z * p1 - p0) / (z * z - 1);
                const long double step = p1 / dp;
                z -= step;
                if (std::abs(step) < 1e-19L) break;
            }
            x.push_back(z);
            w.push_back(2 / ((1 - z * z) * dp * dp));
        }
    }
};
const GaussLegendre kRule(10);

// The profile f(q) of density_kernel.hpp, q = distance / R < 1, in long double.
long double profile(DensityKernelKind kind, long double q) {
    switch (kind) {
        case DensityKernelKind::uniform: return 1;
        case DensityKernelKind::poly1: return 1 - q * q;
        case DensityKernelKind::poly2: return (1 - q * q) * (1 - q * q);
        case DensityKernelKind::gaussian: {
            const long double k = kGaussianSupportSigmas;
            return std::exp(-q * q * k * k / 2);
        }
    }
    return 0;
}

struct Particle3 {
    glm::vec3 centre;
    float radius;
};

// [t_in, t_out] of the ray's stretch inside the particle's support ahead of the origin (empty: t_out <= t_in),
// from the quadratic |o + t·d − c|² = R², solved in long double.
std::array<long double, 2> support_interval(const DensityKernel& k, const glm::vec3& o, const glm::dvec3& d,
                                            const Particle3& p) {
    const LongVec v{(long double)p.centre.x - o.x, (long double)p.centre.y - o.y, (long double)p.centre.z - o.z};
    const LongVec dd{(long double)d.x, (long double)d.y, (long double)d.z};
    const long double R = (long double)k.support * p.radius;
    const long double s0 = v[0] * dd[0] + v[1] * dd[1] + v[2] * dd[2];
    const long double v2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    const long double b2 = std::max(0.0L, v2 - s0 * s0);
    if (b2 >= R * R) return {0, 0};
    const long double a = std::sqrt(R * R - b2);
    return {std::max(0.0L, s0 - a), s0 + a};
}

// The summed density of `ps` at o + t·d, evaluated from the point itself.
long double density_at(const DensityKernel& k, const glm::vec3& o, const glm::dvec3& d, std::span<const Particle3> ps,
                       long double t) {
    long double sum = 0;
    for (const Particle3& p : ps) {
        const long double x = o.x + t * d.x - p.centre.x, y = o.y + t * d.y - p.centre.y,
                          z = o.z + t * d.z - p.centre.z;
        const long double R = (long double)k.support * p.radius;
        const long double q = std::sqrt(x * x + y * y + z * z) / R;
        if (q < 1) sum += k.peak * profile(k.kind, q);
    }
    return sum;
}

// ∫ of the summed density along the ray over t >= 0 by composite Gauss–Legendre on panels between all the
// supports' boundaries (the density is smooth between them).
long double quadrature(const DensityKernel& k, const glm::vec3& o, const glm::dvec3& d, std::span<const Particle3> ps) {
    std::vector<long double> cuts;
    for (const Particle3& p : ps) {
        const auto [t0, t1] = support_interval(k, o, d, p);
        if (t1 > t0) cuts.push_back(t0), cuts.push_back(t1);
    }
    std::sort(cuts.begin(), cuts.end());
    constexpr int kPanels = 64;
    long double sum = 0;
    for (std::size_t c = 0; c + 1 < cuts.size(); ++c) {
        const long double a = cuts[c], b = cuts[c + 1];
        if (!(b > a)) continue;
        const long double h = (b - a) / kPanels;
        for (int panel = 0; panel < kPanels; ++panel) {
            const long double mid = a + (panel + 0.5L) * h;
            for (std::size_t i = 0; i < kRule.x.size(); ++i)
                sum += kRule.w[i] * h / 2 * density_at(k, o, d, ps, mid + kRule.x[i] * h / 2);
        }
    }
    return sum;
}

// How far the closed form may be from the exact integral (density_kernel.hpp). Its inputs are exact (floats
// widened, the test's own double direction); it rounds in s0 and b² (ulps of |c − o| and of b·|c − o|) and in
// R² − b² = a², then in the closed form's few operations (ulps of R). An error in s0 moves a share by at most
// peak per unit length (the density is at most peak); an error δ in a² moves the poly kernels' shares by at
// most ~4·peak·δ/R (their density vanishes at the rim), but a kernel whose density is f(1) > 0 at the rim
// (uniform 1, the Gaussian e^{-4.5}) has a chord 2a = 2√(a²), which an error δ in a² moves by up to 2√δ at a
// grazing ray: the square-root edge, well conditioned nowhere near b = R. With δ <= 6 ulps of R·(|c − o| + R)
// (b² <= R² from two-term cross products, R² once), kRoundingUlps ulps in both places covers the sum with a
// margin (the poly kernels' largest errors are under a sixth of their tolerance). The Gaussian adds its two
// erf() errors times its prefactor peak·σ√(π/2), and that dominates: erf's error comes within 7 % of A&S's
// bound (tests/test_special_functions.cpp), so its shares reach 0.9 of their tolerance.
constexpr double kRoundingUlps = 32.0;
double tolerance(const DensityKernel& k, const glm::vec3& o, const Particle3& p) {
    const double dist = glm::length(glm::dvec3(p.centre) - glm::dvec3(o));
    const double R = double(k.support) * p.radius;
    const double rim = k.kind == DensityKernelKind::uniform    ? 1.0
                       : k.kind == DensityKernelKind::gaussian ? kGaussianRimDensity
                                                               : 0.0;
    const double ulp = 0x1p-52;
    double t = k.peak * (kRoundingUlps * ulp * (dist + R) + 2 * rim * std::sqrt(kRoundingUlps * ulp * R * (dist + R)));
    if (k.kind == DensityKernelKind::gaussian)
        t += 2 * simd::kErfMaxError * k.peak * R / kGaussianSupportSigmas * 1.2533141373155003;
    return t;
}

glm::dvec3 random_direction(Pcg32& rng) {
    for (;;) {
        const glm::dvec3 v(rng.uniform01() * 2.0 - 1.0, rng.uniform01() * 2.0 - 1.0, rng.uniform01() * 2.0 - 1.0);
        const double l = glm::length(v);
        if (l > 0.1 && l <= 1.0) return v / l;
    }
}

enum class Chord { through, inside, grazing, behind };

// A ray and a particle at scale 10^e: the ray through the support, starting inside it, grazing it (closest
// approach within 10^-3 … 10^-12 of R, either side), or starting past it.
struct Case {
    glm::vec3 origin;
    glm::dvec3 direction;
    Particle3 particle;
};
Case random_case(Pcg32& rng, const DensityKernel& k, Chord chord, double scale) {
    Case c;
    c.direction = random_direction(rng);
    c.particle.radius = float(scale * (0.5 + rng.uniform01()));
    c.particle.centre = glm::vec3(glm::dvec3(rng.uniform01() - 0.5, rng.uniform01() - 0.5, rng.uniform01() - 0.5) *
                                  (4.0 * scale));
    const double R = double(k.support) * c.particle.radius;
    glm::dvec3 perp = glm::cross(c.direction, random_direction(rng));
    perp /= glm::length(perp);
    double b = 0, s = 0;  // the closest approach's distance, and the origin's s (= −s0)
    switch (chord) {
        case Chord::through: b = R * rng.uniform01(), s = -R * (1.0 + 3.0 * rng.uniform01()); break;
        case Chord::inside: b = R * 0.7 * rng.uniform01(), s = R * 0.7 * (2.0 * rng.uniform01() - 1.0); break;
        case Chord::grazing:
            b = R * (1.0 + std::pow(10.0, -3.0 - 9.0 * rng.uniform01()) * (rng.below(2) ? 1.0 : -1.0));
            s = -R * (1.0 + rng.uniform01());
            break;
        case Chord::behind: b = R * rng.uniform01(), s = R * (1.0 + 2.0 * rng.uniform01()); break;
    }
    c.origin = glm::vec3(glm::dvec3(c.particle.centre) - b * perp + s * c.direction);
    return c;
}

bool same_bits(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

// detail::stretch_integrals() at width N over arrays (a multiple of N long).
template <DensityKernelKind Kind, unsigned N>
std::vector<double> raw_kind_at_width(const DensityKernel& k, const std::vector<double>& s0, const std::vector<double>& b2,
                                      const std::vector<double>& radius) {
    using D = simd::Doubles<N>;
    std::vector<double> out(s0.size());
    alignas(64) double a[N], b[N], c[N], y[N];
    for (std::size_t i = 0; i < s0.size(); i += N) {
        std::copy_n(&s0[i], N, a), std::copy_n(&b2[i], N, b), std::copy_n(&radius[i], N, c);
        simd::store(y, detail::stretch_integrals<Kind, N>(D::load(a), D::load(b), D::load(c), double(k.peak)));
        std::copy_n(y, N, &out[i]);
    }
    return out;
}
template <unsigned N>
std::vector<double> raw_at_width(const DensityKernel& k, const std::vector<double>& s0, const std::vector<double>& b2,
                                 const std::vector<double>& radius) {
    switch (k.kind) {
        case DensityKernelKind::uniform: return raw_kind_at_width<DensityKernelKind::uniform, N>(k, s0, b2, radius);
        case DensityKernelKind::gaussian: return raw_kind_at_width<DensityKernelKind::gaussian, N>(k, s0, b2, radius);
        case DensityKernelKind::poly1: return raw_kind_at_width<DensityKernelKind::poly1, N>(k, s0, b2, radius);
        case DensityKernelKind::poly2: return raw_kind_at_width<DensityKernelKind::poly2, N>(k, s0, b2, radius);
    }
    return {};
}

}  // namespace

TEST_CASE("density kernel: each closed form matches quadrature over random chords at every scale", "[kernel]") {
    Pcg32 rng(2033);
    for (const DensityKernelKind kind : kKinds) {
        const DensityKernel k = density_kernel(kind);
        for (const Chord chord : {Chord::through, Chord::inside, Chord::grazing, Chord::behind}) {
            double worst = 0;  // error / tolerance
            for (const double scale : {1e-30, 1e-6, 1.0, 1e6, 1e30}) {
                for (int i = 0; i < 200; ++i) {
                    const Case c = random_case(rng, k, chord, scale);
                    const std::array<Particle3, 1> one{c.particle};
                    const double exact = double(quadrature(k, c.origin, c.direction, one));
                    const double got = particle_stretch_integral(k, c.origin, c.direction, c.particle.centre,
                                                                 c.particle.radius);
                    const double tol = tolerance(k, c.origin, c.particle);
                    worst = std::max(worst, std::abs(got - exact) / tol);
                    if (chord == Chord::behind) REQUIRE(got == 0.0);
                    INFO(k.name() << " chord " << int(chord) << " scale " << scale << " got " << got << " exact " << exact << " tol " << tol);
                    REQUIRE(std::abs(got - exact) <= tol);
                }
            }
            INFO(k.name() << " chord " << int(chord) << ": largest error " << worst << " of the tolerance");
            CHECK(worst <= 1.0);
        }
    }
}

TEST_CASE("density kernel: closed forms at the centre are the profile's known integrals", "[kernel]") {
    // Through the centre, ρ's chord integral is peak·R·∫_{−1}^{1} f: 4/3 (poly1), 16/15 (poly2), 2 (uniform),
    // √(2π)/k·erf(k/√2) (the Gaussian); from the centre, half of it.
    for (const DensityKernelKind kind : kKinds) {
        const DensityKernel k = density_kernel(kind);
        const double k3 = kGaussianSupportSigmas;
        const double whole = kind == DensityKernelKind::uniform ? 2.0
                             : kind == DensityKernelKind::poly1 ? 4.0 / 3.0
                             : kind == DensityKernelKind::poly2 ? 16.0 / 15.0
                                                                : std::sqrt(2.0 * M_PI) / k3 * std::erf(k3 / std::sqrt(2.0));
        const double R = 2.0;
        const double tol = kind == DensityKernelKind::gaussian ? 2 * simd::kErfMaxError * k.peak * R : 1e-14;
        CHECK(std::abs(kernel_stretch_integral(k, 5.0, 0.0, R) - k.peak * R * whole) <= tol);
        CHECK(std::abs(kernel_stretch_integral(k, 0.0, 0.0, R) - k.peak * R * whole / 2) <= tol);
        CHECK(kernel_stretch_integral(k, 5.0, R * R, R) == 0.0);   // tangent: an empty chord
        CHECK(kernel_stretch_integral(k, -R, 0.0, R) == 0.0);      // the origin on the far rim
    }
}

TEST_CASE("density kernel: shares add up to the quadrature of the summed density where particles overlap",
          "[kernel]") {
    Pcg32 rng(77);
    for (const DensityKernelKind kind : kKinds) {
        const DensityKernel k = density_kernel(kind);
        for (int trial = 0; trial < 50; ++trial) {
            // A ray from inside a cluster of overlapping particles.
            const glm::dvec3 d = random_direction(rng);
            const glm::vec3 o(rng.uniform01(), rng.uniform01(), rng.uniform01());
            std::vector<Particle3> ps;
            for (int i = 0; i < 8; ++i) {
                const double along = 2.5 * rng.uniform01();
                const glm::dvec3 off = 0.4 * glm::dvec3(rng.uniform01() - 0.5, rng.uniform01() - 0.5, rng.uniform01() - 0.5);
                ps.push_back({glm::vec3(glm::dvec3(o) + along * d + off), float(0.3 + 0.5 * rng.uniform01())});
            }
            const double exact = double(quadrature(k, o, d, ps));
            double sum = 0, tol = 0;
            for (const Particle3& p : ps) {
                sum += particle_stretch_integral(k, o, d, p.centre, p.radius);
                tol += tolerance(k, o, p);
            }
            REQUIRE(exact > 0.0);
            CHECK(std::abs(sum - exact) <= tol);
        }
    }
}

TEST_CASE("density kernel: the lanes give the scalar twin's bits at every width", "[kernel][simd]") {
    Pcg32 rng(5);
    for (const DensityKernelKind kind : kKinds) {
        const DensityKernel k = density_kernel(kind);
        KernelStretches stretches;
        std::vector<double> one;
        const glm::dvec3 d = random_direction(rng);
        for (int i = 0; i < 1003; ++i) {  // not a multiple of any width: the tail too
            const Chord chord = Chord(rng.below(4));
            Case c = random_case(rng, k, chord, std::pow(10.0, double(rng.below(9)) - 4.0));
            c.direction = d;
            stretches.add(c.origin, c.particle.centre, c.particle.radius);
            one.push_back(particle_stretch_integral(k, c.origin, d, c.particle.centre, c.particle.radius));
        }
        std::vector<double> batch(one.size());
        integrate_stretches(k, d, stretches, batch);
        std::size_t differ = 0;
        for (std::size_t i = 0; i < one.size(); ++i) differ += !same_bits(batch[i], one[i]);
        INFO(k.name() << " at " << simd::kDoubleLanes << " lanes");
        CHECK(differ == 0);
        // And the kernel itself at widths 2, 4, 8 on raw (s0, b², R), degenerate lanes included.
        std::vector<double> s0, b2, radius;
        for (int i = 0; i < 64; ++i) {
            radius.push_back(0.1 + rng.uniform01());
            s0.push_back((rng.uniform01() - 0.5) * 4.0 * radius.back());
            b2.push_back(rng.uniform01() * 1.5 * radius.back() * radius.back());
        }
        const std::vector<double> raw1 = raw_at_width<1>(k, s0, b2, radius);
        for (const auto& wide : {raw_at_width<2>(k, s0, b2, radius), raw_at_width<4>(k, s0, b2, radius),
                                 raw_at_width<8>(k, s0, b2, radius)}) {
            std::size_t raw_differ = 0;
            for (std::size_t i = 0; i < raw1.size(); ++i) raw_differ += !same_bits(wide[i], raw1[i]);
            CHECK(raw_differ == 0);
        }
    }
}

TEST_CASE("density kernel: names, parsing and the fitted defaults", "[kernel]") {
    for (const DensityKernelKind kind : kKinds) {
        const DensityKernel k = density_kernel(kind);
        CHECK(k.kind == kind);
        CHECK(parse_density_kernel(k.name()) == k);
        CHECK_NOTHROW(validate(k));
        // The fitted supports lie inside the icosahedron: its stand-in then meets every particle whose support
        // a ray meets (density_kernel.hpp), and gives the sphere's sums.
        if (k.smooth()) CHECK(double(k.support) <= kIcosahedronInradius);
    }
    CHECK(kGaussianRimDensity == std::exp(-kGaussianSupportSigmas * kGaussianSupportSigmas / 2));
    CHECK(kUniformKernel == DensityKernel{});
    CHECK_FALSE(kUniformKernel.smooth());
    CHECK_FALSE(parse_density_kernel("Gaussian"));
    CHECK_FALSE(parse_density_kernel("poly3"));
    CHECK_FALSE(parse_density_kernel(""));
    CHECK_THROWS_AS(validate(DensityKernel{DensityKernelKind::poly1, 1.5f, 1.0f}), std::invalid_argument);
    CHECK_THROWS_AS(validate(DensityKernel{DensityKernelKind::poly1, 0.5f, 0.0f}), std::invalid_argument);
    CHECK_THROWS_AS(validate(DensityKernel{DensityKernelKind::poly1, 0.0f, 1.0f}), std::invalid_argument);
    CHECK_THROWS_AS(validate(DensityKernel{DensityKernelKind::uniform, 0.5f, 1.0f}), std::invalid_argument);
    CHECK_THROWS_AS(validate(DensityKernel{DensityKernelKind::uniform, 1.0f, 2.0f}), std::invalid_argument);
}

TEST_CASE("density kernel: the icosahedron's inradius is kIcosahedronInradius", "[kernel]") {
    // The smallest distance from the centre to a face plane of make_icosahedron(1).
    const TriangleMesh m = make_icosahedron(1.0f);
    double smallest = 1.0;
    for (const glm::uvec3& t : m.triangles) {
        const glm::dvec3 a(m.vertices[t.x]), b(m.vertices[t.y]), c(m.vertices[t.z]);
        const glm::dvec3 n = glm::normalize(glm::cross(b - a, c - a));
        smallest = std::min(smallest, std::abs(glm::dot(n, a)));
    }
    CHECK(std::abs(smallest - kIcosahedronInradius) <= 1e-7);  // the vertices are floats: 2^-24 of 1
}
