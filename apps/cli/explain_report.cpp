// smoketrace explain's text and SVG, see explain_report.hpp.
#include "explain_report.hpp"

#include <smoketrace/core/image.hpp>
#include <smoketrace/smoke/scene_description.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <map>
#include <vector>

namespace smoketrace::cli {
namespace {

[[gnu::format(printf, 1, 2)]] std::string fmt(const char* f, ...) {
    char buf[512];
    va_list args;
    va_start(args, f);
    std::vsnprintf(buf, sizeof buf, f, args);
    va_end(args);
    return buf;
}

std::string num(double v) { return format_number(v); }
// Six digits, for the columns of the pixel's layer table (the pixel itself is printed in full).
std::string brief(double v) { return fmt("%.6g", v); }
std::string brief(const glm::vec3& v) {
    return fmt("(%s, %s, %s)", brief(v.x).c_str(), brief(v.y).c_str(), brief(v.z).c_str());
}
std::string vec(const glm::vec3& v) {
    return fmt("(%s, %s, %s)", num(v.x).c_str(), num(v.y).c_str(), num(v.z).c_str());
}

// A stored position in world coordinates: the scene's origin plus it, in double. For a scene at the origin
// (the usual case) exactly the stored floats.
std::string point(const glm::vec3& local, const glm::dvec3& origin) {
    if (origin == glm::dvec3(0.0)) return vec(local);
    const glm::dvec3 w = origin + glm::dvec3(local);
    return fmt("(%.15g, %.15g, %.15g)", w.x, w.y, w.z);
}

const char* surface(std::int32_t value) { return value > 0 ? "entry" : "exit"; }

const char* status_name(DepthStatus s) {
    switch (s) {
        case DepthStatus::ok: return "ok";
        case DepthStatus::occluded: return "occluded";
        case DepthStatus::cutoff: return "cutoff";
    }
    return "?";
}

// Text for an SVG text node or attribute: the five characters XML reserves, escaped.
std::string xml(const std::string& s) {
    std::string out;
    for (char c : s) {
        switch (c) {
            case '&': out += "&amp;"; break;
            case '<': out += "&lt;"; break;
            case '>': out += "&gt;"; break;
            case '"': out += "&quot;"; break;
            case '\'': out += "&apos;"; break;
            default: out += c;
        }
    }
    return out;
}

// A linear colour as the PNG stores it (8-bit sRGB), as an SVG colour.
std::string css(const glm::vec3& c) {
    return fmt("#%02x%02x%02x", linear_to_srgb8(c.x), linear_to_srgb8(c.y), linear_to_srgb8(c.z));
}

// Tick positions: about `count` round numbers (1, 2 or 5 times a power of ten) from 0 to `hi`.
std::vector<double> ticks(double hi, int count) {
    if (!(hi > 0.0)) return {0.0};
    const double raw = hi / count, p = std::pow(10.0, std::floor(std::log10(raw)));
    const double step = raw / p < 1.5 ? p : raw / p < 3.5 ? 2 * p : raw / p < 7.5 ? 5 * p : 10 * p;
    std::vector<double> out;
    for (double t = 0.0; t <= hi * (1 + 1e-9); t += step) out.push_back(t);
    return out;
}

// A smooth kernel's density about a particle of radius `radius`, for the text: peak * f(|x - centre| / R)
// inside R = support * radius.
std::string kernel_density(const DensityKernel& k, float radius) {
    const std::string f =
        k.kind == DensityKernelKind::gaussian
            ? fmt("exp(-q^2 * %g^2 / 2) (a Gaussian cut at %g sigma)", kGaussianSupportSigmas, kGaussianSupportSigmas)
        : k.kind == DensityKernelKind::poly1 ? "1 - q^2"
        : k.kind == DensityKernelKind::poly2 ? "(1 - q^2)^2"
                                             : "1";
    return k.name() + " kernel: peak * f(|x - centre| / R), f(q) = " + f + ", peak " + num(k.peak) + ", R = " +
           num(k.support) + " * radius = " + num(double(k.support) * double(radius));
}

// A particle's chord: where the ray entered and left its stand-in (nullopt: before the origin, or not seen).
struct Chord {
    std::uint32_t particle;
    std::optional<float> enter, leave;
};

std::vector<Chord> chords_of(std::span<const StoryHit> hits) {
    std::map<std::uint32_t, Chord> by_particle;
    for (const StoryHit& h : hits) {
        Chord& c = by_particle.try_emplace(h.particle, Chord{h.particle, {}, {}}).first->second;
        if (h.value > 0)
            c.enter = c.enter ? std::min(*c.enter, h.t) : h.t;
        else
            c.leave = c.leave ? std::max(*c.leave, h.t) : h.t;
    }
    std::vector<Chord> out;
    for (const auto& [p, c] : by_particle) out.push_back(c);
    std::stable_sort(out.begin(), out.end(),
                     [](const Chord& a, const Chord& b) { return a.enter.value_or(0.0f) < b.enter.value_or(0.0f); });
    return out;
}

}  // namespace

std::string format_number(double v) {
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    // Most of a story's numbers are floats: the shortest text that reads back as the float, as `depths` writes.
    if (const float f = float(v); double(f) == v) {
        char text[32];
        return std::string(text, std::to_chars(text, text + sizeof text, f).ptr);
    }
    return fmt("%.9g", v);
}

void write_particle_text(std::ostream& out, const OpticalDepthStory& s, std::span<const Particle> particles,
                         const std::string& scene_name, const char* shape_name, const glm::dvec3& origin) {
    const Particle& p = particles[s.particle];
    const bool smooth = s.kernel.smooth();
    out << "smoketrace explain: particle " << s.particle << " of " << scene_name << " (frame 0)\n\n";
    out << (smooth ? "The optical-depth ray (thesis 4.3.2): from the particle's centre toward the light; its any-hit\n"
                     "callback sees every particle surface it crosses, and each one it leaves adds that particle's\n"
                     "share of the density along the ray (the density kernel's closed-form integral).\n"
                   : "The optical-depth ray (thesis 4.3.2): from the particle's centre toward the light; its any-hit\n"
                     "callback stores +1 for every particle surface it enters and -1 for every one it leaves.\n");
    out << "  particle    centre " << point(p.center, origin) << ", radius " << num(p.radius) << "\n";
    out << "  origin      " << point(s.ray.origin, origin) << "\n";
    out << "  direction   " << vec(s.ray.direction) << " (toward the light, unit length)\n";
    out << "  t range     [" << num(s.ray.tmin) << ", " << num(s.ray.tmax) << "] (tmin: 2^-22 of the radius)\n";
    out << "  stand-ins   " << shape_name << "; cutoff "
        << (s.cutoff ? std::to_string(s.cutoff) + " surfaces" : std::string("none")) << "\n";
    if (smooth) out << "  density     " << kernel_density(s.kernel, p.radius) << "\n";
    out << "\n";

    const bool summed = smooth && s.outcome.status == DepthStatus::ok;
    out << "1. Every candidate the any-hit callback saw, in the order trace() met them (" << s.seen.size() << ")"
        << (summed ? ", and its share of l:\n"
                     "   an exit adds its particle's integral of the density along the ray, from where the ray enters\n"
                     "   the particle's support (or from the origin, inside it) to where it leaves; an entry adds\n"
                     "   nothing. # counts the any-hit calls, as the cutoff does.\n"
                   : ":\n");
    if (summed) {
        out << fmt("   %5s  %9s  %-7s %-15s %-15s %s\n", "#", "particle", "surface", "t", "share", "sum");
        bool outside_support = false;
        for (std::size_t i = 0; i < s.seen.size(); ++i) {
            if (s.seen[i].value > 0) {
                out << fmt("   %5zu  %9u  %-7s %s\n", i + 1, s.seen[i].particle, surface(s.seen[i].value),
                           num(s.seen[i].t).c_str());
                continue;
            }
            outside_support = outside_support || s.shares[i] == 0.0;
            out << fmt("   %5zu  %9u  %-7s %-15s %-15s %s\n", i + 1, s.seen[i].particle, surface(s.seen[i].value),
                       num(s.seen[i].t).c_str(), num(s.shares[i]).c_str(), num(s.sum_after[i]).c_str());
        }
        if (outside_support)
            out << "   A share of 0: the ray's stretch inside that particle's stand-in misses its support (the\n"
                   "   sphere of radius R about the centre, where the density lives) or has it behind the origin.\n";
    } else {
        out << fmt("   %5s  %9s  %-7s %s\n", "#", "particle", "surface", "t");
        for (std::size_t i = 0; i < s.seen.size(); ++i)
            out << fmt("   %5zu  %9u  %-7s %s\n", i + 1, s.seen[i].particle, surface(s.seen[i].value),
                       num(s.seen[i].t).c_str());
    }
    if (s.ground_t)
        out << "   The ground was met at t = " << num(*s.ground_t)
            << " (opaque: committed without calling any-hit): the particle is occluded.\n";
    if (s.cut_off)
        out << "   The cutoff ended the search: a surface beyond the first " << s.cutoff
            << (s.outcome.status == DepthStatus::occluded
                    ? "; a ray for the ground alone then found the ground on the way: the particle is occluded.\n"
                    : " (thesis 4.4.3), so the particle counts as fully dark.\n");
    out << "\n";

    if (summed) {
        out << "2. No sort, no counter: the ray leaves every particle it meets exactly once, so its exits name each\n"
               "   one once, and where particles overlap their densities add.\n";
        out << "   l = " << num(s.length) << "  (the sum of the shares, rounded to float; what `smoketrace depths "
            << "--kernel " << s.kernel.name() << "` writes)\n\n";
    } else if (s.outcome.status == DepthStatus::ok) {
        out << "2. The stored hits sorted by t, and the counter of eq. 3.1:\n";
        out << "   counter start = -(sum of the values) = " << s.counter_start
            << ": the number of particles that cover the ray's origin\n";
        out << fmt("   %5s  %9s  %-7s %-15s %s\n", "#", "particle", "surface", "t", "counter after");
        for (std::size_t i = 0; i < s.sorted.size(); ++i)
            out << fmt("   %5zu  %9u  %-7s %-15s %lld%s\n", i + 1, s.sorted[i].particle, surface(s.sorted[i].value),
                       num(s.sorted[i].t).c_str(), static_cast<long long>(s.counter_after[i]),
                       s.counter_after[i] > 0 ? "  in smoke" : "");
        out << "\n3. The ray is in smoke while the counter is > 0; gaps between separate clouds do not count:\n";
        out << fmt("   %-15s %-15s %s\n", "from t", "to t", "length");
        double sum = 0.0;
        for (const SmokeStretch& st : s.stretches) {
            out << fmt("   %-15s %-15s %s\n", num(st.t0).c_str(), num(st.t1).c_str(),
                       num(double(st.t1) - double(st.t0)).c_str());
            sum += double(st.t1) - double(st.t0);
        }
        out << "   sum of the stretches " << num(sum) << "\n";
        out << "   l = " << num(s.length)
            << "  (the resolver's optical path length, summed gap by gap; what `smoketrace depths` writes)\n\n";
    } else {
        out << "2. Status " << status_name(s.outcome.status)
            << (smooth ? ": the shares are not summed; the particle is fully dark (thesis 4.3.3).\n"
                       : ": the hits are not sorted or walked; the particle is fully dark (thesis 4.3.3).\n")
            << "   l = " << num(s.length) << "\n\n";
    }
    out << (s.outcome.status == DepthStatus::ok && !smooth ? "4" : "3") << ". status " << status_name(s.outcome.status)
        << ", " << s.outcome.hits << " hits (as `depths` reports them)\n";
    out << "   trace() counters: TLAS nodes " << s.counters.tlas_nodes << ", BLAS nodes " << s.counters.blas_nodes
        << ", boxes tested " << s.counters.boxes_tested << ", instances entered " << s.counters.instances_entered
        << ", primitives tested " << s.counters.primitives_tested << ", any-hit calls "
        << s.counters.any_hit_invocations << "\n";
    out << "   optical depth   tau = l * sigma_t = " << num(s.length) << " * " << num(s.sigma_t) << " = "
        << num(s.optical_depth) << " (eq. 2.12)\n";
    out << "   transmittance   T = exp(-tau) = " << num(s.transmittance)
        << " (eq. 2.10): the share of the light that reaches the particle\n";
}

void write_particle_svg(std::ostream& out, const OpticalDepthStory& s, const std::string& scene_name) {
    const bool ok = s.outcome.status == DepthStatus::ok;
    const bool smooth = s.kernel.smooth();
    const bool summed = ok && smooth;  // the shares and their sum instead of eq. 3.1's counter
    const std::vector<Chord> chords =
        chords_of(ok && !smooth ? std::span<const StoryHit>(s.sorted) : std::span(s.seen));
    std::map<std::uint32_t, double> share_of;  // a smooth kernel's: each particle's share (its exit's)
    if (summed)
        for (std::size_t i = 0; i < s.seen.size(); ++i)
            if (s.seen[i].value < 0) share_of[s.seen[i].particle] = s.shares[i];
    float t_end = 0.0f;
    for (const StoryHit& h : s.seen) t_end = std::max(t_end, h.t);
    if (s.ground_t) t_end = std::max(t_end, *s.ground_t);
    if (!(t_end > 0.0f)) t_end = 1.0f;
    const double span = double(t_end) * 1.04;

    const double W = 960, left = summed ? 210 : 140, right = 40, plot_w = W - left - right;
    auto X = [&](double t) { return left + t / span * plot_w; };
    const double n = double(std::max<std::size_t>(chords.size(), 1));
    const double lane = std::clamp(220.0 / n, 5.0, 16.0);
    const double chords_top = 96, chords_bottom = chords_top + lane * n;
    const double axis_y = chords_bottom + 14;
    std::int64_t c_min = 0, c_max = 1;
    if (ok) {
        c_max = std::max<std::int64_t>(c_max, s.counter_start);
        for (std::int64_t c : s.counter_after) c_max = std::max(c_max, c), c_min = std::min(c_min, c);
    }
    const double counter_top = axis_y + 70, counter_h = smooth ? 80 : 150, counter_bottom = counter_top + counter_h;
    auto Y = [&](double c) { return counter_bottom - (c - double(c_min)) / double(c_max - c_min) * counter_h; };
    const double legend_y = counter_bottom + 56;
    const double H = legend_y + 70;

    out << R"(<?xml version="1.0" encoding="UTF-8"?>)" << "\n";
    out << fmt(R"(<svg xmlns="http://www.w3.org/2000/svg" width="%.0f" height="%.0f" viewBox="0 0 %.0f %.0f" )"
               R"(font-family="sans-serif" font-size="12">)",
               W, H, W, H)
        << "\n";
    out << fmt(R"(<rect x="0" y="0" width="%.0f" height="%.0f" fill="white"/>)", W, H) << "\n";
    out << "<title>" << xml("Optical-depth ray of particle " + std::to_string(s.particle) + ", " + scene_name)
        << "</title>\n";
    const std::string head =
        "Particle " + std::to_string(s.particle) + ": its ray toward the light (" + scene_name + ", frame 0)";
    const std::string result =
        ok ? "l = " + num(s.length) + (summed ? " (sum of the shares, " + s.kernel.name() + " kernel)"
                                              : std::string(" (sum of the shaded stretches)")) +
                 ", tau = l*sigma_t = " + num(s.optical_depth) + ", T = exp(-tau) = " + num(s.transmittance)
           : std::string("status ") + status_name(s.outcome.status) + ": fully dark (l = inf, T = 0)";
    out << fmt(R"(<text x="%.0f" y="26" font-size="16" font-weight="bold">)", left) << xml(head) << "</text>\n";
    out << fmt(R"(<text x="%.0f" y="46">)", left) << xml(result) << "</text>\n";
    out << fmt(R"(<text x="%.0f" y="%.0f" fill="#555">)", left, chords_top - 12)
        << "Each bar: a particle the ray crosses, from where it enters to where it leaves (the chord it cuts)"
        << "</text>\n";

    // In smoke: shaded across the chords and the counter plot.
    for (const SmokeStretch& st : s.stretches)
        out << fmt(R"(<rect x="%.2f" y="%.2f" width="%.2f" height="%.2f" fill="#9ecae1" fill-opacity="0.45"/>)",
                   X(st.t0), chords_top - 4, std::max(0.5, X(st.t1) - X(st.t0)), counter_bottom - chords_top + 4)
            << "\n";
    // The chords, one lane each, in the order the ray enters them.
    for (std::size_t i = 0; i < chords.size(); ++i) {
        const Chord& c = chords[i];
        const double y = chords_top + lane * (double(i) + 0.5);
        const double x0 = X(c.enter.value_or(0.0f)), x1 = X(c.leave.value_or(t_end));
        out << fmt(R"(<line x1="%.2f" y1="%.2f" x2="%.2f" y2="%.2f" stroke="#636363" stroke-width="%.1f")", x0, y, x1,
                   y, std::max(2.0, lane * 0.55))
            << (c.enter && c.leave ? "" : R"( stroke-dasharray="4 2")") << "/>\n";
        if (c.enter)
            out << fmt(R"(<circle cx="%.2f" cy="%.2f" r="%.1f" fill="#31a354"/>)", x0, y, std::max(2.0, lane * 0.3))
                << "\n";
        if (c.leave)
            out << fmt(R"(<circle cx="%.2f" cy="%.2f" r="%.1f" fill="#de2d26"/>)", x1, y, std::max(2.0, lane * 0.3))
                << "\n";
        const auto share = share_of.find(c.particle);
        out << fmt(R"(<text x="%.0f" y="%.2f" text-anchor="end" font-size="%.0f">particle %u%s%s</text>)", left - 8,
                   y + std::min(lane, 11.0) * 0.35, std::min(lane, 11.0), c.particle,
                   c.particle == s.particle ? " (own)" : "",
                   share != share_of.end() ? (", share " + brief(share->second)).c_str() : "")
            << "\n";
    }
    // The ray as the t axis.
    out << fmt(R"(<line x1="%.0f" y1="%.2f" x2="%.2f" y2="%.2f" stroke="black" stroke-width="1.5"/>)", left, axis_y,
               left + plot_w, axis_y)
        << "\n";
    out << fmt(R"(<path d="M %.2f %.2f l -8 -4 l 0 8 z" fill="black"/>)", left + plot_w, axis_y) << "\n";
    for (double t : ticks(span, 8)) {
        out << fmt(R"(<line x1="%.2f" y1="%.2f" x2="%.2f" y2="%.2f" stroke="black"/>)", X(t), axis_y, X(t), axis_y + 5)
            << "\n";
        out << fmt(R"(<text x="%.2f" y="%.2f" text-anchor="middle">%s</text>)", X(t), axis_y + 18, num(t).c_str())
            << "\n";
    }
    out << fmt(R"(<text x="%.0f" y="%.2f">)", left, axis_y + 36)
        << "t: distance from the particle's centre along the ray toward the light (scene units); the ray starts "
           "at t = 0</text>\n";
    if (s.ground_t) {
        out << fmt(R"(<line x1="%.2f" y1="%.2f" x2="%.2f" y2="%.2f" stroke="#a50f15" stroke-width="3"/>)",
                   X(*s.ground_t), chords_top - 8, X(*s.ground_t), axis_y)
            << "\n";
        out << fmt(R"(<text x="%.2f" y="%.2f" fill="#a50f15" text-anchor="end">ground at t = %s: occluded</text>)",
                   X(*s.ground_t) - 4, chords_top - 12, num(*s.ground_t).c_str())
            << "\n";
    }
    if (s.cut_off)
        out << fmt(R"(<text x="%.2f" y="%.2f" fill="#a50f15" text-anchor="end">)", left + plot_w, chords_top - 12)
            << "search cut off after " << s.cutoff << " surfaces: fully dark</text>\n";

    if (summed) {
        // l as a stacked bar: each particle's share one segment, in the order the walk met (and summed) them.
        const double l_span = double(s.length) > 0.0 ? double(s.length) * 1.04 : 1.0;
        auto L = [&](double v) { return left + v / l_span * plot_w; };
        const double bar_y = counter_top + 10, bar_h = 34, scale_y = bar_y + bar_h + 10;
        out << fmt(R"(<text x="%.0f" y="%.2f" fill="#555">)", left, counter_top - 14)
            << "l, the sum of the shares: one segment per particle, in the order the walk met them (no sort)"
            << "</text>\n";
        double before = 0.0;
        std::size_t segment = 0;
        for (std::size_t i = 0; i < s.seen.size(); ++i) {
            if (s.seen[i].value > 0) continue;
            out << fmt(R"(<rect x="%.2f" y="%.2f" width="%.2f" height="%.0f" fill="%s" stroke="white" )"
                       R"(stroke-width="0.5"><title>particle %u: share %s</title></rect>)",
                       L(before), bar_y, std::max(0.0, L(s.sum_after[i]) - L(before)), bar_h,
                       segment % 2 == 0 ? "#6baed6" : "#2171b5", s.seen[i].particle, num(s.shares[i]).c_str())
                << "\n";
            if (L(s.sum_after[i]) - L(before) > 36)  // room for the particle's number
                out << fmt(R"(<text x="%.2f" y="%.2f" text-anchor="middle" fill="%s">%u</text>)",
                           0.5 * (L(before) + L(s.sum_after[i])), bar_y + bar_h / 2 + 4,
                           segment % 2 == 0 ? "black" : "white", s.seen[i].particle)
                    << "\n";
            ++segment;
            before = s.sum_after[i];
        }
        out << fmt(R"(<line x1="%.0f" y1="%.2f" x2="%.2f" y2="%.2f" stroke="black"/>)", left, scale_y, left + plot_w,
                   scale_y)
            << "\n";
        for (double v : ticks(l_span, 8)) {
            out << fmt(R"(<line x1="%.2f" y1="%.2f" x2="%.2f" y2="%.2f" stroke="black"/>)", L(v), scale_y, L(v),
                       scale_y + 5)
                << "\n";
            out << fmt(R"(<text x="%.2f" y="%.2f" text-anchor="middle">%s</text>)", L(v), scale_y + 18,
                       num(v).c_str())
                << "\n";
        }
        out << fmt(R"(<text x="%.0f" y="%.2f">)", left, scale_y + 36)
            << "density-weighted length (scene units times density)</text>\n";
    } else if (smooth) {
        out << fmt(R"(<text x="%.0f" y="%.2f" fill="#a50f15">)", left + 10, counter_top + 20)
            << "shares not summed: the status is " << status_name(s.outcome.status) << "</text>\n";
    } else {
        // The counter of eq. 3.1 as a step plot.
        out << fmt(R"(<text x="%.0f" y="%.2f" fill="#555">)", left, counter_top - 14)
            << "The counter of eq. 3.1: starts at -(sum of the values), +1 at each entry, -1 at each exit; in smoke "
               "while &gt; 0</text>\n";
        for (std::int64_t c = c_min; c <= c_max; c += std::max<std::int64_t>(1, (c_max - c_min) / 6)) {
            out << fmt(R"(<line x1="%.0f" y1="%.2f" x2="%.2f" y2="%.2f" stroke="#ddd"/>)", left, Y(double(c)),
                       left + plot_w, Y(double(c)))
                << "\n";
            out << fmt(R"(<text x="%.0f" y="%.2f" text-anchor="end">%lld</text>)", left - 8, Y(double(c)) + 4,
                       static_cast<long long>(c))
                << "\n";
        }
        out << fmt(R"(<line x1="%.0f" y1="%.2f" x2="%.2f" y2="%.2f" stroke="black"/>)", left, Y(0), left + plot_w, Y(0))
            << "\n";
        out << fmt(R"svg(<text x="%.0f" y="%.2f" text-anchor="middle" )svg"
                   R"svg(transform="rotate(-90 %.0f %.2f)">counter</text>)svg",
                   left - 50, counter_top + counter_h / 2, left - 50, counter_top + counter_h / 2)
            << "\n";
        if (ok && !s.sorted.empty()) {
            std::string d = fmt("M %.2f %.2f", X(0), Y(double(s.counter_start)));
            for (std::size_t i = 0; i < s.sorted.size(); ++i) {
                d += fmt(" H %.2f V %.2f", X(s.sorted[i].t), Y(double(s.counter_after[i])));
            }
            d += fmt(" H %.2f", left + plot_w);
            out << R"(<path d=")" << d << R"(" fill="none" stroke="#08519c" stroke-width="2"/>)" << "\n";
        } else {
            out << fmt(R"(<text x="%.0f" y="%.2f" fill="#a50f15">)", left + 10, counter_top + counter_h / 2)
                << "not walked: the status is " << status_name(s.outcome.status) << "</text>\n";
        }
    }

    // Legend.
    const double ly = legend_y;
    out << fmt(R"(<line x1="%.0f" y1="%.0f" x2="%.0f" y2="%.0f" stroke="#636363" stroke-width="5"/>)", left, ly,
               left + 30, ly)
        << "\n";
    out << fmt(R"(<circle cx="%.0f" cy="%.0f" r="4" fill="#31a354"/>)"
               R"(<circle cx="%.0f" cy="%.0f" r="4" fill="#de2d26"/>)",
               left, ly, left + 30, ly)
        << "\n";
    out << fmt(R"(<text x="%.0f" y="%.0f">chord: entry (green%s) to exit (red%s); )"
               R"(dashed: entered before t = 0 or not left</text>)",
               left + 40, ly + 4, smooth ? "" : ", +1", smooth ? ", which adds the share" : ", -1")
        << "\n";
    if (smooth) {
        out << fmt(R"(<rect x="%.0f" y="%.0f" width="30" height="12" fill="#6baed6"/>)", left, ly + 14) << "\n";
        out << fmt(R"(<text x="%.0f" y="%.0f">a particle's share: its density integrated over its chord )"
                   R"((ahead of t = 0), added at its exit</text>)",
                   left + 40, ly + 24)
            << "\n";
        out << "</svg>\n";
        return;
    }
    out << fmt(R"(<rect x="%.0f" y="%.0f" width="30" height="12" fill="#9ecae1" fill-opacity="0.45"/>)", left, ly + 14)
        << "\n";
    out << fmt(R"(<text x="%.0f" y="%.0f">in smoke (counter &gt; 0): the stretches summed into l</text>)", left + 40,
               ly + 24)
        << "\n";
    out << fmt(R"(<line x1="%.0f" y1="%.0f" x2="%.0f" y2="%.0f" stroke="#08519c" stroke-width="2"/>)", left, ly + 40,
               left + 30, ly + 40)
        << "\n";
    out << fmt(R"(<text x="%.0f" y="%.0f">the counter after each hit, in sorted order</text>)", left + 40, ly + 44)
        << "\n";
    out << "</svg>\n";
}

void write_pixel_text(std::ostream& out, const PixelStory& p, const glm::vec3& rendered,
                      const std::string& scene_name, std::uint64_t frame, const glm::dvec3& origin) {
    out << "smoketrace explain: pixel " << p.x << "," << p.y << " of " << scene_name << " (frame " << frame << ", mode "
        << to_string(p.mode) << (p.kernel.smooth() ? ", kernel " + p.kernel.name() : std::string())
        << ", compositing " << to_string(p.compositing) << ", " << p.samples.size()
        << (p.samples.size() == 1 ? " sample: the pixel's centre" : " samples, averaged") << ")\n\n";
    const bool over = p.compositing == Compositing::over;
    out << (over ? "Front to back with the over operator: C += T*a*c_new, T *= 1 - a, stopping once T < " +
                       num(p.transmittance_threshold) + ".\n"
                 : std::string("Front to back with the thesis's eq. 4.1: C += (1 - a_prev)*c_new*a, a_prev = the "
                               "previous layer's alpha.\n"))
        << "c_new = light_map * light colour * exp(-l*sigma_t) + ambient (eq. 4.2); alpha = texture alpha * the "
           "scene's alpha * the soft-particle fade.\n";
    const char* w = over ? "T" : "1-a_prev";
    for (std::size_t i = 0; i < p.samples.size(); ++i) {
        const SampleStory& s = p.samples[i];
        out << "\nsample " << i + 1 << " of " << p.samples.size() << " at (" << num(s.offset.x) << ", "
            << num(s.offset.y) << ") in the pixel: camera ray from " << point(s.ray.origin, origin)
            << " along " << vec(s.ray.direction) << "\n";
        out << "  opaque surface behind the billboards: "
            << (s.opaque_t ? "the ground at t = " + num(*s.opaque_t) : std::string("none (the ray leaves the scene)"))
            << "\n";
        out << "  billboard layers met in front of it: " << s.layers_met;
        if (s.search_cut_at)
            out << " (the search stopped at t = " << num(*s.search_cut_at)
                << ": the layers met already left T below the threshold)";
        out << "\n";
        out << fmt("  %3s %9s %-11s %-11s %-11s %-11s %-11s %-33s %-11s %-11s %s\n", "#", "particle", "t", "tex alpha",
                   "alpha", "light map", "l", "c_new (r, g, b)", (std::string(w) + " before").c_str(),
                   (std::string(w) + " after").c_str(), "contribution (r, g, b)");
        for (std::size_t k = 0; k < s.layers.size(); ++k) {
            const LayerStory& l = s.layers[k];
            out << fmt("  %3zu %9u %-11s %-11s %-11s %-11s %-11s %-33s %-11s %-11s %s\n", k + 1, l.particle,
                       brief(l.t).c_str(), brief(l.texture_alpha).c_str(), brief(l.alpha).c_str(),
                       brief(l.light_map).c_str(), brief(l.length).c_str(), brief(l.color).c_str(),
                       brief(l.weight_before).c_str(), brief(l.weight_after).c_str(), brief(l.contribution).c_str());
        }
        switch (s.end) {
            case SampleEnd::transmittance_threshold:
                out << "  stopped: after layer " << s.layers.size() << " the transmittance "
                    << num(s.layers.empty() ? 1.0f : s.layers.back().weight_after) << " is below the threshold "
                    << num(p.transmittance_threshold) << ": nothing behind can show, the background is not added\n";
                break;
            case SampleEnd::ground: {
                const GroundStory& g = *s.ground;
                out << "  stopped: the ground at t = " << num(g.t) << ", point " << point(g.point, origin) << "\n";
                if (!g.shadow_ray)
                    out << "    no shadow ray ("
                        << (p.mode == RenderMode::basic ? "basic mode" : "the light is below the ground") << ")\n";
                else if (!g.shadow_hit)
                    out << "    shadow ray toward " << vec(g.shadow.direction) << ": met no particle, lit (shadow 1)\n";
                else if (g.kernel_shadow) {
                    out << "    shadow ray toward " << vec(g.shadow.direction) << ": the " << p.kernel.name()
                        << " kernel's density summed along it, every particle it leaves adding its share\n"
                           "    (the surfaces in the order trace() met them; an entry adds nothing):\n";
                    out << fmt("      %5s  %9s  %-7s %-15s %s\n", "#", "particle", "surface", "t", "share");
                    for (std::size_t k = 0; k < g.shadow_hits.size(); ++k) {
                        const ShadowHitStory& h = g.shadow_hits[k];
                        if (h.exit)
                            out << fmt("      %5zu  %9u  %-7s %-15s %s\n", k + 1, h.particle, "exit",
                                       num(h.t).c_str(), num(h.share).c_str());
                        else
                            out << fmt("      %5zu  %9u  %-7s %s\n", k + 1, h.particle, "entry", num(h.t).c_str());
                    }
                    out << "    l = the shares' sum = " << num(g.shadow_length) << ", shadow = exp(-l*sigma_t) = exp(-"
                        << num(g.shadow_length) << " * " << num(p.sigma_t) << ") = " << num(g.shadow_factor)
                        << " (eq. 4.3 with the kernel)\n";
                }
                else if (p.mode == RenderMode::full)
                    out << "    shadow ray toward " << vec(g.shadow.direction) << ": nearest particle "
                        << g.shadow_particle << " at t = " << num(g.shadow_t)
                        << ", shadow = its exp(-l*sigma_t) = " << num(g.shadow_factor) << " (eq. 4.3)\n";
                else
                    out << "    shadow ray toward " << vec(g.shadow.direction)
                        << ": met a particle, in shadow (simple-shadow: 0)\n";
                out << "    ground colour c_base*(c_light*max(L.N, 0)*shadow + c_amb) = " << vec(g.color)
                    << " (eq. 4.4)\n";
                out << "    its contribution (weight " << num(s.layers.empty() ? 1.0f : s.layers.back().weight_after)
                    << "): " << vec(s.background_contribution) << "\n";
                break;
            }
            case SampleEnd::sky:
                out << "  stopped: nothing left, the ray leaves the scene: the background " << vec(s.background)
                    << " adds " << vec(s.background_contribution) << "\n";
                break;
        }
        out << "  sample colour " << vec(s.color) << "\n";
    }
    out << "\npixel (linear) " << vec(p.color)
        << ", 8-bit sRGB as the PNG stores it: " << int(linear_to_srgb8(p.color.x)) << " "
        << int(linear_to_srgb8(p.color.y)) << " " << int(linear_to_srgb8(p.color.z)) << "\n";
    out << "render's pixel  " << vec(rendered) << (rendered == p.color ? " (the same)" : " (DIFFERENT)") << "\n";
}

void write_pixel_truth_text(std::ostream& out, const glm::vec3& frame_pixel, const glm::vec3& truth_pixel, int spp,
                            float tolerance) {
    const auto srgb = [](const glm::vec3& c) {
        return fmt("%3d %3d %3d", int(linear_to_srgb8(c.x)), int(linear_to_srgb8(c.y)), int(linear_to_srgb8(c.z)));
    };
    const glm::vec3 error = frame_pixel - truth_pixel;
    out << "\nbeside the ground truth (the smoke as a volume, docs/ground-truth.md: " << spp
        << " samples over the pixel, exact light rays, converged to " << num(tolerance) << " per channel):\n";
    out << fmt("  %-14s %-40s %s\n", "", "linear (r, g, b)", "8-bit sRGB");
    out << fmt("  %-14s %-40s %s\n", "frame", vec(frame_pixel).c_str(), srgb(frame_pixel).c_str());
    out << fmt("  %-14s %-40s %s\n", "truth", vec(truth_pixel).c_str(), srgb(truth_pixel).c_str());
    out << fmt("  %-14s %-40s %+4d %+4d %+4d\n", "frame - truth", vec(error).c_str(),
               int(linear_to_srgb8(frame_pixel.x)) - int(linear_to_srgb8(truth_pixel.x)),
               int(linear_to_srgb8(frame_pixel.y)) - int(linear_to_srgb8(truth_pixel.y)),
               int(linear_to_srgb8(frame_pixel.z)) - int(linear_to_srgb8(truth_pixel.z)));
}

void write_pixel_svg(std::ostream& out, const PixelStory& p, const std::string& scene_name, std::uint64_t frame) {
    auto mean = [](const glm::vec3& c) { return (double(c.x) + double(c.y) + double(c.z)) / 3.0; };
    double scale_max = 0.0;  // the largest sample colour (mean of r, g, b): the bars' full length
    std::size_t rows = 0;
    for (const SampleStory& s : p.samples) {
        scale_max = std::max(scale_max, mean(s.color));
        for (const LayerStory& l : s.layers) scale_max = std::max(scale_max, mean(l.contribution));
        rows += s.layers.size() + 3;
    }
    if (!(scale_max > 0.0)) scale_max = 1.0;
    const double W = 960, left = 250, right = 150, bar_w = W - left - right, row = 18;
    const double H = 120 + double(rows) * row + 20.0 * double(p.samples.size()) + 60;
    auto len = [&](double v) { return std::max(0.0, v / scale_max * bar_w); };

    out << R"(<?xml version="1.0" encoding="UTF-8"?>)" << "\n";
    out << fmt(R"(<svg xmlns="http://www.w3.org/2000/svg" width="%.0f" height="%.0f" viewBox="0 0 %.0f %.0f" )"
               R"(font-family="sans-serif" font-size="12">)",
               W, H, W, H)
        << "\n";
    out << fmt(R"(<rect x="0" y="0" width="%.0f" height="%.0f" fill="white"/>)", W, H) << "\n";
    const std::string head = "Pixel " + std::to_string(p.x) + "," + std::to_string(p.y) + " of " + scene_name +
                             " (frame " + std::to_string(frame) + ", " + to_string(p.mode) +
                             (p.kernel.smooth() ? ", kernel " + p.kernel.name() : std::string()) + ", " +
                             to_string(p.compositing) + ")";
    out << "<title>" << xml(head) << "</title>\n";
    out << R"(<text x="20" y="26" font-size="16" font-weight="bold">)" << xml(head) << "</text>\n";
    out << R"(<text x="20" y="46">)"
        << xml("Each bar: what one layer adds to the pixel, front to back (length: mean of R, G, B, linear; "
               "colour: the layer's own c_new, eq. 4.2)")
        << "</text>\n";
    out << fmt(R"(<text x="20" y="64">pixel %s, 8-bit sRGB %d %d %d</text>)", vec(p.color).c_str(),
               linear_to_srgb8(p.color.x), linear_to_srgb8(p.color.y), linear_to_srgb8(p.color.z))
        << "\n";
    out << fmt(R"(<rect x="%.0f" y="52" width="40" height="16" fill="%s" stroke="black"/>)", W - right + 20,
               css(p.color).c_str())
        << "\n";
    double y = 90;
    const bool over = p.compositing == Compositing::over;
    for (std::size_t i = 0; i < p.samples.size(); ++i) {
        const SampleStory& s = p.samples[i];
        out << fmt(R"(<text x="20" y="%.0f" font-weight="bold">sample %zu of %zu at (%s, %s)</text>)", y + 12, i + 1,
                   p.samples.size(), num(s.offset.x).c_str(), num(s.offset.y).c_str())
            << "\n";
        out << fmt(R"(<text x="%.0f" y="%.0f" fill="#555">%s before</text>)", W - right + 10, y + 12,
                   over ? "T" : "1-a_prev")
            << "\n";
        y += row + 2;
        for (const LayerStory& l : s.layers) {
            out << fmt(R"(<text x="%.0f" y="%.0f" text-anchor="end">particle %u, t %.4g, alpha %.3g</text>)", left - 8,
                       y + 12, l.particle, double(l.t), double(l.alpha))
                << "\n";
            out << fmt(R"(<rect x="%.0f" y="%.0f" width="%.2f" height="%.0f" fill="%s" )"
                       R"(stroke="#333" stroke-width="0.5"/>)",
                       left, y + 2, len(mean(l.contribution)), row - 4, css(l.color).c_str())
                << "\n";
            out << fmt(R"(<text x="%.0f" y="%.0f">%.3g</text>)", W - right + 10, y + 12, double(l.weight_before))
                << "\n";
            y += row;
        }
        if (s.end == SampleEnd::transmittance_threshold) {
            const std::string why = "stopped: T below " + num(p.transmittance_threshold) + ", nothing behind shows";
            out << fmt(R"(<text x="%.0f" y="%.0f" text-anchor="end" fill="#a50f15">%s</text>)", left - 8, y + 12,
                       xml(why).c_str())
                << "\n";
        } else {
            std::string what = "sky (nothing left)";
            if (s.ground) {
                what = !s.ground->shadow_ray ? std::string("ground, no shadow ray")
                       : s.ground->shadow_hit ? "ground, in shadow " + num(s.ground->shadow_factor)
                                              : std::string("ground, lit");
            }
            out << fmt(R"(<text x="%.0f" y="%.0f" text-anchor="end">%s</text>)", left - 8, y + 12, xml(what).c_str())
                << "\n";
            out << fmt(R"(<rect x="%.0f" y="%.0f" width="%.2f" height="%.0f" fill="%s" )"
                       R"(stroke="#333" stroke-width="0.5"/>)",
                       left, y + 2, len(mean(s.background_contribution)), row - 4, css(s.background).c_str())
                << "\n";
        }
        y += row;
        // The sample: the layers' contributions stacked, summing to its colour.
        out << fmt(R"(<text x="%.0f" y="%.0f" text-anchor="end" font-weight="bold">sample colour</text>)", left - 8,
                   y + 12)
            << "\n";
        double x = left;
        for (const LayerStory& l : s.layers) {
            out << fmt(R"(<rect x="%.2f" y="%.0f" width="%.2f" height="%.0f" fill="%s"/>)", x, y + 2,
                       len(mean(l.contribution)), row - 4, css(l.color).c_str())
                << "\n";
            x += len(mean(l.contribution));
        }
        if (s.end != SampleEnd::transmittance_threshold)
            out << fmt(R"(<rect x="%.2f" y="%.0f" width="%.2f" height="%.0f" fill="%s"/>)", x, y + 2,
                       len(mean(s.background_contribution)), row - 4, css(s.background).c_str())
                << "\n";
        out << fmt(R"(<rect x="%.0f" y="%.0f" width="%.2f" height="%.0f" fill="none" stroke="black"/>)", left, y + 2,
                   len(mean(s.color)), row - 4)
            << "\n";
        out << fmt(R"(<rect x="%.0f" y="%.0f" width="40" height="%.0f" fill="%s" stroke="black"/>)", W - right + 20,
                   y + 2, row - 4, css(s.color).c_str())
            << "\n";
        y += row + 20;
    }
    // The scale.
    out << fmt(R"(<line x1="%.0f" y1="%.0f" x2="%.2f" y2="%.0f" stroke="black"/>)", left, y, left + bar_w, y) << "\n";
    for (double v : ticks(scale_max, 5)) {
        out << fmt(R"(<line x1="%.2f" y1="%.0f" x2="%.2f" y2="%.0f" stroke="black"/>)", left + len(v), y, left + len(v),
                   y + 5)
            << "\n";
        out << fmt(R"(<text x="%.2f" y="%.0f" text-anchor="middle">%s</text>)", left + len(v), y + 18, num(v).c_str())
            << "\n";
    }
    out << fmt(R"(<text x="%.0f" y="%.0f">contribution to the pixel (linear, mean of R, G, B)</text>)", left, y + 36)
        << "\n";
    out << "</svg>\n";
}

}  // namespace smoketrace::cli
