#pragma once
// Scene files: JSON in, plain data (SceneDescription) out, with strict validation at the boundary.
//
// ---- Scene file format ------------------------------------------------------------------------------
// The minimal form, which other tools write and which must stay readable exactly as is:
//
//   { "light":  { "direction": [x, y, z] },
//     "smoke":  { "particles": [ { "center": [x, y, z], "radius": r }, ... ] },
//     "ground": { "corners": [[x,y,z], [x,y,z], [x,y,z], [x,y,z]] } }
//
// Conventions: y is up; lengths in world units; every speed is per frame. All keys below are optional
// unless marked REQUIRED; the defaults are in brackets. Any other key is an error.
//
//   light        REQUIRED object
//     direction    REQUIRED [x,y,z]  from the scene toward the (infinitely far) light; any nonzero length,
//                                   stored normalised
//     color        [1,1,1]          light colour c_diff (eq. 4.4) and billboard light colour (4.3.5); >= 0
//     rotation_per_frame_deg [0]    the light turns about +z by this angle each frame, counter-clockwise
//                                   seen from +z (+x toward +y); the thesis's clockwise run (5.2.2) is < 0
//   ambient      [0.05,0.05,0.05]   c_amb (eq. 4.2), added to every smoke layer; >= 0
//   background   [0.53,0.81,0.92]   sky blue, the colour of a view ray that hits nothing (4.3.5); >= 0
//   smoke        REQUIRED object with exactly one of "particles" and "tubes"
//     particles    [ {...}, ... ]   explicit particles, in this order (an empty list is valid):
//       center       REQUIRED [x,y,z]
//       radius       REQUIRED       >= 1.1754944e-38 (the smallest normal float, kMinParticleRadius)
//       velocity     [0,0,0]        world units per frame
//       spin         [0]            billboard rotation speed, radians per frame
//       growth       [0]            radius *= 1 + growth per frame; > -1
//       rotation     [0]            initial billboard rotation, radians
//     tubes        {...}            the thesis's two tubes (4.1.1, tube_generator.hpp), all keys optional:
//       count [750], seed [2022], tube_radius [1], tube_length [6], separation [1.35],
//       particle_radius [0.35], drift [0,0,0], jitter_speed [0], spin_speed [0], growth [0],
//       random_rotation [true]; count 0…kMaxSceneParticles, seed 0…2^64−1 (integers); radii and length
//       > 0; separation, jitter_speed, spin_speed >= 0; growth > -1; drift any [x,y,z]
//     sigma_t      [1.0]            extinction coefficient σt per world unit (eqs. 2.12, 4.2, 4.3); >= 0
//     alpha        [0.5]            particle opacity a_p, multiplied by the texture's alpha; in [0, 1]
//     shape        ["sphere"]       stand-in for optical-depth and shadow rays: "sphere" (exact),
//                                   "icosahedron" (the thesis's) or "icosphere:L", L = 1…4
//   ground       optional object; no ground when absent
//     corners      REQUIRED 4×[x,y,z]  an opaque planar convex quad, counter-clockwise seen from the side
//                                   its normal points to (the lit side)
//     color        [0.8,0.1,0.1]    c_base (eq. 4.4), red as in the thesis; >= 0
//   camera       optional object
//     position     [see below]      default: in front (+z) of the smoke and a little above, far enough
//     look_at      [see below]        that the smoke's bounding sphere fits the view; looks at its centre
//     up           [0,1,0]          must not be parallel to look_at − position; stored normalised
//     fov_deg      [45]             vertical field of view, degrees, in (0, 180); large enough that
//                                   neighbouring pixels' rays are kMinPixelAngle apart (0.028 at 512
//                                   pixels high), and that the default camera stays within
//                                   ±kMaxDefaultCameraCoordinate
//     width, height [512, 512]      pixels, each 1…16384, width·height <= 2^26
//   render       optional object
//     mode         ["full"]         "basic" | "simple-shadow" | "full" (thesis 3.2)
//     cutoff       [0]              optical-depth cutoff point, hits per particle (4.4.3); 0 = none
//     groups       [1]              particle groups: 1/groups of the particles' optical depths are updated
//                                   per frame (4.4.2); 1…1048576
//     frames       [1]              frames to render; 1…1000000
//     softness     [0.3]            soft-particle fade distance (Larsson 2010), world units; 0 = hard
//     transmittance_threshold [1/255]  the compositor stops once transmittance falls below this; [0, 1)
//     compositing  ["over"]         "over" (front-to-back over operator) | "thesis" (eq. 4.1 as published)
//
// Coordinates (particle centres, ground corners, camera position and look_at) lie within
// ±kMaxSceneCoordinate and radii are at most that, also after `frames` frames of motion (velocity, growth);
// colours (light, ambient, background, ground) are at most kMaxSceneColor.
// Every number must be finite and fit a float (1e999 and 1e39 are errors); subnormal floats (down to
// 1.4e-45) are read as they are; a number that rounds to 0 in float (1e-50) reads as 0 where 0 is allowed
// and is an error where the value must be > 0 (sizes, radii, fov_deg); radii (also tubes.particle_radius)
// are at least the smallest normal float. Directions (light.direction, camera.up) are normalised in double
// from the numbers as written. Integers must be written as integers (750, not 750.0); duplicate keys are
// errors; nesting deeper than 64 levels is an error.
// Particle counts above scene_particle_limit() are refused (kMaxSceneParticles, or fewer when this
// machine's memory cannot hold that many at kPeakBytesPerParticle each), a particle list as soon as the
// reader has counted past it. Errors are SceneFileError, "FILE: /json/path: problem", e.g.
//   scene.json: /smoke/particles/3/radius: must be > 0 (got -1)
// ------------------------------------------------------------------------------------------------------
//
// Defaults and why:
// * sigma_t 1: with the default tubes the in-smoke path along the lower tube is ~6 units and across a
//   tube ~2. σt = 1 leaves T = e^-2 ≈ 0.14 through the upper tube (a clear but not black shadow on the
//   lower tube, 5.1), e^-4 ≈ 0.02 under both tubes ("quite strong in the middle", 5.1c), and light that
//   fades along the lower tube but is still visible 3–4 units in (cutoffs 60 vs 80 differ only "at the
//   very leftmost edge", 5.2.3). σt = 2 would make all of those black.
// * alpha 0.5: the thesis's smoke hides the ground behind the tubes' cores but shows it through their
//   fringes. A view ray through a tube's core crosses ~15 billboards (n·πr²·2R); at a_p = 0.5 times a
//   texture alpha around 0.3–0.5 that leaves T ≈ 0.01–0.1, while the 2–3 layers at a fringe leave T ≈ 0.5.
// * ambient 0.05: keeps fully shadowed smoke (l over the cutoff) dark grey rather than black, as in 5.1b.
// * softness 0.3 ≈ the default particle radius 0.35: billboards fade out over about one particle radius
//   where they cut the ground.
// * transmittance_threshold 1/255: below it the remaining layers cannot change an 8-bit output by a step.
// * camera: see default_camera().
#include <smoketrace/smoke/particle_system.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/smoke/tube_generator.hpp>

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <smoketrace/core/image.hpp>

