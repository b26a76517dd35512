// Scene files (see scene_file.hpp for the format and the defaults).
//
// Validation is one pass over the JSON tree with a Node (value + JSON pointer) per visited value; each
// reader checks type, range and single-precision representability and fails with the node's path. A long
// particle list is the exception: the fast reader (below) reads /smoke/particles with simdjson's On-Demand
// API straight from the text, and a PLY file's points come through ply_points.hpp; both go through the same
// value checks (Reader's, on a number and a lazily described site) and local_particle().
#include <smoketrace/io/scene_file.hpp>

#include <smoketrace/io/json_text_file.hpp>
#include <smoketrace/io/ply_points.hpp>
#include <smoketrace/core/memory_budget.hpp>
#include <smoketrace/core/populated_pages.hpp>
#include <smoketrace/core/shown_text.hpp>

#include <nlohmann/json.hpp>
#include <simdjson.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <limits>
#include <map>
#include <set>
#include <span>

namespace smoketrace {

namespace {

using nlohmann::json;

// ---- Named tolerances --------------------------------------------------------------------------------

// A ground quad whose area is below this fraction of (longest edge)² is a sliver without a usable normal:
// float corners carry ~1e-7 relative error, so 1e-6 is ten times that noise.
constexpr double kMinRelativeGroundArea = 1e-6;
// Corners may lie off their common plane by this fraction of the longest edge. Float coordinates are good
// to ~1e-7 relative and typed decimals with 5 significant digits to ~1e-5; a lifted corner is far above 1e-4.
constexpr double kGroundPlanarityTolerance = 1e-4;
// Each corner's turn (cross product of adjacent edges along the normal) must exceed this fraction of
// (longest edge)²; a smaller turn means three corners are collinear (a triangle, not a quad) or the
// winding folds back (not convex).
constexpr double kMinRelativeGroundTurn = 1e-6;
// The camera's up vector must make at least this sine with the view direction; below it the camera's
// right vector is float noise.
constexpr double kMinUpViewSine = 1e-6;
// Default camera: elevation of the view above the horizon and the margin around the framed sphere.
constexpr double kDefaultCameraElevationDeg = 20.0;  // "from the front, a bit above"
constexpr double kDefaultCameraMargin = 1.1;         // 10 % empty border around the smoke
// Smallest framed radius, relative to the distance of the framed centre from the origin (and at least this
// absolute): 1e-6 is ~10 float steps, enough for the camera position to differ from the point it looks at.
constexpr double kMinDefaultFramingRadius = 1e-6;

constexpr double kRadiansPerDegree = 3.14159265358979323846 / 180.0;

constexpr std::uint32_t kMaxGroups = 1u << 20;     // one update spread over 2^20 frames is ~5 h at 60 fps
// Number literals that read as 0 though they are not (1e-400) whose text is kept for messages: the first
// ones are the ones a message names, and a hostile file of millions must not grow a map of millions.
constexpr std::size_t kMaxNotedUnderflows = 1024;

// ---- Paths and messages ------------------------------------------------------------------------------

// A JSON pointer token (RFC 6901): "~" → "~0", "/" → "~1"; paths are for messages only, so the key is also
// shown as a message may repeat it (shown_text.hpp: escaped, at most kMaxShownValueBytes).
std::string pointer_token(std::string_view key) {
    std::string out;
    for (char c : key) {
        if (c == '~') out += "~0";
        else if (c == '/') out += "~1";
        else out += c;
    }
    return shown_text(out, kMaxShownValueBytes);
}

std::string shown_path(const std::string& path) { return path.empty() ? "(document root)" : path; }

// The value as the file wrote it (nlohmann prints numbers round-trip), shortened.
std::string shown_value(const json& j) {
    if (j.is_number_float() && !std::isfinite(j.get<double>())) return "a number out of range for a double";
    return shown_text(j.dump(), kMaxShownValueBytes);
}

// What a value of the wrong type is, in JSON's words, with the value as the file wrote it: "null", "true",
// "a string, \"abc\"", "an array of 2 elements, [1,2]", "an object, {…}", "a number, 5".
std::string described_value(const json& j) {
    switch (j.type()) {
        case json::value_t::null:
            return "null";
        case json::value_t::boolean:
            return j.get<bool>() ? "true" : "false";
        case json::value_t::string:
            return "a string, " + shown_value(j);
        case json::value_t::array:
            return j.empty() ? "an empty array"
                             : "an array of " + std::to_string(j.size()) +
                                   (j.size() == 1 ? " element, " : " elements, ") + shown_value(j);
        case json::value_t::object:
            return j.empty() ? "an empty object" : "an object, " + shown_value(j);
        default:
            return "a number, " + shown_value(j);
    }
}

// Whether a number literal is nonzero as written though it reads as 0, below the smallest double ("1e-400").
bool reads_as_zero(std::string_view literal, double value) {
    if (value != 0.0) return false;
    for (const char c : literal) {
        if (c == 'e' || c == 'E') break;
        if (c >= '1' && c <= '9') return true;
    }
    return false;
}
std::string shown_underflow(std::string_view literal) {
    return shown_text(literal, kMaxShownValueBytes) + ", a number too close to 0 for a double, which reads as 0";
}

std::string shown_number(double v) {
    char buffer[64];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, v);
    return std::string(buffer, result.ptr);
}
// A float as its shortest round-trip decimal (1.1754944e-38, not the double's 1.1754943508222875e-38).
std::string shown_number(float v) {
    char buffer[64];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, v);
    return std::string(buffer, result.ptr);
}

struct Node {
    const json* value;
    std::string path;

    [[nodiscard]] Node child(std::string_view key) const { return {&(*value)[std::string(key)], path + "/" + pointer_token(key)}; }
    [[nodiscard]] Node element(std::size_t i) const { return {&(*value)[i], path + "/" + std::to_string(i)}; }
};

// Allowed range of a number, with its wording for messages.
struct Bounds {
    double lo = -std::numeric_limits<double>::infinity();
    bool lo_open = false;
    double hi = std::numeric_limits<double>::infinity();
    bool hi_open = false;
    // Name only the side that was violated ("must be > 0", "must be <= 1e+15"): for a natural lower bound
    // with a sanity limit on top, where the interval would read oddly.
    bool sided = false;

    [[nodiscard]] bool contains(double v) const {
        return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
    }
    [[nodiscard]] std::string describe(double v) const {
        if (sided) {
            if (!(lo_open ? v > lo : v >= lo)) return Bounds{lo, lo_open}.describe(v);
            return Bounds{-std::numeric_limits<double>::infinity(), false, hi, hi_open}.describe(v);
        }
        const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
        if (has_lo && !has_hi) return std::string(lo_open ? "must be > " : "must be >= ") + shown_number(lo);
        if (!has_lo && has_hi) return std::string(hi_open ? "must be < " : "must be <= ") + shown_number(hi);
        return std::string("must be in ") + (lo_open ? "(" : "[") + shown_number(lo) + ", " + shown_number(hi) +
               (hi_open ? ")" : "]");
    }
};
constexpr Bounds kAny{};
constexpr Bounds kPositive{0.0, true};
constexpr Bounds kNonNegative{0.0, false};
constexpr Bounds kUnit{0.0, false, 1.0, false};
constexpr Bounds kCoordinate{-kMaxSceneCoordinate, false, kMaxSceneCoordinate, false};
constexpr Bounds kRadius{0.0, true, kMaxSceneCoordinate, false, true};
constexpr Bounds kColor{0.0, false, kMaxSceneColor, false, true};

// Where a value sits and how the file wrote it, for messages only: a site builds its path and its shown value
// when a check fails, never on the good path, so that a list of a million particles builds no path string.
// The value checks below take a number and a site, one implementation whatever the value came from (a JSON
// tree, the fast particle reader, a PLY file).
class Reader;
struct NodeSite {
    const Reader& reader;
    const Node& node;
    [[nodiscard]] std::string path() const { return node.path; }
    [[nodiscard]] std::string shown() const;
};

class Reader {
public:
    explicit Reader(std::string source) : source_(std::move(source)) {}

    [[nodiscard]] const std::string& source() const { return source_; }

    // The path's keys and the values in `problem` were shown (shown_text.hpp) where they were put in; the
    // whole is shown again, which leaves them as they are and catches any other text from the file (a PLY
    // header's words, a PLY file's name).
    [[noreturn]] void fail(const std::string& path, const std::string& problem) const {
        throw SceneFileError(shown_text(source_, kMaxShownPathBytes) + ": " +
                             shown_text(shown_path(path), kMaxShownPathBytes) + ": " +
                             shown_text(problem, kShownUncapped));
    }
    [[noreturn]] void fail(const Node& n, const std::string& problem) const { fail(n.path, problem); }
    [[noreturn]] void wrong_type(const Node& n, std::string_view expected) const {
        fail(n, "must be " + std::string(expected) + " (got " + described_value(*n.value) + ")");
    }

    // A number the scan found written nonzero but read as 0 (1e-400), at JSON pointer `path`.
    void note_underflow(const std::string& path, std::string_view literal) const {
        if (underflows_.size() < kMaxNotedUnderflows) underflows_.emplace(path, literal);
    }
    // The value at `n` as the file wrote it.
    [[nodiscard]] std::string shown(const Node& n) const {
        if (const auto u = underflows_.find(n.path); u != underflows_.end()) return shown_underflow(u->second);
        return shown_value(*n.value);
    }
    [[noreturn]] void unknown_key(const std::string& parent_path, std::string_view key,
                                  std::initializer_list<std::string_view> allowed) const {
        std::string list;
        for (std::string_view a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
        fail(parent_path + "/" + pointer_token(key), "unknown key (allowed here: " + list + ")");
    }

    void require_object(const Node& n, std::initializer_list<std::string_view> allowed) const {
        if (!n.value->is_object()) wrong_type(n, "an object");
        for (const auto& [key, value] : n.value->items())
            if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) unknown_key(n.path, key, allowed);
    }

