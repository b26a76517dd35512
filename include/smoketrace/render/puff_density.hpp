#pragma once
// The procedural smoke puff of the six-way baker (sixway_baker.hpp has the model), in one place for both
// its users: the baker, which marches light through it, and the ground truth (truth/), which renders the
// same density as a volume. PuffVoxels is the bake's grid: one column of depth voxels per texel.
#include <smoketrace/render/sixway_baker.hpp>

#include <glm/vec3.hpp>

#include <cmath>
#include <cstddef>
#include <vector>

namespace smoketrace {

// The puff's density at tangent-space point p of flipbook frame `frame`, in [0, 1].
class PuffDensity {
public:
    PuffDensity(const SixwayBakeSettings& settings, int frame);
    [[nodiscard]] float operator()(glm::vec3 p) const;

private:
    const SixwayBakeSettings& s_;
    glm::vec3 noise_offset_;  // -frame · drift · the drift direction
    float support_squared_;   // density is zero at |p|² >= this
};

// The light that reaches a point through optical depth τ, with the baker's approximation of multiple
// scattering: octaves of the transmittance with ever smaller extinction, normalised (Wrenninge 2013),
//     T_ms(τ) = (e^{-τ} + g·e^{-τ/2} + g²·e^{-τ/4} + ...) / (1 + g + g² + ...),
// scattering_octaves terms of weight g = scattering_octave_weight; 1 octave is plain Beer–Lambert.
struct OctaveTransmittance {
    int octaves;
    float weight;
    float norm;  // 1 / (1 + g + g² + ...)

    explicit OctaveTransmittance(const SixwayBakeSettings& s)
        : octaves(s.scattering_octaves), weight(s.scattering_octave_weight), norm(0.0f) {
        float weight_sum = 0.0f, w = 1.0f;
        for (int o = 0; o < octaves; ++o, w *= weight) weight_sum += w;
        norm = 1.0f / weight_sum;
    }
    // Octave o has extinction 2^-o: e^{-τ/2^o} by repeated square roots of e^{-τ}, exact to rounding.
    [[nodiscard]] float operator()(float optical_depth) const {
        float e = std::exp(-optical_depth);
        float sum = e, w = 1.0f;
        for (int o = 1; o < octaves; ++o) {
            e = std::sqrt(e);
            w *= weight;
            sum += w * e;
        }
        return sum * norm;
    }
};

// The bake's voxels over the cube [-1, 1]³: n x n texel columns of nz voxels, index [k][j][i] with k from
// the front (z = 1) back, j from the top row (y = 1) down, i from the left (x = -1).
struct PuffVoxels {
    int n = 0;   // texels per tile side = voxels along x and y
    int nz = 0;  // voxels along z
    float dxy = 0.0f, dz = 0.0f;

    explicit PuffVoxels(const SixwayBakeSettings& s)
        : n(s.tile), nz(s.depth_samples > 0 ? s.depth_samples : s.tile), dxy(2.0f / float(n)), dz(2.0f / float(nz)) {}
    [[nodiscard]] std::size_t count() const { return std::size_t(n) * std::size_t(n) * std::size_t(nz); }
    [[nodiscard]] std::size_t index(int k, int j, int i) const {
        return (std::size_t(k) * std::size_t(n) + std::size_t(j)) * std::size_t(n) + std::size_t(i);
    }
    [[nodiscard]] glm::vec3 centre(int k, int j, int i) const {
        return {-1.0f + (float(i) + 0.5f) * dxy, 1.0f - (float(j) + 0.5f) * dxy, 1.0f - (float(k) + 0.5f) * dz};
    }
};

// The density at every voxel centre of frame `frame` into `density` (resized to voxels.count()); parallel
// over rows (TBB), each value computed by the same float operations whatever thread computes it.
void sample_puff_density(const SixwayBakeSettings& settings, const PuffVoxels& voxels, int frame,
                         std::vector<float>& density);

}  // namespace smoketrace
