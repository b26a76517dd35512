// make_particle_scene: writes the thesis's two tubes (tube_generator.hpp) as explicit particles, to measure
// reading large scenes (scripts/large_scenes.sh, bench/README.md). The recipe is the benchmark's large-scene
// one: N particles of radius 0.35·√(750/N), so that a light ray crosses about as many surfaces as at 750.
//
//   make_particle_scene N OUT_DIR [json|json-exporter|ply|both]
//
// writes OUT_DIR/tubes_N.json (the particles as a JSON list) and/or OUT_DIR/tubes_N.ply (binary little-endian
// x y z radius) with OUT_DIR/tubes_N_ply.json, the same scene reading its particles from that file. Both
// scenes hold the same centres and radii (the JSON's as their shortest round-trip decimals), so they give the
// same depths; the JSON also gives each billboard's rotation, as an exported simulation would.
//
// json-exporter writes OUT_DIR/tubes_N_exporter.json: the same particles as a simulation's exporter in Python
// writes them, byte for byte what json.dump() makes of the floats (float32 values as Python floats): every
// number the shortest decimal of its double (0.2551898956298828 where tubes_N.json has 0.2551899), the whole
// document on one line with ", " and ": " between items, and no "origin" (it then lies near the first particle).
#include <smoketrace/smoke/tube_generator.hpp>

#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <string_view>
#include <vector>

using namespace smoketrace;

namespace {

// Everything but the particles: the two-tube scene lit from above (assets/scenes/two_tubes_above.json), no
// cutoff: every depth is computed in full. The origin is given as 0: with the default one (near the first
// particle) the JSON's decimals would keep digits beyond their floats, and the two scenes would differ there.
constexpr const char* kSceneHead = R"({
  "origin": [0, 0, 0],
  "light": { "direction": [0, 1, 0] },
  "smoke": {
    "particles": )";
constexpr const char* kSceneTail = R"(,
    "sigma_t": 1.0,
    "shape": "sphere"
  },
  "ground": { "corners": [[-5, -3, -5], [-5, -3, 5], [5, -3, 5], [5, -3, -5]] },
  "camera": { "position": [0, 6, 15], "look_at": [0, -0.8, 0] },
  "render": { "cutoff": 0 }
}
)";

void append_float(std::string& out, float v) {
    char buffer[32];
    const auto end = std::to_chars(buffer, buffer + sizeof buffer, v).ptr;
    out.append(buffer, end);
}

void write_json(const std::filesystem::path& path, const std::vector<Particle>& particles) {
    std::string text = kSceneHead;
    text += "[\n";
    text.reserve(particles.size() * 96);
    for (std::size_t i = 0; i < particles.size(); ++i) {
        const Particle& p = particles[i];
        text += "      { \"center\": [";
        append_float(text, p.center.x);
        text += ", ";
        append_float(text, p.center.y);
        text += ", ";
        append_float(text, p.center.z);
        text += "], \"radius\": ";
        append_float(text, p.radius);
        text += ", \"rotation\": ";
        append_float(text, p.rotation);
        text += i + 1 < particles.size() ? " },\n" : " }\n";
    }
    text += "    ]";
    text += kSceneTail;
    std::ofstream(path, std::ios::binary) << text;
}

// A double as Python's repr() writes it, which json.dump() uses: the shortest digits that read back as the same
// double, positional when the decimal exponent is in [-4, 16) (a whole number keeps ".0"), else d.ddde±XX.
void append_python_float(std::string& out, double v) {
    char buffer[32];
    const auto end = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::scientific).ptr;
    const std::string_view text(buffer, std::size_t(end - buffer));  // "-d.ddde-XX"
    const std::size_t e = text.find('e');
    int exponent = 0;
    const char* sign = text.data() + e + 1;
    std::from_chars(sign + (*sign == '+'), end, exponent);
    if (exponent < -4 || exponent >= 16) {
        out.append(text);
        return;
    }
    std::string_view mantissa = text.substr(0, e);
    if (mantissa.front() == '-') {
        out += '-';
        mantissa.remove_prefix(1);
    }
    std::string digits(1, mantissa.front());
    if (mantissa.size() > 2) digits.append(mantissa.substr(2));  // the digits after "d."
    const int point = exponent + 1;                              // digits before the decimal point
    if (point <= 0) {
        out.append("0.").append(std::size_t(-point), '0').append(digits);
    } else if (std::size_t(point) < digits.size()) {
        out.append(digits, 0, std::size_t(point)).append(".").append(digits, std::size_t(point));
    } else {
        out.append(digits).append(std::size_t(point) - digits.size(), '0').append(".0");
    }
}

