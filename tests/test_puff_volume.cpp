// PuffVolume::integrate (truth/puff_volume.hpp) against the interpolant's definition: each voxel's value
// times a tent about its centre along each axis, evaluated in double and integrated along the segment by
// adaptive Simpson, which knows nothing of where the interpolant's kinks are. Segments of a baked puff and of
// a small random grid (nonzero to its edges, so that the outer boundary matters): inside, across the
// boundary, on and beside the support's faces, through its corner, axis-parallel, on centre planes, very
// short, standing still; additivity and bins; and the test shapes' chords against their closed forms.
#include <smoketrace/core/prng.hpp>
#include <smoketrace/render/puff_density.hpp>
#include <smoketrace/render/sixway_baker.hpp>
#include <smoketrace/truth/puff_volume.hpp>

#include <catch2/catch.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

using namespace smoketrace;

namespace {

// The trilinear interpolant of a grid's voxel values, 0 beyond the grid, from its definition: Σ value ·
// tent(Δx/dxy) · tent(Δy/dxy) · tent(Δz/dz), tent(s) = max(0, 1 − |s|), Δ from the voxel's centre
// (PuffVoxels' layout: centre (i, j, k) at (−1 + (i + ½)·dxy, 1 − (j + ½)·dxy, 1 − (k + ½)·dz), with the
// layout's float spacings), in double.
struct TentField {
    int n = 0, nz = 0;
    double dxy = 0, dz = 0;
    std::vector<float> values;
    double max_value = 0;

    TentField(int n_, int nz_, std::vector<float> v) : n(n_), nz(nz_), values(std::move(v)) {
        SixwayBakeSettings layout;
        layout.tile = n;
        layout.depth_samples = nz;
        const PuffVoxels g(layout);
        dxy = double(g.dxy);
        dz = double(g.dz);
        for (const float x : values) max_value = std::max(max_value, double(x));
    }
    static double tent(double s) { return std::max(0.0, 1.0 - std::abs(s)); }
    // Where the tents of an axis have their kinks: the centres, with those of the absent voxels -1 and
    // count (where the outermost tents end); y and z indices run downward from +1.
    [[nodiscard]] double plane(int axis, int index) const {
        const double s = axis == 2 ? dz : dxy;
        return axis == 0 ? -1.0 + (index + 0.5) * s : 1.0 - (index + 0.5) * s;
    }
    [[nodiscard]] int count(int axis) const { return axis == 2 ? nz : n; }
    // [t0, t1] cut wherever q0 + t·dq crosses one of those planes, sorted.
    [[nodiscard]] std::vector<double> breaks(const glm::dvec3& q0, const glm::dvec3& dq, double t0, double t1) const {
        std::vector<double> out{t0, t1};
        for (int axis = 0; axis < 3; ++axis) {
            if (dq[axis] == 0.0) continue;
            for (int m = -1; m <= count(axis); ++m) {
                const double t = (plane(axis, m) - q0[axis]) / dq[axis];
                if (t > t0 && t < t1) out.push_back(t);
            }
        }
        std::sort(out.begin(), out.end());
        return out;
    }
    double operator()(const glm::dvec3& p) const {
        // Only centres within one spacing have a nonzero tent; the loops look one further on each side.
        const int i0 = int(std::floor((p.x + 1.0) / dxy)) - 2;
        const int j0 = int(std::floor((1.0 - p.y) / dxy)) - 2;
        const int k0 = int(std::floor((1.0 - p.z) / dz)) - 2;
        double sum = 0.0;
        for (int k = std::max(k0, 0); k < std::min(k0 + 5, nz); ++k)
            for (int j = std::max(j0, 0); j < std::min(j0 + 5, n); ++j)
                for (int i = std::max(i0, 0); i < std::min(i0 + 5, n); ++i) {
                    const double cx = -1.0 + (i + 0.5) * dxy, cy = 1.0 - (j + 0.5) * dxy, cz = 1.0 - (k + 0.5) * dz;
                    const double v = values[(std::size_t(k) * std::size_t(n) + std::size_t(j)) * std::size_t(n) + i];
                    sum += v * tent((p.x - cx) / dxy) * tent((p.y - cy) / dxy) * tent((p.z - cz) / dz);
                }
        return sum;
    }
};

// Adaptive Simpson between given breaks. Simpson is exact on cubics, and at a kink its error is O(h²), so
// the halves' error is a third of their change from the whole panel: a panel is accepted when that change is
// at most 3·tol, which leaves at most tol in it; the tolerance halves with the panel, so the accepted
// panels' tolerances sum to at most the whole's. `exhausted` counts panels that hit the depth limit instead.
struct AdaptiveSimpson {
    int exhausted = 0;

