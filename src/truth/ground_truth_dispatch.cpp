// The ground truth's entry points (ground_truth.hpp): each runs its pass, compiled in ground_truth.cpp, at the
// process's kernel level (core/simd/dispatch.hpp).
#include <smoketrace/core/simd/dispatch.hpp>
#include <smoketrace/truth/ground_truth.hpp>

namespace smoketrace {

TruthReport GroundTruth::render(ImageRgba& image, WorkProgress* progress) const {
    return simd::at_active_level([&]<simd::Level L> { return render_at_level<L>(image, progress); });
}

LadderReport GroundTruth::render_ladder(std::array<ImageRgba, kTruthRungs>& images, WorkProgress* progress) const {
    return simd::at_active_level([&]<simd::Level L> { return render_ladder_at_level<L>(images, progress); });
}

glm::vec3 GroundTruth::pixel(int x, int y) const {
    return simd::at_active_level([&]<simd::Level L> { return pixel_at_level<L>(x, y); });
}

TruthCheck GroundTruth::check(const ImageRgba& image, const TruthReport& report, int stride,
                              WorkProgress* progress) const {
    return simd::at_active_level([&]<simd::Level L> { return check_at_level<L>(image, report, stride, progress); });
}

std::vector<double> GroundTruth::particle_optical_depths() const {
    return simd::at_active_level([&]<simd::Level L> { return particle_optical_depths_at_level<L>(); });
}

std::vector<std::uint8_t> GroundTruth::ground_shadow_mask() const {
    return simd::at_active_level([&]<simd::Level L> { return ground_shadow_mask_at_level<L>(); });
}

}  // namespace smoketrace
