// The ground truth of a frame (see ground_truth.hpp and docs/ground-truth.md): a kernel source, compiled once
// per kernel level (core/simd/dispatch.hpp); its public entry points are in ground_truth_dispatch.cpp.
#include <smoketrace/truth/ground_truth.hpp>

#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/render/pixel_samples.hpp>
#include <smoketrace/render/puff_density.hpp>
#include <smoketrace/render/view_compositor.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/trace/trace.hpp>
#include <smoketrace/truth/puff_axis_depths.hpp>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>

namespace smoketrace {

namespace {

// One particle as the volume sees it: its sphere (in double, for the ray intervals) and its billboard's
// tangent frame (world → tangent: p = (d·x̂, d·ŷ, d·ẑ) / radius, d = x − centre).
struct PuffPlacement {
    glm::dvec3 centre;
    double radius;
    glm::vec3 centre_f, ex, ey, ez;
    float inv_radius;
    int frame;  // flipbook frame: (view flipbook frame + particle index) % frames, as PixelShader has it
    glm::vec3 light_tangent;  // toward the light in the tangent frame, as PixelShader picks the six-way channels
};


// A puff's stretch of a ray: [t_in, t_out] of its sphere, clipped to the ray's range.
struct Interval {
    double t_in, t_out;
    std::uint32_t puff;
};

// A lit point of a camera ray whose τ_light came from the light volume: where it is, the weight its light
// enters the pixel with (view transmittance · opacity · c_light per channel, or T_view · the ground's lit term),
// τ from the grid, and its error estimate (the weight's largest channel times the light's change between the
// grid and the subgrid).
struct LitSample {
    glm::dvec3 x;
    glm::dvec3 weight;
    double tau;
    double estimate;
    bool ground;  // the ground's light is e^{-τ}, the smoke's T_ms(τ)
};

// Per-thread scratch, reused across rays: no allocation per ray once warm.
struct Scratch {
    std::vector<LitSample> lit;                        // a pixel's lit samples at the current step level
    std::vector<std::pair<double, std::uint32_t>> order;  // (estimate, index) of lit, largest first
    std::vector<std::uint32_t> ids;
    std::vector<Interval> intervals;
    std::vector<Interval> intervals_light;
    std::vector<std::pair<double, double>> segments;  // the union of the intervals
};

// A light-space box sampled on a node grid: τ from each node to the light (a deep shadow map).
struct LightVolume {
    glm::dvec3 u, v, w;  // w = toward the light
    double lo_u = 0, lo_v = 0, lo_w = 0, spacing = 1;
    int nu = 0, nv = 0, nw = 0;
    std::vector<float> tau;  // [j][i][k]: k along w fastest, so a column is contiguous

    [[nodiscard]] std::size_t bytes() const { return tau.size() * sizeof(float); }
    [[nodiscard]] float node(int i, int j, int k) const {
        return tau[(std::size_t(j) * std::size_t(nu) + std::size_t(i)) * std::size_t(nw) + std::size_t(k)];
    }
    // Trilinear on the grid (stride 1) or on its every-other-node subgrid (stride 2); clamped to the box,
    // which gives 0 beside the columns and above them (no puff there) and the column's total below.
    [[nodiscard]] float lookup(const glm::dvec3& x, int stride) const {
        const double s = spacing * stride;
        const int mu = (nu - 1) / stride, mv = (nv - 1) / stride, mw = (nw - 1) / stride;
        const double fu = std::clamp((glm::dot(x, u) - lo_u) / s, 0.0, double(mu));
        const double fv = std::clamp((glm::dot(x, v) - lo_v) / s, 0.0, double(mv));
        const double fw = std::clamp((glm::dot(x, w) - lo_w) / s, 0.0, double(mw));
        const int i = std::min(int(fu), mu - 1), j = std::min(int(fv), mv - 1), k = std::min(int(fw), mw - 1);
        const double a = fu - i, b = fv - j, c = fw - k;
        auto at = [&](int di, int dj, int dk) { return double(node((i + di) * stride, (j + dj) * stride, (k + dk) * stride)); };
        const double c00 = at(0, 0, 0) + a * (at(1, 0, 0) - at(0, 0, 0));
        const double c10 = at(0, 1, 0) + a * (at(1, 1, 0) - at(0, 1, 0));
        const double c01 = at(0, 0, 1) + a * (at(1, 0, 1) - at(0, 0, 1));
        const double c11 = at(0, 1, 1) + a * (at(1, 1, 1) - at(0, 1, 1));
        const double c0 = c00 + b * (c10 - c00), c1 = c01 + b * (c11 - c01);
        return float(c0 + c * (c1 - c0));
    }
};

// What the ladder's rungs light a puff with (TruthRung): per particle τ from its centre, the part of it the other
// puffs make, and its own puff's light volume (τ of its density alone, toward the light); per flipbook frame
// the axis depths of the lights some particle's light direction picks.
struct LadderLight {
    std::vector<double> tau_centre, tau_others;
    std::vector<LightVolume> own;
    std::vector<PuffAxisDepths> axis;
};

}  // namespace

struct GroundTruth::Impl {
    SceneDescription scene;
    SixwayBakeSettings scattering;  // its scattering_octaves and weight: the light's T_ms
    std::vector<PuffVolume> flipbook;
    TruthSettings settings;
    std::uint64_t frame = 0;
    int width = 0, height = 0;

    SixwayTexture texture;  // a placeholder of the right frame count: FrameRenderer needs one, the truth reads none
    std::unique_ptr<FrameRenderer> renderer;
    ViewSettings view;
    std::vector<PuffPlacement> puffs;
    glm::dvec3 to_light{0, 1, 0};
    float sigma_t = 1.0f;
    double min_voxel = 1.0;  // the smallest puff's voxel, world units
    glm::vec3 ground_lit{0.0f};  // c_base · c_light · max(N·L, 0)
    glm::vec3 ground_ambient{0.0f};
    // An exact light ray's light, per unit of its weight, is off by rounding alone: τ is exact to 10⁻¹²
    // relative (PuffVolume::integrate); rounding it to float moves T_ms by at most 2⁻²⁴/e (τ·|T_ms'(τ)| <= 1/e);
    // T_ms itself is evaluated in float, a few units of 2⁻²⁴ ≈ 6·10⁻⁸ on values at most 1. Each exact sample
    // is charged this bound times its weight in the pixel's light estimate.
    static constexpr double kExactLightRounding = 1e-6;
    // A lit sample's volume error per unit of its light's change between the grid and the subgrid. Trilinear
    // interpolation is second order where τ is smooth (the grid's error a third of the change), but τ has a
    // square-root edge below a hard-edged density, where the subgrid's error is only √2 times the grid's;
    // the change itself bounds the grid's error wherever the subgrid's is at least twice it (any first-order
    // convergence), and is what each sample is charged.
    static constexpr double kVolumeErrorPerChange = 1.0;
    mutable tbb::enumerable_thread_specific<Scratch> scratch;

