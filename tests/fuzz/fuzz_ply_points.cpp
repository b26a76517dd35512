// libFuzzer target for the PLY point-cloud reader (PlyPointReader, ply_points.hpp), alone and through a scene
// file that names the cloud ("particles": "cloud.ply").
//
// Contract checked on every input:
//  * the reader either reads the file or throws PlyError whose message starts with the name it was given;
//    any other exception escapes and libFuzzer reports it as a crash, as are sanitizer findings;
//  * a file it reads gives exactly vertex_count() vertices: its pieces follow one another in file order
//    from vertex 0, each gives its vertex_count, and read() then returns 0;
//  * a binary file it reads holds at least 4 bytes (x, y, z, radius of the smallest type) per vertex it
//    declares: a header count cannot make the reader invent vertices the file does not hold;
//  * the scene file that names a cloud the reader read either loads or throws SceneFileError naming the
//    scene file (a cloud the reader refuses, the scene refuses with the reader's message: not run again).
//
// The reader takes a path (it reads the file in pieces, in batches), so each input is written to a file of
// this process's own in the temporary folder first. The pieces are read here in order, on this thread.
// Build and run: scripts/fuzz.sh (clang, -DSMOKETRACE_FUZZ=ON, build-fuzz/); seed corpus: tests/fuzz/corpus_ply/.
#include <smoketrace/io/ply_points.hpp>
#include <smoketrace/io/scene_file.hpp>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include <unistd.h>

using namespace smoketrace;

namespace {

constexpr std::string_view kName = "fuzz.ply";

[[noreturn]] void violated(const char* what, const std::string& detail = {}) {
    std::fprintf(stderr, "fuzz_ply_points: %s %s\n", what, detail.c_str());
    std::abort();
}

const std::filesystem::path& folder() {
    static const std::filesystem::path path = [] {
        auto p = std::filesystem::temp_directory_path() / ("smoketrace_fuzz_ply_" + std::to_string(::getpid()));
        std::filesystem::create_directories(p);
        return p;
    }();
    return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::filesystem::path cloud = folder() / "cloud.ply";
    std::ofstream(cloud, std::ios::binary | std::ios::trunc)
        .write(reinterpret_cast<const char*>(data), std::streamsize(size));
    try {
        PlyPointReader reader(cloud, std::string(kName));
        const bool binary = std::string_view(reinterpret_cast<const char*>(data), size).find("format ascii") ==
                            std::string_view::npos;
        // Odd-sized batches, so that the last one is partial and the batch boundaries move.
        std::vector<PlyPoint> batch(7);
        PlyPointReader::PieceReader piece(reader);
        std::uint64_t read = 0;
        for (const PlyPiece& p : reader.pieces()) {
            if (p.first_vertex != read || p.vertex_count == 0) violated("pieces out of order, overlapping or empty");
            piece.start(p);
            std::uint64_t in_piece = 0;
            while (const std::size_t n = piece.read(batch)) {
                if (n > batch.size()) violated("read() returned more than asked for");
                in_piece += n;
                if (in_piece > p.vertex_count) violated("more vertices than the piece holds");
            }
            if (in_piece != p.vertex_count) violated("fewer vertices than the piece holds");
            if (piece.read(batch) != 0) violated("read() after the piece's last vertex returned vertices");
            read += in_piece;
        }
        reader.finish();
        if (read != reader.vertex_count()) violated("fewer vertices than the header declares");
        if (binary && reader.vertex_count() > size / 4) violated("a binary file declares more vertices than it holds");
    } catch (const PlyError& e) {
        if (std::string_view(e.what()).rfind(std::string(kName) + ": ", 0) != 0)
            violated("error message without the file name:", e.what());
        return 0;
    }
    const std::string scene =
        R"({ "light": { "direction": [0, 1, 0] }, "smoke": { "particles": "cloud.ply" } })";
    const std::string scene_name = (folder() / "scene.json").string();
    try {
        (void)parse_scene(scene, scene_name);
    } catch (const SceneFileError& e) {
        if (std::string_view(e.what()).rfind(scene_name + ": ", 0) != 0)
            violated("scene error message without the file name:", e.what());
    }
    return 0;
}
