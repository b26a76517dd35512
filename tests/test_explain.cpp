// smoketrace explain (issue 24): the stories are the library's own computation, so what they say is what
// depths and render give: l bit for bit, the pixel bit for bit. And the command's bad input and its SVG.
#include "support/cli_runner.hpp"
#include "support/fixtures.hpp"

#include <smoketrace/io/png_io.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>
#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/render/pixel_story.hpp>
#include <smoketrace/smoke/optical_depth_story.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/truth/ground_truth.hpp>

#include <catch2/catch.hpp>

#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace smoketrace;
using smoketrace::test::CliRun;
using smoketrace::test::run_cli;
using smoketrace::test::run_cli_stdout;
using smoketrace::test::TempDir;

namespace {

const fs::path kAssets = SMOKETRACE_ASSET_DIR;
const char* const kShipped[] = {"minimal.json", "two_tubes_above.json", "two_tubes_right.json",
                                "two_tubes_sequence.json"};

SceneDescription shipped(const char* name) { return load_scene_file(kAssets / "scenes" / name); }

const SixwayTexture& texture() {
    static const SixwayTexture t = load_sixway_texture(kAssets / std::string(kSixwayLayoutFile));
    return t;
}

std::uint32_t bits(float f) { return std::bit_cast<std::uint32_t>(f); }

// What `smoketrace depths` computes for a scene (cmd_depths.cpp): every particle through the pass and the
// resolver, the scene's shape and the given cutoff.
struct Depths {
    std::vector<float> lengths;
    std::vector<DepthStatus> status;
    std::vector<std::uint32_t> hits;
};

std::optional<GroundQuad> ground_of(const SceneDescription& d) {
    if (!d.ground) return std::nullopt;
    return GroundQuad{d.ground->corners};
}

Depths depths_of(const SceneDescription& d, const SmokeScene& smoke, std::uint32_t cutoff,
                 const DensityKernel& kernel = {}) {
    OpticalPathLengths depths(d.smoke.particles.size());
    FrameTimings t;
    OpticalDepthSettings settings{cutoff};
    settings.kernel = kernel;
    depths.update(smoke, d.smoke.particles, smoketrace::test::all_of(d.smoke.particles.size()), d.light.direction,
                  settings, HitSort::adaptive, t);
    return {depths.lengths(), depths.status(), depths.hit_counts()};
}

// A story's particle checked against the pass and against itself; returns its status.
DepthStatus check_story(const OpticalDepthStory& s, const Depths& want) {
    const std::uint32_t i = s.particle;
    INFO("particle " << i);
    CHECK(s.outcome.status == want.status[i]);
    CHECK(s.outcome.hits == want.hits[i]);
    CHECK(bits(s.length) == bits(want.lengths[i]));  // l bit for bit: the same hits, sort and walk
    if (s.outcome.status != DepthStatus::ok) {
        CHECK(s.sorted.empty());
        return s.outcome.status;
    }
    REQUIRE(s.sorted.size() == s.seen.size());
    REQUIRE(s.counter_after.size() == s.sorted.size());
    for (std::size_t k = 1; k < s.sorted.size(); ++k) CHECK(s.sorted[k - 1].t <= s.sorted[k].t);
    if (!s.counter_after.empty()) CHECK(s.counter_after.back() == 0);  // eq. 3.1: every stretch closes
    // The counter starts at the number of stand-ins around the origin: those the sorted list leaves without
    // entering them (a convex stand-in the ray starts inside of is only left).
    std::map<std::uint32_t, int> entries, exits;
    for (const StoryHit& h : s.sorted) (h.value > 0 ? entries : exits)[h.particle]++;
    std::int64_t around_origin = 0;
    for (const auto& [p, n] : exits) around_origin += n - (entries.count(p) ? entries[p] : 0);
    CHECK(s.counter_start == around_origin);
    CHECK(exits.count(i) == 1);  // the own stand-in is left
    // The stretches add up to l: the walk sums the same gaps in another order (in double), and l is that sum
    // rounded to float, so they differ by at most about one float rounding, 2^-24 relative; 2^-22 allows the
    // double sums' own rounding on top.
    double sum = 0.0;
    for (const SmokeStretch& st : s.stretches) sum += double(st.t1) - double(st.t0);
    CHECK(std::abs(sum - double(s.length)) <= 0x1.0p-22 * double(s.length));
    CHECK(s.optical_depth == s.length * s.sigma_t);
    return DepthStatus::ok;
}

// A smooth kernel's story checked against the pass and against itself; returns its status.
DepthStatus check_kernel_story(const OpticalDepthStory& s, const Depths& want) {
    const std::uint32_t i = s.particle;
    INFO("particle " << i);
    CHECK(s.outcome.status == want.status[i]);
    CHECK(s.outcome.hits == want.hits[i]);
    // l bit for bit: the pass sums the same shares (over lanes, the scalar twin's bits) in the same order
    // (its trace_bundle() walk is the story's trace() walk, lane by lane).
    CHECK(bits(s.length) == bits(want.lengths[i]));
    CHECK(s.sorted.empty());  // no sort, no counter
    CHECK(s.stretches.empty());
    if (s.outcome.status != DepthStatus::ok) {
        CHECK(s.shares.empty());
        return s.outcome.status;
    }
    REQUIRE(s.shares.size() == s.seen.size());
    REQUIRE(s.sum_after.size() == s.seen.size());
    // Entries add nothing, each exit its share (>= 0), and each particle met is left exactly once.
    std::map<std::uint32_t, int> exits;
    double before = 0.0;
    for (std::size_t k = 0; k < s.seen.size(); ++k) {
        if (s.seen[k].value > 0) {
            CHECK(s.shares[k] == 0.0);
        } else {
            CHECK(s.shares[k] >= 0.0);
            ++exits[s.seen[k].particle];
        }
        CHECK(s.sum_after[k] == before + s.shares[k]);
        before = s.sum_after[k];
    }
    for (const auto& [p, n] : exits) CHECK(n == 1);
    CHECK(exits.count(i) == 1);  // the own stand-in is left
    CHECK(float(before) == s.length);
    CHECK(s.optical_depth == s.length * s.sigma_t);
    return DepthStatus::ok;
}

// The lines of `text` that start with `prefix` (after leading spaces), the rest of each.
std::vector<std::string> lines_after(const std::string& text, const std::string& prefix) {
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
        const auto first = line.find_first_not_of(' ');
        if (first != std::string::npos && line.compare(first, prefix.size(), prefix) == 0)
            out.push_back(line.substr(first + prefix.size()));
    }
    return out;
}