    void init();

    const AccelScene& accel() const { return renderer->smoke().scene(); }

    // σ(x) = σt · Σ ρ_i(x) over the puffs of `intervals` whose stretch holds t (x = the ray's point at t).
    float sigma_at(const glm::vec3& x, double t, const std::vector<Interval>& intervals) const {
        float sum = 0.0f;
        for (const Interval& iv : intervals) {
            if (t < iv.t_in || t > iv.t_out) continue;
            sum += density(iv.puff, x);
        }
        return sigma_t * sum;
    }
    float density(std::uint32_t i, const glm::vec3& x) const {
        const PuffPlacement& p = puffs[i];
        const glm::vec3 d = x - p.centre_f;
        const glm::vec3 q = glm::vec3(glm::dot(d, p.ex), glm::dot(d, p.ey), glm::dot(d, p.ez)) * p.inv_radius;
        return flipbook[std::size_t(p.frame)].density(q);
    }

    // The puffs whose stand-in spheres the ray meets in [tmin, tmax], found through the TLAS (any-hit on the
    // stand-ins, thesis 4.3.2's rays), with their intervals from the spheres in double, sorted by t_in.
    void puffs_on(const Ray& ray, double tmax, Scratch& sc, std::vector<Interval>& out) const {
        puffs_on(ray, glm::dvec3(ray.origin), glm::normalize(glm::dvec3(ray.direction)), tmax, sc, out);
    }
    // The same with the intervals of the ray o + t·d (d unit) in double, `ray` its float copy for the TLAS: a
    // sphere the two disagree on is grazed within float rounding, where a baked puff is 0 (its support ends
    // at 0.95 of the sphere).
    void puffs_on(const Ray& ray, const glm::dvec3& o, const glm::dvec3& d, double tmax, Scratch& sc,
                  std::vector<Interval>& out) const {
        sc.ids.clear();
        const Ray r{ray.origin, ray.tmin, ray.direction, std::numeric_limits<float>::infinity()};
        trace<TlasWalk::all_hits>(accel(), r, ray_flag_force_non_opaque, kStandInMask, [&](const TraceHit& h) {
            sc.ids.push_back(h.instance_id);
            return AnyHitDecision::ignore;
        });
        std::sort(sc.ids.begin(), sc.ids.end());
        sc.ids.erase(std::unique(sc.ids.begin(), sc.ids.end()), sc.ids.end());
        out.clear();
        for (std::uint32_t id : sc.ids) {
            const PuffPlacement& p = puffs[id];
            const glm::dvec3 oc = o - p.centre;
            const double b = glm::dot(oc, d), c = glm::dot(oc, oc) - p.radius * p.radius;
            const double disc = b * b - c;
            if (disc <= 0.0) continue;
            const double root = std::sqrt(disc);
            const double t0 = std::max(-b - root, double(ray.tmin)), t1 = std::min(-b + root, tmax);
            if (t1 > t0) out.push_back({t0, t1, id});
        }
        std::sort(out.begin(), out.end(), [](const Interval& a, const Interval& b2) {
            return a.t_in < b2.t_in || (a.t_in == b2.t_in && a.puff < b2.puff);
        });
    }

    // ∫ ρ_puff(o + t·d) dt over the puff's stretch [a, b], exactly (PuffVolume::integrate_bins), cut into bins
    // of `spacing` from `origin`. In tangent space from the point at a: the stretch lies in the puff's sphere,
    // so the segment and its origin lie in its cube, where the integral's rounding is stated.
    void integrate(std::uint32_t puff, const glm::dvec3& o, const glm::dvec3& d, double a, double b, double origin,
                   double spacing, std::span<double> bins) const {
        const PuffPlacement& p = puffs[puff];
        const glm::dvec3 ex(p.ex), ey(p.ey), ez(p.ez);
        const glm::dvec3 s = o + a * d - p.centre;
        const glm::dvec3 q0 = glm::dvec3(glm::dot(s, ex), glm::dot(s, ey), glm::dot(s, ez)) / p.radius;
        const glm::dvec3 dq = glm::dvec3(glm::dot(d, ex), glm::dot(d, ey), glm::dot(d, ez)) / p.radius;
        flipbook[std::size_t(p.frame)].integrate_bins(q0, dq, 0.0, b - a, origin - a, spacing, bins);
    }
    // The same over [a, b] whole.
    double integrate(std::uint32_t puff, const glm::dvec3& o, const glm::dvec3& d, double a, double b) const {
        double sum = 0.0;
        integrate(puff, o, d, a, b, a, std::numeric_limits<double>::infinity(), {&sum, 1});
        return sum;
    }

    // Exact τ from x to the light: a light ray through the TLAS finds the puffs, each one's stretch integrated
    // exactly; rounding alone (kExactLightRounding).
    double exact_tau(const glm::dvec3& x, Scratch& sc) const {
        const Ray ray{glm::vec3(x), 0.0f, glm::vec3(to_light), std::numeric_limits<float>::infinity()};
        puffs_on(ray, x, to_light, std::numeric_limits<double>::infinity(), sc, sc.intervals_light);
        double tau = 0.0;
        for (const Interval& iv : sc.intervals_light) tau += integrate(iv.puff, x, to_light, iv.t_in, iv.t_out);
        return double(sigma_t) * tau;
    }

    // The light volume's frame and node grid at `spacing` over the spheres of puffs [first, last) (nothing
    // allocated yet), one column of it filled with τ from the puffs of `intervals` (their stretches of the
    // column's ray), and the whole volume filled from the puffs each column's ray meets in the TLAS.
    void layout_light_volume(LightVolume& lv, double spacing, std::size_t first, std::size_t last) const;
    void fill_column(LightVolume& lv, int i, int j, const std::vector<Interval>& intervals, std::vector<double>& tau) const;
    void build_light_volume(LightVolume& lv, WorkProgress* progress) const;
    // The origin of column (i, j)'s ray, one spacing below the box, in float as the ray is traced: node k lies
    // at t = (k + 1)·spacing along it.
    static glm::dvec3 column_origin(const LightVolume& lv, int i, int j) {
        const glm::dvec3 o = (lv.lo_u + i * lv.spacing) * lv.u + (lv.lo_v + j * lv.spacing) * lv.v + (lv.lo_w - lv.spacing) * lv.w;
        return glm::dvec3(glm::vec3(o));
    }

