// PLY point clouds (see ply_points.hpp). The header is a few lines of text, read in order. The vertices are
// read in pieces by pread() at their offsets into the piece reader's buffer, each wanted property decoded
// from its offset (binary) or its index among the vertex's values (ascii): a binary file's bytes are copied
// once, into a buffer a thread reuses (an ascii file's twice: its values are counted first), and no
// allocation happens per vertex.
#include <smoketrace/io/ply_points.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <iterator>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>

#include <sys/stat.h>
#include <unistd.h>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

namespace smoketrace {

namespace {

// The bytes a piece reader reads per pread(): a binary piece at once (kPlyPieceBytes), which stays in cache
// while its batches are decoded. A binary vertex larger than this (a header may give it thousands of
// properties) is read one at a time; an ascii value longer than this grows the buffer.
constexpr std::size_t kReadBytes = std::size_t(kPlyPieceBytes);
// The longest header line we accept: a PLY header line is a keyword and a few names.
constexpr std::size_t kMaxHeaderLine = 4096;

constexpr std::array<std::string_view, 7> kWantedNames = {"x", "y", "z", "radius", "vx", "vy", "vz"};

// a * b and a + b, or nullopt where the result would not fit in 64 bits: header values become sizes and
// offsets only through these.
std::optional<std::uint64_t> checked_product(std::uint64_t a, std::uint64_t b) {
    std::uint64_t r;
    if (__builtin_mul_overflow(a, b, &r)) return std::nullopt;
    return r;
}
std::optional<std::uint64_t> checked_sum(std::optional<std::uint64_t> a, std::optional<std::uint64_t> b) {
    std::uint64_t r;
    if (!a || !b || __builtin_add_overflow(*a, *b, &r)) return std::nullopt;
    return r;
}

std::string trimmed(std::string line) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.pop_back();
    return line;
}

// White space between ascii values, as std::isspace() in the C locale, whatever locale the program set.
constexpr bool ascii_space(unsigned char c) {
    return c == ' ' || c == '\t' || c == '\n' || c == '\v' || c == '\f' || c == '\r';
}

template <class T>
T load(const unsigned char* p, bool swap) {
    using Bits = std::conditional_t<sizeof(T) == 1, std::uint8_t,
                 std::conditional_t<sizeof(T) == 2, std::uint16_t,
                 std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>>>;
    Bits bits;
    std::memcpy(&bits, p, sizeof bits);
    if (swap) {
        if constexpr (sizeof(T) == 2) bits = __builtin_bswap16(bits);
        else if constexpr (sizeof(T) == 4) bits = __builtin_bswap32(bits);
        else if constexpr (sizeof(T) == 8) bits = __builtin_bswap64(bits);
    }
    return std::bit_cast<T>(bits);
}

// An ascii value as its declared type holds it (`type`: PlyPointReader::Type's order), or why it cannot be:
// a binary file cannot give a uchar of 300 or 0.5, so an ascii one is refused too, not read as something
// else. The value stays as written (a float's decimal is not rounded to float here: the scene file's
// checks round every value alike).
const char* ascii_value(std::string_view token, int type, double& value) {
    const char* end = token.data() + token.size();
    if (type <= 5) {  // the integer types, char … uint
        constexpr std::int64_t kMin[] = {-128, 0, -32768, 0, -2147483648LL, 0};
        constexpr std::int64_t kMax[] = {127, 255, 32767, 65535, 2147483647, 4294967295LL};
        std::int64_t whole = 0;
        const auto [stop, error] = std::from_chars(token.data(), end, whole);
        if (stop != end || (error != std::errc() && error != std::errc::result_out_of_range)) {
            double any = 0.0;
            const auto [number_end, number_error] = std::from_chars(token.data(), end, any);
            return number_end == end && number_error == std::errc() ? "not a whole number, as its integer type needs"
                                                                    : "not a number";
        }
        if (error == std::errc::result_out_of_range || whole < kMin[type] || whole > kMax[type]) {
            constexpr const char* kRanges[] = {
                "out of range for char (-128 to 127)",        "out of range for uchar (0 to 255)",
                "out of range for short (-32768 to 32767)",   "out of range for ushort (0 to 65535)",
                "out of range for int (-2147483648 to 2147483647)", "out of range for uint (0 to 4294967295)"};
            return kRanges[type];
        }
        value = double(whole);
        return nullptr;
    }
    // from_chars reads nan and inf too; the scene file's checks refuse them by name.
    const auto [stop, error] = std::from_chars(token.data(), end, value);
    if (error != std::errc() || stop != end) return "not a number";
    // The float type: a finite decimal that rounds to infinity as a float (from FLT_MAX plus half its last
    // place on) is out of range, as a double is for from_chars.
    if (type == 6 && std::isfinite(value) && std::abs(value) >= 0x1.ffffffp127) return "out of range for float";
    return nullptr;
}

}  // namespace