    template <class F>
    double panel(const F& f, double a, double b, double fa, double fm, double fb, double whole, double tol, int depth) {
        const double m = 0.5 * (a + b), lm = 0.5 * (a + m), rm = 0.5 * (m + b);
        const double flm = f(lm), frm = f(rm);
        const double left = (m - a) / 6.0 * (fa + 4.0 * flm + fm), right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
        if (std::abs(left + right - whole) <= 3.0 * tol) return left + right;
        if (depth == 0) {
            ++exhausted;
            return left + right;
        }
        return panel(f, a, m, fa, flm, fm, left, 0.5 * tol, depth - 1) +
               panel(f, m, b, fm, frm, fb, right, 0.5 * tol, depth - 1);
    }
    // ∫ f over [breaks.front(), breaks.back()] to within tol, each stretch between breaks a panel of its own
    // with its share of tol.
    template <class F>
    double operator()(const F& f, const std::vector<double>& breaks, double tol) {
        const double length = breaks.back() - breaks.front();
        double sum = 0.0;
        for (std::size_t p = 0; p + 1 < breaks.size(); ++p) {
            const double x0 = breaks[p], x1 = breaks[p + 1];
            if (!(x1 > x0)) continue;
            const double f0 = f(x0), f1 = f(x1), fm = f(0.5 * (x0 + x1));
            sum += panel(f, x0, x1, f0, fm, f1, (x1 - x0) / 6.0 * (f0 + 4.0 * fm + f1), tol * (x1 - x0) / length, 50);
        }
        return sum;
    }
};

// The reference integral's requested accuracy, per unit of segment length (t units) and of the largest
// voxel value: 10⁻¹³, ten times below the integral's stated rounding bound (10⁻¹² · V · length,
// puff_volume.hpp), so that the comparison tests that bound. Between its breaks (where the segment crosses
// a plane through the tents' centres and ends, found by brute force) the field is a cubic, which Simpson
// integrates exactly; a kink it had missed would cost it subdivisions, not accuracy.
constexpr double kReferenceAccuracy = 1e-13;
// What the two may differ by, per unit of length and of V: the stated bound plus the reference's accuracy,
// and the reference's own rounding (its ~10⁴ evaluations each within a few units of 2⁻⁵³ of V: 10⁻¹⁴ per
// unit length and less), within 2·10⁻¹².
constexpr double kAgreement = 2e-12;

struct Segment {
    glm::dvec3 q0, dq;
    double t0, t1;
    std::string kind;
};

double uniform(Pcg32& rng, double a, double b) { return a + (b - a) * double(rng.next_u32()) * 0x1p-32; }
glm::dvec3 uniform3(Pcg32& rng, double a, double b) {
    const double x = uniform(rng, a, b), y = uniform(rng, a, b);
    return {x, y, uniform(rng, a, b)};
}

// The segments every grid is tested on; `field` gives the grid's geometry (centres and support faces).
std::vector<Segment> segments_for(const TentField& field, std::uint64_t seed) {
    Pcg32 rng(seed);
    std::vector<Segment> out;
    auto centre = [&](int axis, std::uint32_t r) {
        return field.plane(axis, int(r % std::uint32_t(field.count(axis))));
    };
    // The support's faces: where the outermost tents end.
    auto face = [&](int axis, bool first) { return field.plane(axis, first ? -1 : field.count(axis)); };
    for (int r = 0; r < 60; ++r) {
        const glm::dvec3 a = uniform3(rng, -0.95, 0.95), b = uniform3(rng, -0.95, 0.95);
        out.push_back({a, b - a, 0.0, 1.0, "inside"});
    }
    for (int r = 0; r < 60; ++r) {
        const glm::dvec3 a = uniform3(rng, -1.6, 1.6), b = uniform3(rng, -1.6, 1.6);
        out.push_back({a, b - a, uniform(rng, -0.5, 0.2), uniform(rng, 0.8, 1.5), "across the boundary"});
    }
    for (int r = 0; r < 36; ++r) {  // one or two components of dq zero, in turn
        const glm::dvec3 a = uniform3(rng, -1.2, 1.2);
        glm::dvec3 d = uniform3(rng, -2.0, 2.0);
        const int pattern = r % 6;
        if (pattern < 3) d[pattern] = 0.0;
        else d[(pattern + 1) % 3] = d[(pattern + 2) % 3] = 0.0;
        out.push_back({a, d, 0.0, 1.0, "axis-parallel"});
    }
    for (int r = 0; r < 36; ++r) {  // in one centre plane, or on the line where two meet
        glm::dvec3 a = uniform3(rng, -1.1, 1.1), d = uniform3(rng, -2.0, 2.0);
        const int axis = r % 3;
        a[axis] = centre(axis, rng.next_u32());
        d[axis] = 0.0;
        if (r % 2 == 1) {
            const int other = (axis + 1) % 3;
            a[other] = centre(other, rng.next_u32());
            d[other] = 0.0;
        }
        out.push_back({a, d, 0.0, 1.0, "on a centre plane"});
    }
    for (int r = 0; r < 24; ++r) {  // in a face of the support (density 0), or just inside it
        glm::dvec3 a = uniform3(rng, -1.2, 1.2), d = uniform3(rng, -1.5, 1.5);
        const int axis = r % 3;
        const double f = face(axis, (r / 3) % 2 == 0);
        a[axis] = r % 4 < 2 ? f : f - std::copysign(1e-7, f);  // the faces lie at |coordinate| > 1
        d[axis] = 0.0;
        out.push_back({a, d, 0.0, 1.0, "on or beside a face"});
    }
    for (int r = 0; r < 12; ++r) {  // through a corner of the support, in and out of it
        const glm::dvec3 corner(face(0, true), face(1, false), face(2, false));
        const glm::dvec3 d = uniform3(rng, -1.0, 1.0);
        out.push_back({corner - 0.5 * d, d, 0.0, 1.0, "through the corner"});
    }
    for (int r = 0; r < 36; ++r) {  // 10⁻³ down to 10⁻¹⁴ long, from a random point
        const glm::dvec3 a = uniform3(rng, -0.9, 0.9), d = uniform3(rng, -1.0, 1.0);
        const double t0 = uniform(rng, 0.0, 1.0);
        out.push_back({a, d, t0, t0 + std::pow(10.0, -3.0 - double(r % 12)), "very short"});
    }
    for (int r = 0; r < 6; ++r) {
        const glm::dvec3 a = uniform3(rng, -0.9, 0.9);
        out.push_back({a, glm::dvec3(0.0), 0.0, uniform(rng, 0.1, 2.0), "standing still"});
    }
    return out;
}

// Every segment's integral against the reference, and additivity at a random point of it.
void check_against_reference(const PuffVolume& volume, const TentField& field, std::uint64_t seed, int min_nonzero) {
    AdaptiveSimpson simpson;
    Pcg32 rng(seed + 1);
    int nonzero = 0;
    for (const Segment& s : segments_for(field, seed)) {
        const double length = s.t1 - s.t0;
        const double got = volume.integrate(s.q0, s.dq, s.t0, s.t1);
        const auto f = [&](double t) { return field(s.q0 + t * s.dq); };
        const double reference =
            simpson(f, field.breaks(s.q0, s.dq, s.t0, s.t1), kReferenceAccuracy * field.max_value * length);
        INFO(s.kind << ": q0 (" << s.q0.x << ", " << s.q0.y << ", " << s.q0.z << ") dq (" << s.dq.x << ", " << s.dq.y
                    << ", " << s.dq.z << ") t [" << s.t0 << ", " << s.t1 << "] got " << got << " reference "
                    << reference);
        CHECK(std::abs(got - reference) <= kAgreement * field.max_value * length);
        nonzero += reference > 0.0 ? 1 : 0;
        // Cut at a random point: the two halves are within each one's rounding bound of the whole.
        const double tm = s.t0 + length * uniform(rng, 0.0, 1.0);
        const double halves = volume.integrate(s.q0, s.dq, s.t0, tm) + volume.integrate(s.q0, s.dq, tm, s.t1);
        CHECK(std::abs(halves - got) <= 2.0 * 1e-12 * field.max_value * length);
        // In bins (from before t0, the last past t1): each bin is the integral over its span, both within
        // their rounding bounds.
        const double spacing = length / 6.5, origin = s.t0 - 0.3 * spacing;
        std::array<double, 8> bins{};
        volume.integrate_bins(s.q0, s.dq, s.t0, s.t1, origin, spacing, bins);
        for (std::size_t m = 0; m < bins.size(); ++m) {
            const double a = std::max(s.t0, origin + double(m) * spacing);
            const double b = std::min(s.t1, origin + double(m + 1) * spacing);
            const double span = b > a ? volume.integrate(s.q0, s.dq, a, b) : 0.0;
            INFO("bin " << m);
            CHECK(std::abs(bins[m] - span) <= 2.0 * 1e-12 * field.max_value * spacing);
        }
    }
    CHECK(simpson.exhausted == 0);
    CHECK(nonzero >= min_nonzero);  // the comparisons are not of zeros
}

SixwayBakeSettings small_bake() {
    SixwayBakeSettings s;
    s.tile = 24;
    s.depth_samples = 20;  // voxels deeper than wide: dz differs from dxy
    s.seed = 5;
    return s;
}

}  // namespace