    // The camera march's steps: each segment of the union cut into equal steps of at most `step`, and
    // visit(t, dt, x) at each step's midpoint x = o + t·d, front to back (march() and march_ladder()).
    template <class Visit>
    static void for_each_step(const Ray& ray, const std::vector<std::pair<double, double>>& segments, double step,
                              Visit&& visit) {
        const glm::dvec3 o(ray.origin), d(ray.direction);
        for (const auto& [a, b] : segments) {
            const int n = std::max(1, int(std::ceil((b - a) / step)));
            const double dt = (b - a) / n;
            for (int k = 0; k < n; ++k) {
                const double t = a + (k + 0.5) * dt;
                visit(t, dt, o + t * d);
            }
        }
    }
    // One camera sample's radiance with midpoint steps of `step`; τ_light from the volume, each lit point
    // appended to sc.lit with its estimate, or (no volume) from exact light rays.
    struct Sample {
        glm::dvec3 color{0.0};
        std::uint64_t steps = 0;
    };
    Sample march(const Ray& ray, const std::vector<Interval>& intervals, const std::vector<std::pair<double, double>>& segments,
                 const glm::dvec3& ground_point, bool ground, double step, const LightVolume* lv, Scratch& sc) const;

    // A camera ray's ground hit (closest hit on the ground mask), and the puffs in front of it with the union of
    // their stretches, in sc.intervals and sc.segments.
    void prepare_ray(const Ray& ray, Scratch& sc, bool& ground, glm::dvec3& ground_point) const {
        const TraceResult g = trace(accel(), ray, ray_flag_force_opaque, kGroundMask);
        ground = g.hit;
        const double t_end = g.hit ? double(g.committed.t) : std::numeric_limits<double>::infinity();
        ground_point = g.hit ? glm::dvec3(ray.origin) + double(g.committed.t) * glm::dvec3(ray.direction) : glm::dvec3(0.0);
        puffs_on(ray, t_end, sc, sc.intervals);
        sc.segments.clear();
        for (const Interval& iv : sc.intervals) {
            if (!sc.segments.empty() && iv.t_in <= sc.segments.back().second)
                sc.segments.back().second = std::max(sc.segments.back().second, iv.t_out);
            else
                sc.segments.emplace_back(iv.t_in, iv.t_out);
        }
    }

    // A pixel: the mean of its spp samples, the step halved until the pixel changes by less than half the
    // tolerance. Returns the colour; sets the view and light error estimates, the level and whether it hit
    // the limit.
    struct PixelResult {
        glm::vec3 color{0.0f};
        float view_error = 0, light_error = 0;
        float volume_error = 0;  // the light error estimate had every lit sample kept the volume's τ
        int level = 0;
        bool limit = false;
        std::uint64_t steps = 0;
        std::uint64_t lit = 0, exact = 0;  // lit samples at the last level, and those given exact light rays
    };
    PixelResult shade_pixel(int x, int y, const LightVolume* lv, int max_levels, Scratch& sc) const;