PlyPointReader::PlyPointReader(const std::filesystem::path& path, std::string name) : name_(std::move(name)) {
    std::error_code ec;
    // Only regular files: a FIFO or a device named by a scene would block or never end.
    if (!std::filesystem::is_regular_file(path, ec)) {
        if (!std::filesystem::exists(path, ec)) fail("cannot open the file for reading (it does not exist)");
        fail("is not a regular file");
    }
    file_.reset(std::fopen(path.c_str(), "rb"));
    if (!file_) fail("cannot open the file for reading");
    read_header();
    skip_elements_before_vertex();
}

PlyPointReader::~PlyPointReader() = default;

void PlyPointReader::fail(const std::string& problem) const { throw PlyError(name_ + ": " + problem); }

std::string PlyPointReader::truncated(std::uint64_t vertex) const {
    return "truncated: the header declares " + std::to_string(vertex_count_) + " vertices, the data ends in vertex " +
           std::to_string(vertex);
}

std::uint64_t PlyPointReader::file_size() const {
    struct stat info{};
    if (::fstat(fileno(file_.get()), &info) != 0) fail("cannot read the file");
    return std::uint64_t(info.st_size);
}

std::size_t PlyPointReader::read_at(std::uint64_t offset, unsigned char* data, std::size_t size) const {
    std::size_t got = 0;
    while (got < size) {
        // (offset + got is at most the file's size, an off_t, or pieces() would have refused the header)
        const ssize_t n = ::pread(fileno(file_.get()), data + got, size - got, off_t(offset + got));
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) fail("cannot read the file");
        if (n == 0) break;
        got += std::size_t(n);
    }
    return got;
}

