// Particles, billboards and ground as instances of a two-level scene (see smoke_scene.hpp).
#include <smoketrace/smoke/smoke_scene.hpp>

#include <glm/geometric.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <algorithm>
#include <cmath>
#include <vector>

namespace smoketrace {

glm::vec3 GroundQuad::normal() const {
    const glm::dvec3 a(corners[0]), b(corners[1]), c(corners[2]), d(corners[3]);
    // Newell-style: the cross product of the diagonals is twice the quad's vector area.
    return glm::vec3(glm::normalize(glm::cross(c - a, d - b)));
}

namespace {
constexpr std::size_t kInstanceBatch = 1 << 16;
constexpr std::size_t kUpdateBatch = 1 << 14;  // transforms per set_transforms() call: a 1.5 MiB buffer

AffineTransform stand_in_transform(const Particle& p) {
    return AffineTransform::translate_scale(glm::dvec3(p.center), double(p.radius));
}

BottomLevel stand_in_blas(StandInShape shape) {
    // Non-opaque: every crossing must reach the optical-depth any-hit (thesis 4.3.2).
    switch (shape.kind) {
        case StandInKind::sphere: return BottomLevel::from_spheres({Sphere{glm::vec3(0.0f), 1.0f}}, false);
        case StandInKind::icosahedron: return BottomLevel::from_mesh(make_icosahedron(1.0f), false);
        case StandInKind::icosphere: return BottomLevel::from_mesh(make_icosphere(shape.level, 1.0f), false);
    }
    return {};
}

BottomLevel billboard_blas() {
    TriangleMesh quad;
    quad.vertices = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    quad.triangles = {{0, 1, 2}, {0, 2, 3}};  // counter-clockwise seen from +z: the front faces the eye
    return BottomLevel::from_mesh(quad, false);
}
}  // namespace

AffineTransform SmokeScene::billboard_transform(const Particle& p, const glm::vec3& eye) {
    const glm::dvec3 c(p.center);
    glm::dvec3 n = glm::dvec3(eye) - c;
    const double len = glm::length(n);
    n = len > 0.0 ? n / len : glm::dvec3(0, 0, 1);
    // Right and up from the world up (+y, thesis 4.1), or from +z when looking straight up or down.
    const glm::dvec3 ref = std::abs(n.y) < 0.999 ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1);
    glm::dvec3 right = glm::normalize(glm::cross(ref, n));
    glm::dvec3 up = glm::cross(n, right);
    // The particle's own spin turns the quad in its plane.
    const double cs = std::cos(double(p.rotation)), sn = std::sin(double(p.rotation));
    const glm::dvec3 r2 = cs * right + sn * up, u2 = -sn * right + cs * up;
    const double s = p.radius;
    AffineTransform m;
    m.linear = glm::dmat3(r2 * s, u2 * s, n * s);
    m.translation = c;
    return m;
}

SmokeScene::SmokeScene(std::span<const Particle> particles, StandInShape shape, const std::optional<GroundQuad>& ground,
                       bool billboards)
    : count_(particles.size()), shape_(shape), billboards_(billboards) {
    scene_.reserve_instances((billboards ? 2 : 1) * particles.size() + (ground ? 1 : 0));
    // Added a batch at a time: the scene sets a batch up in parallel, and the batch's instances are a
    // small buffer next to the scene's own arrays.
    std::vector<Instance> batch;
    auto add_all = [&](std::uint32_t blas, std::uint8_t mask) {
        for (std::size_t first = 0; first < particles.size(); first += kInstanceBatch) {
            batch.resize(std::min(particles.size(), first + kInstanceBatch) - first);
            using Range = tbb::blocked_range<std::size_t>;
            tbb::parallel_for(Range(0, batch.size(), 4096), [&](const Range& r) {
                for (std::size_t k = r.begin(); k < r.end(); ++k) {
                    const std::size_t i = first + k;
                    batch[k] = Instance{blas, stand_in_transform(particles[i]), mask, std::uint32_t(i)};
                }
            });
            scene_.add_instances(batch);
        }
    };
    add_all(scene_.add_bottom_level(stand_in_blas(shape)), kStandInMask);
    // The billboards' transforms are the stand-ins' until update() turns them toward the eye.
    if (billboards) add_all(scene_.add_bottom_level(billboard_blas()), kBillboardMask);
    if (ground) {
        TriangleMesh quad;
        quad.vertices.assign(ground->corners.begin(), ground->corners.end());
        quad.triangles = {{0, 1, 2}, {0, 2, 3}};
        const std::uint32_t g = scene_.add_bottom_level(BottomLevel::from_mesh(quad, true));
        ground_normal_ = ground->normal();
        ground_instance_ = scene_.add_instance(Instance{g, AffineTransform{}, kGroundMask, kGroundUserId});
    }
}

TlasUpdate SmokeScene::update(std::span<const Particle> particles, const glm::vec3& eye) {
    // A batch of transforms at a time, worked out and set on all threads (AccelScene::set_transforms(),
    // which leaves the unchanged ones alone): the batch is a small buffer, reused, beside the scene's arrays.
    std::vector<AffineTransform> batch(std::min(count_, kUpdateBatch));
    using Range = tbb::blocked_range<std::size_t>;
    for (std::size_t first = 0; first < count_; first += kUpdateBatch) {
        const std::size_t n = std::min(count_, first + kUpdateBatch) - first;
        const std::span<AffineTransform> to(batch.data(), n);
        tbb::parallel_for(Range(0, n, 4096), [&](const Range& r) {
            for (std::size_t k = r.begin(); k < r.end(); ++k) to[k] = stand_in_transform(particles[first + k]);
        });
        scene_.set_transforms(static_cast<std::uint32_t>(first), to);
        if (!billboards_) continue;
        tbb::parallel_for(Range(0, n, 4096), [&](const Range& r) {
            for (std::size_t k = r.begin(); k < r.end(); ++k) to[k] = billboard_transform(particles[first + k], eye);
        });
        scene_.set_transforms(static_cast<std::uint32_t>(count_ + first), to);
    }
    return scene_.commit();
}

}  // namespace smoketrace
