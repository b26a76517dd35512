// A downstream program: the installed headers, the static library and every library it needs at link
// time (oneTBB for the parallel passes, stb to read the installed textures, zlib to write a PNG).
#include <smoketrace/io/png_io.hpp>
#include <smoketrace/io/sixway_files.hpp>
#include <smoketrace/render/sixway_texture.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/smoke/particle_groups.hpp>
#include <smoketrace/trace/trace.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>

using namespace smoketrace;

int main() {
    // trace(): a ray through two unit spheres crosses four surfaces.
    AccelScene scene;
    const auto ball = scene.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1}}, false));
    scene.add_instance({ball, AffineTransform::translate_scale({0, 0, 0}, 1)});
    scene.add_instance({ball, AffineTransform::translate_scale({4, 0, 0}, 1)});
    scene.commit();
    int surfaces = 0;
    trace(scene, Ray{{-5, 0, 0}, 0.0f, {1, 0, 0}}, ray_flag_none, 0xFF, [&](const TraceHit&) {
        ++surfaces;
        return AnyHitDecision::ignore;
    });

    // Optical depths (TBB): two particles of radius 1 stacked along the light; the lower one's ray leaves
    // its own particle (1) and crosses the upper one (2). Float distances below 10: 1e-4 is ample.
    std::vector<Particle> particles(2);
    particles[1].center = {0.0f, 3.0f, 0.0f};
    SmokeScene smoke(particles, StandInShape{StandInKind::sphere, 0}, std::nullopt, false);
    smoke.update(particles, glm::vec3(0.0f, 0.0f, 10.0f));
    OpticalPathLengths depths(particles.size());
    FrameTimings timings;
    depths.update(smoke, particles, particle_group(2, 1, 0), glm::vec3(0, 1, 0), {}, HitSort::adaptive, timings);
    const float l = depths.lengths()[0];

    // The installed textures (stb), and a PNG written (zlib).
    const SixwayTexture texture = load_sixway_texture(std::filesystem::path(SMOKETRACE_DATA_DIR) / kSixwayLayoutFile);
    write_png_srgb("downstream.png", ImageRgba(4, 3, glm::vec4(0.5f)));
    const Rgba8Image back = read_png_rgba8("downstream.png", 4, 3);

    const bool ok = surfaces == 4 && std::abs(l - 3.0f) <= 1e-4f && texture.frame_count() > 0 && back.width == 4;
    std::printf("surfaces %d (4), path length %.6f (3), texture frames %d, png %dx%d\ndownstream: %s\n", surfaces,
                double(l), texture.frame_count(), back.width, back.height, ok ? "ok" : "FAILED");
    return ok ? 0 : 1;
}