TEST_CASE("puff volume: the reference field is the volume's own density, to float rounding", "[truth][puff_volume]") {
    // density() computes grid coordinates of at most 25 in float (≤ 3 roundings: 25·3·2⁻²⁴ ≈ 4.5·10⁻⁶) and the
    // density moves by at most V per unit of each of the three, plus its seven float lerps (7·2⁻²⁴·V):
    // within 1.5·10⁻⁵·V.
    constexpr double kFloatDensity = 1.5e-5;
    const SixwayBakeSettings s = small_bake();
    const PuffVolume volume = PuffVolume::baked(s, 2);
    std::vector<float> values;
    sample_puff_density(s, PuffVoxels(s), 2, values);
    const TentField field(s.tile, s.depth_samples, values);
    Pcg32 rng(11);
    int nonzero = 0;
    for (int r = 0; r < 4000; ++r) {
        const glm::vec3 p(uniform3(rng, -1.1, 1.1));
        const double expected = field(glm::dvec3(p));
        INFO("p (" << p.x << ", " << p.y << ", " << p.z << ")");
        CHECK(std::abs(double(volume.density(p)) - expected) <= kFloatDensity * field.max_value);
        nonzero += expected > 0.0 ? 1 : 0;
    }
    CHECK(nonzero > 200);  // the puff fills some 8 % of the box sampled
}