    [[nodiscard]] static std::optional<Node> optional(const Node& n, std::string_view key) {
        if (!n.value->contains(std::string(key))) return std::nullopt;
        return n.child(key);
    }
    [[nodiscard]] Node required(const Node& n, std::string_view key) const {
        if (!n.value->contains(std::string(key))) fail(n.path + "/" + pointer_token(key), "required key is missing");
        return n.child(key);
    }

    [[nodiscard]] double number(const Node& n) const {
        if (!n.value->is_number()) wrong_type(n, "a number");
        return finite(n.value->get<double>(), NodeSite{*this, n});
    }

    // ---- The value checks, on a number and its site ----

    template <class Site>
    [[nodiscard]] double finite(double v, const Site& site) const {
        if (!std::isfinite(v)) fail(site.path(), "must be finite (got " + site.shown() + ")");
        return v;
    }

    // A finite number within the float range, within `bounds` as written and once rounded to float.
    // Subnormal floats (below 1.2e-38, down to 1.4e-45) are accepted: they are floats like any other. A
    // nonzero number that rounds to 0 in float (|v| <= 2^-150 ≈ 7e-46, e.g. 1e-50) reads as 0 where 0 is
    // allowed (a coordinate, a speed, a colour: 0 is that value to any precision a float scene holds), and
    // is an error saying so where it is not (sizes, radii and the field of view must be > 0; read as 0,
    // 1e-50 would fail with "must be > 0 (got 1e-50)", which reads as a contradiction).
    template <class Site>
    [[nodiscard]] float real(double v, const Bounds& bounds, const Site& site) const {
        // A value that passes every check below at once, tested inline (a list of millions goes through here);
        // the checks themselves, which word the messages, only for the others.
        const auto f = static_cast<float>(v);
        if (std::abs(v) <= static_cast<double>(std::numeric_limits<float>::max()) && bounds.contains(v) &&
            (f != 0.0f || v == 0.0) && bounds.contains(f)) [[likely]]
            return f;
        return checked_real(v, bounds, site);
    }
    template <class Site>
    [[nodiscard, gnu::noinline]] float checked_real(double v, const Bounds& bounds, const Site& site) const {
        (void)finite(v, site);
        if (std::abs(v) > static_cast<double>(std::numeric_limits<float>::max()))
            fail(site.path(), "too large for single precision (got " + site.shown() + ")");
        if (!bounds.contains(v)) fail(site.path(), bounds.describe(v) + " (got " + site.shown() + ")");
        const auto f = static_cast<float>(v);
        if (f == 0.0f && v != 0.0) {
            if (!bounds.contains(0.0))
                fail(site.path(), "too close to 0 for single precision (got " + site.shown() + ", which rounds to 0; " +
                                      bounds.describe(0.0) + ")");
            return 0.0f;  // +0 for -1e-50 too
        }
        if (!bounds.contains(f))
            fail(site.path(), bounds.describe(f) + " (got " + site.shown() + ", which rounds to " + shown_number(f) +
                                  " in single precision)");
        return f;
    }
    [[nodiscard]] float real(const Node& n, const Bounds& bounds = kAny) const {
        return real(number(n), bounds, NodeSite{*this, n});
    }

    // A particle radius: a float in `bounds` and at least kMinParticleRadius, the smallest normal float.
    // Below it a particle's object space (scaled by 1/radius) overflows single precision, and the particle
    // system keeps every radius there anyway (particle_system.hpp).
    template <class Site>
    [[nodiscard]] float radius(double v, const Bounds& bounds, const Site& site) const {
        const float r = real(v, bounds, site);
        if (!(r >= kMinParticleRadius))
            fail(site.path(), "must be at least " + shown_number(kMinParticleRadius) +
                                  ", the smallest normal float (got " + site.shown() +
                                  "): the particle is scaled by 1/radius, which would overflow");
        return r;
    }
    [[nodiscard]] float radius(const Node& n, const Bounds& bounds) const {
        return radius(number(n), bounds, NodeSite{*this, n});
    }

    // One component of a position in world coordinates: within ±kMaxSceneCoordinate, kept in double.
    template <class Site>
    [[nodiscard]] double coordinate(double v, const Site& site) const {
        if (kCoordinate.contains(v)) [[likely]] return v;  // (within the float range; NaN fails it)
        return checked_coordinate(v, site);
    }
    template <class Site>
    [[nodiscard, gnu::noinline]] double checked_coordinate(double v, const Site& site) const {
        (void)finite(v, site);
        if (std::abs(v) > static_cast<double>(std::numeric_limits<float>::max()))
            fail(site.path(), "too large for single precision (got " + site.shown() + ")");
        if (!kCoordinate.contains(v)) fail(site.path(), kCoordinate.describe(v) + " (got " + site.shown() + ")");
        return v;
    }

    // A direction: 3 numbers within the float range, not all 0, normalised in double from the values as
    // written. So [1e-50, 0, 0] is +x (rounding each number to float first would make it the zero vector), and
    // a component that is tiny next to the others is as exact as they are.
    [[nodiscard]] glm::dvec3 direction(const Node& n) const {
        if (!n.value->is_array() || n.value->size() != 3) wrong_type(n, "an array of 3 numbers");
        glm::dvec3 d(0.0);
        for (std::size_t a = 0; a < 3; ++a) {
            const Node c = n.element(a);
            d[int(a)] = number(c);
            if (std::abs(d[int(a)]) > static_cast<double>(std::numeric_limits<float>::max()))
                fail(c, "too large for single precision (got " + shown(c) + ")");
        }
        // Scaled to its largest component first: |d|² of [1e-200, 1e-200, 0] underflows even in double.
        const double largest = std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)});
        if (largest == 0.0) fail(n, "must not be the zero vector");
        return glm::normalize(d / largest);
    }

    // A position in world coordinates: 3 numbers within ±kMaxSceneCoordinate, kept in double (the scene
    // stores it relative to its origin, see local_point()).
    [[nodiscard]] glm::dvec3 point(const Node& n) const {
        if (!n.value->is_array() || n.value->size() != 3) wrong_type(n, "an array of 3 numbers");
        glm::dvec3 p(0.0);
        for (std::size_t a = 0; a < 3; ++a) {
            const Node c = n.element(a);
            p[int(a)] = coordinate(number(c), NodeSite{*this, c});
        }
        return p;
    }

    [[nodiscard]] glm::vec3 vec3(const Node& n, const Bounds& bounds = kAny) const {
        if (!n.value->is_array() || n.value->size() != 3) wrong_type(n, "an array of 3 numbers");
        return {real(n.element(0), bounds), real(n.element(1), bounds), real(n.element(2), bounds)};
    }

    [[nodiscard]] std::uint64_t integer(const Node& n, std::uint64_t lo, std::uint64_t hi) const {
        if (!n.value->is_number_integer()) wrong_type(n, "an integer");
        const std::string range = hi == std::numeric_limits<std::uint64_t>::max()
                                      ? "must be >= " + std::to_string(lo)
                                      : "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
        if (n.value->is_number_unsigned()) {
            const auto v = n.value->get<std::uint64_t>();
            if (v < lo || v > hi) fail(n, range + " (got " + shown(n) + ")");
            return v;
        }
        const auto v = n.value->get<std::int64_t>();  // a signed integer in nlohmann is always negative
        if (v < 0 || static_cast<std::uint64_t>(v) < lo || static_cast<std::uint64_t>(v) > hi)
            fail(n, range + " (got " + shown(n) + ")");
        return static_cast<std::uint64_t>(v);
    }
    [[nodiscard]] std::uint32_t u32(const Node& n, std::uint32_t lo, std::uint32_t hi) const {
        return static_cast<std::uint32_t>(integer(n, lo, hi));
    }

    [[nodiscard]] bool boolean(const Node& n) const {
        if (!n.value->is_boolean()) wrong_type(n, "true or false");
        return n.value->get<bool>();
    }

    [[nodiscard]] std::string string(const Node& n) const {
        if (!n.value->is_string()) wrong_type(n, "a string");
        return n.value->get<std::string>();
    }

private:
    std::string source_;
    mutable std::map<std::string, std::string> underflows_;  // filled by the scan, before any value is read
};

std::string NodeSite::shown() const { return reader.shown(node); }

// ---- The scene's origin -------------------------------------------------------------------------------

// A file without "origin" gets one near its first particle (or the tubes' centre): that point rounded to a
// multiple of the power of two at or above 16·scale (scale: that particle's radius). So every float the
// scene stores is within a few scene sizes of its origin and keeps the precision the file had, however far
// from 0 the scene is; a scene within 8 radii of 0 keeps the origin 0 (its floats are those of the world
// coordinates); and scenes moved by less than a grid step (one frame to the next of an exported sequence)
// share their origin. The grid is a power of two so that a dyadic scene stays exact relative to it.
constexpr double kOriginGridScales = 16.0;

glm::dvec3 origin_near(const glm::dvec3& p, double scale) {
    const double grid = std::exp2(std::ceil(std::log2(kOriginGridScales * scale)));
    glm::dvec3 o;
    for (int a = 0; a < 3; ++a) o[a] = grid * std::nearbyint(p[a] / grid) + 0.0;  // + 0.0: never −0
    return o;
}

