#pragma once
// Point clouds in PLY files (Greg Turk's polygon file format), as Houdini and Blender export particles: the
// `vertex` element's x, y, z and radius properties, and its vx, vy, vz (a velocity) when all three are there.
// Other properties and other elements are skipped. binary_little_endian, binary_big_endian and ascii 1.0;
// every scalar type (char … double, or int8 … float64). A scene file names such a file as its particle list
// (docs/scene-format.md); this reader only decodes it, the scene file checks each value.
//
// The vertices are read in pieces, each on its own from its own offset in the file, so that threads can read
// them at once: PlyPointReader reads the header and cuts the vertices into pieces, a
// PlyPointReader::PieceReader per thread reads them. The pieces depend on the file alone, never on the
// thread count.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace smoketrace {

// The longest header read: a PLY header is a few hundred bytes of keywords, names and comments, so 1 MiB is
// generous; a longer one (endless comment lines) is refused, not read to the end of the file.
inline constexpr std::uint64_t kMaxPlyHeaderBytes = std::uint64_t(1) << 20;

// About how many bytes of the file a piece of vertices takes: large enough that starting a piece costs
// nothing next to reading it, small enough that the pieces of a large cloud share out evenly among threads.
inline constexpr std::uint64_t kPlyPieceBytes = std::uint64_t(1) << 18;

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

// Consecutive vertices that can be read apart from the others: vertices [first_vertex, first_vertex +
// vertex_count), whose data begins at byte `offset`.
struct PlyPiece {
    std::uint64_t first_vertex = 0, vertex_count = 0;
    std::uint64_t offset = 0;
    std::uint64_t skip_values = 0;  // ascii: the values from `offset` on that come before its first vertex's
};

// Reads the header on construction; pieces() then checks the header's counts against the file and cuts the
// vertices into pieces, which PieceReaders read (on any threads, in any order), and finish() checks what
// follows the last vertex. A problem is reported where a reader from the start of the file would meet it
// first: a caller that keeps each piece's first problem and raises the first piece's, then finish()'s,
// reports what a serial reader would.
class PlyPointReader {
public:
    // Opens `path` and reads its header; `name` is how messages name the file. Throws PlyError: not a regular
    // file, no PLY header, a header longer than kMaxPlyHeaderBytes, an unsupported format, no vertex element
    // or two of them, no x, y, z or radius property, only part of vx, vy, vz, a list property in or before
    // the vertex element; ascii: the lines of the elements before vertex end early.
    PlyPointReader(const std::filesystem::path& path, std::string name);
    ~PlyPointReader();
    PlyPointReader(const PlyPointReader&) = delete;
    PlyPointReader& operator=(const PlyPointReader&) = delete;

    [[nodiscard]] std::uint64_t vertex_count() const { return vertex_count_; }
    [[nodiscard]] bool has_velocity() const { return velocity_; }
    [[nodiscard]] const std::string& name() const { return name_; }

    // The vertices in pieces of about kPlyPieceBytes, in file order, each vertex in one of them; call once.
    // First holds the header against the file, so that vertex_count() can be trusted to size a buffer after
    // it, and throws PlyError: binary, the file is shorter than the header's elements (truncated) or longer
    // (trailing data), checked from its size; ascii, the rest of the file cannot hold the vertex count as
    // text. Ascii: the file's values are counted, its parts in parallel (on the calling thread's TBB arena),
    // so that each piece knows which value is its first vertex's; pieces then cover only the vertices whose
    // data begins in the file, and finish() reports the others missing.
    [[nodiscard]] std::vector<PlyPiece> pieces();

    // After every piece has been read: throws PlyError when an ascii file's data ends before its last
    // vertex, or when the lines after that vertex are not those of the header's elements after it (binary
    // files were checked whole by pieces()).
    void finish() const;

    // Reads pieces of a reader's file, one at a time; one per thread, kept from piece to piece (it keeps its
    // buffer). The reader must outlive it.
    class PieceReader {
    public:
        explicit PieceReader(const PlyPointReader& reader) : reader_(&reader) {}

