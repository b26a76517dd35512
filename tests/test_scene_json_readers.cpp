// The scene file's two JSON readers (scene_file.hpp, SceneJsonReader): the fast reader of particle lists
// (simdjson) and the reference reader (nlohmann) must give the same SceneDescription, bit for bit, on the
// shipped scenes and on generated lists that use every particle key and every way of writing a number; and on
// bad input the automatic reader must give the reference reader's message word for word.
#include "support/cli_runner.hpp"

#include <smoketrace/core/prng.hpp>
#include <smoketrace/io/scene_file.hpp>

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

using namespace smoketrace;

namespace {

template <class T>
bool same_bits(const T& a, const T& b) {
    return std::memcmp(&a, &b, sizeof(T)) == 0;
}

// Every value of the two scenes, compared by bits (so that -0 and +0 differ).
void require_same_scene(const SceneDescription& a, const SceneDescription& b) {
    REQUIRE(a.smoke.particles.size() == b.smoke.particles.size());
    for (std::size_t i = 0; i < a.smoke.particles.size(); ++i) {
        const Particle &p = a.smoke.particles[i], &q = b.smoke.particles[i];
        INFO("particle " << i);
        REQUIRE(same_bits(p.center, q.center));
        REQUIRE(same_bits(p.radius, q.radius));
        REQUIRE(same_bits(p.velocity, q.velocity));
        REQUIRE(same_bits(p.spin, q.spin));
        REQUIRE(same_bits(p.growth, q.growth));
        REQUIRE(same_bits(p.rotation, q.rotation));
    }
    CHECK(a.source == b.source);
    CHECK(same_bits(a.origin, b.origin));
    CHECK(same_bits(a.light.direction, b.light.direction));
    CHECK(same_bits(a.light.color, b.light.color));
    CHECK(same_bits(a.ambient, b.ambient));
    CHECK(same_bits(a.background, b.background));
    CHECK(same_bits(a.smoke.sigma_t, b.smoke.sigma_t));
    CHECK(same_bits(a.smoke.alpha, b.smoke.alpha));
    CHECK(a.smoke.shape == b.smoke.shape);
    CHECK(a.smoke.tubes.has_value() == b.smoke.tubes.has_value());
    REQUIRE(a.ground.has_value() == b.ground.has_value());
    if (a.ground) CHECK(same_bits(a.ground->corners, b.ground->corners));
    CHECK(same_bits(a.camera.position, b.camera.position));
    CHECK(same_bits(a.camera.look_at, b.camera.look_at));
    CHECK(same_bits(a.camera.up, b.camera.up));
    CHECK(same_bits(a.camera.fov_deg, b.camera.fov_deg));
    CHECK(a.camera.width == b.camera.width);
    CHECK(a.render.frames == b.render.frames);
    CHECK(a.render.cutoff == b.render.cutoff);
}

// Reads `text` with both readers (the fast one must not decline) and with the automatic one.
void require_readers_agree(const std::string& text) {
    const SceneDescription reference = parse_scene(text, "s.json", SceneJsonReader::reference);
    SceneDescription fast;
    try {
        fast = parse_scene(text, "s.json", SceneJsonReader::fast);
    } catch (const SceneFileError& e) {
        FAIL("the fast reader refused a scene the reference reader reads: " << e.what());
    }
    require_same_scene(fast, reference);
    require_same_scene(parse_scene(text, "s.json"), reference);
}

std::string error_of(const std::string& text, SceneJsonReader reader) {
    try {
        (void)parse_scene(text, "bad.json", reader);
    } catch (const SceneFileError& e) {
        return e.what();
    }
    return "(no error)";
}

// The ways a number may be written, each with the value the reference reader gives it.
const char* const kNumbers[] = {"0", "-0", "-0.0", "0e5", "-0e-3", "1", "-1", "17", "0.25", "-1.5e-3", "2E+2",
                                "1e-40", "1.4e-45", "-1.4e-45", "1e-50", "-1e-50", "7.006e-46", "1.1754944e-38",
                                "123456789012345678901", "9007199254740993", "-9223372036854775808",
                                "18446744073709551615", "3.4028234e38", "0.1000000000000000055511151231257827",
                                "1e15", "-1E15", "0.30000000000000004", "2.5e-3", "1.7976931348623157e-300",
                                "1e-999999", "-1e-999999", "0.000000000000000000000000000000000000000000001",
                                // Exporters' doubles, and the longest numbers simdjson reads on its exact path
                                "-0.009585144929587841", "0.2551898956298828", "-1.2419604063034058",
                                "1.234567890123456789", "-0.1234567890123456789", "1234567890123456789",
                                "-1.234567890123456789e-99", "9.999999999999999999e37", "0.0000000000000000001e-1",
                                "-0.01234567890123456789", "1.234567890123456789e-100"};

const char* const kHead = R"({ "light": { "direction": [0, 1, 0] }, "smoke": { "particles": )";
const char* const kTail = R"( }, "ground": { "corners": [[-5,-3,-5], [-5,-3,5], [5,-3,5], [5,-3,-5]] } })";

// `count` particles that use every key, in shuffled order, numbers written every way kNumbers has (within
// each key's range), separated by varying whitespace.
std::string generated_list(std::size_t count, std::uint64_t seed) {
    Pcg32 rng(seed, 3);
    static const char* const kSpaces[] = {"", " ", "\n", "\t", "\r\n  ", "   "};
    auto space = [&] { return std::string(kSpaces[rng.next_u32() % 6]); };
    auto number = [&] { return std::string(kNumbers[rng.next_u32() % std::size(kNumbers)]); };
    auto coordinate = [&] {  // within ±10^6, so that the ground stays a quad relative to the default origin
        for (;;)
            if (std::string n = number(); std::abs(std::strtod(n.c_str(), nullptr)) <= 1e6) return n;
    };
    // Radii and growth have ranges: positive, at least the smallest normal float / above -1.
    static const char* const kRadii[] = {"0.5", "1", "2E-3", "1.1754944e-38", "3e-2", "1e15", "0.009585145"};
    static const char* const kGrowth[] = {"0", "-0", "0.01", "-0.5", "1e-40", "-1e-50", "2"};
    std::string out = "[";
    for (std::size_t i = 0; i < count; ++i) {
        std::vector<std::string> members;
        auto triple = [&](const std::string& a, const std::string& b, const std::string& c) {
            std::string t(1, '[');  // appended, not "[" + …: GCC 12 warns falsely (-Wrestrict) on that
            for (const std::string* part : {&a, &b, &c}) t.append(space()).append(*part).append(space()).append(",");
            t.back() = ']';
            return t;
        };
        members.push_back("\"center\"" + space() + ":" + space() +
                          triple(coordinate(), coordinate(), coordinate()));
        members.push_back("\"radius\":" + space() + kRadii[rng.next_u32() % std::size(kRadii)]);
        if (rng.next_u32() % 2) members.push_back("\"velocity\":" + triple(number(), number(), number()));
        if (rng.next_u32() % 2) members.push_back("\"spin\":" + number());
        if (rng.next_u32() % 2)
            members.push_back(std::string("\"growth\":") + kGrowth[rng.next_u32() % std::size(kGrowth)]);
        if (rng.next_u32() % 2) members.push_back("\"rotation\"" + space() + ":" + number());
        for (std::size_t m = members.size(); m > 1; --m) std::swap(members[m - 1], members[rng.next_u32() % m]);
        if (i) out += ',';
        out.append(space()).append("{").append(space());
        for (std::size_t m = 0; m < members.size(); ++m)
            out.append(m ? "," : "").append(m ? space() : "").append(members[m]);
        out.append(space()).append("}");
    }
    return out + space() + "]";
}

std::filesystem::path asset(const char* name) { return std::filesystem::path(SMOKETRACE_ASSET_DIR) / "scenes" / name; }

}  // namespace