// A minimal XML well-formedness check of an SVG: one <svg> root, every element closed in order, attribute
// values quoted, no bare '<' or '&' in text. Returns the number of elements of each name (empty: not
// well-formed, with the reason in `why`).
std::map<std::string, int> svg_elements(const std::string& doc, std::string& why) {
    std::map<std::string, int> count;
    std::vector<std::string> open;
    std::size_t i = 0, roots = 0;
    auto fail = [&](const std::string& m) {
        why = m + " at byte " + std::to_string(i);
        return std::map<std::string, int>{};
    };
    if (doc.rfind("<?xml ", 0) != 0) return fail("no XML declaration");
    while (i < doc.size()) {
        if (doc[i] != '<') {
            if (doc[i] == '&') {
                const auto semi = doc.find(';', i);
                const std::string ent = semi == std::string::npos ? "" : doc.substr(i, semi - i + 1);
                if (ent != "&amp;" && ent != "&lt;" && ent != "&gt;" && ent != "&quot;" && ent != "&apos;")
                    return fail("bare '&'");
            }
            if (doc[i] == '>') return fail("bare '>'");
            if (open.empty() && !std::isspace(static_cast<unsigned char>(doc[i]))) return fail("text outside the root");
            ++i;
            continue;
        }
        if (doc.compare(i, 2, "<?") == 0) {
            const auto end = doc.find("?>", i);
            if (end == std::string::npos) return fail("unclosed <?");
            i = end + 2;
            continue;
        }
        const bool closing = doc[i + 1] == '/';
        std::size_t j = i + (closing ? 2 : 1);
        const std::size_t name_start = j;
        while (j < doc.size() && (std::isalnum(static_cast<unsigned char>(doc[j])) || doc[j] == '-' || doc[j] == ':'))
            ++j;
        const std::string name = doc.substr(name_start, j - name_start);
        if (name.empty()) return fail("a tag without a name");
        // Attributes: name="value", values free of '<' and '"'.
        bool self_closing = false;
        for (;;) {
            while (j < doc.size() && std::isspace(static_cast<unsigned char>(doc[j]))) ++j;
            if (j >= doc.size()) return fail("unclosed tag <" + name);
            if (doc[j] == '>') break;
            if (doc.compare(j, 2, "/>") == 0) {
                self_closing = true;
                ++j;
                break;
            }
            if (closing) return fail("attributes in </" + name + ">");
            const std::size_t a = j;
            while (j < doc.size() && doc[j] != '=' && !std::isspace(static_cast<unsigned char>(doc[j]))) ++j;
            if (j == a || j + 1 >= doc.size() || doc[j] != '=' || doc[j + 1] != '"')
                return fail("an unquoted attribute");
            const auto end = doc.find('"', j + 2);
            if (end == std::string::npos || doc.substr(j + 2, end - j - 2).find('<') != std::string::npos)
                return fail("a bad attribute value");
            j = end + 1;
        }
        i = j + 1;
        if (closing) {
            if (open.empty() || open.back() != name) return fail("</" + name + "> closes nothing open");
            open.pop_back();
            continue;
        }
        if (open.empty()) ++roots;
        ++count[name];
        if (!self_closing) open.push_back(name);
    }
    if (!open.empty()) return fail("<" + open.back() + "> never closed");
    if (roots != 1 || count["svg"] != 1) return fail("not one <svg> root");
    return count;
}

// A hand-made scene with a known answer: light straight up, particle 0 (radius 1) at the origin, particles 1
// and 2 (radius 1) above it at y = 3 and 3.5, overlapping. Particle 0's ray leaves its own sphere at t = 1,
// enters 1 at 2 and 2 at 2.5, leaves 1 at 4 and 2 at 4.5: in smoke over [0, 1) and [2, 4.5), l = 3.5.
const char* const kColumn = R"({
    "light": { "direction": [0, 1, 0] },
    "smoke": { "sigma_t": 2, "particles": [
        { "center": [0, 0, 0], "radius": 1 }, { "center": [0, 3, 0], "radius": 1 },
        { "center": [0, 3.5, 0], "radius": 1 }, { "center": [3, 0, 0], "radius": 0.5 } ] },
    "ground": { "corners": [[-6, -2, -6], [-6, -2, 6], [6, -2, 6], [6, -2, -6]] },
    "camera": { "position": [0, 1.5, 9], "look_at": [0, 1.5, 0], "width": 40, "height": 40 } })";

}  // namespace