// A world position as the scene stores it: relative to `origin`, subtracted in double, rounded once to
// float. A nonzero difference that rounds to 0 reads as +0 (as every number that rounds to 0 does).
glm::vec3 local_point(const glm::dvec3& world, const glm::dvec3& origin) {
    const glm::dvec3 d = world - origin;
    return glm::vec3(float(d.x) + 0.0f, float(d.y) + 0.0f, float(d.z) + 0.0f);
}

// One particle as a file gives it, each value checked (the centre in world coordinates, in double).
struct ParticleValues {
    glm::dvec3 center{0.0};
    float radius = 1.0f;
    glm::vec3 velocity{0.0f};
    float spin = 0.0f, growth = 0.0f, rotation = 0.0f;
};

// The one place where a file's particle becomes a Particle of the scene, in its frame: every reader of
// particle lists goes through it.
Particle local_particle(const ParticleValues& v, const glm::dvec3& origin) {
    Particle p;
    p.center = local_point(v.center, origin);
    p.radius = v.radius;
    p.velocity = v.velocity;
    p.spin = v.spin;
    p.growth = v.growth;
    p.rotation = v.rotation;
    return p;
}

// ---- Paths during parsing ----------------------------------------------------------------------------

// The deepest nesting a scene file needs is 3 levels (/ground/corners/0); a document nested deeper than
// this is refused while it is scanned, before recursive code (nlohmann's dump() in messages) meets it.
constexpr std::size_t kMaxNestingDepth = 64;

// Why `count` particles are too many ("" when they are not). `at_least`: the file holds more than
// `count` - 1 and the scan stopped counting there.
std::string particle_count_problem(std::uint64_t count, bool at_least) {
    const std::string shown = at_least ? "more than " + std::to_string(count - 1) : std::to_string(count);
    if (count > kMaxSceneParticles)
        return "too many particles (" + shown + (at_least ? ", " : " > " + std::to_string(kMaxSceneParticles) + ", ") +
               "the most a scene may hold)";
    const std::uint64_t limit = scene_particle_limit();
    if (count > limit)
        return "too many particles for this machine's memory (" + shown + "; at " + std::to_string(kPeakBytesPerParticle) +
               " bytes each, its " + format_bytes(machine_memory_bytes()) + " hold at most " + std::to_string(limit) + ")";
    return {};
}

// nlohmann keeps the last of two equal keys silently, it reports a number that overflows a double (1e999)
// without saying where, and it reads a particle list of any length into memory before the reader could
// count it. So the text is first scanned with this SAX handler, which builds nothing: it follows the JSON
// path itself, fails on a duplicate key on the spot, reports an overflow at the path of the value being
// read, stops counting particles at the limit, and refuses absurd nesting. Only a document that passes
// is parsed into a tree. (The parser-callback interface would do the same in one pass, but nlohmann
// 3.11's callback parser rescans the parent container after every object, which is quadratic in the
// length of a particle list.)
class ScanHandler {
public:
    ScanHandler(const Reader& reader, std::uint64_t particle_limit) : reader_(reader), particle_limit_(particle_limit) {}

    bool null() { return value(); }
    bool boolean(bool) { return value(); }
    bool number_integer(json::number_integer_t) { return value(); }
    bool number_unsigned(json::number_unsigned_t) { return value(); }
    bool number_float(json::number_float_t v, const json::string_t& literal) {
        if (reads_as_zero(literal, v)) reader_.note_underflow(path_of_next_value(), literal);
        return value();
    }
    bool string(json::string_t&) { return value(); }
    bool binary(json::binary_t&) { return value(); }

    bool start_object(std::size_t) { return open(false); }
    bool start_array(std::size_t) { return open(true); }
    bool end_object() { return close(); }
    bool end_array() { return close(); }

    bool key(json::string_t& key) {
        Frame& top = stack_.back();
        top.key = key;
        if (!top.keys.insert(key).second) reader_.fail(path_of_next_value(), "duplicate key");
        return true;
    }

    // The parser's own exception (json::parse_error, or json::out_of_range 406 for a number beyond the
    // double range), thrown as json::parse would throw it; parse_json() turns it into a SceneFileError.
    template <class Exception>
    bool parse_error(std::size_t /*position*/, const std::string& /*last_token*/, const Exception& e) {
        throw e;
    }

    // The JSON pointer of the value the parser is reading now (the member after the last key, or the
    // next array element).
    [[nodiscard]] std::string path_of_next_value() const {
        std::string p;
        for (const Frame& f : stack_) p += f.segment;
        return p + next_segment();
    }

private:
    struct Frame {
        bool array;
        bool particle_list;          // this is /smoke/particles
        std::string segment;         // how the parent addresses this container ("" for the root)
        std::string key;             // objects: the current key
        std::set<std::string> keys;  // objects: the keys seen so far
        std::uint64_t next_index;    // arrays: index of the next element
    };

    // A value or container begins: one more element of the enclosing array.
    void count_element() {
        if (stack_.empty() || !stack_.back().array) return;
        Frame& top = stack_.back();
        if (top.particle_list && top.next_index >= particle_limit_)
            reader_.fail("/smoke/particles", particle_count_problem(particle_limit_ + 1, true));
        ++top.next_index;
    }

    bool value() {
        count_element();
        return true;
    }

    bool open(bool array) {
        if (stack_.size() >= kMaxNestingDepth)
            reader_.fail(path_of_next_value(), "nested deeper than " + std::to_string(kMaxNestingDepth) + " levels");
        std::string segment = next_segment();
        const bool particle_list = array && stack_.size() == 2 && !stack_[0].array && !stack_[1].array &&
                                   stack_[1].segment == "/smoke" && stack_[1].key == "particles";
        count_element();
        stack_.push_back(Frame{array, particle_list, std::move(segment), {}, {}, 0});
        return true;
    }

    bool close() {
        stack_.pop_back();
        return true;
    }

    [[nodiscard]] std::string next_segment() const {
        if (stack_.empty()) return {};
        const Frame& top = stack_.back();
        std::string segment(1, '/');  // appended, not "/" + …: GCC 12 warns falsely (-Wrestrict) on that
        segment += top.array ? std::to_string(top.next_index) : pointer_token(top.key);
        return segment;
    }

    const Reader& reader_;
    std::uint64_t particle_limit_;
    std::vector<Frame> stack_;
};

json parse_json(std::string_view text, const Reader& reader, const std::string& source) {
    ScanHandler scan(reader, scene_particle_limit());
    try {
        json::sax_parse(text.begin(), text.end(), &scan);
        return json::parse(text.begin(), text.end());  // cannot fail: the scan accepted the same text
    } catch (const json::parse_error& e) {
        // e.byte is 1-based; n+1 means "at the end of the input" (truncated file).
        const std::size_t offset = std::min<std::size_t>(e.byte == 0 ? 0 : e.byte - 1, text.size());
        const auto before = text.substr(0, offset);
        const std::size_t line = 1 + static_cast<std::size_t>(std::count(before.begin(), before.end(), '\n'));
        const std::size_t line_start = before.rfind('\n');
        const std::size_t column = offset - (line_start == std::string_view::npos ? 0 : line_start + 1) + 1;
        std::string reason = e.what();
        if (const auto p = reason.find("parse error"); p != std::string::npos)
            if (const auto colon = reason.find(": ", p); colon != std::string::npos) reason = reason.substr(colon + 2);
        std::string where = offset >= text.size() ? "at the end of the input (byte " + std::to_string(offset + 1) + ")"
                                                  : "at byte " + std::to_string(offset + 1);
        throw SceneFileError(source + ": malformed JSON " + where + ", line " + std::to_string(line) + ", column " +
                             std::to_string(column) + ": " + reason);
    } catch (const json::out_of_range& e) {
        // 406 "number overflow parsing '1e999'": the literal is between the quotes.
        std::string literal = e.what();
        const auto open = literal.find('\''), close = literal.rfind('\'');
        literal = open != std::string::npos && close > open ? literal.substr(open + 1, close - open - 1) : "?";
        reader.fail(scan.path_of_next_value(),
                    "must be finite (got " + shown_text(literal) + ", a number out of range for a double)");
    }
}

// ---- Extent and motion ---------------------------------------------------------------------------------

// Empty when the particle (in the frame of `origin`) stays within ±kMaxSceneCoordinate of the world's 0
// with a radius <= kMaxSceneCoordinate over `steps` frame steps of ParticleSystem::advance(), else what
// goes wrong (bounds in double: the float steps' rounding is relative 2^-24 per step, nowhere near the
// factor of 10^4 between the bound and the first overflow).
std::string particle_extent_problem(const Particle& p, std::uint64_t steps, const glm::dvec3& origin) {
    const double n = double(steps);
    for (int a = 0; a < 3; ++a) {
        const double reach = std::abs(origin[a] + double(p.center[a])) + n * std::abs(double(p.velocity[a]));
        if (!(reach <= kMaxSceneCoordinate)) {
            const std::string where = steps == 0 ? "lies" : "moves";
            return where + " beyond the coordinate range +-" + shown_number(kMaxSceneCoordinate) +
                   (steps == 0 ? "" : " within " + std::to_string(steps + 1) + " frames") + " (" + "xyz"[a] +
                   " reaches " + shown_number(reach) + ")";
        }
    }
    if (p.growth > 0.0f && steps > 0 &&
        !(std::log(double(p.radius)) + n * std::log1p(double(p.growth)) <= std::log(kMaxSceneCoordinate)))
        return "grows beyond a radius of " + shown_number(kMaxSceneCoordinate) + " within " + std::to_string(steps + 1) +
               " frames";
    if (!(double(p.radius) <= kMaxSceneCoordinate))
        return "has a radius beyond " + shown_number(kMaxSceneCoordinate);
    return {};
}

