// Particle stand-in meshes (see stand_in_shapes.hpp).
#include <smoketrace/smoke/stand_in_shapes.hpp>

#include <glm/geometric.hpp>
#include <cmath>
#include <algorithm>
#include <map>
#include <stdexcept>
#include <utility>

namespace smoketrace {

std::string StandInShape::name() const {
    switch (kind) {
        case StandInKind::sphere: return "sphere";
        case StandInKind::icosahedron: return "icosahedron";
        case StandInKind::icosphere: return "icosphere:" + std::to_string(level);
    }
    return "?";
}

std::optional<StandInShape> parse_stand_in_shape(std::string_view text) {
    if (text == "sphere") return StandInShape{StandInKind::sphere, 0};
    if (text == "icosahedron") return StandInShape{StandInKind::icosahedron, 0};
    constexpr std::string_view prefix = "icosphere:";
    if (text.size() == prefix.size() + 1 && text.substr(0, prefix.size()) == prefix) {
        const char c = text.back();
        if (c >= '1' && c <= '4') return StandInShape{StandInKind::icosphere, c - '0'};
    }
    return std::nullopt;
}

namespace {
// Vertices in double so the normalisation of each vertex rounds once, to float, at the end.
std::vector<glm::dvec3> unit_icosahedron_vertices() {
    const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
    // Cyclic permutations of (0, ±1, ±φ): (0, ±1, ±φ), (±1, ±φ, 0), (±φ, 0, ±1).
    std::vector<glm::dvec3> v = {
        {0, -1, -phi}, {0, -1, phi}, {0, 1, -phi}, {0, 1, phi},
        {-1, -phi, 0}, {-1, phi, 0}, {1, -phi, 0}, {1, phi, 0},
        {-phi, 0, -1}, {phi, 0, -1}, {-phi, 0, 1}, {phi, 0, 1},
    };
    for (auto& p : v) p = glm::normalize(p);
    return v;
}

// The 20 faces: the triples of mutually adjacent vertices (edge length 2 before normalisation),
// each ordered counter-clockwise seen from outside, i.e. with (b − a) × (c − a) pointing away from the
// centre. Found from the vertex set rather than typed in, so the winding is right by construction.
std::vector<glm::uvec3> icosahedron_faces(const std::vector<glm::dvec3>& v) {
    const double edge2 = glm::dot(v[0] - v[2], v[0] - v[2]);  // (0,-1,-φ)–(0,1,-φ) is an edge
    auto adjacent = [&](unsigned a, unsigned b) { return std::abs(glm::dot(v[a] - v[b], v[a] - v[b]) - edge2) < 1e-9; };
    std::vector<glm::uvec3> faces;
    for (unsigned a = 0; a < 12; ++a)
        for (unsigned b = a + 1; b < 12; ++b)
            for (unsigned c = b + 1; c < 12; ++c) {
                if (!adjacent(a, b) || !adjacent(b, c) || !adjacent(a, c)) continue;
                const glm::dvec3 n = glm::cross(v[b] - v[a], v[c] - v[a]);
                faces.push_back(glm::dot(n, v[a] + v[b] + v[c]) > 0.0 ? glm::uvec3(a, b, c) : glm::uvec3(a, c, b));
            }
    if (faces.size() != 20) throw std::logic_error("icosahedron: expected 20 faces");
    return faces;
}

TriangleMesh to_mesh(const std::vector<glm::dvec3>& unit, std::vector<glm::uvec3> faces, float radius) {
    TriangleMesh m;
    m.vertices.reserve(unit.size());
    for (const auto& p : unit) m.vertices.push_back(glm::vec3(p * double(radius)));
    m.triangles = std::move(faces);
    return m;
}
}  // namespace

TriangleMesh make_icosahedron(float radius) {
    const auto v = unit_icosahedron_vertices();
    return to_mesh(v, icosahedron_faces(v), radius);
}

TriangleMesh make_icosphere(int level, float radius) {
    if (level < 0 || level > 8) throw std::invalid_argument("make_icosphere: level must be in 0…8");
    auto v = unit_icosahedron_vertices();
    auto faces = icosahedron_faces(v);
    for (int l = 0; l < level; ++l) {
        std::map<std::pair<unsigned, unsigned>, unsigned> midpoint_of;
        auto midpoint = [&](unsigned a, unsigned b) {
            const auto key = std::pair<unsigned, unsigned>(std::min(a, b), std::max(a, b));
            auto [it, inserted] = midpoint_of.try_emplace(key, unsigned(v.size()));
            if (inserted) v.push_back(glm::normalize(0.5 * (v[a] + v[b])));  // pushed back onto the sphere
            return it->second;
        };
        std::vector<glm::uvec3> next;
        next.reserve(faces.size() * 4);
        for (const auto& f : faces) {
            const unsigned ab = midpoint(f.x, f.y), bc = midpoint(f.y, f.z), ca = midpoint(f.z, f.x);
            next.push_back({f.x, ab, ca});
            next.push_back({ab, f.y, bc});
            next.push_back({ca, bc, f.z});
            next.push_back({ab, bc, ca});
        }
        faces = std::move(next);
    }
    return to_mesh(v, std::move(faces), radius);
}

}  // namespace smoketrace