void PlyPointReader::read_header() {
    std::uint64_t header_bytes = 0;
    auto next_line = [&](std::string& line) {
        line.clear();
        for (int c; (c = std::fgetc(file_.get())) != EOF;) {
            if (++header_bytes > kMaxPlyHeaderBytes)
                fail("the header is longer than " + std::to_string(kMaxPlyHeaderBytes) + " bytes");
            if (c == '\n') return true;
            if (line.size() >= kMaxHeaderLine)
                fail("header line longer than " + std::to_string(kMaxHeaderLine) + " bytes");
            line.push_back(char(c));
        }
        return false;
    };
    std::string line;
    if (!next_line(line) || trimmed(line) != "ply") fail("not a PLY file (it does not begin with the line \"ply\")");

    struct Element {
        std::string name;
        std::uint64_t count;
        bool has_list = false;
        std::uint32_t bytes = 0, properties = 0;
    };
    std::vector<Element> elements;
    bool format_seen = false;
    std::array<int, 7> found;
    found.fill(-1);
    std::array<Type, 7> found_type{};
    std::array<std::uint32_t, 7> found_token{};
    while (true) {
        if (!next_line(line)) fail("truncated header (no end_header line)");
        std::istringstream words(trimmed(line));
        std::string keyword;
        words >> keyword;
        if (keyword == "end_header") break;
        if (keyword.empty() || keyword == "comment" || keyword == "obj_info") continue;
        if (keyword == "format") {
            std::string format, version;
            words >> format >> version;
            if (format == "ascii") format_ = Format::ascii;
            else if (format == "binary_little_endian") format_ = Format::binary_little_endian;
            else if (format == "binary_big_endian") format_ = Format::binary_big_endian;
            else fail("unsupported format \"" + format + "\" (use ascii, binary_little_endian or binary_big_endian)");
            if (version != "1.0") fail("unsupported format version \"" + version + "\" (only 1.0)");
            format_seen = true;
        } else if (keyword == "element") {
            std::string element_name, count_text;
            words >> element_name >> count_text;
            std::uint64_t count = 0;
            const auto [end, error] = std::from_chars(count_text.data(), count_text.data() + count_text.size(), count);
            if (error != std::errc() || end != count_text.data() + count_text.size())
                fail("element " + element_name + ": the count \"" + count_text + "\" is not a whole number");
            if (element_name == "vertex" &&
                std::any_of(elements.begin(), elements.end(), [](const Element& e) { return e.name == "vertex"; }))
                fail("element vertex appears twice in the header (which would be the particles?)");
            elements.push_back({element_name, count});
        } else if (keyword == "property") {
            if (elements.empty()) fail("property before any element");
            Element& e = elements.back();
            std::string type_name, property_name;
            words >> type_name;
            if (type_name == "list") {
                e.has_list = true;
                ++e.properties;
                continue;
            }
            words >> property_name;
            static constexpr std::pair<std::string_view, Type> kTypes[] = {
                {"char", Type::i8},    {"int8", Type::i8},     {"uchar", Type::u8},    {"uint8", Type::u8},
                {"short", Type::i16},  {"int16", Type::i16},   {"ushort", Type::u16},  {"uint16", Type::u16},
                {"int", Type::i32},    {"int32", Type::i32},   {"uint", Type::u32},    {"uint32", Type::u32},
                {"float", Type::f32},  {"float32", Type::f32}, {"double", Type::f64},  {"float64", Type::f64}};
            const auto* type = std::find_if(std::begin(kTypes), std::end(kTypes),
                                            [&](const auto& t) { return t.first == type_name; });
            if (type == std::end(kTypes))
                fail("element " + e.name + ", property " + property_name + ": unknown type \"" + type_name + "\"");
            if (e.name == "vertex") {
                for (std::size_t w = 0; w < kWantedNames.size(); ++w) {
                    if (property_name != kWantedNames[w]) continue;
                    if (found[w] >= 0) fail("element vertex: property " + property_name + " appears twice");
                    found[w] = int(e.bytes);
                    found_type[w] = type->second;
                    found_token[w] = e.properties;
                }
            }
            // Within 32 bits: kMaxPlyHeaderBytes leaves room for some 10^5 properties of at most 8 bytes.
            static constexpr std::uint32_t kSizes[] = {1, 1, 2, 2, 4, 4, 4, 8};
            e.bytes += kSizes[int(type->second)];
            ++e.properties;
        } else {
            fail("unknown header line \"" + trimmed(line) + "\"");
        }
    }
    if (!format_seen) fail("the header has no format line");

    const auto vertex =
        std::find_if(elements.begin(), elements.end(), [](const Element& e) { return e.name == "vertex"; });
    if (vertex == elements.end()) fail("no element vertex (the particles are the vertices of a point cloud)");
    if (vertex->has_list) fail("element vertex: list properties are not supported");
    for (std::size_t w = 0; w < 4; ++w)
        if (found[w] < 0) fail("element vertex has no property " + std::string(kWantedNames[w]));
    const int velocity_parts = int(found[4] >= 0) + int(found[5] >= 0) + int(found[6] >= 0);
    if (velocity_parts != 0 && velocity_parts != 3)
        fail("element vertex has only part of a velocity (give all of vx, vy, vz, or none)");
    velocity_ = velocity_parts == 3;
    for (std::size_t w = 0; w < 7; ++w)
        if (found[w] >= 0)
            wanted_[w] = {found_type[w], format_ == Format::ascii ? found_token[w] : std::uint32_t(found[w])};
    // Binary: where each part of the data begins and ends, in checked arithmetic, so that a count that
    // overflows cannot move the reader backwards into the header; compared with the file's size before the
    // first vertex is read. Elements after vertex with list properties have no size the header gives.
    const auto at = std::ftell(file_.get());
    if (at < 0) fail("cannot read the file");
    std::optional<std::uint64_t> offset = std::uint64_t(at);
    std::optional<std::uint64_t> after_lines = 0;
    after_sized_ = true;
    for (auto e = elements.begin(); e != elements.end(); ++e) {
        if (e == vertex) {
            vertex_start_ = offset;
            offset = checked_sum(offset, checked_product(e->count, e->bytes));
            vertex_end_ = offset;
        } else if (e < vertex || !e->has_list) {
            offset = checked_sum(offset, checked_product(e->count, e->bytes));
        } else {
            after_sized_ = false;
        }
        if (e > vertex) after_lines = checked_sum(after_lines, e->count);
    }
    data_end_ = offset;
    after_lines_ = after_lines;
    vertex_count_ = vertex->count;
    vertex_bytes_ = vertex->bytes;
    vertex_properties_ = vertex->properties;
    for (auto e = elements.begin(); e != vertex; ++e) {
        if (e->has_list && format_ != Format::ascii)
            fail("element " + e->name + " (before vertex): list properties are not supported in binary files");
        before_.emplace_back(e->count, e->bytes);
    }
}

