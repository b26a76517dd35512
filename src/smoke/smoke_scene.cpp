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

bool same(const AffineTransform& a, const AffineTransform& b) {
    return a.linear == b.linear && a.translation == b.translation;
}

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
    // Which transforms changed is found a batch at a time on all threads (a frame that moves nothing, such
    // as the first after construction, is then all parallel); the changes are applied in index order, as
    // one serial pass would.
    std::vector<std::uint8_t> changed;
    std::vector<AffineTransform> billboard(billboards_ ? std::min(count_, kInstanceBatch) : 0);  // not worked out twice
    for (std::size_t first = 0; first < count_; first += kInstanceBatch) {
        const std::size_t n = std::min(count_, first + kInstanceBatch) - first;
        changed.assign(n, 0);
        using Range = tbb::blocked_range<std::size_t>;
        tbb::parallel_for(Range(0, n, 4096), [&](const Range& r) {
            for (std::size_t k = r.begin(); k < r.end(); ++k) {
                const std::size_t i = first + k;
                const auto idx = static_cast<std::uint32_t>(i);
                std::uint8_t c = !same(scene_.transform(idx), stand_in_transform(particles[i]));
                if (billboards_) {
                    const auto b_idx = static_cast<std::uint32_t>(count_ + i);
                    billboard[k] = billboard_transform(particles[i], eye);
                    c |= std::uint8_t(!same(scene_.transform(b_idx), billboard[k]) << 1);
                }
                changed[k] = c;
            }
        });
        for (std::size_t k = 0; k < n; ++k) {
            if (changed[k] == 0) continue;
            const std::size_t i = first + k;
            if (changed[k] & 1) scene_.set_transform(static_cast<std::uint32_t>(i), stand_in_transform(particles[i]));
            if (changed[k] & 2) scene_.set_transform(static_cast<std::uint32_t>(count_ + i), billboard[k]);
        }
    }
    return scene_.commit();
}

}  // namespace smoketrace