TEST_CASE("explain: a particle's l is the one depths computes, bit for bit, on the shipped scenes", "[explain]") {
    std::size_t seen[3] = {0, 0, 0};
    for (const char* name : kShipped) {
        for (const bool icosahedra : {false, true}) {
            const SceneDescription d = shipped(name);
            const StandInShape shape = icosahedra ? StandInShape{StandInKind::icosahedron, 0} : d.smoke.shape;
            INFO(name << ", " << shape.name());
            SmokeScene smoke(d.smoke.particles, shape, ground_of(d), /*billboards=*/false);
            smoke.update(d.smoke.particles, d.camera.position);
            const Depths want = depths_of(d, smoke, d.render.cutoff);
            for (std::uint32_t i = 0; i < d.smoke.particles.size(); ++i) {
                const OpticalDepthStory s =
                    explain_optical_depth(smoke, d.smoke.particles, i, d.light.direction,
                                          OpticalDepthSettings{d.render.cutoff}, HitSort::adaptive, d.smoke.sigma_t);
                ++seen[int(check_story(s, want))];
            }
        }
    }
    // The shipped tubes have cut-off particles (cutoff 60) and many ok ones; the occluded status is covered by
    // the hand-made scene below.
    CHECK(seen[int(DepthStatus::ok)] > 1000);
    CHECK(seen[int(DepthStatus::cutoff)] > 0);
}

TEST_CASE("explain: under a smooth kernel a particle's l is the pass's sum of shares, bit for bit", "[explain][kernel]") {
    std::size_t seen[3] = {0, 0, 0};
    for (const char* name : kShipped) {
        for (const DensityKernel& kernel : {kGaussianKernel, kPoly1Kernel, kPoly2Kernel}) {
            for (const bool icosahedra : {false, true}) {
                const SceneDescription d = shipped(name);
                const StandInShape shape = icosahedra ? StandInShape{StandInKind::icosahedron, 0} : d.smoke.shape;
                INFO(name << ", " << shape.name() << ", " << kernel.name() << " kernel");
                SmokeScene smoke(d.smoke.particles, shape, ground_of(d), /*billboards=*/false);
                smoke.update(d.smoke.particles, d.camera.position);
                const Depths want = depths_of(d, smoke, d.render.cutoff, kernel);
                OpticalDepthSettings settings{d.render.cutoff};
                settings.kernel = kernel;
                for (std::uint32_t i = 0; i < d.smoke.particles.size(); ++i) {
                    const OpticalDepthStory s = explain_optical_depth(smoke, d.smoke.particles, i, d.light.direction,
                                                                      settings, HitSort::adaptive, d.smoke.sigma_t);
                    CHECK(s.kernel == kernel);
                    ++seen[int(check_kernel_story(s, want))];
                }
            }
        }
    }
    CHECK(seen[int(DepthStatus::ok)] > 1000);
    CHECK(seen[int(DepthStatus::cutoff)] > 0);
}

TEST_CASE("explain: under poly1 the hand-made column's l is its shares' known sum", "[explain][kernel]") {
    // The light straight up through the three centres: each ray of the column passes its particles at b = 0,
    // where poly1's share of a whole chord is peak·∫(1 − s²/R²) ds over [−R, R] = peak·4R/3, and half of that
    // from the centre out. Particle 0 leaves its own support (2R/3) and crosses 1's and 2's (4R/3 each):
    // l = peak·R·10/3, the overlap of 1 and 2 counted twice (the densities add). Tolerance: a few roundings
    // of the closed form, 1e-6 relative.
    TempDir dir;
    const SceneDescription d = load_scene_file(dir.write("column.json", kColumn));
    SmokeScene smoke(d.smoke.particles, d.smoke.shape, ground_of(d), /*billboards=*/false);
    smoke.update(d.smoke.particles, d.camera.position);
    OpticalDepthSettings settings;
    settings.kernel = kPoly1Kernel;
    const OpticalDepthStory s =
        explain_optical_depth(smoke, d.smoke.particles, 0, d.light.direction, settings, HitSort::adaptive, 2.0f);
    REQUIRE(s.outcome.status == DepthStatus::ok);
    REQUIRE(s.seen.size() == 5);
    const double R = double(kPoly1Kernel.support), peak = double(kPoly1Kernel.peak);
    for (std::size_t k = 0; k < s.seen.size(); ++k) {
        INFO("candidate " << k << ", particle " << s.seen[k].particle);
        if (s.seen[k].value > 0) continue;
        CHECK(s.shares[k] == Approx(peak * R * (s.seen[k].particle == 0 ? 2.0 : 4.0) / 3.0).epsilon(1e-6));
    }
    CHECK(s.length == Approx(peak * R * 10.0 / 3.0).epsilon(1e-6));
    CHECK(s.transmittance == Approx(std::exp(-2.0 * peak * R * 10.0 / 3.0)).epsilon(1e-5));
    check_kernel_story(s, depths_of(d, smoke, 0, kPoly1Kernel));
    OpticalDepthSettings bad;
    bad.kernel = DensityKernel{DensityKernelKind::poly1, 1.5f, 1.0f};  // a support beyond the stand-in
    CHECK_THROWS_AS(explain_optical_depth(smoke, d.smoke.particles, 0, d.light.direction, bad, HitSort::adaptive, 1.0f),
                    std::invalid_argument);
}