    // The ladder (TruthRung): τ of puff i's own density from x to its sphere's exit toward the light (exact, as
    // exact_tau's), each puff's own light volume, each rung's light for puff i at x (and the own light's change
    // between the own volume's grid and subgrid), a camera sample's radiance in every rung, and a pixel's,
    // steps halved until every rung settles.
    double own_tau(std::uint32_t i, const glm::dvec3& x) const;
    void build_own_volumes(LadderLight& ll) const;
    void rung_lights(std::uint32_t i, const glm::dvec3& x, const LadderLight& ll, std::array<double, kTruthRungs>& out,
                     double& own_change) const;
    using RungColors = std::array<glm::dvec3, kTruthRungs>;
    struct RungSample {
        RungColors color{};
        double own_estimate = 0;  // the weight of the own light's change, over the ray's samples
        std::uint64_t steps = 0;
    };
    RungSample march_ladder(const Ray& ray, const std::vector<Interval>& intervals,
                            const std::vector<std::pair<double, double>>& segments, const glm::dvec3& ground_point,
                            bool ground, double step, const LadderLight& ll) const;
    struct LadderPixel {
        RungColors color{};
        float view_error = 0, light_error = 0;
        int level = 0;
        bool limit = false;
        std::uint64_t steps = 0;
    };
    LadderPixel shade_ladder_pixel(int x, int y, const LadderLight& ll, Scratch& sc) const;
    // The exact light rays that bring the pixel's light error within its share (see the definition); returns
    // what they change the pixel by and sets r.light_error, r.lit and r.exact.
    glm::dvec3 light_correction(Scratch& sc, int spp, double half_tol, PixelResult& r) const;
};

void GroundTruth::Impl::layout_light_volume(LightVolume& lv, double spacing, std::size_t first, std::size_t last) const {
    lv.w = to_light;
    const glm::dvec3 helper = std::abs(lv.w.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
    lv.u = glm::normalize(glm::cross(lv.w, helper));
    lv.v = glm::cross(lv.w, lv.u);
    glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (std::size_t i = first; i < last; ++i) {
        const PuffPlacement& p = puffs[i];
        const glm::dvec3 c(glm::dot(p.centre, lv.u), glm::dot(p.centre, lv.v), glm::dot(p.centre, lv.w));
        lo = glm::min(lo, c - p.radius);
        hi = glm::max(hi, c + p.radius);
    }
    // One node of margin on each side, and an odd node count so that the every-other-node subgrid spans the box.
    auto nodes = [&](double extent) { return 2 * int(std::ceil((extent + 2.0 * spacing) / (2.0 * spacing))) + 1; };
    lv.spacing = spacing;
    lv.lo_u = lo.x - spacing;
    lv.lo_v = lo.y - spacing;
    lv.lo_w = lo.z - spacing;
    lv.nu = nodes(hi.x - lo.x);
    lv.nv = nodes(hi.y - lo.y);
    lv.nw = nodes(hi.z - lo.z);
}

void GroundTruth::Impl::fill_column(LightVolume& lv, int i, int j, const std::vector<Interval>& intervals,
                                    std::vector<double>& tau) const {
    const double spacing = lv.spacing, t0 = spacing;
    const glm::dvec3 o = column_origin(lv, i, j);
    tau.assign(std::size_t(lv.nw), 0.0);
    // Each puff's share of each node-to-node segment (bin k: from node k to node k + 1), exact; then τ of a
    // node is the sum of the segments above it.
    for (const Interval& iv : intervals)
        integrate(iv.puff, o, lv.w, iv.t_in, iv.t_out, t0, spacing, {tau.data(), std::size_t(lv.nw - 1)});
    double above = 0.0;
    float* column = &lv.tau[(std::size_t(j) * std::size_t(lv.nu) + std::size_t(i)) * std::size_t(lv.nw)];
    for (int k = lv.nw - 1; k >= 0; --k) {
        above += tau[std::size_t(k)];  // the segment from node k to node k + 1
        column[k] = float(double(sigma_t) * above);
    }
}

void GroundTruth::Impl::build_light_volume(LightVolume& lv, WorkProgress* progress) const {
    lv.tau.assign(std::size_t(lv.nu) * std::size_t(lv.nv) * std::size_t(lv.nw), 0.0f);
    if (progress) progress->begin("light volume", std::uint64_t(lv.nv));

    tbb::parallel_for(tbb::blocked_range<int>(0, lv.nv), [&](const tbb::blocked_range<int>& rows) {
        Scratch& sc = scratch.local();
        std::vector<double> tau;
        for (int j = rows.begin(); j != rows.end(); ++j) {
            for (int i = 0; i < lv.nu; ++i) {
                const Ray ray{glm::vec3(column_origin(lv, i, j)), 0.0f, glm::vec3(lv.w), std::numeric_limits<float>::infinity()};
                puffs_on(ray, std::numeric_limits<double>::infinity(), sc, sc.intervals_light);
                fill_column(lv, i, j, sc.intervals_light, tau);
            }
            if (progress) progress->add(1);
        }
    });
}

GroundTruth::Impl::Sample GroundTruth::Impl::march(const Ray& ray, const std::vector<Interval>& intervals,
                                                   const std::vector<std::pair<double, double>>& segments,
                                                   const glm::dvec3& ground_point, bool ground, double step,
                                                   const LightVolume* lv, Scratch& sc) const {
    const OctaveTransmittance light_t(scattering);
    const glm::dvec3 c_light(view.light_color), c_amb(view.ambient);
    const double c_light_max = std::max({c_light.x, c_light.y, c_light.z});
    Sample s;
    double transmittance = 1.0;
    for_each_step(ray, segments, step, [&](double t, double dt, const glm::dvec3& xd) {
        const glm::vec3 x(xd);
        const float sigma = sigma_at(x, t, intervals);
        ++s.steps;
        if (sigma == 0.0f) return;
        // The baker's voxel rule, per step: the share of the view ray the step stops, 1 − e^{−σΔ}, scatters
        // the light that reaches it (T_ms of its τ toward the light) plus the ambient term; Beer–Lambert (eq. 2.10).
        const double opacity = transmittance * -std::expm1(-double(sigma) * dt);
        double tau;
        if (lv) {
            tau = double(lv->lookup(xd, 1));
            const double change = std::abs(double(light_t(float(tau))) - double(light_t(lv->lookup(xd, 2))));
            sc.lit.push_back({xd, opacity * c_light, tau, opacity * c_light_max * change * kVolumeErrorPerChange, false});
        } else {
            tau = exact_tau(xd, sc);
        }
        s.color += opacity * (c_light * double(light_t(float(tau))) + c_amb);
        transmittance *= std::exp(-double(sigma) * dt);
    });
    glm::dvec3 back(view.background);
    if (ground) {
        double tau;
        const glm::dvec3 lit = transmittance * glm::dvec3(ground_lit);
        if (lv) {
            tau = double(lv->lookup(ground_point, 1));
            const double change = std::abs(std::exp(-tau) - std::exp(-double(lv->lookup(ground_point, 2))));
            sc.lit.push_back({ground_point, lit, tau, std::max({lit.x, lit.y, lit.z}) * change * kVolumeErrorPerChange, true});
        } else {
            tau = exact_tau(ground_point, sc);
        }
        // Eqs. 4.3/4.4 with the field's transmittance as the shadow: c_base·(c_light·max(N·L, 0)·e^{−τ} + c_amb).
        back = glm::dvec3(ground_lit) * std::exp(-tau) + glm::dvec3(ground_ambient);
    }
    s.color += transmittance * back;
    return s;
}

GroundTruth::Impl::PixelResult GroundTruth::Impl::shade_pixel(int x, int y, const LightVolume* lv, int max_levels,
                                                              Scratch& sc) const {
    const PixelSamples samples(settings.spp);
    const Camera& camera = renderer->camera();
    const double h0 = double(settings.step_voxels) * min_voxel;
    const double half_tol = 0.5 * double(settings.tolerance);
    PixelResult r;
    glm::dvec3 previous(0.0);
    // Each level finds a sample's puffs again rather than keeping spp lists: one TLAS walk, far less than
    // the sample's march.
    for (int level = 0; level <= max_levels; ++level) {
        const double step = h0 / double(1 << level);
        glm::dvec3 sum(0.0);
        sc.lit.clear();  // the last level's lit samples are the ones the light correction below works on
        for (int i = 0; i < samples.count(); ++i) {
            const glm::vec2 off = samples[i];
            const Ray ray = camera.ray_through(float(x) + off.x, float(y) + off.y, kViewRayTmin);
            bool ground;
            glm::dvec3 gp;
            prepare_ray(ray, sc, ground, gp);
            const Sample s = march(ray, sc.intervals, sc.segments, gp, ground, step, lv, sc);
            sum += s.color;
            r.steps += s.steps;
        }
        const glm::dvec3 pixel = sum / double(samples.count());
        if (level > 0) {
            const glm::dvec3 change = glm::abs(pixel - previous);
            r.view_error = float(std::max({change.x, change.y, change.z}));
            r.level = level;
            previous = pixel;
            if (double(r.view_error) < half_tol) break;
            if (level == max_levels) r.limit = true;
        } else {
            previous = pixel;
        }
    }
    if (lv) previous += light_correction(sc, samples.count(), half_tol, r);
    r.color = glm::vec3(previous);
    return r;
}

glm::dvec3 GroundTruth::Impl::light_correction(Scratch& sc, int spp, double half_tol, PixelResult& r) const {
    // The pixel's light error is at most the sum of its samples' errors (each enters the pixel mean with
    // weight 1/spp): a conservative bound from the per-sample estimates. While it, with the exact rays'
    // rounding, is above the light's half of the tolerance, the sample with the largest estimate takes an exact
    // light ray instead.
    const double inv_n = 1.0 / double(spp);
    double remaining = 0.0;
    for (const LitSample& l : sc.lit) remaining += l.estimate;
    remaining *= inv_n;
    r.volume_error = float(remaining);
    r.lit = sc.lit.size();
    glm::dvec3 correction(0.0);
    double exact_bound = 0.0;
    if (remaining > half_tol) {
        sc.order.clear();
        for (std::size_t i = 0; i < sc.lit.size(); ++i) sc.order.emplace_back(sc.lit[i].estimate, std::uint32_t(i));
        // Largest first, ties by index: the same samples whatever the thread.
        std::sort(sc.order.begin(), sc.order.end(), [](const auto& a, const auto& b) {
            return a.first > b.first || (a.first == b.first && a.second < b.second);
        });
        const OctaveTransmittance light_t(scattering);
        auto light = [&](const LitSample& l, double tau) {
            return l.ground ? std::exp(-tau) : double(light_t(float(tau)));
        };
        for (const auto& [estimate, i] : sc.order) {
            if (remaining + exact_bound <= half_tol) break;
            const LitSample& l = sc.lit[i];
            const double tau = exact_tau(l.x, sc);
            correction += l.weight * (light(l, tau) - light(l, l.tau));
            remaining -= estimate * inv_n;
            exact_bound += std::max({l.weight.x, l.weight.y, l.weight.z}) * kExactLightRounding * inv_n;
            ++r.exact;
        }
    }
    r.light_error = float(std::max(remaining, 0.0) + exact_bound);
    return correction * inv_n;
}

void GroundTruth::Impl::init() {
    if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide)
        throw std::invalid_argument("truth: image size " + std::to_string(width) + "x" + std::to_string(height) + " is out of range");
    if (!(settings.tolerance > 0.0f)) throw std::invalid_argument("truth: tolerance must be > 0");
    if (settings.spp < 1 || settings.spp > kMaxSpp)
        throw std::invalid_argument("truth: spp must be in [1, " + std::to_string(kMaxSpp) + "]");
    if (settings.max_view_levels < 1 || settings.max_view_levels > 12)
        throw std::invalid_argument("truth: max_view_levels must be in [1, 12]");
    if (!(settings.step_voxels > 0.0f) || !(settings.light_spacing_voxels > 0.0f) ||
        !(settings.own_light_spacing_voxels > 0.0f))
        throw std::invalid_argument("truth: step_voxels, light_spacing_voxels and own_light_spacing_voxels must be > 0");
    const int frames = int(flipbook.size());
    const SixwayAtlasGrid grid = sixway_grid_for_frames(frames);
    texture = SixwayTexture(Rgba8Image(grid.columns, grid.rows), Rgba8Image(grid.columns, grid.rows), grid);

    RenderOptions options = RenderOptions::from_scene(scene);
    options.render.mode = RenderMode::basic;  // no optical-depth pass: the truth finds its own
    options.render.spp = 1;
    options.shape = StandInShape{};           // spheres of radius r bound each puff
    options.width = width;
    options.height = height;
    renderer = std::make_unique<FrameRenderer>(scene, options, texture);
    renderer->skip_to(frame + 1);  // particles, light and TLAS as frame `frame` renders them
    view = renderer->view_settings(frame);
    to_light = glm::normalize(glm::dvec3(view.to_light));
    sigma_t = view.sigma_t;

    const std::span<const Particle> particles = renderer->particles().particles();
    const glm::vec3 eye = renderer->camera().position();
    puffs.resize(particles.size());
    min_voxel = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < particles.size(); ++i) {
        const AffineTransform m = SmokeScene::billboard_transform(particles[i], eye);
        PuffPlacement& p = puffs[i];
        p.centre = glm::dvec3(particles[i].center);
        p.radius = double(particles[i].radius);
        p.centre_f = particles[i].center;
        p.ex = glm::vec3(glm::normalize(m.linear[0]));
        p.ey = glm::vec3(glm::normalize(m.linear[1]));
        p.ez = glm::vec3(glm::normalize(m.linear[2]));
        p.inv_radius = 1.0f / particles[i].radius;
        p.frame = (view.flipbook_frame + int(i)) % frames;
        p.light_tangent = glm::vec3(glm::dot(view.to_light, p.ex), glm::dot(view.to_light, p.ey), glm::dot(view.to_light, p.ez));
        min_voxel = std::min(min_voxel, p.radius * double(flipbook[std::size_t(p.frame)].voxel()));
    }
    if (puffs.empty()) min_voxel = 1.0;
    const SmokeScene& smoke = renderer->smoke();
    const float n_dot_l = smoke.has_ground() ? std::max(glm::dot(glm::normalize(smoke.ground_normal()), view.to_light), 0.0f) : 0.0f;
    ground_lit = view.ground_color * view.light_color * n_dot_l;
    ground_ambient = view.ground_color * view.ambient;
}