void PlyPointReader::skip_elements_before_vertex() {
    if (format_ == Format::ascii) {
        for (const auto& [count, bytes] : before_) {
            // One element a line.
            for (std::uint64_t i = 0; i < count; ++i)
                for (int c; (c = std::fgetc(file_.get())) != '\n';)
                    if (c == EOF) fail(truncated(0));
        }
        const auto at = std::ftell(file_.get());
        if (at < 0) fail("cannot read the file");
        text_start_ = std::uint64_t(at);
    }
}

void PlyPointReader::check_binary_layout() const {
    const std::uint64_t size = file_size();
    const auto past_the_end = [&](std::optional<std::uint64_t> end) {
        return " end, by the header's counts, " + (end ? "at byte " + std::to_string(*end) : "beyond byte 2^64") +
               ", past the end of the file (" + std::to_string(size) + " bytes)";
    };
    if (!vertex_start_ || *vertex_start_ > size) fail("the elements before vertex" + past_the_end(vertex_start_));
    if (!vertex_end_ || *vertex_end_ > size) fail(truncated((size - *vertex_start_) / vertex_bytes_));
    if (!data_end_ || *data_end_ > size) fail("truncated: the elements after vertex" + past_the_end(data_end_));
    if (after_sized_ && *data_end_ < size)
        fail("the header's elements end at byte " + std::to_string(*data_end_) + ", but the file has " +
             std::to_string(size) + " bytes: " + std::to_string(size - *data_end_) +
             " bytes of trailing data (is the vertex count wrong?)");
}

void PlyPointReader::check_ascii_room() const {
    // Each value is at least one character and a separator: a count the rest of the file cannot hold is
    // refused before a caller sizes anything by it.
    const std::uint64_t size = file_size();
    const std::uint64_t left = size - std::min(size, text_start_);
    const std::optional<std::uint64_t> values = checked_product(vertex_count_, vertex_properties_);
    if (!values || *values > left / 2 + 1)
        fail("truncated: the header declares " + std::to_string(vertex_count_) + " vertices of " +
             std::to_string(vertex_properties_) + " values, more than the " + std::to_string(left) +
             " bytes after it can hold as text");
}