TEST_CASE("scene JSON readers: the shipped scenes read the same", "[scene][json_readers]") {
    for (const char* name :
         {"minimal.json", "two_tubes_above.json", "two_tubes_right.json", "two_tubes_sequence.json"}) {
        INFO(name);
        require_readers_agree(test::file_bytes(asset(name)));
    }
}

TEST_CASE("scene JSON readers: every particle key and every way of writing a number", "[scene][json_readers]") {
    // A list of one particle per number (as centre x, spin and rotation), so that each is checked alone.
    for (const char* n : kNumbers) {
        INFO("number " << n);
        const double v = std::abs(std::strtod(n, nullptr));
        auto list = [&](const std::string& c) {
            return R"([{"center": [)" + c + ", " + c + ", " + c + R"(], "radius": 1, "spin": )" + n +
                   R"(, "rotation": )" + n + R"(, "velocity": [)" + n + ",0," + n + "]}]";
        };
        // As a centre only where the scene stays valid: near 0 for the default origin (which moves to the
        // first particle, and the ground at 5 from 0 must stay a quad relative to it), else with the origin 0.
        require_readers_agree(kHead + list(v <= 1e6 ? n : "0.5") + kTail);
        require_readers_agree(std::string(R"({ "origin": [0, 0, 0],)") + (kHead + 1) +
                              list(v <= kMaxSceneCoordinate ? n : "0.5") + kTail);
    }
    for (std::uint64_t seed = 1; seed <= 20; ++seed) {
        INFO("seed " << seed);
        require_readers_agree(kHead + generated_list(50, seed) + kTail);
    }
}