namespace {
std::vector<PuffVolume> baked_flipbook(const SceneDescription& scene, const SixwayBakeSettings& puff, std::uint64_t frame) {
    validate(puff);
    // Only the flipbook frames some particle shows: (frame % frames + i) % frames over the particles.
    const std::size_t n = scene.smoke.particles.size();
    const int frames = puff.frames;
    std::vector<bool> used(std::size_t(frames), false);
    const int first = int(frame % std::uint64_t(frames));
    for (std::size_t i = 0; i < std::min<std::size_t>(n, std::size_t(frames)); ++i) used[std::size_t((first + int(i)) % frames)] = true;
    auto flipbook = std::vector<PuffVolume>(std::size_t(frames));
    for (int f = 0; f < frames; ++f)
        if (used[std::size_t(f)]) flipbook[std::size_t(f)] = PuffVolume::baked(puff, f);  // each parallel inside
    return flipbook;
}
}  // namespace

GroundTruth::GroundTruth(const SceneDescription& scene, const SixwayBakeSettings& puff, std::uint64_t frame, int width,
                         int height, const TruthSettings& settings)
    : GroundTruth(scene, puff, baked_flipbook(scene, puff, frame), frame, width, height, settings) {}

GroundTruth::GroundTruth(const SceneDescription& scene, const SixwayBakeSettings& scattering,
                         std::vector<PuffVolume> flipbook, std::uint64_t frame, int width, int height,
                         const TruthSettings& settings)
    : impl_(std::make_unique<Impl>()) {
    if (flipbook.empty()) throw std::invalid_argument("truth: the flipbook has no frames");
    impl_->scene = scene;
    impl_->scattering = scattering;
    impl_->flipbook = std::move(flipbook);
    impl_->settings = settings;
    impl_->frame = frame;
    impl_->width = width;
    impl_->height = height;
    impl_->init();
}

GroundTruth::~GroundTruth() = default;

int GroundTruth::width() const { return impl_->width; }
int GroundTruth::height() const { return impl_->height; }

