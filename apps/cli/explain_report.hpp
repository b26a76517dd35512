#pragma once
// smoketrace explain's output: a story of the library (optical_depth_story.hpp, pixel_story.hpp) as text for
// the terminal and as an SVG diagram that reads without the text. Presentation only: every number comes
// from the story.
#include <smoketrace/render/pixel_story.hpp>
#include <smoketrace/smoke/optical_depth_story.hpp>

#include <cstdint>
#include <ostream>
#include <span>
#include <string>

namespace smoketrace::cli {

// Numbers as the text prints them: a float as the shortest text that reads back as it (`depths` writes l
// alike), any other double as %.9g.
std::string format_number(double v);

// Positions are printed in world coordinates: `origin` (the scene's, SceneDescription::origin) plus the
// stored position, added in double.
void write_particle_text(std::ostream& out, const OpticalDepthStory& story, std::span<const Particle> particles,
                         const std::string& scene_name, const char* shape_name, const glm::dvec3& origin);
void write_particle_svg(std::ostream& out, const OpticalDepthStory& story, const std::string& scene_name);

// `rendered`: the pixel the frame's render_view() wrote, shown beside the explained one; `frame`: which frame
// of the sequence the story is of.
void write_pixel_text(std::ostream& out, const PixelStory& story, const glm::vec3& rendered,
                      const std::string& scene_name, std::uint64_t frame, const glm::dvec3& origin);
void write_pixel_svg(std::ostream& out, const PixelStory& story, const std::string& scene_name, std::uint64_t frame);
// The pixel beside its ground truth (truth/ground_truth.hpp): both in linear radiance and 8-bit sRGB, and the
// frame's error, frame − truth. `spp`, `tolerance`: the truth's settings, named in the text.
void write_pixel_truth_text(std::ostream& out, const glm::vec3& frame_pixel, const glm::vec3& truth_pixel, int spp,
                            float tolerance);

}  // namespace smoketrace::cli
