#pragma once
// Point clouds in PLY files (Greg Turk's polygon file format), as Houdini and Blender export particles: the
// `vertex` element's x, y, z and radius properties, and its vx, vy, vz (a velocity) when all three are there.
// Other properties and other elements are skipped. binary_little_endian, binary_big_endian and ascii 1.0;
// every scalar type (char … double, or int8 … float64). A scene file names such a file as its particle list
// (docs/scene-format.md); this reader only decodes it, the scene file checks each value.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace smoketrace {

// The longest header read: a PLY header is a few hundred bytes of keywords, names and comments, so 1 MiB is
// generous; a longer one (endless comment lines) is refused, not read to the end of the file.
inline constexpr std::uint64_t kMaxPlyHeaderBytes = std::uint64_t(1) << 20;

// A PLY file that cannot be read: the message names the file, the element, property or vertex, and the problem.
class PlyError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// One vertex as the file gives it, in double (a float property converts exactly).
struct PlyPoint {
    double x = 0.0, y = 0.0, z = 0.0, radius = 0.0;
    double vx = 0.0, vy = 0.0, vz = 0.0;  // 0 without velocity properties
};

// Reads the header on construction, then the vertices in order, a batch at a time, so that a cloud of any size
// is read with a fixed buffer.
class PlyPointReader {
public:
    // Opens `path` and reads its header; `name` is how messages name the file. Throws PlyError: not a regular
    // file, no PLY header, a header longer than kMaxPlyHeaderBytes, an unsupported format, no vertex element
    // or two of them, no x, y, z or radius property, only part of vx, vy, vz, a list property in or before
    // the vertex element.
    PlyPointReader(const std::filesystem::path& path, std::string name);
    ~PlyPointReader();
    PlyPointReader(const PlyPointReader&) = delete;
    PlyPointReader& operator=(const PlyPointReader&) = delete;

    [[nodiscard]] std::uint64_t vertex_count() const { return vertex_count_; }
    [[nodiscard]] bool has_velocity() const { return velocity_; }
    [[nodiscard]] const std::string& name() const { return name_; }

    // Fills `out` with the next vertices; returns how many (fewer than out.size() only at the last vertex,
    // 0 after it). Throws PlyError when the data ends early, when more data follows than the header declares
    // (binary: checked from the file's size before the first vertex; ascii: when the last vertex is read),
    // when the file is too short for the vertex count (checked at the first call, so that vertex_count() can
    // be trusted to size a buffer after it), or when an ascii value is not a number its declared type holds
    // (a uchar of 300 or 0.5).
    std::size_t read(std::span<PlyPoint> out);

private:
    enum class Format { ascii, binary_little_endian, binary_big_endian };
    enum class Type : std::uint8_t { i8, u8, i16, u16, i32, u32, f32, f64 };
    struct Property {
        Type type;
        std::uint32_t offset;  // bytes into a binary vertex
    };

    void read_header();
    void skip_elements_before_vertex();
    void check_binary_layout();
    void check_ascii_room();
    void check_ascii_end();
    [[noreturn]] void fail(const std::string& problem) const;
    [[noreturn]] void truncated(std::uint64_t vertex) const;
    std::size_t read_binary(std::span<PlyPoint> out);
    std::size_t read_ascii(std::span<PlyPoint> out);
    bool ascii_token(std::string& token);

    std::string name_;
    struct CloseFile {
        void operator()(std::FILE* f) const { std::fclose(f); }
    };
    // Owned from the constructor's first line on, so that a header it refuses (it throws) closes the file.
    std::unique_ptr<std::FILE, CloseFile> file_;
    Format format_ = Format::ascii;
    std::uint64_t vertex_count_ = 0, next_vertex_ = 0;
    std::uint32_t vertex_bytes_ = 0;     // binary: the size of one vertex
    std::uint32_t vertex_properties_ = 0;  // ascii: tokens per vertex
    bool velocity_ = false;
    // x, y, z, radius, vx, vy, vz; ascii: offset is the property's token index.
    Property wanted_[7]{};
    // Elements before "vertex": (count, bytes each; ascii: their count of lines) to skip.
    std::vector<std::pair<std::uint64_t, std::uint32_t>> before_;
    std::vector<unsigned char> buffer_;
    // Binary: byte offsets of the first vertex, the end of the vertices and of
    // all elements; nullopt where the header's counts overflow 64 bits. after_sized_: whether the elements
    // after vertex have a size (no list properties), so that data_end_ is where the file must end.
    std::optional<std::uint64_t> vertex_start_, vertex_end_, data_end_;
    bool after_sized_ = true;
    // Ascii: lines the elements after vertex take (nullopt: more than 2^64).
    std::optional<std::uint64_t> after_lines_;
    bool started_ = false, ended_ = false;
};

}  // namespace smoketrace