template <simd::Level L>
TruthReport GroundTruth::render_at_level(ImageRgba& image, WorkProgress* progress) const {
    static_assert(L == simd::kCompiledLevel);
    const auto start = std::chrono::steady_clock::now();
    const Impl& m = *impl_;
    TruthReport report;
    image = ImageRgba(m.width, m.height, glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));

    // The light volume at light_spacing_voxels, coarser if it would exceed the memory cap: the exact light
    // rays make up for its interpolation wherever a pixel needs them.
    LightVolume lv;
    double spacing = double(m.settings.light_spacing_voxels) * m.min_voxel;
    const double half_tol = 0.5 * double(m.settings.tolerance);
    for (;;) {
        m.layout_light_volume(lv, spacing, 0, m.puffs.size());
        const std::size_t bytes = std::size_t(lv.nu) * std::size_t(lv.nv) * std::size_t(lv.nw) * sizeof(float);
        if (bytes <= m.settings.light_volume_max_bytes) break;
        spacing *= 2.0;
    }
    m.build_light_volume(lv, progress);
    report.light_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    report.light_columns_u = lv.nu;
    report.light_columns_v = lv.nv;
    report.light_nodes_w = lv.nw;
    report.light_spacing = float(lv.spacing);

    struct Row {
        float view = 0, light = 0, total = 0, volume = 0;
        int level = 0;
        std::uint64_t limit = 0, steps = 0, lit = 0, exact = 0, exact_pixels = 0;
    };
    std::vector<Row> rows(std::size_t(m.height));
    report.pixel_error_estimate.assign(std::size_t(m.width) * std::size_t(m.height), 0.0f);
    report.pixel_unconverged.assign(std::size_t(m.width) * std::size_t(m.height), 0);
    if (progress) progress->begin("truth", std::uint64_t(m.height));
    tbb::parallel_for(tbb::blocked_range<int>(0, m.height, 1), [&](const tbb::blocked_range<int>& range) {
        Scratch& sc = m.scratch.local();
        for (int y = range.begin(); y != range.end(); ++y) {
            Row& row = rows[std::size_t(y)];
            for (int x = 0; x < m.width; ++x) {
                const Impl::PixelResult p = m.shade_pixel(x, y, &lv, m.settings.max_view_levels, sc);
                image.at(x, y) = glm::vec4(p.color, 1.0f);
                row.view = std::max(row.view, p.view_error);
                row.light = std::max(row.light, p.light_error);
                row.volume = std::max(row.volume, p.volume_error);
                row.total = std::max(row.total, p.view_error + p.light_error);
                row.level = std::max(row.level, p.level);
                const bool unconverged = p.limit || double(p.light_error) > half_tol;
                row.limit += unconverged ? 1 : 0;
                const std::size_t at = std::size_t(y) * std::size_t(m.width) + std::size_t(x);
                report.pixel_error_estimate[at] = p.view_error + p.light_error;
                report.pixel_unconverged[at] = unconverged ? 1 : 0;
                row.steps += p.steps;
                row.lit += p.lit;
                row.exact += p.exact;
                row.exact_pixels += p.exact > 0 ? 1 : 0;
            }
            if (progress) progress->add(1);
        }
    });
    for (const Row& r : rows) {
        report.view_error_estimate = std::max(report.view_error_estimate, r.view);
        report.light_error_estimate = std::max(report.light_error_estimate, r.light);
        report.light_volume_error_estimate = std::max(report.light_volume_error_estimate, r.volume);
        report.max_error_estimate = std::max(report.max_error_estimate, r.total);
        report.view_levels_used = std::max(report.view_levels_used, r.level);
        report.unconverged_pixels += r.limit;
        report.camera_samples += r.steps;
        report.light_samples += r.lit;
        report.exact_light_samples += r.exact;
        report.exact_light_pixels += r.exact_pixels;
    }
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return report;
}

// ---- The ladder: the frame's approximations of the light, one rung at a time ------------------------------

const char* to_string(TruthRung r) {
    switch (r) {
        case TruthRung::one_transmittance: return "one-transmittance";
        case TruthRung::light_map: return "light-map";
        case TruthRung::six_axis: return "six-axis";
        case TruthRung::bake_extinction: return "bake-extinction";
    }
    return "?";
}

double GroundTruth::Impl::own_tau(std::uint32_t i, const glm::dvec3& x) const {
    const PuffPlacement& p = puffs[i];
    const glm::dvec3 oc = x - p.centre;
    const double b = glm::dot(oc, to_light), c = glm::dot(oc, oc) - p.radius * p.radius;
    const double disc = b * b - c;
    if (disc <= 0.0) return 0.0;
    const double t_exit = -b + std::sqrt(disc);
    if (!(t_exit > 0.0)) return 0.0;
    return double(sigma_t) * integrate(i, x, to_light, 0.0, t_exit);
}

void GroundTruth::Impl::build_own_volumes(LadderLight& ll) const {
    // Each puff's own light volume at the light volume's spacing in its own voxels, coarser for all if together
    // they would exceed the light volume's memory cap.
    double scale = double(settings.own_light_spacing_voxels);
    ll.own.assign(puffs.size(), LightVolume{});
    for (;;) {
        std::size_t bytes = 0;
        for (std::size_t i = 0; i < puffs.size(); ++i) {
            const double voxel = puffs[i].radius * double(flipbook[std::size_t(puffs[i].frame)].voxel());
            layout_light_volume(ll.own[i], scale * voxel, i, i + 1);
            bytes += std::size_t(ll.own[i].nu) * std::size_t(ll.own[i].nv) * std::size_t(ll.own[i].nw) * sizeof(float);
        }
        if (bytes <= settings.light_volume_max_bytes) break;
        scale *= 2.0;
    }
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, puffs.size(), 1), [&](const tbb::blocked_range<std::size_t>& r) {
        std::vector<double> tau;
        std::vector<Interval> own(1);
        for (std::size_t p = r.begin(); p != r.end(); ++p) {
            LightVolume& lv = ll.own[p];
            lv.tau.assign(std::size_t(lv.nu) * std::size_t(lv.nv) * std::size_t(lv.nw), 0.0f);
            const PuffPlacement& puff = puffs[p];
            for (int j = 0; j < lv.nv; ++j)
                for (int i = 0; i < lv.nu; ++i) {
                    // The column's stretch through this puff's sphere alone, as puffs_on() finds it in double.
                    const glm::dvec3 o = column_origin(lv, i, j);
                    const glm::dvec3 oc = o - puff.centre;
                    const double b = glm::dot(oc, lv.w), c = glm::dot(oc, oc) - puff.radius * puff.radius;
                    const double disc = b * b - c;
                    own.clear();
                    if (disc > 0.0) {
                        const double root = std::sqrt(disc);
                        const double t0 = std::max(-b - root, 0.0), t1 = -b + root;
                        if (t1 > t0) own.push_back({t0, t1, std::uint32_t(p)});
                    }
                    fill_column(lv, i, j, own, tau);
                }
        }
    });
}

void GroundTruth::Impl::rung_lights(std::uint32_t i, const glm::dvec3& x, const LadderLight& ll,
                                    std::array<double, kTruthRungs>& out, double& own_change) const {
    const OctaveTransmittance light_t(scattering);
    auto t_ms = [&](double tau) { return double(light_t(float(tau))); };
    const LightVolume& own_volume = ll.own[i];
    const double own = double(own_volume.lookup(x, 1));
    // As the light volume's estimate (march()): the change of the own light between the grid and its subgrid.
    own_change = std::abs(t_ms(own) - t_ms(double(own_volume.lookup(x, 2))));
    const double centre = std::exp(-ll.tau_centre[i]);  // eq. 4.2's exp(-l·σt), with the true τ
    out[std::size_t(TruthRung::one_transmittance)] = t_ms(own + ll.tau_others[i]);
    out[std::size_t(TruthRung::light_map)] = t_ms(own) * centre;
    // The six-way light map, h·lx² + v·ly² + d·lz² (sixway_light_map()), of the own puff's axis depths.
    const PuffPlacement& p = puffs[i];
    const glm::vec3 d = glm::vec3(x) - p.centre_f;
    const glm::vec3 q = glm::vec3(glm::dot(d, p.ex), glm::dot(d, p.ey), glm::dot(d, p.ez)) * p.inv_radius;
    const PuffAxisDepths& axis = ll.axis[std::size_t(p.frame)];
    double six = 0.0, bake = 0.0;
    for (int a = 0; a < 3; ++a) {
        const double l = double(p.light_tangent[a]);
        if (l == 0.0) continue;
        const double depth = double(axis(l > 0.0 ? a : a + 3, q));  // tangent units
        six += l * l * t_ms(double(sigma_t) * p.radius * depth);
        bake += l * l * t_ms(double(scattering.extinction) * depth);
    }
    out[std::size_t(TruthRung::six_axis)] = six * centre;
    out[std::size_t(TruthRung::bake_extinction)] = bake * centre;
}