std::vector<PlyPiece> PlyPointReader::pieces() {
    if (format_ == Format::ascii) {
        check_ascii_room();
        return ascii_pieces();
    }
    check_binary_layout();
    return binary_pieces();
}

std::vector<PlyPiece> PlyPointReader::binary_pieces() const {
    // Whole vertices of about kPlyPieceBytes each; check_binary_layout() has held them within the file.
    const std::uint64_t per_piece = std::max<std::uint64_t>(1, kPlyPieceBytes / vertex_bytes_);
    std::vector<PlyPiece> pieces;
    pieces.reserve(std::size_t((vertex_count_ + per_piece - 1) / per_piece));
    for (std::uint64_t first = 0; first < vertex_count_; first += per_piece)
        pieces.push_back(
            {first, std::min(per_piece, vertex_count_ - first), *vertex_start_ + first * vertex_bytes_, 0});
    return pieces;
}

std::vector<PlyPiece> PlyPointReader::ascii_pieces() {
    // A vertex is the next vertex_properties_ values, wherever the lines break, so where a vertex begins is
    // known only from the values before it: the text is cut into parts of kPlyPieceBytes, each part's values
    // are counted (a value is counted in the part where it begins), and a piece is the vertices whose first
    // value begins in a part.
    const std::uint64_t size = file_size();
    const std::uint64_t text_bytes = size - std::min(size, text_start_);
    const auto parts = std::size_t((text_bytes + kPlyPieceBytes - 1) / kPlyPieceBytes);
    std::vector<std::uint64_t> first_value(parts), values(parts);
    tbb::enumerable_thread_specific<std::vector<unsigned char>> buffers;
    tbb::parallel_for(std::size_t{0}, parts, [&](std::size_t i) {
        std::vector<unsigned char>& buffer = buffers.local();
        buffer.resize(std::size_t(kPlyPieceBytes) + 1);
        const std::uint64_t begin = text_start_ + i * kPlyPieceBytes;
        const std::uint64_t end = std::min(size, begin + kPlyPieceBytes);
        // From the byte before the part, which says whether a value begins at its first byte (text_start_ > 0:
        // the byte before it ends the header's last line, or the last line of an element before vertex).
        const std::size_t got = read_at(begin - 1, buffer.data(), std::size_t(end - begin) + 1);
        std::uint64_t count = 0, first = end;
        for (std::size_t j = 1; j < got; ++j) {
            if (ascii_space(buffer[j]) || !ascii_space(buffer[j - 1])) continue;
            if (count++ == 0) first = begin + j - 1;
        }
        first_value[i] = first;
        values[i] = count;
    });

    const std::uint64_t per_vertex = vertex_properties_;
    text_parts_.clear();
    text_parts_.reserve(parts);
    std::vector<PlyPiece> pieces;
    std::uint64_t before = 0;
    for (std::size_t i = 0; i < parts; ++i) {
        text_parts_.push_back({first_value[i], before});
        // The vertices whose first value is one of values [before, before + values[i]).
        const std::uint64_t first = (before + per_vertex - 1) / per_vertex;
        before += values[i];
        const std::uint64_t end = std::min(vertex_count_, (before + per_vertex - 1) / per_vertex);
        if (end > first)
            pieces.push_back({first, end - first, first_value[i], first * per_vertex - text_parts_[i].values_before});
    }
    text_values_ = before;
    return pieces;
}