        // Begins reading `piece` (one of reader.pieces()).
        void start(const PlyPiece& piece);
        // Fills `out` with the piece's next vertices; returns how many, 0 after its last. A vertex that cannot
        // be read ends the batch before it, and the next call throws PlyError for it (so the vertices before
        // it can be checked first): the data ends early (the file shrank since pieces() measured it, or an
        // ascii file has too few values), an ascii value is not a number its declared type holds (a uchar of
        // 300 or 0.5), or the file cannot be read.
        std::size_t read(std::span<PlyPoint> out);

    private:
        friend class PlyPointReader;
        std::size_t read_binary(std::span<PlyPoint> out);
        std::size_t read_ascii(std::span<PlyPoint> out);
        // Ascii: the file's text from byte `offset` on, a value at a time; next_value() is false at the end
        // of the file, its view valid until the next call.
        void start_text(std::uint64_t offset);
        bool next_value(std::string_view& value);
        bool read_more(std::size_t keep_from);

        const PlyPointReader* reader_;
        std::uint64_t next_vertex_ = 0, end_vertex_ = 0;
        // The file's byte at which the next read begins, that of buffer_[end_]; buffer_[pos_, end_) is read
        // from the file but not yet decoded (binary: whole vertices).
        std::uint64_t offset_ = 0;
        std::vector<unsigned char> buffer_;
        std::size_t pos_ = 0, end_ = 0;
        std::optional<std::string> pending_;  // the problem of the vertex that ended the last batch
    };

private:
    enum class Format { ascii, binary_little_endian, binary_big_endian };
    enum class Type : std::uint8_t { i8, u8, i16, u16, i32, u32, f32, f64 };
    struct Property {
        Type type;
        std::uint32_t offset;  // bytes into a binary vertex
    };
    // Ascii: a part of the file from `offset` on (the first value that begins in it), and the values before it.
    struct TextPart {
        std::uint64_t offset, values_before;
    };

    void read_header();
    void skip_elements_before_vertex();
    void check_binary_layout() const;
    void check_ascii_room() const;
    std::vector<PlyPiece> binary_pieces() const;
    std::vector<PlyPiece> ascii_pieces();
    [[noreturn]] void fail(const std::string& problem) const;
    [[nodiscard]] std::string truncated(std::uint64_t vertex) const;
    [[nodiscard]] std::uint64_t file_size() const;
    // pread() until `size` bytes or the end of the file; returns how many. Throws PlyError on a read error.
    std::size_t read_at(std::uint64_t offset, unsigned char* data, std::size_t size) const;

    std::string name_;
    struct CloseFile {
        void operator()(std::FILE* f) const { std::fclose(f); }
    };
    // Owned from the constructor's first line on, so that a header it refuses (it throws) closes the file.
    // The header is read through it, in order; the vertices at their offsets, by pread() on its descriptor.
    std::unique_ptr<std::FILE, CloseFile> file_;
    Format format_ = Format::ascii;
    std::uint64_t vertex_count_ = 0;
    std::uint32_t vertex_bytes_ = 0;     // binary: the size of one vertex
    std::uint32_t vertex_properties_ = 0;  // ascii: values per vertex
    bool velocity_ = false;
    // x, y, z, radius, vx, vy, vz; ascii: offset is the property's index among the vertex's values.
    Property wanted_[7]{};
    // Elements before "vertex": (count, bytes each; ascii: their count of lines) to skip.
    std::vector<std::pair<std::uint64_t, std::uint32_t>> before_;
    // Binary: byte offsets of the first vertex, the end of the vertices and of
    // all elements; nullopt where the header's counts overflow 64 bits. after_sized_: whether the elements
    // after vertex have a size (no list properties), so that data_end_ is where the file must end.
    std::optional<std::uint64_t> vertex_start_, vertex_end_, data_end_;
    bool after_sized_ = true;
    // Ascii: lines the elements after vertex take (nullopt: more than 2^64); where the values begin (after
    // the elements before vertex); the parts pieces() counted, and every value in the file.
    std::optional<std::uint64_t> after_lines_;
    std::uint64_t text_start_ = 0;
    std::vector<TextPart> text_parts_;
    std::uint64_t text_values_ = 0;
};

}  // namespace smoketrace