// ---- The default camera -------------------------------------------------------------------------------

// Where default_camera() puts the camera, in double (before rounding to float, so that a position beyond
// the float range can be reported rather than turned into inf).
struct DefaultView {
    glm::dvec3 position, look_at;
};
DefaultView default_view(const std::vector<Particle>& particles, const std::optional<GroundDescription>& ground,
                         float fov_deg, std::uint32_t width, std::uint32_t height) {
    // Bounding sphere: centre of the box, radius to the farthest surface point. Both are reductions over the
    // particles, in parallel: minima and maxima are exact, so the result is the same whatever the split.
    glm::dvec3 center(0.0);
    double radius = 1.0;
    if (!particles.empty()) {
        using Range = tbb::blocked_range<std::size_t>;
        const Range all(0, particles.size());
        struct Box {
            glm::dvec3 lo, hi;
        };
        constexpr double kInf = std::numeric_limits<double>::infinity();
        const Box box = tbb::parallel_reduce(
            all, Box{glm::dvec3(kInf), glm::dvec3(-kInf)},
            [&](const Range& range, Box b) {
                for (std::size_t i = range.begin(); i != range.end(); ++i) {
                    const Particle& p = particles[i];
                    b.lo = glm::min(b.lo, glm::dvec3(p.center) - double(p.radius));
                    b.hi = glm::max(b.hi, glm::dvec3(p.center) + double(p.radius));
                }
                return b;
            },
            [](const Box& a, const Box& b) { return Box{glm::min(a.lo, b.lo), glm::max(a.hi, b.hi)}; });
        center = 0.5 * (box.lo + box.hi);
        radius = tbb::parallel_reduce(
            all, 0.0,
            [&](const Range& range, double farthest) {
                for (std::size_t i = range.begin(); i != range.end(); ++i) {
                    const Particle& p = particles[i];
                    farthest = std::max(farthest, glm::length(glm::dvec3(p.center) - center) + p.radius);
                }
                return farthest;
            },
            [](double a, double b) { return std::max(a, b); });
    } else if (ground) {
        for (const glm::vec3& c : ground->corners) center += 0.25 * glm::dvec3(c);
        radius = 0.0;
        for (const glm::vec3& c : ground->corners) radius = std::max(radius, glm::length(glm::dvec3(c) - center));
    }

    const double half_vertical = 0.5 * fov_deg * kRadiansPerDegree;
    const double half_horizontal = std::atan(std::tan(half_vertical) * double(width) / double(height));
    const double half = std::min(half_vertical, half_horizontal);
    // Never closer than float resolution at the centre allows: a lone particle of radius 1e-38 at (1, 1, 1)
    // would otherwise put the camera on the point it looks at.
    radius = std::max(radius, kMinDefaultFramingRadius * std::max(1.0, glm::length(center)));
    const double distance = kDefaultCameraMargin * radius / std::sin(half);
    const double elevation = kDefaultCameraElevationDeg * kRadiansPerDegree;
    const glm::dvec3 toward_camera(0.0, std::sin(elevation), std::cos(elevation));

    return {center + distance * toward_camera, center};
}

// v rounded up to 3 significant digits, for "at least v" in messages.
std::string shown_rounded_up(double v) {
    const double step = std::pow(10.0, std::floor(std::log10(v)) - 2.0);
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.3g", std::ceil(v / step) * step);
    return buffer;
}

std::string shown_3_digits(double v) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.3g", v);
    return buffer;
}

// A field of view so small that neighbouring pixels' rays are closer than kMinPixelAngle is refused at
// fov_deg (n): the float camera would accept it and render blocks of equal pixels (1e-20 even failed there,
// blamed on camera.up).
void check_fov_resolution(const Reader& r, const Node& n, float fov_deg, std::uint32_t height) {
    if (const std::string problem = pixel_angle_problem(fov_deg, height); !problem.empty())
        r.fail(n, "too small for a usable camera (got " + r.shown(n) + "): " + problem);
}

// The default camera must stand within ±kMaxDefaultCameraCoordinate of the world's 0. `path`:
// /camera/fov_deg when the file gave the field of view (it is what backs the camera off), else /camera.
void check_default_position(const Reader& r, const DefaultView& v, const std::string& path, bool fov_given,
                            const glm::dvec3& origin) {
    const glm::dvec3 at = origin + v.position;  // in world coordinates, as the file's
    const double reach = std::max({std::abs(at.x), std::abs(at.y), std::abs(at.z)});
    if (reach <= kMaxDefaultCameraCoordinate) return;
    const std::string where = "(to fit the smoke into this view it would stand at (" + shown_3_digits(at.x) + ", " +
                              shown_3_digits(at.y) + ", " + shown_3_digits(at.z) + "))";
    if (fov_given)
        r.fail(path, "pushes the default camera beyond the coordinate limit of " +
                         shown_number(kMaxDefaultCameraCoordinate) + " " + where +
                         ": give camera.position, or a larger fov_deg");
    r.fail(path, "the default camera would stand beyond the coordinate limit of " +
                     shown_number(kMaxDefaultCameraCoordinate) + " " + where +
                     ": give camera.position, a larger fov_deg, or a less narrow image");
}

// ---- Sections ----------------------------------------------------------------------------------------

LightDescription read_light(const Reader& r, const Node& n) {
    r.require_object(n, {"direction", "color", "rotation_per_frame_deg"});
    LightDescription light;
    light.direction = glm::vec3(r.direction(r.required(n, "direction")));
    if (auto c = Reader::optional(n, "color")) light.color = r.vec3(*c, kColor);
    if (auto a = Reader::optional(n, "rotation_per_frame_deg")) light.rotation_per_frame_deg = r.real(*a);
    return light;
}

ParticleValues read_particle(const Reader& r, const Node& n) {
    r.require_object(n, {"center", "radius", "velocity", "spin", "growth", "rotation"});
    ParticleValues p;
    p.center = r.point(r.required(n, "center"));
    p.radius = r.radius(r.required(n, "radius"), kRadius);
    if (auto v = Reader::optional(n, "velocity")) p.velocity = r.vec3(*v);
    if (auto s = Reader::optional(n, "spin")) p.spin = r.real(*s);
    if (auto g = Reader::optional(n, "growth")) p.growth = r.real(*g, Bounds{-1.0, true});
    if (auto a = Reader::optional(n, "rotation")) p.rotation = r.real(*a);
    return p;
}

// `origin`: the file's, or (when it gave none) set here from the tubes' centre.
TubeSettings read_tubes(const Reader& r, const Node& n, std::optional<glm::dvec3>& origin) {
    r.require_object(n, {"count", "seed", "center", "tube_radius", "tube_length", "separation", "particle_radius",
                         "drift", "jitter_speed", "spin_speed", "growth", "random_rotation"});
    TubeSettings t;
    if (auto v = Reader::optional(n, "count")) {
        const std::uint64_t count = r.integer(*v, 0, std::numeric_limits<std::uint64_t>::max());
        if (const std::string problem = particle_count_problem(count, false); !problem.empty()) r.fail(*v, problem);
        t.particles = static_cast<std::uint32_t>(count);
    }
    if (auto v = Reader::optional(n, "seed")) t.seed = r.integer(*v, 0, std::numeric_limits<std::uint64_t>::max());
    if (auto v = Reader::optional(n, "tube_radius")) t.tube_radius = r.real(*v, kPositive);
    if (auto v = Reader::optional(n, "tube_length")) t.tube_length = r.real(*v, kPositive);
    if (auto v = Reader::optional(n, "separation")) t.separation = r.real(*v, kNonNegative);
    if (auto v = Reader::optional(n, "particle_radius")) t.particle_radius = r.radius(*v, kPositive);
    if (auto v = Reader::optional(n, "drift")) t.drift = r.vec3(*v);
    if (auto v = Reader::optional(n, "jitter_speed")) t.jitter_speed = r.real(*v, kNonNegative);
    if (auto v = Reader::optional(n, "spin_speed")) t.spin_speed = r.real(*v, kNonNegative);
    if (auto v = Reader::optional(n, "growth")) t.growth = r.real(*v, Bounds{-1.0, true});
    if (auto v = Reader::optional(n, "random_rotation")) t.random_rotation = r.boolean(*v);
    glm::dvec3 center(0.0);
    if (auto v = Reader::optional(n, "center")) center = r.point(*v);
    if (!origin) origin = origin_near(center, t.particle_radius);
    t.center = local_point(center, *origin);
    return t;
}

// ---- Particles from a PLY point cloud -----------------------------------------------------------------

// A PLY vertex's property, for messages: "/smoke/particles: FILE: vertex 17, property radius".
struct PlyValueSite {
    const std::string& file;
    std::uint64_t vertex;
    std::string_view property;
    double value;

    [[nodiscard]] std::string path() const {
        return "/smoke/particles: " + file + ": vertex " + std::to_string(vertex) + ", property " +
               std::string(property);
    }
    [[nodiscard]] std::string shown() const {
        if (std::isnan(value)) return "nan";
        if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
        return shown_number(value);
    }
};

// Vertices decoded per call of PlyPointReader::PieceReader::read().
constexpr std::size_t kPlyBatch = 1024;