TEST_CASE("scene JSON readers: a large list, far from 0, and keys around the list in any order",
          "[scene][json_readers]") {
    const std::string list = generated_list(20000, 99);
    require_readers_agree(kHead + list + kTail);
    require_readers_agree(R"({ "render": { "cutoff": 3 }, "smoke": { "alpha": 0.25, "particles": )" + list +
                          R"(, "sigma_t": 2 }, "origin": [1e6, -2e6, 3], "light": { "direction": [1, 1, 0] } })");
    require_readers_agree(std::string(kHead) + "[]" + kTail);  // no particles
    // A file far from 0: the default origin near the first particle.
    require_readers_agree(std::string(kHead) + R"([{"center": [1000000.125, 3e5, -7e5], "radius": 0.25},
                          {"center": [1000001, 3e5, -7e5], "radius": 0.5, "velocity": [1, 0, 0]}])" + kTail);
}

TEST_CASE("scene JSON readers: bad input reads as the reference reader words it", "[scene][json_readers]") {
    const std::string ok = R"({"center": [0, 0, 0], "radius": 1})";
    const std::vector<std::string> bad_lists = {
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": -1}])",                   // a range
        "[" + ok + R"(, {"center": [0, 1e999, 0], "radius": 1}])",                // overflow, at its path
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 1, "radius": 2}])",       // a duplicate key
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 1, "colour": 2}])",       // an unknown key
        "[" + ok + R"(, {"center": [0, 0], "radius": 1}])",                       // two numbers
        "[" + ok + R"(, {"center": [0, 0, "0"], "radius": 1}])",                  // a string
        "[" + ok + R"(, {"center": [0, 0, 0]}])",                                 // no radius
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 1e-50}])",                // rounds to 0
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 1e-40}])",                // subnormal radius
        "[" + ok + R"(, {"center": [0, 0, 2e15], "radius": 1}])",                 // beyond the coordinates
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 1, "growth": -1}])",      // growth
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 1, "spin": 1e39}])",      // beyond float
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 1, "velocity": null}])",  // null
        "[" + ok + R"(, {"center": [0, 0, 0] "radius": 1}])",                     // a missing comma
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 1},])",                   // a trailing comma
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 01}])",                   // a leading zero
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 1.}])",                   // no digits after '.'
        "[" + ok + R"(, {"center": [0, 0, [[0]]], "radius": 1}])",                // nested
        "[" + ok + R"(, 7])",                                                     // not an object
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 1} {"center": [0, 0, 0], "radius": 1}])",
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 1})",                     // unclosed
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 1,}])",                   // a trailing comma in an object
        "[" + ok + R"(, {"center": [0, 0, 0,], "radius": 1}])",                   // ... in a centre
        "[" + ok + R"(, {"center": [0 0, 0], "radius": 1}])",                     // no comma between numbers
        "[" + ok + R"(, {"center" [0, 0, 0], "radius": 1}])",                     // no colon
        "[" + ok + R"(, {center: [0, 0, 0], "radius": 1}])",                      // a bare key
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 1}}])",                   // a brace too many
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": +1}])",                   // a plus sign
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": .5}])",                   // no leading digit
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 1e}])",                   // no exponent digits
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": -}])",                    // a sign alone
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": 0x10}])",                 // hexadecimal
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": NaN}])",                  // NaN
        "[" + ok + R"(, {"center": [0, 0, Infinity], "radius": 1}])",             // Infinity
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": "1"}])",                  // a string
        "[" + ok + R"(, {"center": [0, 0, 0], "radius": true}])",                 // a boolean
        "[" + ok + "\n, {\"center\": [0, 0, 0], \"radius\": 1, \"sp\tin\": 1}]",  // a control character in a key
    };
    for (const std::string& list : bad_lists) {
        const std::string text = kHead + list + kTail;
        INFO("list: " << list);
        const std::string reference = error_of(text, SceneJsonReader::reference);
        CHECK(reference.rfind("bad.json: ", 0) == 0);
        CHECK(error_of(text, SceneJsonReader::automatic) == reference);
        CHECK(error_of(text, SceneJsonReader::fast) != "(no error)");
    }
    // Problems outside the list, and the order in which the reference reader reports them: a duplicate key
    // anywhere comes first, then the sections in the order they are read (light before the particles).
    const std::vector<std::string> bad_documents = {
        kHead + ("[" + ok + "]") + R"(, "alpha": 2)" + kTail,
        kHead + ("[" + ok + "]") + R"(, "sigma_t": 1, "sigma_t": 1)" + kTail,
        R"({ "light": { "direction": [0, 0, 0] }, "smoke": { "particles": [{"center": [0, 0, 0], "radius": -1}] } })",
        R"({ "light": { "direction": [0, 1, 0] }, "smoke": { "particles": [{"center": [0, 0, 0], "radius": -1}] },
             "camera": { "fov_deg": 1, "fov_deg": 2 } })",
        R"({ "light": { "direction": [0, 1, 0] }, "smoke": { "particles": [{"center": [0, 0, 0], "radius": 1}] } } x)",
        R"({ "light": { "direction": [0, 1, 0] }, "smoke": { "particles": [{"center": [0, 0, 0], "radius": 1}] },
             "smoke": {} })",
        R"({ "light": { "direction": [0, 1, 0] }, "smoke": { "particles": [], "particles": [] } })",
        R"({ "light": { "direction": [0, 1, 0] }, "smoke": { "particles": [], "tubes": {} } })",
        std::string(kHead) + "[" + ok + "]" + R"(, "sigma_t": 1 )" + "\xff" + kTail,  // not UTF-8
    };
    for (const std::string& text : bad_documents) {
        INFO("document: " << text);
        const std::string reference = error_of(text, SceneJsonReader::reference);
        CHECK(reference.rfind("bad.json: ", 0) == 0);
        CHECK(error_of(text, SceneJsonReader::automatic) == reference);
    }
}

