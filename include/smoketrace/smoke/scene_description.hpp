#pragma once
// The plain data a scene becomes (light, smoke, ground, camera, render settings): what the renderer
// takes, whoever made it. io/scene_file.hpp reads it from a scene file, with the format and its
// defaults in docs/scene-format.md; a program may also fill it in directly. A description, not a render
// type: it lives beside the particles, so that `depths` and the optical-depth pass need nothing of render/.
#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/particle_system.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/smoke/tube_generator.hpp>

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace smoketrace {

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
    std::string particle_file;         // the PLY file they came from, as messages name it; else empty
    float sigma_t = 1.0f;
    float alpha = 0.5f;
    StandInShape shape{};              // sphere
    // The stand-ins' density (density_kernel.hpp): poly1, the kernel the error study against the ground truth
    // recommends (docs/accuracy.md); kUniformKernel is the thesis's balls (eq. 3.1).
    DensityKernel kernel = kPoly1Kernel;
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

// Throws std::invalid_argument ("camera: …") unless a pinhole camera can be set up from these: an image of at
// least 1x1, fov_deg in (0, 180), look_at apart from position, and up at least 1e-6 (as a sine) off the view
// direction, in double. The checks of render's Camera, which calls this: the scene reader calls it too, so
// that a scene that reads fine also renders.
void validate_camera(const glm::vec3& position, const glm::vec3& look_at, const glm::vec3& up, float fov_deg,
                     int width, int height);

// The most samples per pixel (render.spp, --spp). 64 covers an edge in steps of 1/64 of a pixel, already
// fine for an 8-bit image; each sample costs a full pixel's rays, so the bound also keeps a typo (640) from
// making a render hundreds of times slower.
inline constexpr int kMaxSpp = 64;

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
    std::uint32_t spp = 1;  // samples per pixel, 1…kMaxSpp (render/pixel_samples.hpp); 1 = the pixel's centre
    std::uint32_t fps = 24;  // frames per second of an animated PNG of the sequence (the film rate)
};

struct SceneDescription {
    std::string source;  // the file name (or source name) it was read from, for messages
    // The scene's origin in world coordinates, in double: everything below that is a position (particle
    // centres, the tubes' centre, the ground's corners, the camera's position and look_at) is relative to it.
    // Single-precision positions near this point keep the precision the file had wherever the scene is
    // (a float at 10^6 is 1/16 off; relative to an origin nearby, 10^-7); world = origin + position, added in
    // double. Directions, speeds and sizes need no origin. docs/scene-format.md says how a file sets it.
    glm::dvec3 origin{0.0};
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

}  // namespace smoketrace