// "particles": "cloud.ply": the file's vertices, a path relative to the scene file's folder (`base_dir`), each
// through the checks of a JSON list's particle, the file's pieces in parallel. `origin`, when the file gave
// none, from the first vertex. Returns the file's name as messages give it.
std::string read_ply_particles(const Reader& r, const Node& list, const std::filesystem::path& base_dir,
                               std::vector<Particle>& particles, std::optional<glm::dvec3>& origin) {
    const std::filesystem::path path = base_dir / r.string(list);
    const std::string name = path.string();
    try {
        PlyPointReader ply(path, name);
        if (const std::string problem = particle_count_problem(ply.vertex_count(), false); !problem.empty())
            r.fail(list.path + ": " + name + ": element vertex", problem);
        const std::vector<PlyPiece> pieces = ply.pieces();
        // Only now: pieces() has held the count against the file's size, so a header that lies cannot claim
        // more memory than the file could hold. Its fresh pages faulted in by the threads together.
        resize_populated(particles, std::size_t(ply.vertex_count()));

        // One thread's piece reader and batch, kept from piece to piece.
        struct Scratch {
            PlyPointReader::PieceReader piece;
            std::vector<PlyPoint> batch = std::vector<PlyPoint>(kPlyBatch);
        };
        tbb::enumerable_thread_specific<Scratch> scratch([&] { return Scratch{PlyPointReader::PieceReader(ply)}; });
        const auto read_piece = [&](const PlyPiece& piece, std::optional<glm::dvec3>& piece_origin) {
            Scratch& s = scratch.local();
            s.piece.start(piece);
            std::uint64_t index = piece.first_vertex;
            for (std::size_t count; (count = s.piece.read(s.batch)) != 0;) {
                for (const PlyPoint& p : std::span(s.batch).first(count)) {
                    ParticleValues v;
                    v.center = {r.coordinate(p.x, PlyValueSite{name, index, "x", p.x}),
                                r.coordinate(p.y, PlyValueSite{name, index, "y", p.y}),
                                r.coordinate(p.z, PlyValueSite{name, index, "z", p.z})};
                    v.radius = r.radius(p.radius, kRadius, PlyValueSite{name, index, "radius", p.radius});
                    if (ply.has_velocity())
                        v.velocity = {r.real(p.vx, kAny, PlyValueSite{name, index, "vx", p.vx}),
                                      r.real(p.vy, kAny, PlyValueSite{name, index, "vy", p.vy}),
                                      r.real(p.vz, kAny, PlyValueSite{name, index, "vz", p.vz})};
                    if (!piece_origin) piece_origin = origin_near(v.center, v.radius);
                    particles[std::size_t(index++)] = local_particle(v, *piece_origin);
                }
            }
        };
        // The first piece alone, so that its first vertex sets the origin before any other is placed.
        if (!pieces.empty()) read_piece(pieces[0], origin);
        // Every piece keeps its own problem, and the first piece's in file order is raised, then finish()'s:
        // the problem a reader from the file's start would have met first, whatever the thread count. A
        // piece after one with a problem is not read.
        std::vector<std::exception_ptr> problems(pieces.size());
        std::atomic<std::size_t> first_problem = pieces.size();
        tbb::parallel_for(std::size_t{1}, pieces.size(), [&](std::size_t i) {
            if (i > first_problem.load(std::memory_order_relaxed)) return;
            try {
                std::optional<glm::dvec3> piece_origin = origin;
                read_piece(pieces[i], piece_origin);
            } catch (...) {
                problems[i] = std::current_exception();
                std::size_t seen = first_problem.load();
                while (i < seen && !first_problem.compare_exchange_weak(seen, i)) {}
            }
        });
        for (const std::exception_ptr& problem : problems)
            if (problem) std::rethrow_exception(problem);
        ply.finish();
    } catch (const PlyError& e) {
        r.fail(list.path, e.what());
    }
    return name;
}

// ---- The fast reader of a particle list ---------------------------------------------------------------

namespace ondemand = simdjson::ondemand;

// The fast reader gives up on a list it does not read exactly as the reference reader would (bad syntax, a
// value of the wrong type, an unknown, escaped or repeated key): parse_scene() then reads the whole document
// with the reference reader, which finds the problem and words it as it always has.
struct FastReaderDeclined {
    const char* reason;
};

constexpr bool json_whitespace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

// Where /smoke/particles begins (its '['), when it is an array; null when it is not there, not an array, or the
// document is broken on the way to it (the reference reader then reads the document). On-Demand reads only as far
// as the list's first byte, so that the text after it need not have been indexed.
const char* find_particle_list(ondemand::document& document) {
    ondemand::object root;
    if (document.get_object().get(root)) return nullptr;
    for (auto member : root) {
        ondemand::field field;
        if (std::move(member).get(field)) return nullptr;
        if (!(field.key() == "smoke")) continue;
        ondemand::object smoke;
        if (field.value().get_object().get(smoke)) return nullptr;
        for (auto smoke_member : smoke) {
            ondemand::field smoke_field;
            if (std::move(smoke_member).get(smoke_field)) return nullptr;
            if (!(smoke_field.key() == "particles")) continue;
            ondemand::value list = smoke_field.value();
            const std::string_view token = list.raw_json_token();
            return !token.empty() && token.front() == '[' ? token.data() : nullptr;
        }
        return nullptr;
    }
    return nullptr;
}

// Where the particle list opened at text[open] ends: the ']' after it when only JSON white space lies between
// (an empty list), else the last ']' in the text that follows a '}' (white space between), as a list of
// particles ends; npos when there is none. Sought from the text's end, it costs the bytes after the list alone,
// not a pass over the list. A ']' that only looks like the list's end (in a string, or closing an array of
// objects after the list) leaves in the list's text what is no particle, and the fast reader then declines the
// list: it reads each piece as an array of particles with nothing after it (FastParticleList), so a list it
// reads did end there.
std::size_t particle_list_end(std::string_view text, std::size_t open) {
    std::size_t first = open + 1;
    while (first < text.size() && json_whitespace(text[first])) ++first;
    if (first < text.size() && text[first] == ']') return first;
    for (std::size_t i = text.size(); i-- > open + 1;) {
        if (text[i] != ']') continue;
        std::size_t before = i;
        while (before > open + 1 && json_whitespace(text[before - 1])) --before;
        if (text[before - 1] == '}') return i;
    }
    return std::string_view::npos;
}

// A number of a particle in the list, for messages: its path, and its text as the file wrote it.
struct ListValueSite {
    std::size_t particle;
    std::string_view key;
    int component;  // -1: the key's value itself
    std::string_view token;

    [[nodiscard]] std::string path() const {
        std::string p = "/smoke/particles/" + std::to_string(particle) + "/" + std::string(key);
        if (component >= 0) p += "/" + std::to_string(component);
        return p;
    }
    [[nodiscard]] std::string shown() const {
        try {
            const json value = json::parse(token);
            if (value.is_number_float() && reads_as_zero(token, value.get<double>())) return shown_underflow(token);
            return shown_value(value);
        } catch (const json::exception&) {
            return shown_text(token);
        }
    }
};

// simdjson 3.0's get_double() misreads some numbers of more than 19 digits (0.1000000000000000055511151231257827
// as 4e-16: past a 0's leading zeros it counts too few digits and overflows its 64-bit integer; simdjson issue
// #2093, fixed in 3.6.3). A number token longer than kLongestTokenForSimdjson is converted by std::from_chars
// unless it has at most 19 digits before its exponent (leading zeros included), which that integer holds
// exactly, and an exponent of at most 2 digits, which keeps its power of ten (at least 10^-118) within
// get_double()'s exact range (10^-342 … 10^308). An exporter's doubles ("-0.009585144929587841": 19 digits in
// 21 characters) read there.
constexpr std::size_t kLongestTokenForSimdjson = 18;
constexpr std::size_t kMostDigitsForSimdjson = 19;
constexpr std::size_t kMostExponentDigitsForSimdjson = 2;

// A number token's length (simdjson's raw token runs on over the white space after the number), and its digits
// before and after an exponent's 'e', in one pass.
struct NumberShape {
    std::size_t length = 0;
    std::size_t digits = 0;
    std::size_t exponent_digits = 0;
};
NumberShape shape_of(std::string_view token) {
    NumberShape shape;
    std::size_t* count = &shape.digits;
    for (; shape.length < token.size() && !json_whitespace(token[shape.length]); ++shape.length) {
        const char c = token[shape.length];
        if (c >= '0' && c <= '9') ++*count;
        else if (c == 'e' || c == 'E') count = &shape.exponent_digits;
    }
    return shape;
}

// A JSON number as the reference reader reads it (nlohmann: strtod, correctly rounded). nlohmann reads "-0" as
// the integer 0, which is +0 as a double; simdjson's get_double() gives -0.
double list_number(ondemand::value& value, std::string_view& token) {
    token = value.raw_json_token();
    double v;
    if (value.get_double().get(v)) throw FastReaderDeclined{"not a number"};  // also checks the JSON syntax
    if (token.size() > kLongestTokenForSimdjson) {
        const NumberShape n = shape_of(token);
        const bool exact = n.digits <= kMostDigitsForSimdjson && n.exponent_digits <= kMostExponentDigitsForSimdjson;
        if (n.length > kLongestTokenForSimdjson && !exact &&
            std::from_chars(token.data(), token.data() + n.length, v).ec != std::errc())
            throw FastReaderDeclined{"a number from_chars does not read"};
    }
    if (v == 0.0 && std::signbit(v) && token.find_first_of(".eE") == std::string_view::npos) v = 0.0;
    return v;
}