TEST_CASE("scene JSON readers: what the fast reader leaves to the reference reader still reads",
          "[scene][json_readers]") {
    // An escaped key is the same key to JSON; the fast reader compares keys as written and hands over.
    const std::string text = std::string(kHead) + R"([{"cent\u0065r": [1, 2, 3], "radius": 1}])" + kTail;
    CHECK(error_of(text, SceneJsonReader::fast).find("the fast reader declined") != std::string::npos);
    require_same_scene(parse_scene(text, "s.json"), parse_scene(text, "s.json", SceneJsonReader::reference));
}

// The fast reader cuts a long list into pieces of about 256 KiB, each cut before a '{' that follows a comma,
// and reads them in parallel: what it reads must not depend on where the cuts fall.
TEST_CASE("scene JSON readers: a list read in pieces, with problems in and across them", "[scene][json_readers]") {
    const std::string ok = R"({"center": [0, 0, 0], "radius": 1})";
    auto oks = [&](std::size_t count) {  // `count` particles, each followed by a comma
        std::string out;
        for (std::size_t i = 0; i < count; ++i) out.append(ok).append(", ");
        return out;
    };
    const std::string many = oks(16000);  // ~600 KB: the list is cut at least once before what follows it
    auto expect_reference_error = [&](const std::string& list) {
        const std::string text = kHead + list + kTail;
        const std::string reference = error_of(text, SceneJsonReader::reference);
        CHECK(reference.rfind("bad.json: ", 0) == 0);
        CHECK(error_of(text, SceneJsonReader::automatic) == reference);
        CHECK(error_of(text, SceneJsonReader::fast) != "(no error)");
        return reference;
    };
    SECTION("a valid list reads the same whatever the cuts") {
        require_readers_agree(kHead + ("[" + many + ok + "]") + kTail);
        require_readers_agree(kHead + ("[" + oks(7000) + "\n\n" + many + ok + " \n]") + kTail);
    }
    SECTION("the first problem in the list is the one reported, by the fast reader too") {
        const std::string list = "[" + many + R"({"center": [0, 0, 0], "radius": -1}, )" + many +
                                 R"({"center": [0, 0, 0], "radius": -2}, )" + many + ok + "]";
        const std::string reference = expect_reference_error(list);
        CHECK(reference.find("/smoke/particles/16000/radius") != std::string::npos);
        CHECK(error_of(kHead + list + kTail, SceneJsonReader::fast) == reference);
    }
    SECTION("a problem after the last cut, and syntax broken across a cut") {
        (void)expect_reference_error("[" + many + R"({"center": [0, 0, 0], "radius": 1} {"center": [0, 0, 0]}])");
        (void)expect_reference_error("[" + many + R"({"center": [0, 0, 0], "radius": 1}, 7, )" + many + ok + "]");
        (void)expect_reference_error("[" + many + many + ok + ",]");
    }
    SECTION("braces where a cut may fall that are not a particle's") {
        // A key of '{'s longer than a piece: cuts fall inside the string.
        (void)expect_reference_error("[" + ok + R"(, {"center": [0, 0, 0], "radius": 1, ")" + std::string(600000, '{') +
                                     "\": 1}, " + many + ok + "]");
        (void)expect_reference_error("[" + ok + R"(, {"center": [0, 0, 0], "radius": 1, ")" +
                                     std::string(300000, ',') + ", {" + std::string(300000, ' ') + "\": 1}, " +
                                     many + ok + "]");
        // An object inside a particle at exactly the first cut: the first '{' at or after 256 KiB into the
        // list (after its '['), following a comma.
        const std::string nested = R"({"center": [0, 0, 0], "velocity": [1, 2, 3, {}], "radius": 1}, )";
        const std::size_t cut = (std::size_t{256} << 10) + 1;
        std::string list = "[" + oks(7000);
        list.append(cut - nested.find("{}") - list.size(), ' ') += nested;
        REQUIRE(list.find('{', cut) == list.find("{}"));
        (void)expect_reference_error(list + many + ok + "]");
    }
}