void PlyPointReader::finish() const {
    if (format_ != Format::ascii) return;
    // (no overflow: check_ascii_room() held the product within the file's size)
    const std::uint64_t vertex_values = vertex_count_ * vertex_properties_;
    if (text_values_ < vertex_values) fail(truncated(text_values_ / vertex_properties_));

    // What follows the last vertex: the lines of the elements after it, then only white space. From the end
    // of the last vertex's last value, found from the part where that value begins.
    PieceReader text(*this);
    if (vertex_values == 0) {
        text.start_text(text_start_);
    } else {
        const auto part = std::prev(std::upper_bound(
            text_parts_.begin(), text_parts_.end(), vertex_values - 1,
            [](std::uint64_t value, const TextPart& p) { return value < p.values_before; }));
        text.start_text(part->offset);
        std::string_view value;
        for (std::uint64_t v = part->values_before; v < vertex_values; ++v)
            if (!text.next_value(value)) fail("cannot read the file");  // (the file shrank since pieces())
    }
    std::uint64_t lines = 0;
    bool in_line = false;
    do {
        for (; text.pos_ < text.end_; ++text.pos_) {
            const unsigned char c = text.buffer_[text.pos_];
            if (c == '\n') {
                in_line = false;
            } else if (!ascii_space(c) && !in_line) {
                in_line = true;
                ++lines;
            }
        }
    } while (text.read_more(text.end_));
    if (!after_lines_ || lines != *after_lines_)
        fail("after the last vertex the file has " + std::to_string(lines) + " more non-blank lines, where the " +
             "header's elements after vertex give " + (after_lines_ ? std::to_string(*after_lines_) : "more") +
             " (is the vertex count wrong, or is there trailing data?)");
}

// ---- PlyPointReader::PieceReader ------------------------------------------------------------------------

void PlyPointReader::PieceReader::start(const PlyPiece& piece) {
    next_vertex_ = piece.first_vertex;
    end_vertex_ = piece.first_vertex + piece.vertex_count;
    pending_.reset();
    if (reader_->format_ != Format::ascii) {
        offset_ = piece.offset;
        pos_ = end_ = 0;
        return;
    }
    start_text(piece.offset);
    // The rest of the vertex that began in the part before (were they missing, the first vertex's are too).
    std::string_view value;
    for (std::uint64_t i = 0; i < piece.skip_values && next_value(value); ++i) {}
}

std::size_t PlyPointReader::PieceReader::read(std::span<PlyPoint> out) {
    if (pending_) reader_->fail(*pending_);
    out = out.first(std::size_t(std::min<std::uint64_t>(out.size(), end_vertex_ - next_vertex_)));
    if (out.empty()) return 0;
    return reader_->format_ == Format::ascii ? read_ascii(out) : read_binary(out);
}

std::size_t PlyPointReader::PieceReader::read_binary(std::span<PlyPoint> out) {
    const PlyPointReader& r = *reader_;
    const bool swap = (r.format_ == Format::binary_big_endian) != (std::endian::native == std::endian::big);
    const std::size_t properties = r.velocity_ ? 7 : 4;
    const std::size_t vertex_bytes = r.vertex_bytes_;
    std::size_t done = 0;
    while (done < out.size()) {
        if (pos_ == end_) {
            // The buffer is read: the piece's next whole vertices, up to kReadBytes of them (at least one).
            const std::uint64_t unread = end_vertex_ - next_vertex_;
            const std::size_t want =
                std::size_t(std::min<std::uint64_t>(unread, std::max<std::size_t>(1, kReadBytes / vertex_bytes))) *
                vertex_bytes;
            if (buffer_.size() < want) buffer_.resize(want);
            pos_ = 0;
            end_ = r.read_at(offset_, buffer_.data(), want) / vertex_bytes * vertex_bytes;
            offset_ += end_;
            if (end_ == 0) {
                // The file ends before the vertices pieces() measured: it shrank since.
                pending_ = r.truncated(next_vertex_);
                if (done == 0) r.fail(*pending_);
                break;
            }
        }
        const std::size_t count = std::min(out.size() - done, (end_ - pos_) / vertex_bytes);
        for (std::size_t i = 0; i < count; ++i) {
            const unsigned char* vertex = buffer_.data() + pos_ + i * vertex_bytes;
            double values[7] = {};
            for (std::size_t w = 0; w < properties; ++w) {
                const unsigned char* p = vertex + r.wanted_[w].offset;
                switch (r.wanted_[w].type) {
                    case Type::i8: values[w] = load<std::int8_t>(p, swap); break;
                    case Type::u8: values[w] = load<std::uint8_t>(p, swap); break;
                    case Type::i16: values[w] = load<std::int16_t>(p, swap); break;
                    case Type::u16: values[w] = load<std::uint16_t>(p, swap); break;
                    case Type::i32: values[w] = load<std::int32_t>(p, swap); break;
                    case Type::u32: values[w] = load<std::uint32_t>(p, swap); break;
                    case Type::f32: values[w] = load<float>(p, swap); break;
                    case Type::f64: values[w] = load<double>(p, swap); break;
                }
            }
            out[done + i] = {values[0], values[1], values[2], values[3], values[4], values[5], values[6]};
        }
        pos_ += count * vertex_bytes;
        done += count;
        next_vertex_ += count;
    }
    return done;
}

