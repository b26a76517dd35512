// libFuzzer target for the scene-file reader (parse_scene, scene_file.hpp).
//
// Contract checked on every input:
//  * parse_scene either returns or throws SceneFileError whose message starts with the source name
//    ("fuzz.json: ..."); any other exception escapes and libFuzzer reports it as a crash (uncaught
//    exception → abort), as are sanitizer findings (the build makes every ASan/UBSan report fatal);
//  * a scene it accepts honours the documented format: every number finite and within its documented
//    range (subnormals included; radii normal floats), a unit light direction, a camera the renderer
//    accepts with a field of view it can resolve, a particle count within the limit;
//  * the scene file's two JSON readers agree (scene_file.hpp, SceneJsonReader): the automatic reader accepts
//    exactly what the reference reader accepts, with the same scene bit for bit, and otherwise fails with the
//    reference's message word for word; the fast reader alone, where it does not decline, accepts only what
//    the reference accepts, with the same scene;
//  * a small accepted scene (<= kMaxPipelineParticles) also goes through the pipeline: the optical-depth
//    pass, and one 4x4 frame in basic and full mode; its lengths are finite or the documented +inf and its
//    pixels finite. Any exception there is a crash too: the reader accepted something the renderer cannot use.
// A generator asked for more than kMaxFuzzedTubes particles is skipped: reading it is linear in the count
// (10^6 tubes in 0.08 s, a release build's read_scene), but three readers and these checks over 10^7 particles
// under ASan take longer than the fuzzer's 30 s timeout for one input, which would report a hang.
//
// Build and run: scripts/fuzz.sh (clang, -DSMOKETRACE_FUZZ=ON, build-fuzz/); seed corpus: tests/fuzz/corpus/.
#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

using namespace smoketrace;