// The fast reader finds the list's start in the document's first 64 KiB (the whole document when it begins
// later) and its end from the document's end (the last ']' after a '}'): what follows the list, or a head
// longer than that, must not change what it reads, and what only looks like the list's end must not either.
TEST_CASE("scene JSON readers: where the list begins and ends, whatever comes before and after it",
          "[scene][json_readers]") {
    const std::string list = generated_list(3000, 7);  // ~200 KB: longer than the head simdjson indexes
    REQUIRE(list.size() > (std::size_t{64} << 10));
    SECTION("a long head, a long tail, an empty list") {
        const std::string blank(70000, ' ');
        require_readers_agree(R"({ "light": { "direction": [0, 1, 0] },)" + blank + R"("smoke": { "particles": )" +
                              list + kTail);
        require_readers_agree(kHead + list + R"(, "sigma_t": 1 )" + blank + kTail);
        require_readers_agree(kHead + (" [ \n ]" + blank) + kTail);
        require_readers_agree(std::string(kHead) + "[\n" + list.substr(1, list.size() - 2) + "\n\t\r\n]" + kTail);
    }
    SECTION("a ']' after a '}' that is not the list's end") {
        const std::string ok = R"({"center": [0, 0, 0], "radius": 1})";
        const std::vector<std::string> texts = {
            // After the list: an array of objects, and the two bytes in a string.
            kHead + list + R"(, "shape": "}]" )" + kTail,
            kHead + list + R"(, "shape": "sphere", "extra": [{}] )" + kTail,
            kHead + list + std::string(kTail, std::strlen(kTail) - 1) + R"(, "more": [{"a": 1}] })",
            // In the list: a key holding them, and an object in a particle's array.
            kHead + ("[" + ok + R"(, {"center": [0, 0, 0], "radius": 1, "}]": 2}, )") + list.substr(1) + kTail,
            kHead + list.substr(0, list.size() - 1) + R"(, {"center": [0, 0, 0], "velocity": [{}], "radius": 1}])" +
                kTail,
        };
        for (const std::string& text : texts) {
            INFO("text: " << text.substr(0, 200) << " ... " << text.substr(text.size() - 200));
            const std::string reference = error_of(text, SceneJsonReader::reference);
            CHECK(reference.rfind("bad.json: ", 0) == 0);
            CHECK(error_of(text, SceneJsonReader::automatic) == reference);
            CHECK(error_of(text, SceneJsonReader::fast) != "(no error)");
        }
    }
}
