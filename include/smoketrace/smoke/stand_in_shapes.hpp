#pragma once
// The shapes a particle can stand in as for optical-depth and shadow rays (thesis 4.1: "each particle is
// made up of a quad and an icosahedron"; smoketrace adds exact spheres and finer icospheres).
#include <smoketrace/accel/triangle_mesh.hpp>

#include <optional>
#include <string>
#include <string_view>

namespace smoketrace {

enum class StandInKind : std::uint8_t { sphere, icosahedron, icosphere };

struct StandInShape {
    StandInKind kind = StandInKind::sphere;
    int level = 0;  // icosphere subdivision level 1…4 (0 for sphere and icosahedron)

    [[nodiscard]] std::string name() const;  // "sphere", "icosahedron", "icosphere:2"
    bool operator==(const StandInShape&) const = default;
};

// Parses "sphere", "icosahedron" or "icosphere:L" (L = 1…4); nullopt for anything else.
[[nodiscard]] std::optional<StandInShape> parse_stand_in_shape(std::string_view text);

// The thesis's icosahedron: the 12 vertices are the normalised cyclic permutations of (0, ±1, ±φ),
// φ = (1 + √5)/2, scaled by `radius` so that they lie ON the sphere; 20 faces, counter-clockwise seen
// from outside (front faces outward, see ray_triangle.hpp).
[[nodiscard]] TriangleMesh make_icosahedron(float radius = 1.0f);

// The icosahedron subdivided `level` times: each triangle split into four at its edge midpoints, the
// midpoints pushed back onto the sphere. Shared edges share their midpoint vertex, so the mesh stays
// closed (20·4^level faces, 10·4^level + 2 vertices).
[[nodiscard]] TriangleMesh make_icosphere(int level, float radius = 1.0f);

}  // namespace smoketrace
