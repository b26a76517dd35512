#pragma once
// Scene files: JSON in, plain data (SceneDescription) out, with strict validation at the boundary.
// The format, every key's default and range, and why each default is what it is: docs/scene-format.md.
// Conventions: y is up, every speed is per frame. A SceneDescription from parse_scene() holds only checked
// values (finite, within kMaxSceneCoordinate / kMaxSceneColor, at most scene_particle_limit() particles);
// every problem is a SceneFileError reading "FILE: /json/path: problem". The file's positions are world
// coordinates, read in double; the SceneDescription holds them relative to its `origin` (the file's
// "origin", else one near the first particle or the tubes' centre: docs/scene-format.md). The particles may
// also come from a PLY point cloud the file names ("particles": "cloud.ply", ply_points.hpp), read through
// the same checks; its problems name the PLY file, the vertex and the property.
#include <smoketrace/smoke/scene_description.hpp>
#include <smoketrace/smoke/particle_system.hpp>

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
// The longest scene file read (4 GiB): a list of 10^7 particles is about 1 GB in the form the generators write
// and stays within it at 400 bytes a particle. A longer file (or a FIFO or device that goes on longer) is
// refused by its size, before it fills memory; larger clouds belong in a PLY file.
inline constexpr std::uint64_t kMaxSceneFileBytes = std::uint64_t(1) << 32;
// Scene coordinates (world coordinates, as the file gives them) and radii: far beyond any sensible scene,
// yet small enough that nothing the pipeline derives in float overflows: squared distances between scene
// points (camera normalisation, box areas; stored relative to the origin, within 2·10^15) stay below
// ~10^32, against FLT_MAX ≈ 3.4·10^38. Past it a particle would fail deep in the pipeline (a non-finite
// world box) with no file or JSON path in the message.
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
// render.frames: ~4.6 h at 60 fps; anything more is a typo.
inline constexpr std::uint32_t kMaxSceneFrames = 1'000'000;
// render.fps, the frame rate an animated PNG plays at: a screen shows at most one frame per refresh (60 Hz
// on most), and browsers play a frame of 10 ms or less for 100 ms, so more would play slower, not faster.
inline constexpr std::uint32_t kMaxSceneFps = 60;
// Colour components: the image clamps at 1, so 10^6 is far beyond any meaningful intensity, and products
// of three colours summed over layers (c_base·(c_light + c_amb), front-to-back sums) stay finite, where light
// and ambient near FLT_MAX would render infinite pixels that the PNG writer refuses.
inline constexpr double kMaxSceneColor = 1e6;

// The most particles a scene may hold on this machine: kMaxSceneParticles, or machine_memory_bytes() /
// kPeakBytesPerParticle (memory_budget.hpp) when that is fewer.
[[nodiscard]] std::uint64_t scene_particle_limit();
// The camera a scene gets without a "camera" object (in the frame of the particles and the ground it is
// given, the scene's): looking at the centre of the particles' bounding
// sphere (of the ground's when there are no particles; the origin when there is neither) from the front
// (+z) and a little above, at the distance where that sphere fits the narrower field of view with a margin.
[[nodiscard]] CameraDescription default_camera(const std::vector<Particle>& particles,
                                               const std::optional<GroundDescription>& ground,
                                               float fov_deg, std::uint32_t width, std::uint32_t height);

// Throws SceneFileError, naming the particle's JSON path (/smoke/particles/i, or /smoke/tubes), when a
// particle of `scene` would leave ±kMaxSceneCoordinate or grow beyond it within `frames` frames. parse_scene()
// checks the file's render.frames; a caller that renders more frames (--frames) checks again.
void check_scene_motion(const SceneDescription& scene, std::uint32_t frames);

// Empty when a camera of vertical field of view `fov_deg` at `height` pixels puts neighbouring pixels' rays at
// least kMinPixelAngle apart; else why not, with the smallest fov_deg that would do. parse_scene() checks the
// file's camera; a caller that changes the image height (render --size) checks again.
[[nodiscard]] std::string pixel_angle_problem(float fov_deg, std::uint32_t height);

// How parse_scene() reads the JSON. `automatic`: a particle list (/smoke/particles) is read by the fast reader
// (simdjson's On-Demand API, straight from the text: no tree, no path string per value) and the rest of the
// document by the reference reader (nlohmann: a scan for duplicate keys, overflowing numbers, nesting and the
// particle limit, then a tree). Any problem at all sends the whole document back to the reference reader, so
// that every message is the reference's, word for word. `fast` and `reference` take one path only (`fast`
// reports "the fast reader declined" where it would hand over): tests and the fuzzer hold the two to the
// same results with them.
enum class SceneJsonReader { automatic, fast, reference };

// Parses and validates; throws SceneFileError. `source_name` names the file in messages, and its folder is
// where a particle file ("particles": "cloud.ply") is found.
[[nodiscard]] SceneDescription parse_scene(std::string_view json_text, std::string_view source_name,
                                           SceneJsonReader reader = SceneJsonReader::automatic);

// Reads the file and parse_scene()s it, naming the file as given in messages; throws SceneFileError also
// when the file cannot be read, is longer than kMaxSceneFileBytes, or cannot be a JSON object (a NUL byte, a
// first non-blank byte other than '{'), the last two found without reading further than the bound or the
// offending byte.
[[nodiscard]] SceneDescription load_scene_file(const std::filesystem::path& path);

}  // namespace smoketrace
