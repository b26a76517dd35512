// One frame of the smoke renderer, from a scene file to a PNG: the whole pipeline (optical depths, view
// pass) as the command line's `smoketrace render` runs it, in a dozen calls.
//
//   render_frame SCENE.json ASSETS_DIR OUT.png WIDTHxHEIGHT
// ASSETS_DIR holds the six-way textures (sixway.json and its PNGs): assets/ in the source tree,
// <prefix>/share/smoketrace once installed.
#include <smoketrace/io/png_io.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>
#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/render/sixway_texture.hpp>

#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>

using namespace smoketrace;

int main(int argc, char** argv) {
    if (argc != 5) {
        std::fprintf(stderr, "usage: render_frame SCENE.json ASSETS_DIR OUT.png WIDTHxHEIGHT\n");
        return 2;
    }
    try {
        // The scene file: particles, light, ground, camera and render settings (see the README's schema).
        const SceneDescription scene = load_scene_file(argv[1]);
        // The billboards' six-way lit smoke puff, baked by `smoketrace bake-sixway`.
        const SixwayTexture texture = load_sixway_texture(std::filesystem::path(argv[2]) / kSixwayLayoutFile);

        // The scene's own settings, with the image size from the command line.
        RenderOptions options = RenderOptions::from_scene(scene);
        if (std::sscanf(argv[4], "%dx%d", &options.width, &options.height) != 2 || options.width < 1 ||
            options.height < 1 || options.width > 4096 || options.height > 4096) {
            std::fprintf(stderr, "render_frame: '%s' is not WIDTHxHEIGHT (1…4096 each)\n", argv[4]);
            return 2;
        }

        // The renderer keeps the scene's acceleration structures and optical depths from frame to frame;
        // frame 0 builds them. The image is linear RGB; the PNG writer turns it into 8-bit sRGB.
        FrameRenderer renderer(scene, options, texture);
        ImageRgba image;
        const FrameReport report = renderer.render(0, image);
        write_png_srgb(argv[3], image);

        std::printf("wrote %s, %dx%d, in %.1f ms (optical depths %.1f ms, view %.1f ms)\n", argv[3], image.width,
                    image.height, report.timings.total, report.timings.od_pass + report.timings.resolve,
                    report.timings.view);
        return 0;
    } catch (const std::exception& e) {  // a bad scene file or texture: the message names the file and field
        std::fprintf(stderr, "render_frame: %s\n", e.what());
        return 1;
    }
}
