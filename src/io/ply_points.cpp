// PLY point clouds (see ply_points.hpp). The header is a few lines of text; the body is read a batch of
// vertices at a time and each wanted property decoded from its offset, so no allocation happens per vertex.
#include <smoketrace/io/ply_points.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <sstream>
#include <string_view>
#include <system_error>

#include <sys/stat.h>

namespace smoketrace {

namespace {

// Vertices decoded per fread(): large enough that the call's cost vanishes, small enough to stay in cache;
// fewer when a vertex is large (a header may give it thousands of properties), so the buffer stays small.
constexpr std::size_t kBatchVertices = 4096;
constexpr std::size_t kBatchBytes = std::size_t(1) << 18;
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
const char* ascii_value(const std::string& token, int type, double& value) {
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

void PlyPointReader::truncated(std::uint64_t vertex) const {
    fail("truncated: the header declares " + std::to_string(vertex_count_) + " vertices, the data ends in vertex " +
         std::to_string(vertex));
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
    if (format_ != Format::ascii) return;  // check_binary_layout() seeks to the first vertex
    for (const auto& [count, bytes] : before_) {
        // One element a line.
        for (std::uint64_t i = 0; i < count; ++i)
            for (int c; (c = std::fgetc(file_.get())) != '\n';)
                if (c == EOF) truncated(0);
    }
}

void PlyPointReader::check_binary_layout() {
    struct stat info{};
    if (::fstat(fileno(file_.get()), &info) != 0) fail("cannot read the file");
    const auto size = std::uint64_t(info.st_size);
    const auto past_the_end = [&](std::optional<std::uint64_t> end) {
        return " end, by the header's counts, " + (end ? "at byte " + std::to_string(*end) : "beyond byte 2^64") +
               ", past the end of the file (" + std::to_string(size) + " bytes)";
    };
    if (!vertex_start_ || *vertex_start_ > size) fail("the elements before vertex" + past_the_end(vertex_start_));
    if (!vertex_end_ || *vertex_end_ > size) truncated((size - *vertex_start_) / vertex_bytes_);
    if (!data_end_ || *data_end_ > size) fail("truncated: the elements after vertex" + past_the_end(data_end_));
    if (after_sized_ && *data_end_ < size)
        fail("the header's elements end at byte " + std::to_string(*data_end_) + ", but the file has " +
             std::to_string(size) + " bytes: " + std::to_string(size - *data_end_) +
             " bytes of trailing data (is the vertex count wrong?)");
    if (*vertex_start_ > std::uint64_t(std::numeric_limits<off_t>::max()) ||
        ::fseeko(file_.get(), off_t(*vertex_start_), SEEK_SET) != 0)
        fail("cannot seek to the first vertex (byte " + std::to_string(*vertex_start_) + ")");
}

void PlyPointReader::check_ascii_room() {
    // Each value is at least one character and a separator: a count the rest of the file cannot hold is
    // refused before a caller sizes anything by it.
    struct stat info{};
    const auto at = std::ftell(file_.get());
    if (::fstat(fileno(file_.get()), &info) != 0 || at < 0) fail("cannot read the file");
    const std::uint64_t left = std::uint64_t(info.st_size) - std::min(std::uint64_t(info.st_size), std::uint64_t(at));
    const std::optional<std::uint64_t> values = checked_product(vertex_count_, vertex_properties_);
    if (!values || *values > left / 2 + 1)
        fail("truncated: the header declares " + std::to_string(vertex_count_) + " vertices of " +
             std::to_string(vertex_properties_) + " values, more than the " + std::to_string(left) +
             " bytes after it can hold as text");
}

void PlyPointReader::check_ascii_end() {
    // What follows the last vertex: the lines of the elements after it, then only white space.
    std::uint64_t lines = 0;
    bool in_line = false;
    for (int c; (c = std::fgetc(file_.get())) != EOF;) {
        if (c == '\n') {
            in_line = false;
        } else if (!std::isspace(c) && !in_line) {
            in_line = true;
            ++lines;
        }
    }
    if (std::ferror(file_.get())) fail("cannot read the file");
    if (!after_lines_ || lines != *after_lines_)
        fail("after the last vertex the file has " + std::to_string(lines) + " more non-blank lines, where the " +
             "header's elements after vertex give " + (after_lines_ ? std::to_string(*after_lines_) : "more") +
             " (is the vertex count wrong, or is there trailing data?)");
}

std::size_t PlyPointReader::read(std::span<PlyPoint> out) {
    if (!started_) {
        started_ = true;
        if (format_ == Format::ascii) check_ascii_room();
        else check_binary_layout();
    }
    out = out.first(std::size_t(std::min<std::uint64_t>(out.size(), vertex_count_ - next_vertex_)));
    const std::size_t done = out.empty() ? 0 : format_ == Format::ascii ? read_ascii(out) : read_binary(out);
    if (next_vertex_ == vertex_count_ && !ended_) {
        ended_ = true;
        if (format_ == Format::ascii) check_ascii_end();
    }
    return done;
}

std::size_t PlyPointReader::read_binary(std::span<PlyPoint> out) {
    const bool swap = (format_ == Format::binary_big_endian) != (std::endian::native == std::endian::big);
    std::size_t done = 0;
    while (done < out.size()) {
        const std::size_t batch =
            std::min({kBatchVertices, std::max<std::size_t>(1, kBatchBytes / vertex_bytes_), out.size() - done});
        buffer_.resize(batch * vertex_bytes_);
        const std::size_t got = std::fread(buffer_.data(), 1, buffer_.size(), file_.get());
        if (got < buffer_.size()) truncated(next_vertex_ + got / vertex_bytes_);
        for (std::size_t i = 0; i < batch; ++i) {
            const unsigned char* vertex = buffer_.data() + i * vertex_bytes_;
            double values[7] = {};
            for (std::size_t w = 0; w < (velocity_ ? 7u : 4u); ++w) {
                const unsigned char* p = vertex + wanted_[w].offset;
                switch (wanted_[w].type) {
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
        done += batch;
        next_vertex_ += batch;
    }
    return done;
}

bool PlyPointReader::ascii_token(std::string& token) {
    token.clear();
    int c;
    while ((c = std::fgetc(file_.get())) != EOF && std::isspace(c)) {}
    for (; c != EOF && !std::isspace(c); c = std::fgetc(file_.get())) token.push_back(char(c));
    return !token.empty();
}

std::size_t PlyPointReader::read_ascii(std::span<PlyPoint> out) {
    std::string token;
    for (PlyPoint& point : out) {
        double values[7] = {};
        for (std::uint32_t property = 0; property < vertex_properties_; ++property) {
            if (!ascii_token(token)) truncated(next_vertex_);
            for (std::size_t w = 0; w < (velocity_ ? 7u : 4u); ++w) {
                if (wanted_[w].offset != property) continue;
                if (const char* problem = ascii_value(token, int(wanted_[w].type), values[w]))
                    fail("vertex " + std::to_string(next_vertex_) + ", property " + std::string(kWantedNames[w]) +
                         ": " + problem + " (got \"" + token.substr(0, 40) + "\")");
            }
        }
        point = {values[0], values[1], values[2], values[3], values[4], values[5], values[6]};
        ++next_vertex_;
    }
    return out.size();
}

}  // namespace smoketrace