TEST_CASE("explain: the hand-made column gives its known story, and each status", "[explain]") {
    TempDir dir;
    const SceneDescription d = load_scene_file(dir.write("column.json", kColumn));
    SmokeScene smoke(d.smoke.particles, d.smoke.shape, ground_of(d), /*billboards=*/false);
    smoke.update(d.smoke.particles, d.camera.position);
    const OpticalDepthStory s =
        explain_optical_depth(smoke, d.smoke.particles, 0, d.light.direction, {}, HitSort::adaptive, d.smoke.sigma_t);
    REQUIRE(s.outcome.status == DepthStatus::ok);
    CHECK(s.seen.size() == 5);
    REQUIRE(s.sorted.size() == 5);
    // Sphere hits are exact to a few float steps (the exact ray/sphere test rounds its result once):
    // 1e-6 relative is about eight steps of 2^-23.
    const float want_t[] = {1.0f, 2.0f, 2.5f, 4.0f, 4.5f};
    const std::uint32_t want_particle[] = {0, 1, 2, 1, 2};
    const std::int32_t want_value[] = {-1, +1, +1, -1, -1};
    const std::int64_t want_counter[] = {0, 1, 2, 1, 0};
    for (std::size_t k = 0; k < 5; ++k) {
        INFO("sorted hit " << k);
        CHECK(s.sorted[k].t == Approx(want_t[k]).epsilon(1e-6));
        CHECK(s.sorted[k].particle == want_particle[k]);
        CHECK(s.sorted[k].value == want_value[k]);
        CHECK(s.counter_after[k] == want_counter[k]);
    }
    CHECK(s.counter_start == 1);
    REQUIRE(s.stretches.size() == 2);
    CHECK(s.stretches[0].t0 == 0.0f);
    CHECK(s.stretches[0].t1 == Approx(1.0f).epsilon(1e-6));
    CHECK(s.stretches[1].t0 == Approx(2.0f).epsilon(1e-6));
    CHECK(s.stretches[1].t1 == Approx(4.5f).epsilon(1e-6));
    CHECK(s.length == Approx(3.5f).epsilon(1e-6));
    CHECK(s.optical_depth == Approx(7.0f).epsilon(1e-6));
    CHECK(s.transmittance == Approx(std::exp(-7.0)).epsilon(1e-5));
    CHECK_FALSE(s.cut_off);
    CHECK_FALSE(s.ground_t);
    CHECK(s.counters.any_hit_invocations == 5);

    // A cutoff of 2: the third candidate ends the search.
    const OpticalDepthStory cut =
        explain_optical_depth(smoke, d.smoke.particles, 0, d.light.direction, {2}, HitSort::adaptive, 1.0f);
    CHECK(cut.cut_off);
    CHECK(cut.outcome.status == DepthStatus::cutoff);
    CHECK(cut.outcome.hits == 3);
    CHECK(cut.seen.size() == 2);
    CHECK(std::isinf(cut.length));
    CHECK(cut.transmittance == 0.0f);

    // A roof above particle 3 (and only it): occluded, the ground met at y = 1 − 0 = t 1.
    SceneDescription roofed = d;
    roofed.ground = GroundDescription{};
    roofed.ground->corners = {glm::vec3(2, 1, 2), glm::vec3(4, 1, 2), glm::vec3(4, 1, -2), glm::vec3(2, 1, -2)};
    SmokeScene roofed_smoke(roofed.smoke.particles, roofed.smoke.shape, ground_of(roofed), false);
    roofed_smoke.update(roofed.smoke.particles, roofed.camera.position);
    const OpticalDepthStory occ =
        explain_optical_depth(roofed_smoke, roofed.smoke.particles, 3, d.light.direction, {}, HitSort::adaptive, 1.0f);
    CHECK(occ.outcome.status == DepthStatus::occluded);
    REQUIRE(occ.ground_t);
    CHECK(*occ.ground_t == Approx(1.0f).epsilon(1e-6));
    CHECK(std::isinf(occ.length));
    const Depths want = depths_of(roofed, roofed_smoke, 0);
    for (std::uint32_t i = 0; i < roofed.smoke.particles.size(); ++i)
        check_story(explain_optical_depth(roofed_smoke, roofed.smoke.particles, i, d.light.direction, {},
                                          HitSort::adaptive, 1.0f),
                    want);

    CHECK_THROWS_AS(explain_optical_depth(smoke, d.smoke.particles, 4, d.light.direction, {}, HitSort::adaptive, 1.0f),
                    std::out_of_range);
}