// Three numbers, each through `check` (a value check of Reader's, on the number and its site).
template <class Check>
auto list_triple(ondemand::value& value, std::size_t particle, std::string_view key, Check&& check) {
    ondemand::array array;
    if (value.get_array().get(array)) throw FastReaderDeclined{"not an array"};
    std::array<decltype(check(0.0, ListValueSite{})), 3> out{};
    int n = 0;
    for (auto element : array) {
        ondemand::value component;
        if (element.get(component) || n == 3) throw FastReaderDeclined{"not an array of 3 numbers"};
        std::string_view token;
        const double v = list_number(component, token);
        out[std::size_t(n)] = check(v, ListValueSite{particle, key, n, token});
        ++n;
    }
    if (n != 3) throw FastReaderDeclined{"not an array of 3 numbers"};
    return out;
}

// Reads /smoke/particles from its text (the array, '[' to the ']' particle_list_end() found) in
// pieces of about kListPieceBytes read in parallel, each by its own On-Demand parser: no tree, no path string
// per value. read_particle() is its reference: the same keys and the same checks in the same order.
//
// A piece starts at a '{' (a particle's: a valid list has no other, since particles hold no objects and the
// keys it accepts hold no braces) and ends before the next piece's, so that "[" + piece, less its last comma,
// + "]" is a JSON array of its particles. If every piece reads as one, the list does; a cut that fell inside a
// string leaves an unterminated string in the piece before it, which then does not read, and the reference
// reader takes over. Each piece's particles are counted first (its '{'s), so that every piece knows where in
// the list its particles go; a piece with as many '}' as '{' that reads another number of particles declines.
class FastParticleList {
public:
    explicit FastParticleList(std::string_view list_text) : text_(list_text) {}

    // The particles, as local_particle() makes them; `origin`, when the file gave none, from the first.
    // Declines unless every piece reads, which also shows that particle_list_end() found the list's end.
    void read(const Reader& r, std::vector<Particle>& particles, std::optional<glm::dvec3>& origin) const {
        const std::vector<std::string_view> pieces = cut_into_pieces();
        std::vector<std::size_t> first(pieces.size() + 1, 0);  // each piece's first particle in the list
        std::vector<char> balanced(pieces.size());
        tbb::parallel_for(std::size_t{0}, pieces.size(), [&](std::size_t i) {
            first[i + 1] = std::size_t(std::count(pieces[i].begin(), pieces[i].end(), '{'));
            balanced[i] = first[i + 1] == std::size_t(std::count(pieces[i].begin(), pieces[i].end(), '}'));
        });
        // A cut inside a particle (at a brace it should not hold) leaves a piece with a brace unclosed.
        if (std::find(balanced.begin(), balanced.end(), 0) != balanced.end())
            throw FastReaderDeclined{"a brace outside a particle"};
        for (std::size_t i = 0; i < pieces.size(); ++i) first[i + 1] += first[i];
        if (const std::string problem = particle_count_problem(first.back(), false); !problem.empty())
            r.fail("/smoke/particles", problem);
        particles.resize(first.back());

        // The first piece alone, so that its first particle sets the origin before any other is placed.
        tbb::enumerable_thread_specific<PieceReader> readers;
        if (!pieces.empty()) readers.local().read(r, pieces[0], first[0], first[1], particles, origin);
        // Every piece keeps its own problem, and the first piece's in list order is raised: the problem a
        // reader from the list's start would have met first, whatever the thread count.
        std::vector<std::exception_ptr> problems(pieces.size());
        tbb::parallel_for(std::size_t{1}, pieces.size(), [&](std::size_t i) {
            try {
                readers.local().read(r, pieces[i], first[i], first[i + 1], particles, origin);
            } catch (...) {
                problems[i] = std::current_exception();
            }
        });
        for (const std::exception_ptr& problem : problems)
            if (problem) std::rethrow_exception(problem);
    }

private:
    // Large enough that a piece's parser set-up is lost in its reading, small enough to share work evenly.
    static constexpr std::size_t kListPieceBytes = std::size_t{256} << 10;

    // One thread's parser and padded buffer, reused for every piece it reads.
    struct PieceReader {
        ondemand::parser parser;
        std::string buffer;

        // The piece's particles, which are particles[index, end) of the list.
        void read(const Reader& r, std::string_view piece, std::size_t index, std::size_t end,
                  std::vector<Particle>& particles, std::optional<glm::dvec3>& origin) {
            buffer.clear();
            buffer.reserve(piece.size() + 2 + simdjson::SIMDJSON_PADDING);
            buffer.append(1, '[').append(piece).append(1, ']');
            ondemand::document document;
            ondemand::array list;
            if (parser.iterate(simdjson::padded_string_view(buffer.data(), buffer.size(), buffer.capacity()))
                    .get(document) ||
                document.get_array().get(list))
                throw FastReaderDeclined{"not JSON simdjson can index"};
            for (auto element : list) {
                ondemand::object object;
                if (element.get_object().get(object)) throw FastReaderDeclined{"a particle is not an object"};
                if (index == end) throw FastReaderDeclined{"a brace outside a particle"};
                const ParticleValues values = read_particle(r, object, index);
                if (!origin) origin = origin_near(values.center, values.radius);
                particles[index++] = local_particle(values, *origin);
            }
            if (index != end) throw FastReaderDeclined{"a brace outside a particle"};
            // The array read, nothing may follow it: the piece held particles and nothing else.
            if (!document.current_location().error()) throw FastReaderDeclined{"text after the particles"};
        }
    };

    // The list's text between its brackets, cut before a particle's '{' into pieces of about kListPieceBytes,
    // each without the comma that followed it.
    [[nodiscard]] std::vector<std::string_view> cut_into_pieces() const {
        std::string_view body = text_;  // (simdjson's raw text of a value runs on over the whitespace after it)
        while (!body.empty() && json_whitespace(body.back())) body.remove_suffix(1);
        if (body.size() < 2 || body.front() != '[' || body.back() != ']') throw FastReaderDeclined{"not an array"};
        body = body.substr(1, body.size() - 2);
        while (!body.empty() && json_whitespace(body.back())) body.remove_suffix(1);
        std::vector<std::string_view> pieces;
        if (std::all_of(body.begin(), body.end(), json_whitespace)) return pieces;
        for (std::size_t begin = 0; begin < body.size();) {
            std::size_t end = body.size();
            if (body.size() - begin > 2 * kListPieceBytes)
                end = std::min(end, body.find('{', begin + kListPieceBytes));
            std::string_view piece = body.substr(begin, end - begin);
            if (end != body.size()) {
                while (!piece.empty() && json_whitespace(piece.back())) piece.remove_suffix(1);
                if (piece.empty() || piece.back() != ',') throw FastReaderDeclined{"no comma between particles"};
                piece.remove_suffix(1);
            }
            pieces.push_back(piece);
            begin = end;
        }
        return pieces;
    }

    static ParticleValues read_particle(const Reader& r, ondemand::object& object, std::size_t index) {
        enum Key : unsigned { center = 1, radius = 2, velocity = 4, spin = 8, growth = 16, rotation = 32 };
        ParticleValues p;
        unsigned seen = 0;
        for (auto member : object) {
            ondemand::field field;
            if (std::move(member).get(field)) throw FastReaderDeclined{"broken object"};
            const ondemand::raw_json_string key = field.key();
            const Key k = key == "center" ? center : key == "radius" ? radius : key == "velocity" ? velocity
                        : key == "spin" ? spin : key == "growth" ? growth : key == "rotation" ? rotation : Key(0);
            if (k == 0 || (seen & k)) throw FastReaderDeclined{"an unknown or repeated key"};
            seen |= k;
            ondemand::value value = field.value();
            std::string_view token;
            switch (k) {
                case center: {
                    const auto c = list_triple(value, index, "center",
                                               [&](double v, const ListValueSite& s) { return r.coordinate(v, s); });
                    p.center = {c[0], c[1], c[2]};
                    break;
                }
                case radius: {
                    const double v = list_number(value, token);
                    p.radius = r.radius(v, kRadius, ListValueSite{index, "radius", -1, token});
                    break;
                }
                case velocity: {
                    const auto c = list_triple(value, index, "velocity",
                                               [&](double v, const ListValueSite& s) { return r.real(v, kAny, s); });
                    p.velocity = {c[0], c[1], c[2]};
                    break;
                }
                case spin:
                case growth:
                case rotation: {
                    const double v = list_number(value, token);
                    if (k == spin) p.spin = r.real(v, kAny, ListValueSite{index, "spin", -1, token});
                    if (k == growth)
                        p.growth = r.real(v, Bounds{-1.0, true}, ListValueSite{index, "growth", -1, token});
                    if (k == rotation) p.rotation = r.real(v, kAny, ListValueSite{index, "rotation", -1, token});
                    break;
                }
            }
        }
        if ((seen & (center | radius)) != (center | radius)) throw FastReaderDeclined{"a required key is missing"};
        return p;
    }

    std::string_view text_;
};