GroundTruth::Impl::RungSample GroundTruth::Impl::march_ladder(const Ray& ray, const std::vector<Interval>& intervals,
                                                              const std::vector<std::pair<double, double>>& segments,
                                                              const glm::dvec3& ground_point, bool ground, double step,
                                                              const LadderLight& ll) const {
    const glm::dvec3 c_light(view.light_color), c_amb(view.ambient);
    const double c_light_max = std::max({c_light.x, c_light.y, c_light.z});
    RungSample s;
    double transmittance = 1.0;
    std::array<double, kTruthRungs> lit{}, puff_lit{};
    for_each_step(ray, segments, step, [&](double t, double dt, const glm::dvec3& xd) {
        const glm::vec3 x(xd);
        ++s.steps;
        // As sigma_at(): the densities summed in float in interval order, then σt; each puff's share of the
        // sample's scattering lit by its own rung light.
        float sum = 0.0f;
        double change = 0.0;
        lit.fill(0.0);
        for (const Interval& iv : intervals) {
            if (t < iv.t_in || t > iv.t_out) continue;
            const float rho = density(iv.puff, x);
            if (rho == 0.0f) continue;
            sum += rho;
            double own_change;
            rung_lights(iv.puff, xd, ll, puff_lit, own_change);
            for (int r = 0; r < kTruthRungs; ++r) lit[std::size_t(r)] += double(rho) * puff_lit[std::size_t(r)];
            change += double(rho) * own_change;
        }
        const float sigma = sigma_t * sum;
        if (sigma == 0.0f) return;
        const double opacity = transmittance * -std::expm1(-double(sigma) * dt);  // eq. 2.10, as march()
        for (int r = 0; r < kTruthRungs; ++r)
            s.color[std::size_t(r)] += opacity * (c_light * (lit[std::size_t(r)] / double(sum)) + c_amb);
        // The own light's change enters both rungs that use it, each with at most this weight (the
        // transmittance from the centre is at most 1; T_ms is 1-Lipschitz).
        s.own_estimate += opacity * c_light_max * change / double(sum);
        transmittance *= std::exp(-double(sigma) * dt);
    });
    glm::dvec3 back(view.background);
    if (ground) {
        // Eq. 4.3 with the true τ: the shadow is the transmittance of the nearest particle toward the light,
        // found as the frame finds it (closest stand-in from the ground point, TMin 0).
        const Ray shadow{glm::vec3(ground_point), 0.0f, glm::vec3(to_light), std::numeric_limits<float>::infinity()};
        const TraceResult hit = trace(accel(), shadow, ray_flag_force_opaque, kStandInMask);
        const double lit_fraction = hit.hit ? std::exp(-ll.tau_centre[hit.committed.instance_id]) : 1.0;
        back = glm::dvec3(ground_lit) * lit_fraction + glm::dvec3(ground_ambient);
    }
    for (glm::dvec3& c : s.color) c += transmittance * back;
    return s;
}

GroundTruth::Impl::LadderPixel GroundTruth::Impl::shade_ladder_pixel(int x, int y, const LadderLight& ll,
                                                                     Scratch& sc) const {
    const PixelSamples samples(settings.spp);
    const Camera& camera = renderer->camera();
    const double h0 = double(settings.step_voxels) * min_voxel;
    const double half_tol = 0.5 * double(settings.tolerance);
    LadderPixel r;
    RungColors previous{};
    for (int level = 0; level <= settings.max_view_levels; ++level) {
        const double step = h0 / double(1 << level);
        RungColors sum{};
        double own_estimate = 0.0;
        for (int i = 0; i < samples.count(); ++i) {
            const glm::vec2 off = samples[i];
            const Ray ray = camera.ray_through(float(x) + off.x, float(y) + off.y, kViewRayTmin);
            bool ground;
            glm::dvec3 gp;
            prepare_ray(ray, sc, ground, gp);
            const RungSample c = march_ladder(ray, sc.intervals, sc.segments, gp, ground, step, ll);
            for (int k = 0; k < kTruthRungs; ++k) sum[std::size_t(k)] += c.color[std::size_t(k)];
            own_estimate += c.own_estimate;
            r.steps += c.steps;
        }
        r.light_error = float(own_estimate / double(samples.count()));
        double change = 0.0;
        for (int k = 0; k < kTruthRungs; ++k) {
            const glm::dvec3 pixel = sum[std::size_t(k)] / double(samples.count());
            const glm::dvec3 delta = glm::abs(pixel - previous[std::size_t(k)]);
            change = std::max({change, delta.x, delta.y, delta.z});
            previous[std::size_t(k)] = pixel;
        }
        if (level == 0) continue;
        r.view_error = float(change);
        r.level = level;
        if (change < half_tol) break;
        if (level == settings.max_view_levels) r.limit = true;
    }
    r.color = previous;
    return r;
}