TEST_CASE("explain: the explained pixel is the rendered one, bit for bit, in every mode", "[explain]") {
    // render_view() draws with the tiled compositor; the story runs the per-ray one with a recording observer.
    // The two give the same bits (test_view_compositor.cpp), so any difference is the observer changing
    // what it watches. Tolerance 0.
    TempDir dir;
    std::vector<std::pair<std::string, SceneDescription>> scenes;
    for (const char* name : kShipped) scenes.emplace_back(name, shipped(name));
    scenes.emplace_back("column", load_scene_file(dir.write("column.json", kColumn)));
    std::set<SampleEnd> ends;
    bool shadowed = false, cut_short = false;
    std::size_t compared = 0, kernel_shadows = 0;
    struct Look {
        RenderMode mode;
        DensityKernel kernel;
    };
    const Look looks[] = {{RenderMode::basic, kUniformKernel},         {RenderMode::simple_shadow, kUniformKernel},
                          {RenderMode::full, kUniformKernel},          {RenderMode::full, kGaussianKernel},
                          {RenderMode::simple_shadow, kGaussianKernel}, {RenderMode::full, kPoly2Kernel}};
    for (const auto& [name, d] : scenes)
        for (const auto& [mode, kernel] : looks)
            for (const Compositing compositing : {Compositing::over, Compositing::thesis})
                for (const std::uint32_t spp : {1u, 3u}) {
                    RenderOptions o = RenderOptions::from_scene(d);
                    o.render.mode = mode;
                    o.kernel = kernel;
                    o.render.compositing = compositing;
                    o.render.spp = spp;
                    o.width = o.height = 24;
                    FrameRenderer renderer(d, o, texture());
                    ImageRgba image;
                    renderer.render(0, image);
                    for (int y = 0; y < o.height; ++y)
                        for (int x = (y % 2); x < o.width; x += 2) {
                            INFO(name << ", " << to_string(mode) << ", " << kernel.name() << ", "
                                      << to_string(compositing) << ", spp " << spp << ", pixel " << x << "," << y);
                            const PixelStory p = explain_pixel(renderer, 0, x, y);
                            const glm::vec4 want = image.at(x, y);
                            CHECK(bits(p.color.x) == bits(want.x));
                            CHECK(bits(p.color.y) == bits(want.y));
                            CHECK(bits(p.color.z) == bits(want.z));
                            REQUIRE(p.samples.size() == spp);
                            for (const SampleStory& s : p.samples) {
                                // The recorded contributions are the terms the compositor added, in its order.
                                glm::vec3 sum(0.0f);
                                for (std::size_t k = 0; k < s.layers.size(); ++k) {
                                    sum += s.layers[k].contribution;
                                    if (k > 0) CHECK(s.layers[k - 1].t <= s.layers[k].t);
                                    if (k > 0)
                                        CHECK(bits(s.layers[k - 1].weight_after) == bits(s.layers[k].weight_before));
                                }
                                if (s.end != SampleEnd::transmittance_threshold) sum += s.background_contribution;
                                CHECK(sum == s.color);
                                if (s.end == SampleEnd::transmittance_threshold) {
                                    REQUIRE_FALSE(s.layers.empty());
                                    CHECK(s.layers.back().weight_after < o.render.transmittance_threshold);
                                }
                                CHECK((s.end == SampleEnd::ground) == s.ground.has_value());
                                if (s.ground) {
                                    // A smooth kernel's shadow: the recorded shares, summed in their order,
                                    // are the compositor's l_g, and its shadow exp(−σt·l_g).
                                    const GroundStory& g = *s.ground;
                                    CHECK(g.kernel_shadow == (g.shadow_ray && mode == RenderMode::full &&
                                                              kernel.smooth()));
                                    double l = 0.0;
                                    for (const ShadowHitStory& h : g.shadow_hits) {
                                        if (!h.exit) CHECK(h.share == 0.0);
                                        l += h.share;
                                    }
                                    if (g.kernel_shadow) {
                                        CHECK(bits(float(l)) == bits(g.shadow_length));
                                        CHECK(bits(g.shadow_factor) == bits(std::exp(-g.shadow_length * p.sigma_t)));
                                        kernel_shadows += g.shadow_length > 0.0f;
                                    } else {
                                        CHECK(g.shadow_hits.empty());
                                    }
                                }
                                ends.insert(s.end);
                                shadowed = shadowed || (s.ground && s.ground->shadow_hit);
                                cut_short = cut_short || s.search_cut_at.has_value();
                            }
                            ++compared;
                        }
                }
    // Not vacuous: every way a sample can end, shadows, and a billboard search cut short were met.
    CHECK(ends.size() == 3);
    CHECK(shadowed);
    CHECK(cut_short);
    CHECK(kernel_shadows > 20);
    CHECK(compared == 5 * 6 * 2 * 2 * 24 * 12);

    SceneDescription d = shipped("minimal.json");
    RenderOptions o = RenderOptions::from_scene(d);
    FrameRenderer renderer(d, o, texture());
    ImageRgba image;
    renderer.render(0, image);
    CHECK_THROWS_AS(explain_pixel(renderer, 0, o.width, 0), std::out_of_range);
    CHECK_THROWS_AS(explain_pixel(renderer, 0, 0, -1), std::out_of_range);
}

TEST_CASE("cli: explain prints depths' l and render's pixel", "[explain][cli]") {
    TempDir dir;
    const fs::path above = kAssets / "scenes" / "two_tubes_above.json";
    // depths' CSV rows.
    const fs::path csv = dir.path / "d.csv";
    REQUIRE(run_cli("depths " + above.string() + " -o " + csv.string()).exit_code == 0);
    std::vector<std::string> rows;
    {
        std::istringstream in(smoketrace::test::file_bytes(csv));
        for (std::string line; std::getline(in, line);) rows.push_back(line);
    }
    int inf_rows = 0;
    for (const int i : {0, 17, 200, 443, 749}) {
        const CliRun r = run_cli_stdout("explain " + above.string() + " --particle " + std::to_string(i));
        INFO("particle " << i << ": " << r.err);
        REQUIRE(r.exit_code == 0);
        const auto l = lines_after(r.out, "l = ");
        REQUIRE(l.size() == 1);
        const std::string printed = l[0].substr(0, l[0].find(' '));
        const std::string row = rows.at(std::size_t(i) + 1);
        const auto a = row.find(','), b = row.find(',', a + 1);
        CHECK(printed == row.substr(a + 1, b - a - 1));  // the same %.9g text as the CSV: the same float
        inf_rows += printed == "inf";
    }
    CHECK(inf_rows >= 1);  // 443 is cut off (cutoff 60): fully dark

    // --pixel against render's PNG, in every mode, both compositings and several samples: scene files made
    // from the hand-made column with the render settings in them.
    struct Variant {
        const char* render;
    };
    const Variant variants[] = {{R"({"mode": "basic"})"},
                                {R"({"mode": "simple-shadow"})"},
                                {R"({"mode": "full"})"},
                                {R"({"mode": "full", "compositing": "thesis"})"},
                                {R"({"mode": "full", "spp": 4})"}};
    int k = 0;
    for (const Variant& v : variants) {
        std::string text = kColumn;
        text.insert(text.rfind('}'), std::string(R"(, "render": )") + v.render);
        std::string stem("variant");
        stem += std::to_string(k++);
        const fs::path scene = dir.write(stem + ".json", text);
        const fs::path png = dir.path / (stem + ".png");
        INFO(v.render);
        REQUIRE(run_cli("render " + scene.string() + " -o " + png.string()).exit_code == 0);
        const Rgba8Image image = read_png_rgba8(png);
        for (const auto& [x, y] : {std::pair{20, 20}, std::pair{20, 12}, std::pair{3, 35}, std::pair{0, 0}}) {
            const CliRun r =
                run_cli_stdout("explain " + scene.string() + " --pixel " + std::to_string(x) + "," + std::to_string(y));
            INFO("pixel " << x << "," << y << ": " << r.err);
            REQUIRE(r.exit_code == 0);
            const auto srgb = lines_after(r.out, "pixel (linear) ");
            REQUIRE(srgb.size() == 1);
            std::istringstream in(srgb[0].substr(srgb[0].rfind(':') + 1));
            int rgb[3] = {-1, -1, -1};
            in >> rgb[0] >> rgb[1] >> rgb[2];
            const std::uint8_t* px = &image.pixels[(std::size_t(y) * std::size_t(image.width) + std::size_t(x)) * 4];
            CHECK(rgb[0] == px[0]);
            CHECK(rgb[1] == px[1]);
            CHECK(rgb[2] == px[2]);
            CHECK(r.out.find("(the same)") != std::string::npos);
        }
    }
}