TEST_CASE("puff volume: a baked puff's line integrals are exact, on every kind of segment", "[truth][puff_volume]") {
    const SixwayBakeSettings s = small_bake();
    std::vector<float> values;
    sample_puff_density(s, PuffVoxels(s), 1, values);
    const TentField field(s.tile, s.depth_samples, values);
    check_against_reference(PuffVolume::baked(s, 1), field, 21, 60);  // the puff fills a few % of the box
}

TEST_CASE("puff volume: a small random grid's line integrals are exact, its boundary cells included",
          "[truth][puff_volume]") {
    // 5 x 5 x 3 voxels, a third of them 0 (cells whose corners are all 0 are skipped), the rest up to 1 to
    // the grid's edge: the density falls to 0 over the outermost half cells, where a boundary error would show.
    const int n = 5, nz = 3;
    Pcg32 rng(3);
    std::vector<float> values(std::size_t(n * n * nz));
    for (float& v : values) v = rng.below(3) == 0 ? 0.0f : rng.uniform01();
    const TentField field(n, nz, values);
    check_against_reference(PuffVolume::voxels(n, nz, values), field, 8, 200);
}

TEST_CASE("puff volume: the test shapes' integrals are their chords", "[truth][puff_volume]") {
    Pcg32 rng(17);
    SECTION("uniform ball") {
        const double radius = double(0.6f), value = 2.5;  // the shape keeps floats
        const PuffVolume ball = PuffVolume::uniform_ball(float(radius), float(value));
        for (int r = 0; r < 200; ++r) {
            // A line at distance `offset` from the centre, run at speed `speed`: its chord is
            // 2·√(radius² − offset²)/speed long in t, centred where it passes nearest the centre.
            const glm::dvec3 u = glm::normalize(uniform3(rng, -1.0, 1.0));
            glm::dvec3 side = glm::cross(u, glm::normalize(uniform3(rng, -1.0, 1.0)));
            side = glm::normalize(side);
            const double offset = uniform(rng, 0.0, 0.9) * radius, speed = uniform(rng, 0.2, 3.0);
            const double tc = uniform(rng, -1.0, 1.0);
            const glm::dvec3 dq = speed * u, q0 = offset * side - tc * dq;
            const double half = std::sqrt(radius * radius - offset * offset) / speed;
            const double t0 = tc - half * uniform(rng, 0.0, 1.5), t1 = tc + half * uniform(rng, 0.0, 1.5);
            const double expected = value * (std::min(t1, tc + half) - std::max(t0, tc - half));
            // Rounding of the construction and of the chord, away from tangency (offset <= 0.9 radius keeps the
            // square root's condition within 1/(1 − 0.81)): 10⁻¹² of the chord is generous.
            INFO("offset " << offset << " speed " << speed);
            CHECK(std::abs(ball.integrate(q0, dq, t0, t1) - expected) <= 1e-12 * value * 2.0 * half);
        }
        // Just inside tangency the chord is ill-conditioned: offset² rounds to 4·2⁻⁵³ relative, and
        // radius² − offset² = 2·10⁻⁶·radius² magnifies that 5·10⁵ times, half of it in the square root:
        // 1.1·10⁻¹⁰ relative; 10⁻⁹ holds it. Just outside, nothing.
        const glm::dvec3 dq(0.0, 0.0, 1.0);
        const double inside = radius * (1.0 - 1e-6), outside = radius * (1.0 + 1e-9);
        const double half = std::sqrt(radius * radius - inside * inside);
        const double chord = ball.integrate({inside, 0.0, 0.0}, dq, -1.0, 1.0);
        CHECK(std::abs(chord - 2.0 * value * half) <= 1e-9 * 2.0 * value * half);
        CHECK(ball.integrate({outside, 0.0, 0.0}, dq, -1.0, 1.0) == 0.0);
        CHECK(ball.integrate(glm::dvec3(0.1), glm::dvec3(0.0), 2.0, 3.5) == Approx(1.5 * value).epsilon(1e-15));
        // In bins: the chord through the centre along x, t in [2 - radius, 2 + radius], in bins of 0.5 from
        // 1.5 (the part before 1.5 dropped, the third bin partly covered, the fourth not at all).
        std::array<double, 4> bins{};
        ball.integrate_bins({-2.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, 0.0, 4.0, 1.5, 0.5, bins);
        for (std::size_t m = 0; m < bins.size(); ++m) {
            const double a = std::max(2.0 - radius, 1.5 + 0.5 * double(m));
            const double b = std::min(2.0 + radius, 2.0 + 0.5 * double(m));
            CHECK(bins[m] == Approx(value * std::max(0.0, b - a)).margin(1e-15));
        }
    }
    SECTION("uniform cube") {
        const double h = 0.5, value = 1.5;
        const PuffVolume cube = PuffVolume::uniform_cube(float(h), float(value));
        // Through two opposite faces, along an axis; corner to corner along the diagonal (√3 per unit t).
        CHECK(cube.integrate({0.2, -2.0, 0.3}, {0.0, 1.0, 0.0}, 0.0, 4.0) == Approx(value * 2.0 * h).epsilon(1e-15));
        CHECK(cube.integrate({0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}, -1.0, 1.0) == Approx(value * 2.0 * h).epsilon(1e-15));
        CHECK(cube.integrate({0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}, 0.1, 1.0) == Approx(value * (h - 0.1)).epsilon(1e-14));
        CHECK(cube.integrate({0.7, 0.0, 0.0}, {0.0, 1.0, 0.0}, -1.0, 1.0) == 0.0);  // beside it, parallel to a face
        // Random segments against a midpoint sum of density() on 2²⁰ panels: a convex shape's chord has two
        // ends, each misjudged by at most one panel (and the float points' rounding at a face, far less).
        constexpr int kPanels = 1 << 20;
        for (int r = 0; r < 20; ++r) {
            const glm::dvec3 q0 = uniform3(rng, -1.0, 1.0), dq = uniform3(rng, -1.5, 1.5);
            double sum = 0.0;
            for (int k = 0; k < kPanels; ++k) sum += double(cube.density(glm::vec3(q0 + (k + 0.5) / kPanels * dq)));
            INFO("q0 (" << q0.x << ", " << q0.y << ", " << q0.z << ")");
            CHECK(std::abs(cube.integrate(q0, dq, 0.0, 1.0) - sum / kPanels) <= 2.0 * value / kPanels);
        }
    }
}

TEST_CASE("puff volume: a grid of the wrong size or with a value that is no density is refused",
          "[truth][puff_volume]") {
    CHECK_THROWS_WITH(PuffVolume::voxels(2, 2, std::vector<float>(7, 0.5f)),
                      Catch::Contains("7 voxel values for a 2x2x2 grid"));
    CHECK_THROWS_WITH(PuffVolume::voxels(0, 2, {}), Catch::Contains("voxel counts"));
    std::vector<float> values(8, 0.5f);
    values[3] = -0.25f;
    CHECK_THROWS_WITH(PuffVolume::voxels(2, 2, values), Catch::Contains(">= 0"));
    values[3] = std::numeric_limits<float>::quiet_NaN();
    CHECK_THROWS_WITH(PuffVolume::voxels(2, 2, values), Catch::Contains(">= 0"));
    values[3] = 0.25f;
    CHECK_NOTHROW(PuffVolume::voxels(2, 2, values));
}