// `origin`: the file's, or (when it gave none) set here from the first particle or the tubes; 0 if neither.
// `fast`: reads /smoke/particles in place of the tree (whose list is then a placeholder).
SmokeDescription read_smoke(const Reader& r, const Node& n, std::optional<glm::dvec3>& origin, const FastParticleList* fast,
                            const std::filesystem::path& base_dir) {
    r.require_object(n, {"particles", "tubes", "sigma_t", "alpha", "shape", "kernel"});
    SmokeDescription smoke;
    const auto list = Reader::optional(n, "particles");
    const auto tubes = Reader::optional(n, "tubes");
    if (list && tubes) r.fail(n, "has both \"particles\" and \"tubes\"; give exactly one");
    if (!list && !tubes) r.fail(n, "needs \"particles\" (a list) or \"tubes\" (the generator)");
    if (list) {
        // Every reader of a list hands each particle's checked values here, in order.
        const auto add = [&](const ParticleValues& values) {
            if (!origin) origin = origin_near(values.center, values.radius);
            smoke.particles.push_back(local_particle(values, *origin));
        };
        if (list->value->is_string()) {
            smoke.particle_file = read_ply_particles(r, *list, base_dir, smoke.particles, origin);
        } else if (fast) {
            fast->read(r, smoke.particles, origin);
        } else {
            if (!list->value->is_array()) r.wrong_type(*list, "an array of particles");
            if (const std::string problem = particle_count_problem(list->value->size(), false); !problem.empty())
                r.fail(*list, problem);  // (the scan already stopped longer lists)
            smoke.particles.reserve(list->value->size());
            for (std::size_t i = 0; i < list->value->size(); ++i) add(read_particle(r, list->element(i)));
        }
        if (!origin) origin = glm::dvec3(0.0);  // no particles
    } else {
        smoke.tubes = read_tubes(r, *tubes, origin);
        smoke.particles = generate_tubes(*smoke.tubes);
        for (std::size_t i = 0; i < smoke.particles.size(); ++i)
            if (const std::string problem = particle_extent_problem(smoke.particles[i], 0, *origin); !problem.empty())
                r.fail(*tubes, "generated particle " + std::to_string(i) + " " + problem);
    }
    if (auto v = Reader::optional(n, "sigma_t")) smoke.sigma_t = r.real(*v, kNonNegative);
    if (auto v = Reader::optional(n, "alpha")) smoke.alpha = r.real(*v, kUnit);
    if (auto v = Reader::optional(n, "shape")) {
        const std::string text = r.string(*v);
        const auto shape = parse_stand_in_shape(text);
        if (!shape)
            r.fail(*v, "unknown shape " + shown_value(*v->value) +
                           " (use \"sphere\", \"icosahedron\" or \"icosphere:1\"…\"icosphere:4\")");
        smoke.shape = *shape;
    }
    if (auto v = Reader::optional(n, "kernel")) {
        const auto kernel = parse_density_kernel(r.string(*v));
        if (!kernel)
            r.fail(*v, "unknown kernel " + shown_value(*v->value) + " (use \"uniform\", \"gaussian\", \"poly1\" or \"poly2\")");
        smoke.kernel = *kernel;
    }
    return smoke;
}

GroundDescription read_ground(const Reader& r, const Node& n, const glm::dvec3& origin) {
    r.require_object(n, {"corners", "color"});
    GroundDescription ground;
    const Node corners = r.required(n, "corners");
    if (!corners.value->is_array() || corners.value->size() != 4) r.wrong_type(corners, "an array of 4 points");
    // The checks below run on the corners relative to the origin, in double: as exact as the file's values.
    std::array<glm::dvec3, 4> v;
    for (std::size_t i = 0; i < 4; ++i) {
        v[i] = r.point(corners.element(i)) - origin;
        ground.corners[i] = local_point(v[i], glm::dvec3(0.0));
    }

    // Newell's normal: twice the vector area, robust for any planar polygon and pointing to the side from
    // which the corners run counter-clockwise.
    glm::dvec3 newell(0.0);
    double longest_edge = 0.0;
    for (std::size_t i = 0; i < 4; ++i) {
        newell += glm::cross(v[i], v[(i + 1) % 4]);
        longest_edge = std::max(longest_edge, glm::length(v[(i + 1) % 4] - v[i]));
    }
    const double area = 0.5 * glm::length(newell);
    if (!(area > kMinRelativeGroundArea * longest_edge * longest_edge))
        r.fail(corners, "degenerate quad (area " + shown_number(area) + ")");
    const glm::dvec3 normal = newell / (2.0 * area);

    // Off-plane distances from the plane through the centroid with Newell's normal (the least-squares-like
    // plane of the four corners); one lifted corner moves all four off it, so the quad as a whole is named.
    const glm::dvec3 centroid = 0.25 * (v[0] + v[1] + v[2] + v[3]);
    double off = 0.0;
    for (std::size_t i = 0; i < 4; ++i) off = std::max(off, std::abs(glm::dot(v[i] - centroid, normal)));
    if (off > kGroundPlanarityTolerance * longest_edge)
        r.fail(corners, "not planar: the corners are up to " + shown_number(off) + " off their common plane (tolerance " +
                            shown_number(kGroundPlanarityTolerance * longest_edge) + ")");
    for (std::size_t i = 0; i < 4; ++i) {
        const glm::dvec3 a = v[(i + 3) % 4], b = v[i], c = v[(i + 1) % 4];
        const double turn = glm::dot(glm::cross(b - a, c - b), normal);
        if (!(turn > kMinRelativeGroundTurn * longest_edge * longest_edge))
            r.fail(corners.element(i), "the quad is not convex at this corner (corners must go around the quad in "
                                       "order, and no three may be collinear)");
    }
    ground.normal = glm::vec3(normal);
    if (auto c = Reader::optional(n, "color")) ground.color = r.vec3(*c, kColor);
    return ground;
}

// The ground is lit on the face the camera sees, whichever way the file winds its corners: a quad wound the
// other way would otherwise show its unlit back and render black (ambient only) with no word. Reversing the
// corners (0 3 2 1: the same diagonal 0–2, so the same two triangles) keeps "counter-clockwise seen from the
// side `normal` points to" true. The camera does not move, so the face it sees is the same in every frame.
void face_ground_to_camera(SceneDescription& scene) {
    if (!scene.ground) return;
    GroundDescription& g = *scene.ground;
    glm::dvec3 centroid(0.0);
    for (const glm::vec3& c : g.corners) centroid += 0.25 * glm::dvec3(c);
    if (glm::dot(glm::dvec3(scene.camera.position) - centroid, glm::dvec3(g.normal)) >= 0.0) return;
    std::swap(g.corners[1], g.corners[3]);
    g.normal = -g.normal;
}

// The renderer's camera makes these checks (validate_camera) on the floats read: they must pass here, or a
// scene that reads fine would fail at render time with a message that names no file.
void check_renderer_accepts(const Reader& r, const CameraDescription& c, const std::string& path) {
    try {
        validate_camera(c.position, c.look_at, c.up, c.fov_deg, int(c.width), int(c.height));
    } catch (const std::invalid_argument& e) {
        r.fail(path, std::string("the camera is unusable: ") + e.what());
    }
}

CameraDescription read_camera(const Reader& r, const Node& n, const SceneDescription& scene) {
    r.require_object(n, {"position", "look_at", "up", "fov_deg", "width", "height"});
    float fov = CameraDescription{}.fov_deg;
    std::uint32_t width = CameraDescription{}.width, height = CameraDescription{}.height;
    const auto fov_node = Reader::optional(n, "fov_deg");
    if (fov_node) fov = r.real(*fov_node, Bounds{0.0, true, 180.0, true});
    if (auto v = Reader::optional(n, "width")) width = r.u32(*v, 1, std::uint32_t(kMaxImageSide));
    if (auto v = Reader::optional(n, "height")) height = r.u32(*v, 1, std::uint32_t(kMaxImageSide));
    if (std::uint64_t{width} * height > kMaxImagePixels)
        r.fail(n, "image too large (" + std::to_string(width) + "x" + std::to_string(height) + " > " +
                      std::to_string(kMaxImagePixels) + " pixels)");
    if (fov_node) check_fov_resolution(r, *fov_node, fov, height);

    CameraDescription camera;
    camera.fov_deg = fov;
    camera.width = width;
    camera.height = height;
    const auto position = Reader::optional(n, "position"), look_at = Reader::optional(n, "look_at");
    // The default view is two passes over the particles: taken only when the file leaves position or look_at
    // to it.
    std::optional<DefaultView> fallback;
    if (!position || !look_at) fallback = default_view(scene.smoke.particles, scene.ground, fov, width, height);
    if (position) {
        camera.position = local_point(r.point(*position), scene.origin);
    } else {
        check_default_position(r, *fallback, fov_node ? fov_node->path : n.path, fov_node.has_value(), scene.origin);
        camera.position = glm::vec3(fallback->position);
    }
    camera.look_at = look_at ? local_point(r.point(*look_at), scene.origin) : glm::vec3(fallback->look_at);
    const auto up = Reader::optional(n, "up");
    // Unit length (normalised in double from the file's numbers): the renderer's camera then sees |forward ×
    // up| = the sine checked below, whatever length the file gave (up = [0, 1e-30, 0] underflowed there; up =
    // [3e38, 3e38, 0] overflowed to a zero right vector).
    const glm::dvec3 up_d = up ? r.direction(*up) : glm::dvec3(camera.up);

    const glm::dvec3 view = glm::dvec3(camera.look_at) - glm::dvec3(camera.position);
    if (glm::length(view) == 0.0) r.fail(n, "position and look_at are the same point");
    const std::string up_path = up ? up->path : n.path + "/up";
    const double sine = glm::length(glm::cross(glm::normalize(view), up_d));
    if (!(sine >= kMinUpViewSine)) r.fail(up_path, "is parallel to the view direction (look_at - position)");
    camera.up = glm::vec3(up_d);
    check_renderer_accepts(r, camera, up_path);
    return camera;
}