TEST_CASE("cli: explain --kernel tells the kernel's sums, depths' l and render's pixel", "[explain][cli][kernel]") {
    TempDir dir;
    const std::string above = (kAssets / "scenes" / "two_tubes_above.json").string();
    const fs::path csv = dir.path / "d.csv";
    REQUIRE(run_cli("depths " + above + " -o " + csv.string() + " --kernel gaussian").exit_code == 0);
    std::vector<std::string> rows;
    {
        std::istringstream in(smoketrace::test::file_bytes(csv));
        for (std::string line; std::getline(in, line);) rows.push_back(line);
    }
    for (const int i : {17, 443, 560}) {
        const CliRun r = run_cli_stdout("explain " + above + " --particle " + std::to_string(i) + " --kernel gaussian");
        INFO("particle " << i << ": " << r.err);
        REQUIRE(r.exit_code == 0);
        CHECK(r.out.find("density     gaussian kernel") != std::string::npos);
        const auto l = lines_after(r.out, "l = ");
        REQUIRE(l.size() == 1);
        const std::string row = rows.at(std::size_t(i) + 1);
        const auto a = row.find(','), b = row.find(',', a + 1);
        CHECK(l[0].substr(0, l[0].find(' ')) == row.substr(a + 1, b - a - 1));
        // Ok rays list each candidate's share; 443 is cut off (cutoff 60): no shares summed.
        CHECK((r.out.find("its share of l:") != std::string::npos) == (row.substr(a + 1, b - a - 1) != "inf"));
    }
    // A pixel of the tubes' shadow, at render's size and kernel: its story names the kernel and every share.
    const fs::path png = dir.path / "poly2.png";
    const std::string options = " --size 128x128 --kernel poly2";
    REQUIRE(run_cli("render " + above + " -o " + png.string() + options).exit_code == 0);
    const Rgba8Image image = read_png_rgba8(png);
    const CliRun r = run_cli_stdout("explain " + above + " --pixel 64,82" + options);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK(r.out.find("mode full, kernel poly2") != std::string::npos);
    CHECK(r.out.find("the poly2 kernel's density summed along it") != std::string::npos);
    CHECK(r.out.find("(the same)") != std::string::npos);
    const auto srgb = lines_after(r.out, "pixel (linear) ");
    REQUIRE(srgb.size() == 1);
    std::istringstream in(srgb[0].substr(srgb[0].rfind(':') + 1));
    int rgb[3] = {-1, -1, -1};
    in >> rgb[0] >> rgb[1] >> rgb[2];
    const std::uint8_t* px = &image.pixels[(82 * std::size_t(image.width) + 64) * 4];
    CHECK(rgb[0] == px[0]);
    CHECK(rgb[1] == px[1]);
    CHECK(rgb[2] == px[2]);
}