std::size_t PlyPointReader::PieceReader::read_ascii(std::span<PlyPoint> out) {
    const PlyPointReader& r = *reader_;
    const std::size_t properties = r.velocity_ ? 7 : 4;
    std::string_view value;
    std::size_t done = 0;
    for (; done < out.size(); ++done) {
        double values[7] = {};
        for (std::uint32_t property = 0; property < r.vertex_properties_ && !pending_; ++property) {
            if (!next_value(value)) {
                pending_ = r.truncated(next_vertex_);
                break;
            }
            for (std::size_t w = 0; w < properties; ++w) {
                if (r.wanted_[w].offset != property) continue;
                if (const char* problem = ascii_value(value, int(r.wanted_[w].type), values[w])) {
                    pending_ = "vertex " + std::to_string(next_vertex_) + ", property " + std::string(kWantedNames[w]) +
                               ": " + problem + " (got \"" + std::string(value.substr(0, 40)) + "\")";
                    break;
                }
            }
        }
        if (pending_) {
            if (done == 0) r.fail(*pending_);
            break;
        }
        out[done] = {values[0], values[1], values[2], values[3], values[4], values[5], values[6]};
        ++next_vertex_;
    }
    return done;
}

void PlyPointReader::PieceReader::start_text(std::uint64_t offset) {
    offset_ = offset;
    pos_ = end_ = 0;
}

bool PlyPointReader::PieceReader::read_more(std::size_t keep_from) {
    // buffer_[keep_from, end_) moves to the front (a value that runs on past the buffer's end), then the
    // next bytes of the file follow it; a value as long as the buffer doubles it.
    if (buffer_.size() < kReadBytes) buffer_.resize(kReadBytes);
    const std::size_t kept = end_ - keep_from;
    std::memmove(buffer_.data(), buffer_.data() + keep_from, kept);
    pos_ -= keep_from;
    if (kept == buffer_.size()) buffer_.resize(2 * buffer_.size());
    const std::size_t got = reader_->read_at(offset_, buffer_.data() + kept, buffer_.size() - kept);
    offset_ += got;
    end_ = kept + got;
    return got != 0;
}

bool PlyPointReader::PieceReader::next_value(std::string_view& value) {
    while (true) {
        while (pos_ < end_ && ascii_space(buffer_[pos_])) ++pos_;
        if (pos_ < end_) break;
        if (!read_more(end_)) return false;
    }
    std::size_t begin = pos_;
    while (true) {
        while (pos_ < end_ && !ascii_space(buffer_[pos_])) ++pos_;
        if (pos_ < end_) break;
        const bool more = read_more(begin);  // (the value moves to the buffer's front)
        begin = 0;
        if (!more) break;  // the file's end ends the value
    }
    value = std::string_view(reinterpret_cast<const char*>(buffer_.data()) + begin, pos_ - begin);
    return true;
}

}  // namespace smoketrace