RenderSettings read_render(const Reader& r, const Node& n) {
    r.require_object(n, {"mode", "cutoff", "groups", "frames", "softness", "transmittance_threshold", "compositing",
                         "spp", "fps"});
    RenderSettings s;
    if (auto v = Reader::optional(n, "mode")) {
        const std::string m = r.string(*v);
        if (m == "basic") s.mode = RenderMode::basic;
        else if (m == "simple-shadow") s.mode = RenderMode::simple_shadow;
        else if (m == "full") s.mode = RenderMode::full;
        else
            r.fail(*v, "unknown mode " + shown_value(*v->value) + " (use \"basic\", \"simple-shadow\" or \"full\")");
    }
    if (auto v = Reader::optional(n, "cutoff")) s.cutoff = r.u32(*v, 0, std::numeric_limits<std::uint32_t>::max());
    if (auto v = Reader::optional(n, "groups")) s.groups = r.u32(*v, 1, kMaxGroups);
    if (auto v = Reader::optional(n, "frames")) s.frames = r.u32(*v, 1, kMaxSceneFrames);
    if (auto v = Reader::optional(n, "softness")) s.softness = r.real(*v, kNonNegative);
    if (auto v = Reader::optional(n, "transmittance_threshold"))
        s.transmittance_threshold = r.real(*v, Bounds{0.0, false, 1.0, true});
    if (auto v = Reader::optional(n, "compositing")) {
        const std::string c = r.string(*v);
        if (c == "over") s.compositing = Compositing::over;
        else if (c == "thesis") s.compositing = Compositing::thesis;
        else
            r.fail(*v, "unknown compositing " + shown_value(*v->value) + " (use \"over\" or \"thesis\")");
    }
    if (auto v = Reader::optional(n, "spp")) s.spp = r.u32(*v, 1, std::uint32_t(kMaxSpp));
    if (auto v = Reader::optional(n, "fps")) s.fps = r.u32(*v, 1, kMaxSceneFps);
    return s;
}

// ---- The whole document ------------------------------------------------------------------------------

// The scene from its JSON tree. `fast`: reads /smoke/particles (the tree holds a placeholder there).
// `base_dir`: the scene file's folder, where a PLY particle file is found.
SceneDescription read_scene(const json& document, const Reader& r, const FastParticleList* fast,
                            const std::filesystem::path& base_dir) {
    const Node root{&document, ""};
    r.require_object(root, {"origin", "light", "ambient", "background", "smoke", "ground", "camera", "render"});

    SceneDescription scene;
    scene.source = r.source();
    scene.light = read_light(r, r.required(root, "light"));
    if (auto v = Reader::optional(root, "ambient")) scene.ambient = r.vec3(*v, kColor);
    if (auto v = Reader::optional(root, "background")) scene.background = r.vec3(*v, kColor);
    std::optional<glm::dvec3> origin;
    if (auto v = Reader::optional(root, "origin")) origin = r.point(*v);
    scene.smoke = read_smoke(r, r.required(root, "smoke"), origin, fast, base_dir);
    scene.origin = *origin;
    if (auto v = Reader::optional(root, "ground")) scene.ground = read_ground(r, *v, scene.origin);
    if (auto v = Reader::optional(root, "render")) scene.render = read_render(r, *v);
    check_scene_motion(scene, scene.render.frames);
    if (auto v = Reader::optional(root, "camera")) {
        scene.camera = read_camera(r, *v, scene);
    } else {
        CameraDescription& c = scene.camera = CameraDescription{};
        const DefaultView view = default_view(scene.smoke.particles, scene.ground, c.fov_deg, c.width, c.height);
        check_default_position(r, view, "/camera", false, scene.origin);
        c.position = glm::vec3(view.position);
        c.look_at = glm::vec3(view.look_at);
        check_renderer_accepts(r, scene.camera, "/camera");
    }
    face_ground_to_camera(scene);
    return scene;
}

// The fast path, for a document with a particle list: simdjson finds the list's start, particle_list_end() its
// end; the rest (small) goes through the reference reader's scan and tree, with [] in the list's place, and the
// list is read by FastParticleList. Empty when there is no list (nothing to gain). Throws FastReaderDeclined, or
// SceneFileError for any problem; parse_scene_text() then asks the reference reader.
std::optional<SceneDescription> parse_fast(simdjson::padded_string_view text, const Reader& r,
                                           const std::filesystem::path& base_dir) {
    // simdjson indexes a copy of the first kHeadBytes alone, cut before a '{' (a particle's, where a list has
    // begun) so that the cut falls outside a string, and closed by a '}' (On-Demand checks a root object's last
    // byte before it reads it): a scene's keys before its list take far fewer bytes, and the list itself (10^6
    // particles: tens of millions of positions, 4 bytes each, in memory touched once) is then indexed only piece
    // by piece, by the pieces' readers. A list that begins later is found in the whole text.
    constexpr std::size_t kHeadBytes = std::size_t{64} << 10;
    const std::string_view whole(text.data(), text.length());
    ondemand::parser parser;
    std::size_t begin = std::string_view::npos;
    const std::size_t cut = whole.size() > kHeadBytes ? whole.rfind('{', kHeadBytes) : std::string_view::npos;
    if (cut != std::string_view::npos && cut > 0) {
        const simdjson::padded_string head(std::string(whole.substr(0, cut)) + '}');
        ondemand::document document;
        if (!parser.iterate(head).get(document))
            if (const char* list = find_particle_list(document)) begin = std::size_t(list - head.data());
    }
    if (begin == std::string_view::npos) {
        ondemand::document document;
        if (parser.iterate(text).get(document)) throw FastReaderDeclined{"not JSON simdjson can index"};
        const char* list = find_particle_list(document);
        if (!list) return std::nullopt;
        begin = std::size_t(list - text.data());
    }
    const std::size_t end = particle_list_end(whole, begin);
    if (end == std::string_view::npos) throw FastReaderDeclined{"no end of a particle list"};
    const std::string_view list_text = whole.substr(begin, end + 1 - begin);
    std::string rest;
    rest.reserve(whole.size() - list_text.size() + 2);
    rest.append(whole.substr(0, begin)).append("[]").append(whole.substr(end + 1));
    const json tree = parse_json(rest, r, r.source());
    const FastParticleList fast(list_text);
    return read_scene(tree, r, &fast, base_dir);
}

SceneDescription parse_scene_text(simdjson::padded_string_view text, std::string_view source_name,
                                   SceneJsonReader reader) {
    const Reader r{std::string(source_name)};
    const std::filesystem::path base_dir = std::filesystem::path(source_name).parent_path();
    if (reader != SceneJsonReader::reference) {
        try {
            if (auto scene = parse_fast(text, r, base_dir)) return std::move(*scene);
        } catch (const FastReaderDeclined& declined) {
            if (reader == SceneJsonReader::fast)
                r.fail("", std::string("the fast reader declined: ") + declined.reason);
        } catch (const SceneFileError&) {
            if (reader == SceneJsonReader::fast) throw;
        }
    }
    const json document = parse_json(std::string_view(text.data(), text.length()), r, r.source());
    return read_scene(document, r, nullptr, base_dir);
}

}  // namespace

// ---- Public API --------------------------------------------------------------------------------------

void check_scene_motion(const SceneDescription& scene, std::uint32_t frames) {
    if (frames <= 1) return;
    const Reader r(scene.source);
    for (std::size_t i = 0; i < scene.smoke.particles.size(); ++i) {
        const std::string problem = particle_extent_problem(scene.smoke.particles[i], frames - 1, scene.origin);
        if (problem.empty()) continue;
        if (scene.smoke.tubes) r.fail("/smoke/tubes", "generated particle " + std::to_string(i) + " " + problem);
        if (!scene.smoke.particle_file.empty())
            r.fail("/smoke/particles: " + scene.smoke.particle_file + ": vertex " + std::to_string(i), problem);
        r.fail("/smoke/particles/" + std::to_string(i), problem);
    }
}

std::string pixel_angle_problem(float fov_deg, std::uint32_t height) {
    const double half = 0.5 * double(fov_deg) * kRadiansPerDegree;
    if (2.0 * std::tan(half) / double(height) >= kMinPixelAngle) return {};
    const double smallest = 2.0 * std::atan(0.5 * kMinPixelAngle * double(height)) / kRadiansPerDegree;
    return "at " + std::to_string(height) +
           " pixels high, neighbouring pixels' rays would be less than 2^-20 radians apart, within a few roundings "
           "of their direction, and the image would fall apart into blocks; at this height fov_deg must be at least " +
           shown_rounded_up(smallest);
}

std::uint64_t scene_particle_limit() {
    return std::min(kMaxSceneParticles, machine_memory_bytes() / kPeakBytesPerParticle);
}

CameraDescription default_camera(const std::vector<Particle>& particles, const std::optional<GroundDescription>& ground,
                                 float fov_deg, std::uint32_t width, std::uint32_t height) {
    const DefaultView view = default_view(particles, ground, fov_deg, width, height);
    CameraDescription camera;
    camera.position = glm::vec3(view.position);
    camera.look_at = glm::vec3(view.look_at);
    camera.up = {0.0f, 1.0f, 0.0f};
    camera.fov_deg = fov_deg;
    camera.width = width;
    camera.height = height;
    return camera;
}

SceneDescription parse_scene(std::string_view json_text, std::string_view source_name, SceneJsonReader reader) {
    const simdjson::padded_string text(json_text.data(), json_text.size());
    return parse_scene_text(text, source_name, reader);
}

SceneDescription load_scene_file(const std::filesystem::path& path) {
    const std::string name = path.string();
    JsonText text;
    try {
        // Padded for simdjson, so that the text is held once however large the file.
        text = read_json_object_text(path, kMaxSceneFileBytes, simdjson::SIMDJSON_PADDING);
    } catch (const JsonTextFileError& e) {
        throw SceneFileError(name + ": " + e.what());
    }
    return parse_scene_text(simdjson::padded_string_view(text.data(), text.size(), text.capacity()), name,
                            SceneJsonReader::automatic);
}

}  // namespace smoketrace
