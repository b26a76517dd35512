#pragma once
// Scene files: JSON in, plain data (SceneDescription) out, with strict validation at the boundary.
// The format, every key's default and range, and why each default is what it is: docs/scene-format.md.
// Conventions: y is up, every speed is per frame. A SceneDescription from parse_scene() holds only checked
// values (finite, within kMaxSceneCoordinate / kMaxSceneColor, at most scene_particle_limit() particles);
// every problem is a SceneFileError reading "FILE: /json/path: problem".
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