namespace {

constexpr std::size_t kMaxPipelineParticles = 32;
// About 5 s for one input here (four reads and the checks, ASan at -O1), a sixth of the timeout.
constexpr double kMaxFuzzedTubes = 1e6;
constexpr std::string_view kSource = "fuzz.json";

[[noreturn]] void violated(const char* what) {
    std::fprintf(stderr, "fuzz_scene_file: accepted scene violates the format: %s\n", what);
    std::abort();
}

void require(bool ok, const char* what) {
    if (!ok) violated(what);
}

bool finite(float v) { return std::isfinite(v); }
bool finite(const glm::vec3& v) { return finite(v.x) && finite(v.y) && finite(v.z); }
bool within(const glm::vec3& v, double lo, double hi) {
    for (int a = 0; a < 3; ++a)
        if (!(double(v[a]) >= lo && double(v[a]) <= hi)) return false;
    return true;
}

void check_format(const SceneDescription& s) {
    require(s.source == kSource, "source name");
    require(finite(s.light.direction) && std::abs(glm::length(glm::dvec3(s.light.direction)) - 1.0) < 1e-6,
            "light direction not unit");
    require(within(s.light.color, 0.0, kMaxSceneColor), "light colour");
    require(finite(s.light.rotation_per_frame_deg), "light rotation");
    require(within(s.ambient, 0.0, kMaxSceneColor) && within(s.background, 0.0, kMaxSceneColor), "ambient/background");
    require(s.smoke.particles.size() <= scene_particle_limit(), "particle count");
    // Positions are stored relative to the origin: the origin and every world position within
    // ±kMaxSceneCoordinate put the stored ones within twice that.
    for (int a = 0; a < 3; ++a) require(std::abs(s.origin[a]) <= kMaxSceneCoordinate, "origin");
    const double local_limit = 2.0 * kMaxSceneCoordinate;
    for (const Particle& p : s.smoke.particles) {
        require(within(p.center, -local_limit, local_limit), "particle centre");
        // A normal float: the reader refuses subnormal radii (1/radius would overflow).
        require(p.radius >= kMinParticleRadius && double(p.radius) <= kMaxSceneCoordinate, "particle radius");
        require(finite(p.velocity) && finite(p.spin) && finite(p.rotation), "particle motion");
        require(finite(p.growth) && p.growth > -1.0f, "particle growth");
    }
    require(finite(s.smoke.sigma_t) && s.smoke.sigma_t >= 0.0f, "sigma_t");
    require(s.smoke.alpha >= 0.0f && s.smoke.alpha <= 1.0f, "alpha");
    if (s.ground) {
        for (const glm::vec3& c : s.ground->corners)
            require(within(c, -local_limit, local_limit), "ground corner");
        require(finite(s.ground->normal) && std::abs(glm::length(glm::dvec3(s.ground->normal)) - 1.0) < 1e-6, "ground normal");
        require(within(s.ground->color, 0.0, kMaxSceneColor), "ground colour");
    }
    const CameraDescription& c = s.camera;
    require(finite(c.position) && finite(c.look_at) && finite(c.up), "camera vectors");
    require(c.fov_deg > 0.0f && c.fov_deg < 180.0f, "fov");
    // Neighbouring pixels' rays at least kMinPixelAngle apart at the file's height, and a default camera no
    // farther out than kMaxDefaultCameraCoordinate (a given position is within kMaxSceneCoordinate).
    // (The reader's expression, rounding for rounding.)
    const double half_fov = 0.5 * double(c.fov_deg) * (3.14159265358979323846 / 180.0);
    require(2.0 * std::tan(half_fov) / double(c.height) >= kMinPixelAngle, "fov too small for the image height");
    require(within(c.position, -kMaxDefaultCameraCoordinate - kMaxSceneCoordinate,
                   kMaxDefaultCameraCoordinate + kMaxSceneCoordinate),
            "camera position");
    require(c.width >= 1 && c.height >= 1 && c.width <= std::uint32_t(kMaxImageSide) && c.height <= std::uint32_t(kMaxImageSide) &&
                std::uint64_t(c.width) * c.height <= kMaxImagePixels,
            "image size");
    const RenderSettings& r = s.render;
    require(r.groups >= 1 && r.frames >= 1, "groups/frames");
    require(finite(r.softness) && r.softness >= 0.0f, "softness");
    require(r.transmittance_threshold >= 0.0f && r.transmittance_threshold < 1.0f, "threshold");
    check_scene_motion(s, r.frames);  // the reader checked it: must not throw
    // The renderer's camera must accept it (Camera throws std::invalid_argument otherwise).
    (void)Camera(c.position, c.look_at, c.up, c.fov_deg, int(c.width), int(c.height));
}

const SixwayTexture& texture() {
    static const SixwayTexture t =
        load_sixway_texture(std::filesystem::path(SMOKETRACE_ASSET_DIR) / std::string(kSixwayLayoutFile));
    return t;
}

void check_pipeline(const SceneDescription& s) {
    for (const RenderMode mode : {RenderMode::basic, RenderMode::full}) {
        RenderOptions o = RenderOptions::from_scene(s);
        o.width = o.height = 4;
        o.render.mode = mode;
        FrameRenderer renderer(s, o, texture());
        ImageRgba image;
        renderer.render(0, image);
        for (const glm::vec4& px : image.pixels)
            require(std::isfinite(px.x) && std::isfinite(px.y) && std::isfinite(px.z) && std::isfinite(px.w), "pixel not finite");
        const OpticalPathLengths& d = renderer.depths();
        for (std::size_t i = 0; i < d.lengths().size(); ++i) {
            const float l = d.lengths()[i];
            if (d.status()[i] == DepthStatus::ok) require(std::isfinite(l) && l >= 0.0f, "optical path length");
            else require(l == kFullyDarkPathLength, "dark path length");
        }
    }
}

template <class T>
bool same_bits(const T& a, const T& b) {
    return std::memcmp(&a, &b, sizeof(T)) == 0;
}

bool same_scene(const SceneDescription& a, const SceneDescription& b) {
    if (a.smoke.particles.size() != b.smoke.particles.size()) return false;
    if (!a.smoke.particles.empty() &&
        std::memcmp(a.smoke.particles.data(), b.smoke.particles.data(),
                    a.smoke.particles.size() * sizeof(Particle)) != 0)
        return false;
    return same_bits(a.origin, b.origin) && same_bits(a.light.direction, b.light.direction) &&
           same_bits(a.camera.position, b.camera.position) && same_bits(a.camera.look_at, b.camera.look_at) &&
           same_bits(a.smoke.sigma_t, b.smoke.sigma_t) && a.ground.has_value() == b.ground.has_value() &&
           a.render.frames == b.render.frames;
}

// The scene, or the message of the SceneFileError.
struct Outcome {
    std::optional<SceneDescription> scene;
    std::string message;
};
Outcome read_with(std::string_view text, SceneJsonReader reader) {
    try {
        return {parse_scene(text, kSource, reader), {}};
    } catch (const SceneFileError& e) {
        return {std::nullopt, e.what()};
    }
}

void check_readers_agree(std::string_view text, const Outcome& automatic) {
    const Outcome reference = read_with(text, SceneJsonReader::reference);
    require(automatic.scene.has_value() == reference.scene.has_value(), "automatic and reference readers disagree");
    if (!reference.scene) require(automatic.message == reference.message, "automatic reader's message differs");
    else require(same_scene(*automatic.scene, *reference.scene), "automatic reader's scene differs");
    const Outcome fast = read_with(text, SceneJsonReader::fast);
    if (fast.scene)
        require(reference.scene && same_scene(*fast.scene, *reference.scene), "fast reader accepts otherwise");
    else if (fast.message.find("the fast reader declined") == std::string::npos)
        require(!reference.scene, "fast reader refuses a scene the reference reader accepts");
}

// True when the text asks the tube generator for more than kMaxFuzzedTubes particles (as the JSON reads
// without the reader's checks: any number at /smoke/tubes/count).
bool asks_for_many_tubes(std::string_view text) {
    const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (!j.is_object()) return false;
    const auto smoke = j.find("smoke");
    if (smoke == j.end() || !smoke->is_object()) return false;
    const auto tubes = smoke->find("tubes");
    if (tubes == smoke->end() || !tubes->is_object()) return false;
    const auto count = tubes->find("count");
    return count != tubes->end() && count->is_number() && count->get<double>() > kMaxFuzzedTubes;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    if (asks_for_many_tubes(text)) return 0;
    const Outcome automatic = read_with(text, SceneJsonReader::automatic);
    check_readers_agree(text, automatic);
    if (!automatic.scene) {
        const std::string_view message = automatic.message;
        if (message.rfind(std::string(kSource) + ": ", 0) != 0 || message.size() <= kSource.size() + 2) {
            std::fprintf(stderr, "fuzz_scene_file: error message without the file name: %s\n",
                         automatic.message.c_str());
            std::abort();
        }
        return 0;
    }
    const SceneDescription& scene = *automatic.scene;
    check_format(scene);
    if (scene.smoke.particles.size() <= kMaxPipelineParticles) check_pipeline(scene);
    return 0;
}