// explain takes render's and depths' own options, read by the same code (scene_overrides.hpp), so that its
// story is of the pixel the user looked at: a sequence rendered with every option that changes a frame, and
// pixels of its frames (beyond the scene's 512 pixels wide) explained with the same options and --frame. The
// particle's l follows depths' --shape and --cutoff. Tolerance 0: the same computation.
TEST_CASE("cli: explain follows render's and depths' options and frames", "[explain][cli]") {
    TempDir dir;
    const std::string scene = (kAssets / "scenes" / "two_tubes_sequence.json").string();
    REQUIRE(shipped("two_tubes_sequence.json").camera.width == 512);
    const std::string options = " --size 600x40 --mode simple-shadow --spp 2 --groups 2 --cutoff 4 "
                                "--shape icosahedron --compositing thesis";
    REQUIRE(run_cli("render " + scene + " -o " + (dir.path / "f.png").string() + options + " --frames 3").exit_code ==
            0);
    const auto rendered_at = [&](int frame, int x, int y) {
        const Rgba8Image image = read_png_rgba8(dir.path / ("f_000" + std::to_string(frame) + ".png"));
        REQUIRE(image.width == 600);
        REQUIRE(image.height == 40);
        const std::uint8_t* px = &image.pixels[(std::size_t(y) * std::size_t(image.width) + std::size_t(x)) * 4];
        return std::array<int, 3>{px[0], px[1], px[2]};
    };
    const auto explained_at = [&](int frame, int x, int y, const std::string& extra) {
        const CliRun r = run_cli_stdout("explain " + scene + " --pixel " + std::to_string(x) + "," +
                                        std::to_string(y) + options + extra);
        INFO(r.err);
        REQUIRE(r.exit_code == 0);
        CHECK(r.out.find("(frame " + std::to_string(frame) + ", mode simple-shadow") != std::string::npos);
        const auto srgb = lines_after(r.out, "pixel (linear) ");
        REQUIRE(srgb.size() == 1);
        std::istringstream in(srgb[0].substr(srgb[0].rfind(':') + 1));
        std::array<int, 3> rgb{-1, -1, -1};
        in >> rgb[0] >> rgb[1] >> rgb[2];
        return rgb;
    };
    bool frames_differ = false;
    for (const auto& [x, y] : {std::pair{300, 20}, std::pair{560, 5}, std::pair{280, 30}}) {
        INFO("pixel " << x << "," << y);
        CHECK(explained_at(0, x, y, " --frames 3") == rendered_at(0, x, y));  // the first frame, by default
        CHECK(explained_at(2, x, y, " --frames 3 --frame 2") == rendered_at(2, x, y));
        frames_differ = frames_differ || rendered_at(0, x, y) != rendered_at(2, x, y);
    }
    CHECK(frames_differ);  // --frame is followed, not frame 0 drawn for every frame
    // --frames A:B (of the scene's 24): frame A by default, the one render --frames 1:3 writes first.
    CHECK(explained_at(1, 300, 20, " --frames 1:3") == rendered_at(1, 300, 20));

    // A particle's l under depths' --cutoff and --shape: the same text as the CSV's.
    const fs::path csv = dir.path / "d.csv";
    const std::string depths_options = " --cutoff 4 --shape icosahedron";
    REQUIRE(run_cli("depths " + scene + " -o " + csv.string() + depths_options).exit_code == 0);
    std::vector<std::string> rows;
    {
        std::istringstream in(smoketrace::test::file_bytes(csv));
        for (std::string line; std::getline(in, line);) rows.push_back(line);
    }
    // Not vacuous: at K = 4 particles 10 and 600 are cut off (without it they are lit), so an explain that
    // ignored --cutoff would print a finite l where the CSV has inf.
    CHECK(rows.at(11).ends_with(",cutoff"));
    CHECK(rows.at(601).ends_with(",cutoff"));
    for (const int i : {10, 300, 600}) {
        const CliRun r = run_cli_stdout("explain " + scene + " --particle " + std::to_string(i) + depths_options);
        INFO("particle " << i << ": " << r.err);
        REQUIRE(r.exit_code == 0);
        CHECK(r.out.find("icosahedron; cutoff 4") != std::string::npos);
        const auto l = lines_after(r.out, "l = ");
        REQUIRE(l.size() == 1);
        const std::string row = rows.at(std::size_t(i) + 1);
        const auto a = row.find(','), b = row.find(',', a + 1);
        CHECK(l[0].substr(0, l[0].find(' ')) == row.substr(a + 1, b - a - 1));
    }
}

TEST_CASE("cli: explain's bad input names the argument and writes nothing", "[explain][cli]") {
    TempDir dir;
    const std::string scene = (kAssets / "scenes" / "minimal.json").string();
    const fs::path svg = dir.path / "out.svg";
    const std::string o = " -o " + svg.string();
    const fs::path empty = dir.write("empty.json", R"({"light":{"direction":[0,1,0]},"smoke":{"particles":[]}})");
    struct Case {
        std::string args, expect;
    };
    const Case cases[] = {
        {"explain " + scene + " --particle 5" + o, "--particle: 5 is out of range"},
        {"explain " + scene + " --particle -1" + o, "--particle"},
        {"explain " + scene + " --particle x" + o, "--particle: 'x' is not a whole number"},
        {"explain " + empty.string() + " --particle 0" + o, "has no particles"},
        {"explain " + scene + " --pixel 512,0" + o, "--pixel: 512,0 is outside the 512x512 image"},
        {"explain " + scene + " --pixel 40,0 --size 40x30" + o, "--pixel: 40,0 is outside the 40x30 image"},
        {"explain " + scene + " --pixel 1,2 --frame 1" + o, "--frame: 1 is not one of the frames rendered, 0…0"},
        {"explain " + scene + " --pixel 1,2 --frames 2:4 --frame 1" + o, "--frames 2:4: B is beyond the 1 frames"},
        {"explain " + scene + " --pixel 1,2 --mode fancy" + o, "--mode: 'fancy' is not one of"},
        {"explain " + scene + " --particle 0 --size 40x30" + o, "--size: --particle takes only depths' --shape"},
        {"explain " + scene + " --particle 0 --frame 0" + o, "--frame: --particle explains frame 0"},
        {"explain " + scene + " --pixel 0,512" + o, "--pixel"},
        {"explain " + scene + " --pixel 3" + o, "--pixel: '3' is not of the form X,Y"},
        {"explain " + scene + " --pixel a,b" + o, "--pixel: X: 'a' is not a whole number"},
        {"explain " + scene + " --pixel -1,2" + o, "--pixel: X"},
        {"explain " + scene + " --pixel 1,2,3" + o, "--pixel: Y: '2,3' is not a whole number"},
        {"explain " + scene + " --pixel 1,2 --particle 0" + o, "give one of them, not both"},
        {"explain " + scene + o, "give --particle N"},
        {"explain --particle 0" + o, "missing scene file"},
        {"explain " + scene + " --particle 0 -o " + (dir.path / "out.png").string(), "must end in .svg"},
        {"explain " + scene + " --particle 0 -o " + scene, "-o"},
        {"explain " + scene + " --particle 0 -o " + (dir.path / "no" / "x.svg").string(), "does not exist"},
    };
    for (const Case& c : cases) {
        INFO(c.args);
        const CliRun r = run_cli(c.args);
        INFO(r.err);
        CHECK(r.exit_code != 0);
        CHECK(r.err.find(c.expect) != std::string::npos);
        CHECK_FALSE(fs::exists(svg));
    }
    for (const auto& e : fs::directory_iterator(dir.path)) CHECK(e.path().extension() == ".json");
}