template <simd::Level L>
LadderReport GroundTruth::render_ladder_at_level(std::array<ImageRgba, kTruthRungs>& images,
                                                WorkProgress* progress) const {
    static_assert(L == simd::kCompiledLevel);
    const auto start = std::chrono::steady_clock::now();
    const Impl& m = *impl_;
    LadderLight ll;
    ll.tau_centre = particle_optical_depths_at_level<L>();
    ll.tau_others.resize(m.puffs.size());
    unsigned lights = 0;  // the axis lights some particle's light direction picks
    for (std::size_t i = 0; i < m.puffs.size(); ++i) {
        ll.tau_others[i] = ll.tau_centre[i] - m.own_tau(std::uint32_t(i), m.puffs[i].centre);
        for (int a = 0; a < 3; ++a) {
            const float l = m.puffs[i].light_tangent[a];
            if (l != 0.0f) lights |= 1u << (l > 0.0f ? a : a + 3);
        }
    }
    std::vector<bool> shown(m.flipbook.size(), false);
    for (const PuffPlacement& p : m.puffs) shown[std::size_t(p.frame)] = true;
    ll.axis.resize(m.flipbook.size());
    for (std::size_t f = 0; f < m.flipbook.size(); ++f)
        if (shown[f]) ll.axis[f] = PuffAxisDepths(m.flipbook[f], lights);
    if (progress) progress->begin("own light volumes", 0);
    m.build_own_volumes(ll);

    for (ImageRgba& image : images) image = ImageRgba(m.width, m.height, glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
    struct Row {
        float view = 0, light = 0;
        int level = 0;
        std::uint64_t limit = 0, steps = 0;
    };
    std::vector<Row> rows(std::size_t(m.height));
    if (progress) progress->begin("ladder", std::uint64_t(m.height));
    tbb::parallel_for(tbb::blocked_range<int>(0, m.height, 1), [&](const tbb::blocked_range<int>& range) {
        Scratch& sc = m.scratch.local();
        for (int y = range.begin(); y != range.end(); ++y) {
            Row& row = rows[std::size_t(y)];
            for (int x = 0; x < m.width; ++x) {
                const Impl::LadderPixel p = m.shade_ladder_pixel(x, y, ll, sc);
                for (int k = 0; k < kTruthRungs; ++k)
                    images[std::size_t(k)].at(x, y) = glm::vec4(glm::vec3(p.color[std::size_t(k)]), 1.0f);
                row.view = std::max(row.view, p.view_error);
                row.light = std::max(row.light, p.light_error);
                row.level = std::max(row.level, p.level);
                row.limit += p.limit ? 1 : 0;
                row.steps += p.steps;
            }
            if (progress) progress->add(1);
        }
    });
    LadderReport report;
    for (const Row& r : rows) {
        report.view_error_estimate = std::max(report.view_error_estimate, r.view);
        report.own_light_error_estimate = std::max(report.own_light_error_estimate, r.light);
        report.view_levels_used = std::max(report.view_levels_used, r.level);
        report.unconverged_pixels += r.limit;
        report.camera_samples += r.steps;
    }
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return report;
}

template <simd::Level L>
glm::vec3 GroundTruth::pixel_at_level(int x, int y) const {
    static_assert(L == simd::kCompiledLevel);
    if (x < 0 || y < 0 || x >= impl_->width || y >= impl_->height)
        throw std::out_of_range("truth: pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") is outside the image");
    Scratch sc;
    return impl_->shade_pixel(x, y, nullptr, impl_->settings.max_view_levels, sc).color;
}

template <simd::Level L>
TruthCheck GroundTruth::check_at_level(const ImageRgba& image, const TruthReport& report, int stride,
                                       WorkProgress* progress) const {
    static_assert(L == simd::kCompiledLevel);
    const auto start = std::chrono::steady_clock::now();
    const Impl& m = *impl_;
    if (stride < 1) throw std::invalid_argument("truth: the check's stride must be >= 1");
    if (image.width != m.width || image.height != m.height ||
        report.pixel_error_estimate.size() != std::size_t(m.width) * std::size_t(m.height))
        throw std::invalid_argument("truth: check() wants the image and report of this truth's render()");
    std::vector<std::array<int, 2>> at;
    for (int y = stride / 2; y < m.height; y += stride)
        for (int x = stride / 2; x < m.width; x += stride) at.push_back({x, y});
    std::vector<float> difference(at.size());
    if (progress) progress->begin("checking against exact light", std::uint64_t(at.size()));
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, at.size(), 1), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t k = r.begin(); k != r.end(); ++k) {
            const auto [x, y] = at[k];
            const glm::vec3 d = glm::abs(glm::vec3(image.at(x, y)) - pixel_at_level<L>(x, y));
            difference[k] = std::max({d.x, d.y, d.z});
            if (progress) progress->add(1);
        }
    });
    TruthCheck c;
    c.pixels = at.size();
    const float half_tol = 0.5f * m.settings.tolerance;
    for (std::size_t k = 0; k < at.size(); ++k) {  // in order: ties go to the first, whatever the threads
        const auto [x, y] = at[k];
        const float estimate = report.pixel_error_estimate[std::size_t(y) * std::size_t(m.width) + std::size_t(x)];
        if (difference[k] > c.largest_difference) {
            c.largest_difference = difference[k];
            c.x = x;
            c.y = y;
            c.estimate_there = estimate;
        }
        c.above_tolerance += difference[k] > m.settings.tolerance ? 1 : 0;
        c.above_estimate += difference[k] > estimate + half_tol ? 1 : 0;
    }
    c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return c;
}

template <simd::Level L>
std::vector<double> GroundTruth::particle_optical_depths_at_level() const {
    static_assert(L == simd::kCompiledLevel);
    const Impl& m = *impl_;
    std::vector<double> tau(m.puffs.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tau.size(), 16), [&](const tbb::blocked_range<std::size_t>& r) {
        Scratch& sc = m.scratch.local();
        for (std::size_t i = r.begin(); i != r.end(); ++i) tau[i] = m.exact_tau(m.puffs[i].centre, sc);
    });
    return tau;
}

template <simd::Level L>
std::vector<std::uint8_t> GroundTruth::ground_shadow_mask_at_level() const {
    static_assert(L == simd::kCompiledLevel);
    const Impl& m = *impl_;
    std::vector<std::uint8_t> mask(std::size_t(m.width) * std::size_t(m.height), 0);
    tbb::parallel_for(tbb::blocked_range<int>(0, m.height), [&](const tbb::blocked_range<int>& rows) {
        for (int y = rows.begin(); y != rows.end(); ++y)
            for (int x = 0; x < m.width; ++x) {
                const Ray ray = m.renderer->camera().ray(x, y, kViewRayTmin);
                const TraceResult g = trace(m.accel(), ray, ray_flag_force_opaque, kGroundMask);
                if (!g.hit) continue;
                const glm::vec3 p = ray.origin + g.committed.t * ray.direction;
                const Ray shadow{p, 0.0f, glm::vec3(m.to_light), std::numeric_limits<float>::infinity()};
                const TraceResult s = trace(m.accel(), shadow,
                                            ray_flag_force_opaque | ray_flag_accept_first_hit_and_end_search |
                                                ray_flag_skip_closest_hit_shader,
                                            kStandInMask);
                mask[std::size_t(y) * std::size_t(m.width) + std::size_t(x)] = s.hit ? 1 : 0;
            }
    });
    return mask;
}

// This copy's passes (core/simd/dispatch.hpp); the public members that run them are in ground_truth_dispatch.cpp.
template TruthReport GroundTruth::render_at_level<simd::kCompiledLevel>(ImageRgba&, WorkProgress*) const;
template LadderReport GroundTruth::render_ladder_at_level<simd::kCompiledLevel>(std::array<ImageRgba, kTruthRungs>&,
                                                                               WorkProgress*) const;
template glm::vec3 GroundTruth::pixel_at_level<simd::kCompiledLevel>(int, int) const;
template TruthCheck GroundTruth::check_at_level<simd::kCompiledLevel>(const ImageRgba&, const TruthReport&, int,
                                                                      WorkProgress*) const;
template std::vector<double> GroundTruth::particle_optical_depths_at_level<simd::kCompiledLevel>() const;
template std::vector<std::uint8_t> GroundTruth::ground_shadow_mask_at_level<simd::kCompiledLevel>() const;

}  // namespace smoketrace