namespace smoketrace {

// Any problem with a scene file: the message names the file, the JSON path (or the byte, line and column
// for malformed JSON) and the problem.
class SceneFileError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// 50 million particles already need ~2.4 GB as Particle structs alone, before stand-ins, billboards, the
// BVHs and the hit lists (several times more); a larger count is almost surely a typo.
inline constexpr std::uint64_t kMaxSceneParticles = 50'000'000;
// Scene coordinates and radii: far beyond any sensible scene, yet small enough that nothing the pipeline
// derives in float overflows: squared distances between scene points (camera normalisation, box areas)
// stay below ~10^32, against FLT_MAX ≈ 3.4·10^38. A particle at 10^38 used to end in "Scene: instance 0 has
// a non-finite or empty world box", with no file or JSON path.
inline constexpr double kMaxSceneCoordinate = 1e15;
// A default camera (no camera.position) frames the smoke from outside it, so it may stand beyond
// kMaxSceneCoordinate: with the default view (45°, square image) every scene within the limits puts it
// within ~1.3·10^16. Up to 10^17 leaves room for narrower views and still keeps its squared distances
// below 10^35. A narrower field of view (or a tall, narrow image) that backs it off farther is an error.
inline constexpr double kMaxDefaultCameraCoordinate = 1e17;
// The smallest angle between the rays of neighbouring pixels (radians, about tan(fov/2)·2/height): 2^-20,
// 16 float steps (2^-24) of the unit view direction. Closer, the rounding of each ray's direction is a
// sizeable part of a pixel and neighbouring pixels merge into blocks: the field of view is too small.
inline constexpr double kMinPixelAngle = 0x1.0p-20;
// Colour components: the image clamps at 1, so 10^6 is far beyond any meaningful intensity, and products
// of three colours summed over layers (c_base·(c_light + c_amb), front-to-back sums) stay finite; light and
// ambient of 3·10^38 used to render infinite pixels, which the PNG writer then refused.
inline constexpr double kMaxSceneColor = 1e6;

// The most particles a scene may hold on this machine: kMaxSceneParticles, or machine_memory_bytes() /
// kPeakBytesPerParticle (memory_budget.hpp) when that is fewer.
[[nodiscard]] std::uint64_t scene_particle_limit();
// Largest image side: kMaxImageSide (image.hpp). Largest pixel count: 2^26 pixels of RGBA float are 1 GiB, the most a render may take.
inline constexpr std::uint64_t kMaxImagePixels = std::uint64_t{1} << 26;

struct LightDescription {
    glm::vec3 direction{0.0f, 1.0f, 0.0f};  // unit vector, scene → light
    glm::vec3 color{1.0f};
    float rotation_per_frame_deg = 0.0f;