TEST_CASE("cli: explain's SVGs are well-formed and written whole", "[explain][cli]") {
    TempDir dir;
    std::string text = kColumn;
    text.insert(text.rfind('}'), R"(, "render": {"spp": 2})");
    const fs::path scene = dir.write("column.json", text);
    const fs::path above = kAssets / "scenes" / "two_tubes_above.json";
    const fs::path svg = dir.path / "story.svg";
    struct Case {
        std::string args;
        const char* needs;  // an element the drawing cannot do without
    };
    const Case cases[] = {
        {scene.string() + " --particle 0", "path"},    // the counter's step plot
        {above.string() + " --particle 443", "line"},  // cut off: chords, no walk
        {above.string() + " --particle 17", "path"},
        {scene.string() + " --pixel 20,20", "rect"},  // two samples' bars
        {above.string() + " --particle 560 --kernel gaussian", "rect"},  // the shares stacked into l
        {above.string() + " --particle 443 --kernel poly1", "line"},     // cut off: no shares
        {above.string() + " --pixel 256,330 --spp 1 --kernel poly2", "rect"},
    };
    for (const Case& c : cases) {
        INFO(c.args);
        dir.write("story.svg", "an older file, replaced whole");
        const CliRun r = run_cli("explain " + c.args + " -o " + svg.string());
        INFO(r.err);
        REQUIRE(r.exit_code == 0);
        const std::string doc = smoketrace::test::file_bytes(svg);
        std::string why;
        const auto elements = svg_elements(doc, why);
        INFO(why);
        REQUIRE_FALSE(elements.empty());
        CHECK(elements.count(c.needs) == 1);
        CHECK(elements.at("text") >= 5);  // labels, legend, units
        // Nothing beside it: the temporary file was renamed into place.
        std::size_t files = 0;
        for (const auto& e : fs::directory_iterator(dir.path)) files += e.path().extension() != ".json";
        CHECK(files == 1);
        // -o -: the same SVG on standard output, the text on standard error.
        const CliRun piped = run_cli_stdout("explain " + c.args + " -o -");
        REQUIRE(piped.exit_code == 0);
        CHECK(piped.out == doc);
        CHECK(piped.err.find("smoketrace explain:") != std::string::npos);
    }
}

TEST_CASE("cli: explain prints positions in world coordinates for a scene far from the origin", "[explain][cli]") {
    // The column moved by 10^6 (an explicit origin near it): the stored positions are relative to the origin,
    // and the story must give them back as the file wrote them. The pixel's camera ray starts at the camera.
    TempDir dir;
    const fs::path scene = dir.write("far.json", R"({
        "origin": [1000000, 0, -1000000],
        "light": { "direction": [0, 1, 0] },
        "smoke": { "particles": [ { "center": [1000000.25, 0.5, -1000000], "radius": 1 },
                                  { "center": [1000000.25, 3.5, -1000000], "radius": 1 } ] },
        "camera": { "position": [1000000, 1.5, -999991], "look_at": [1000000, 1.5, -1000000],
                    "width": 40, "height": 40 } })");
    const CliRun p = run_cli_stdout("explain " + scene.string() + " --particle 1");
    INFO(p.err);
    REQUIRE(p.exit_code == 0);
    CHECK(p.out.find("centre (1000000.25, 3.5, -1000000)") != std::string::npos);
    const CliRun x = run_cli_stdout("explain " + scene.string() + " --pixel 20,20");
    INFO(x.err);
    REQUIRE(x.exit_code == 0);
    CHECK(x.out.find("camera ray from (1000000, 1.5, -999991)") != std::string::npos);
}

// explain --pixel --truth prints the pixel's ground truth beside the frame's: the truth is the library's
// GroundTruth::pixel() of the same frame and size, to the last bit of its shortest text, and the frame's
// value is the one render writes. A puff baked at 8x8 texels keeps the truth's volume small (the test's
// time); the minimal scene at 8x8 pixels.
TEST_CASE("cli: explain --pixel --truth prints the truth's pixel beside the frame's", "[explain][cli][truth]") {
    TempDir dir;
    const CliRun bake = run_cli("bake-sixway --frames 1 --tile 8 -o " + dir.path.string());
    REQUIRE(bake.exit_code == 0);
    const std::string scene_path = std::string(SMOKETRACE_ASSET_DIR) + "/scenes/minimal.json";
    const CliRun r = run_cli_stdout("explain " + scene_path + " --pixel 3,4 --size 8x8 --truth --assets " +
                                    dir.path.string());
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const SceneDescription desc = load_scene_file(scene_path);
    const GroundTruth truth(desc, read_sixway_bake_settings(dir.path / kSixwayLayoutFile), 0, 8, 8);
    const glm::vec3 expected = truth.pixel(3, 4);
    const auto shortest = [](float v) {
        char text[32];
        return std::string(text, std::to_chars(text, text + sizeof text, v).ptr);
    };
    std::string triple = "(";
    triple.append(shortest(expected.x)).append(", ").append(shortest(expected.y)).append(", ");
    triple.append(shortest(expected.z)).append(")");
    INFO(r.out);
    CHECK_THAT(r.out, Catch::Contains("\n  truth          " + triple + " "));
    CHECK_THAT(r.out, Catch::Contains("\n  frame - truth  ("));
    // Not with --particle: a particle's truth is depths --truth.
    const CliRun particle = run_cli("explain " + scene_path + " --particle 0 --truth");
    CHECK(particle.exit_code == 2);
    CHECK_THAT(particle.err, Catch::Contains("--truth"));
}