void write_exporter_json(const std::filesystem::path& path, const std::vector<Particle>& particles) {
    std::string text = R"({"light": {"direction": [0, 1, 0]}, "smoke": {"particles": [)";
    text.reserve(particles.size() * 140);
    for (std::size_t i = 0; i < particles.size(); ++i) {
        const Particle& p = particles[i];
        text += i == 0 ? R"({"center": [)" : R"(, {"center": [)";
        append_python_float(text, p.center.x);
        text += ", ";
        append_python_float(text, p.center.y);
        text += ", ";
        append_python_float(text, p.center.z);
        text += R"(], "radius": )";
        append_python_float(text, p.radius);
        text += R"(, "rotation": )";
        append_python_float(text, p.rotation);
        text += '}';
    }
    text += R"(], "sigma_t": 1.0, "shape": "sphere"}, "ground": {"corners": [[-5, -3, -5], [-5, -3, 5], )"
            R"([5, -3, 5], [5, -3, -5]]}, "camera": {"position": [0, 6, 15], "look_at": [0, -0.8, 0]}, )"
            R"("render": {"cutoff": 0}})";
    std::ofstream(path, std::ios::binary) << text;
}

void write_ply(const std::filesystem::path& ply, const std::filesystem::path& scene,
               const std::vector<Particle>& particles) {
    static_assert(std::endian::native == std::endian::little, "the PLY body is written as this machine's floats");
    std::ofstream out(ply, std::ios::binary);
    out << "ply\nformat binary_little_endian 1.0\ncomment two tubes, make_particle_scene\nelement vertex "
        << particles.size() << "\nproperty float x\nproperty float y\nproperty float z\nproperty float radius\n"
        << "end_header\n";
    std::vector<float> body;
    body.reserve(particles.size() * 4);
    for (const Particle& p : particles) body.insert(body.end(), {p.center.x, p.center.y, p.center.z, p.radius});
    out.write(reinterpret_cast<const char*>(body.data()), std::streamsize(body.size() * sizeof(float)));
    std::ofstream(scene, std::ios::binary) << kSceneHead << '"' << ply.filename().string() << '"' << kSceneTail;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3 || argc > 4) {
        std::cerr << "usage: make_particle_scene N OUT_DIR [json|json-exporter|ply|both]\n";
        return 2;
    }
    const unsigned long count = std::strtoul(argv[1], nullptr, 10);
    const std::filesystem::path dir = argv[2];
    const std::string what = argc == 4 ? argv[3] : "both";
    if (count == 0 || count > 50'000'000 ||
        (what != "json" && what != "json-exporter" && what != "ply" && what != "both")) {
        std::cerr << "make_particle_scene: N must be 1 … 50000000 and the format json, json-exporter, ply or both\n";
        return 2;
    }
    std::filesystem::create_directories(dir);
    TubeSettings settings;
    settings.particles = std::uint32_t(count);
    settings.particle_radius = float(0.35 * std::sqrt(750.0 / double(count)));
    const std::vector<Particle> particles = generate_tubes(settings);
    const std::string stem = "tubes_" + std::to_string(count);
    if (what == "json" || what == "both") write_json(dir / (stem + ".json"), particles);
    if (what == "json-exporter") write_exporter_json(dir / (stem + "_exporter.json"), particles);
    if (what == "ply" || what == "both") write_ply(dir / (stem + ".ply"), dir / (stem + "_ply.json"), particles);
    return 0;
}