    // The direction at frame `frame` (frame 0 = `direction`): rotated about +z by frame ·
    // rotation_per_frame_deg degrees, computed from the frame number in double (no drift accumulates).
    [[nodiscard]] glm::vec3 direction_at_frame(std::int64_t frame) const;
};

struct SmokeDescription {
    std::vector<Particle> particles;   // tubes already expanded; file order
    std::optional<TubeSettings> tubes; // set when the particles came from "tubes"
    float sigma_t = 1.0f;
    float alpha = 0.5f;
    StandInShape shape{};              // sphere
};

struct GroundDescription {
    std::array<glm::vec3, 4> corners{};  // counter-clockwise seen from the side `normal` points to
    glm::vec3 normal{0.0f, 1.0f, 0.0f};  // unit, derived from the corners' winding
    glm::vec3 color{0.8f, 0.1f, 0.1f};
};

struct CameraDescription {
    glm::vec3 position{0.0f, 0.0f, 10.0f};
    glm::vec3 look_at{0.0f};
    glm::vec3 up{0.0f, 1.0f, 0.0f};
    float fov_deg = 45.0f;  // vertical
    std::uint32_t width = 512;
    std::uint32_t height = 512;
};

enum class RenderMode : std::uint8_t { basic, simple_shadow, full };
enum class Compositing : std::uint8_t { over, thesis };

struct RenderSettings {
    RenderMode mode = RenderMode::full;
    std::uint32_t cutoff = 0;  // 0 = no cutoff
    std::uint32_t groups = 1;
    std::uint32_t frames = 1;
    float softness = 0.3f;
    float transmittance_threshold = 1.0f / 255.0f;
    Compositing compositing = Compositing::over;
};

struct SceneDescription {
    std::string source;  // the file name (or source name) it was read from, for messages
    LightDescription light;
    glm::vec3 ambient{0.05f};
    glm::vec3 background{0.53f, 0.81f, 0.92f};
    SmokeDescription smoke;
    std::optional<GroundDescription> ground;
    CameraDescription camera;
    RenderSettings render;
};

[[nodiscard]] const char* to_string(RenderMode m);    // "basic", "simple-shadow", "full"
[[nodiscard]] const char* to_string(Compositing c);   // "over", "thesis"

// The camera a scene gets without a "camera" object: looking at the centre of the particles' bounding
// sphere (of the ground's when there are no particles; the origin when there is neither) from the front
// (+z) and a little above, at the distance where that sphere fits the narrower field of view with a margin.
[[nodiscard]] CameraDescription default_camera(const std::vector<Particle>& particles,
                                               const std::optional<GroundDescription>& ground,
                                               float fov_deg, std::uint32_t width, std::uint32_t height);

// Throws SceneFileError, naming the particle's JSON path (/smoke/particles/i, or /smoke/tubes), when a
// particle of `scene` would leave ±kMaxSceneCoordinate or grow beyond it within `frames` frames. parse_scene()
// checks the file's render.frames; a caller that renders more frames (--frames) checks again.
void check_scene_motion(const SceneDescription& scene, std::uint32_t frames);

// Parses and validates; throws SceneFileError. `source_name` is used in messages only.
[[nodiscard]] SceneDescription parse_scene(std::string_view json_text, std::string_view source_name);

// Reads the file and parse_scene()s it, naming the file as given in messages; throws SceneFileError also
// when the file cannot be read.
[[nodiscard]] SceneDescription load_scene_file(const std::filesystem::path& path);

}  // namespace smoketrace
