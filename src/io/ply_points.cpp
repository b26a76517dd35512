// PLY point clouds (see ply_points.hpp). The header is a few lines of text; the body is read a batch of
// vertices at a time and each wanted property decoded from its offset, so no allocation happens per vertex.
#include <smoketrace/io/ply_points.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <charconv>
#include <cstring>
#include <sstream>
#include <string_view>
#include <system_error>

namespace smoketrace {

namespace {

// Vertices decoded per fread(): large enough that the call's cost vanishes, small enough to stay in cache.
constexpr std::size_t kBatchVertices = 4096;
// The longest header line we accept: a PLY header line is a keyword and a few names.
constexpr std::size_t kMaxHeaderLine = 4096;

constexpr std::array<std::string_view, 7> kWantedNames = {"x", "y", "z", "radius", "vx", "vy", "vz"};

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

}  // namespace

PlyPointReader::PlyPointReader(const std::filesystem::path& path, std::string name) : name_(std::move(name)) {
    std::error_code ec;
    // Only regular files: a FIFO or a device named by a scene would block or never end.
    if (!std::filesystem::is_regular_file(path, ec)) {
        if (!std::filesystem::exists(path, ec)) fail("cannot open the file for reading (it does not exist)");
        fail("is not a regular file");
    }
    file_ = std::fopen(path.c_str(), "rb");
    if (!file_) fail("cannot open the file for reading");
    read_header();
    skip_elements_before_vertex();
}

PlyPointReader::~PlyPointReader() {
    if (file_) std::fclose(file_);
}

void PlyPointReader::fail(const std::string& problem) const { throw PlyError(name_ + ": " + problem); }

void PlyPointReader::truncated(std::uint64_t vertex) const {
    fail("truncated: the header declares " + std::to_string(vertex_count_) + " vertices, the data ends in vertex " +
         std::to_string(vertex));
}

void PlyPointReader::read_header() {
    auto next_line = [&](std::string& line) {
        line.clear();
        for (int c; (c = std::fgetc(file_)) != EOF;) {
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
            if (e.name == "vertex" && std::count_if(elements.begin(), elements.end(),
                                                    [](const Element& x) { return x.name == "vertex"; }) == 1) {
                for (std::size_t w = 0; w < kWantedNames.size(); ++w) {
                    if (property_name != kWantedNames[w]) continue;
                    if (found[w] >= 0) fail("element vertex: property " + property_name + " appears twice");
                    found[w] = int(e.bytes);
                    found_type[w] = type->second;
                    found_token[w] = e.properties;
                }
            }
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
    for (const auto& [count, bytes] : before_) {
        if (format_ == Format::ascii) {
            // One element a line.
            for (std::uint64_t i = 0; i < count; ++i)
                for (int c; (c = std::fgetc(file_)) != '\n';)
                    if (c == EOF) truncated(0);
        } else if (std::fseek(file_, long(count * bytes), SEEK_CUR) != 0) {
            truncated(0);
        }
    }
}

std::size_t PlyPointReader::read(std::span<PlyPoint> out) {
    out = out.first(std::size_t(std::min<std::uint64_t>(out.size(), vertex_count_ - next_vertex_)));
    if (out.empty()) return 0;
    return format_ == Format::ascii ? read_ascii(out) : read_binary(out);
}

std::size_t PlyPointReader::read_binary(std::span<PlyPoint> out) {
    const bool swap = (format_ == Format::binary_big_endian) != (std::endian::native == std::endian::big);
    std::size_t done = 0;
    while (done < out.size()) {
        const std::size_t batch = std::min(kBatchVertices, out.size() - done);
        buffer_.resize(batch * vertex_bytes_);
        const std::size_t got = std::fread(buffer_.data(), 1, buffer_.size(), file_);
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
    while ((c = std::fgetc(file_)) != EOF && std::isspace(c)) {}
    for (; c != EOF && !std::isspace(c); c = std::fgetc(file_)) token.push_back(char(c));
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
                const char* end = token.data() + token.size();
                // from_chars reads nan and inf too; the scene file's checks refuse them by name.
                const auto [stop, error] = std::from_chars(token.data(), end, values[w]);
                if (error != std::errc() || stop != end)
                    fail("vertex " + std::to_string(next_vertex_) + ", property " + std::string(kWantedNames[w]) +
                         ": not a number (got \"" + token.substr(0, 40) + "\")");
            }
        }
        point = {values[0], values[1], values[2], values[3], values[4], values[5], values[6]};
        ++next_vertex_;
    }
    return out.size();
}

}  // namespace smoketrace
