#pragma once
// A puff's optical depth toward each of the six-way baker's six lights (sixway_baker.hpp): from a point of the
// tangent cube [-1, 1]³ to the cube's face along +x, +y, +z, -x, -y, -z (the baker's light order), as ∫ρ ds
// in tangent units. The ground truth's ladder (ground_truth.hpp, TruthRung::six_axis) lights each puff with
// these, blended as the frame blends the six-way light map, to measure what the six axis lights cost.
//
// For the baked grid the depths are exact at the voxel centres: along an axis line through centres the
// trilinear density is linear from centre to centre, so the trapezoid sums (the baker's own running sums)
// are its integral; between centres they are interpolated trilinearly, as the density is. For the test shapes
// (uniform ball and cube) they are the closed-form chords.
#include <smoketrace/truth/puff_volume.hpp>

#include <glm/vec3.hpp>

#include <array>
#include <vector>

namespace smoketrace {

class PuffAxisDepths {
public:
    PuffAxisDepths() = default;
    // The depths of the lights whose bit is set in `lights` (bit l for light l; the grid's take a float per voxel
    // each, so a caller builds only those its particles' light directions pick).
    explicit PuffAxisDepths(const PuffVolume& puff, unsigned lights = 0x3F);

    // ∫ρ ds from p to the face along light `light` (0..5: +x, +y, +z, -x, -y, -z), tangent units; a light not
    // built throws std::logic_error.
    [[nodiscard]] float operator()(int light, glm::vec3 p) const;

private:
    const PuffVolume* puff_ = nullptr;
    std::array<std::vector<float>, 6> depths_;  // the grid's: per light, at every voxel centre
};

}  // namespace smoketrace
