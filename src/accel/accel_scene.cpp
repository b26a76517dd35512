// Two-level scene and its TLAS update policy (see accel_scene.hpp).
#include <smoketrace/accel/bvh_builder.hpp>
#include <smoketrace/accel/accel_scene.hpp>
#include "bvh_bottom_up.hpp"

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace smoketrace {

const char* to_string(TlasUpdate u) {
    switch (u) {
        case TlasUpdate::none: return "none";
        case TlasUpdate::refit: return "refit";
        case TlasUpdate::rebuild: return "rebuild";
    }
    return "?";
}

BottomLevel BottomLevel::from_mesh(const TriangleMesh& m, bool opaque) {
    BottomLevel b;
    b.kind = GeometryKind::triangles;
    b.mesh = MeshBlas(m);
    b.opaque = opaque;
    return b;
}

BottomLevel BottomLevel::from_spheres(const std::vector<Sphere>& s, bool opaque) {
    BottomLevel b;
    b.kind = GeometryKind::spheres;
    b.spheres = SphereBlas(s, BvhBuildSettings{.max_leaf_size = 2});
    b.opaque = opaque;
    return b;
}

namespace {

// Whether m is s·I bit for bit (then glm::dmat3(s) gives back the same bits): the diagonal the same
// number, the rest +0.0.
bool uniform_scale(const glm::dmat3& m, double& s) {
    const auto bits = [&](int c, int r) { return std::bit_cast<std::uint64_t>(m[c][r]); };
    if (bits(0, 0) != bits(1, 1) || bits(0, 0) != bits(2, 2)) return false;
    if ((bits(0, 1) | bits(0, 2) | bits(1, 0) | bits(1, 2) | bits(2, 0) | bits(2, 1)) != 0) return false;
    s = m[0][0];
    return true;
}

}  // namespace

void AccelScene::store_linear(std::uint32_t i, const glm::dmat3& m, std::uint32_t new_slot) {
    StoredInstance& s = instances_[i];
    s.scaled = uniform_scale(m, s.scale);
    if (s.scaled) return;
    if (s.linear_slot == kNoLinearSlot) {
        if (new_slot == kNoLinearSlot) {
            new_slot = static_cast<std::uint32_t>(linears_.size());
            linears_.emplace_back();
        }
        s.linear_slot = new_slot;
    }
    linears_[s.linear_slot] = m;
}

std::uint32_t AccelScene::add_bottom_level(BottomLevel blas) {
    blases_.push_back(std::make_unique<BottomLevel>(std::move(blas)));
    return static_cast<std::uint32_t>(blases_.size() - 1);
}

std::uint32_t AccelScene::add_instance(const Instance& instance) {
    if (instance.blas >= blases_.size())
        throw std::out_of_range("AccelScene::add_instance: no bottom level " + std::to_string(instance.blas));
    // Checked before anything is added, so that a rejected instance leaves the scene as it was.
    const Aabb world_box = checked_world_box(static_cast<std::uint32_t>(instances_.size()), *blases_[instance.blas],
                                             instance.object_to_world);
    instances_.push_back(StoredInstance{instance.object_to_world.translation, 0.0, instance.blas, instance.user_id,
                                        kNoLinearSlot, kNoInstanceDetail, 0, instance.mask, instance.flags, false});
    StoredInstance& added = instances_.back();
    store_linear(static_cast<std::uint32_t>(instances_.size() - 1), instance.object_to_world.linear);
    // Whether an instance keeps a detail and takes the world_triangles path depends on the BLAS alone, so
    // its slots are fixed here.
    const BottomLevel& b = *blases_[instance.blas];
    if (keeps_detail(b)) {
        added.detail = static_cast<std::uint32_t>(details_.size());
        details_.emplace_back();
    }
    if (takes_world_triangles(b)) {
        added.first_world_triangle = static_cast<std::uint32_t>(world_triangles_.size());
        world_triangles_.resize(world_triangles_.size() + b.mesh.leaf_triangles().size());
    }
    world_boxes_.push_back(Aabb{});
    instance_masks_.push_back(instance.mask);
    update_instance(static_cast<std::uint32_t>(instances_.size() - 1), world_box);
    structure_dirty_ = true;
    return static_cast<std::uint32_t>(instances_.size() - 1);
}

std::uint32_t AccelScene::add_instances(std::span<const Instance> added) {
    for (const Instance& in : added)
        if (in.blas >= blases_.size())
            throw std::out_of_range("AccelScene::add_instances: no bottom level " + std::to_string(in.blas));
    const std::size_t first = instances_.size(), last = first + added.size();
    const std::size_t first_triangle = world_triangles_.size(), first_detail = details_.size();
    // Grown unwritten: every new element is written once, by the parallel set-up below, so that the
    // fresh pages are first touched on all threads instead of in serial fills.
    instances_.resize(last);
    world_boxes_.resize(last);
    instance_masks_.resize(last);
    // Detail and world-triangle slots in instance order, as add_instance() lays them out one by one: each
    // fixed-size chunk's counts first, then each chunk's slots from the running totals before it (the same
    // slots whatever the thread count).
    constexpr std::size_t kChunk = 4096;
    const std::size_t chunks = (added.size() + kChunk - 1) / kChunk;
    std::vector<std::uint32_t> blas_triangles(blases_.size());  // per BLAS: world triangles per instance
    std::vector<std::uint8_t> blas_detail(blases_.size());
    for (std::size_t b = 0; b < blases_.size(); ++b) {
        blas_detail[b] = keeps_detail(*blases_[b]);
        blas_triangles[b] = takes_world_triangles(*blases_[b])
                                ? static_cast<std::uint32_t>(blases_[b]->mesh.leaf_triangles().size())
                                : 0;
    }
    struct Slots {
        std::size_t details, triangles, linears;
    };
    const std::size_t first_linear = linears_.size();
    std::vector<Slots> chunk_first(chunks + 1, Slots{first_detail, first_triangle, first_linear});
    using Range = tbb::blocked_range<std::size_t>;
    tbb::parallel_for(Range(0, chunks), [&](const Range& r) {
        for (std::size_t c = r.begin(); c < r.end(); ++c) {
            Slots n{0, 0, 0};
            double scale = 0.0;
            for (std::size_t k = c * kChunk; k < std::min(added.size(), (c + 1) * kChunk); ++k) {
                n.details += blas_detail[added[k].blas];
                n.triangles += blas_triangles[added[k].blas];
                n.linears += !uniform_scale(added[k].object_to_world.linear, scale);
            }
            chunk_first[c + 1] = n;
        }
    });
    for (std::size_t c = 0; c < chunks; ++c) {
        chunk_first[c + 1].details += chunk_first[c].details;
        chunk_first[c + 1].triangles += chunk_first[c].triangles;
        chunk_first[c + 1].linears += chunk_first[c].linears;
    }
    world_triangles_.resize(chunk_first[chunks].triangles);
    details_.resize(chunk_first[chunks].details);
    linears_.resize(chunk_first[chunks].linears);
    // Each instance's set-up reads only its own instance and bottom level and writes only its own slots.
    try {
        tbb::parallel_for(Range(0, chunks), [&](const Range& r) {
            for (std::size_t c = r.begin(); c < r.end(); ++c) {
                Slots next = chunk_first[c];
                for (std::size_t k = c * kChunk; k < std::min(added.size(), (c + 1) * kChunk); ++k) {
                    const Instance& in = added[k];
                    const std::size_t i = first + k;
                    StoredInstance& s = instances_[i];
                    s = StoredInstance{in.object_to_world.translation, 0.0, in.blas, in.user_id, kNoLinearSlot,
                                       kNoInstanceDetail, 0, in.mask, in.flags, false};
                    store_linear(static_cast<std::uint32_t>(i), in.object_to_world.linear,
                                 static_cast<std::uint32_t>(next.linears));
                    if (!s.scaled) ++next.linears;
                    instance_masks_[i] = in.mask;
                    if (blas_detail[in.blas]) s.detail = static_cast<std::uint32_t>(next.details++);
                    if (blas_triangles[in.blas] != 0) {
                        s.first_world_triangle = static_cast<std::uint32_t>(next.triangles);
                        next.triangles += blas_triangles[in.blas];
                    }
                    update_instance(static_cast<std::uint32_t>(i));
                }
            }
        });
    } catch (...) {
        instances_.resize(first);
        world_boxes_.resize(first);
        instance_masks_.resize(first);
        world_triangles_.resize(first_triangle);
        details_.resize(first_detail);
        linears_.resize(first_linear);
        throw;
    }
    if (!added.empty()) structure_dirty_ = true;
    return static_cast<std::uint32_t>(first);
}

void AccelScene::reserve_instances(std::size_t count) {
    instances_.reserve(count);
    records_.reserve(count);
    record_slot_.reserve(count);
    world_boxes_.reserve(count);
    instance_masks_.reserve(count);
}

void AccelScene::remove_instance(std::uint32_t index) {
    if (index >= instances_.size()) throw std::out_of_range("AccelScene::remove_instance");
    // The records need nothing: the rebuild that removal makes due writes them all again.
    const StoredInstance gone = instances_[index];
    if (takes_world_triangles(*blases_[gone.blas])) {
        const std::uint32_t first = gone.first_world_triangle;
        const auto n = static_cast<std::uint32_t>(blases_[gone.blas]->mesh.leaf_triangles().size());
        world_triangles_.erase(world_triangles_.begin() + first, world_triangles_.begin() + first + n);
        for (StoredInstance& in : instances_)
            if (takes_world_triangles(*blases_[in.blas]) && in.first_world_triangle > first) in.first_world_triangle -= n;
    }
    if (gone.detail != kNoInstanceDetail) {
        details_.erase(details_.begin() + gone.detail);
        for (StoredInstance& in : instances_)
            if (in.detail != kNoInstanceDetail && in.detail > gone.detail) --in.detail;
    }
    if (gone.linear_slot != kNoLinearSlot) {
        linears_.erase(linears_.begin() + gone.linear_slot);
        for (StoredInstance& in : instances_)
            if (in.linear_slot != kNoLinearSlot && in.linear_slot > gone.linear_slot) --in.linear_slot;
    }
    instances_.erase(instances_.begin() + index);
    world_boxes_.erase(world_boxes_.begin() + index);
    instance_masks_.erase(instance_masks_.begin() + index);
    structure_dirty_ = true;
}

void AccelScene::set_transform(std::uint32_t index, const AffineTransform& m) {
    if (index >= instances_.size()) throw std::out_of_range("AccelScene::set_transform");
    if (transform(index) == m) return;  // an unchanged frame does no TLAS work
    const Aabb world_box = checked_world_box(index, *blases_[instances_[index].blas], m);  // before any write
    instances_[index].translation = m.translation;
    store_linear(index, m.linear);
    update_instance(index, world_box);
    refresh_record(index);
    transforms_dirty_ = true;
}

void AccelScene::set_transforms(std::uint32_t first, std::span<const AffineTransform> m) {
    if (first > instances_.size() || m.size() > instances_.size() - first)
        throw std::out_of_range("AccelScene::set_transforms: instances " + std::to_string(first) + " + " +
                                std::to_string(m.size()) + " pass the last of " + std::to_string(instances_.size()));
    // Two passes over fixed chunks (the same outcome whatever the thread count). The first checks each
    // changed transform and writes its world box, the only state it writes (a rejection puts the old boxes
    // back, from the transforms still stored, and names the lowest rejected instance), and counts the
    // instances that need a linears_ slot; these are handed out in instance order, as set_transform() one by
    // one would. The second writes the rest, each instance its own.
    constexpr std::size_t kChunk = 4096;
    constexpr std::size_t kNoRejection = ~std::size_t{0};
    const std::size_t chunks = (m.size() + kChunk - 1) / kChunk;
    struct ChunkScan {
        std::size_t first_slot = 0;  // the chunk's new slots; after the prefix sum, its first one
        std::size_t changed = 0;
        std::size_t rejected = kNoRejection;  // the chunk's lowest rejected position in m
        std::string why;
    };
    std::vector<ChunkScan> scan(chunks + 1);
    using Range = tbb::blocked_range<std::size_t>;
    auto for_each_changed = [&](auto&& f) {
        tbb::parallel_for(Range(0, chunks), [&](const Range& r) {
            for (std::size_t c = r.begin(); c < r.end(); ++c)
                for (std::size_t k = c * kChunk; k < std::min(m.size(), (c + 1) * kChunk); ++k) {
                    const auto i = static_cast<std::uint32_t>(first + k);
                    if (!(transform(i) == m[k]) && !f(c, k, i)) break;
                }
        });
    };
    for_each_changed([&](std::size_t c, std::size_t k, std::uint32_t i) {
        ChunkScan& cs = scan[c + 1];
        ++cs.changed;
        double scale = 0.0;
        cs.first_slot += instances_[i].linear_slot == kNoLinearSlot && !uniform_scale(m[k].linear, scale);
        try {
            world_boxes_[i] = checked_world_box(i, *blases_[instances_[i].blas], m[k]);
        } catch (const std::exception& e) {
            cs.rejected = k;
            cs.why = e.what();
            return false;  // the rest of the chunk keeps its boxes
        }
        return true;
    });
    std::size_t changed = 0;
    std::string rejected;
    scan[0].first_slot = linears_.size();
    for (std::size_t c = 1; c <= chunks; ++c) {
        if (scan[c].rejected != kNoRejection && rejected.empty()) rejected = scan[c].why;
        scan[c].first_slot += scan[c - 1].first_slot;
        changed += scan[c].changed;
    }
    if (!rejected.empty()) {
        for_each_changed([&](std::size_t c, std::size_t k, std::uint32_t i) {
            if (k == scan[c + 1].rejected) return false;
            world_boxes_[i] = checked_world_box(i, *blases_[instances_[i].blas], transform(i));
            return true;
        });
        throw std::domain_error(rejected);
    }
    if (changed == 0) return;
    linears_.resize(scan[chunks].first_slot);
    tbb::parallel_for(Range(0, chunks), [&](const Range& r) {
        for (std::size_t c = r.begin(); c < r.end(); ++c) {
            std::size_t next_slot = scan[c].first_slot;
            for (std::size_t k = c * kChunk; k < std::min(m.size(), (c + 1) * kChunk); ++k) {
                const auto i = static_cast<std::uint32_t>(first + k);
                if (transform(i) == m[k]) continue;
                const bool needs_slot = instances_[i].linear_slot == kNoLinearSlot;
                instances_[i].translation = m[k].translation;
                store_linear(i, m[k].linear, needs_slot ? static_cast<std::uint32_t>(next_slot) : kNoLinearSlot);
                if (needs_slot && !instances_[i].scaled) ++next_slot;
                update_instance(i, world_boxes_[i]);
                refresh_record(i);
            }
        }
    });
    transforms_dirty_ = true;
}

void AccelScene::set_mask(std::uint32_t index, std::uint8_t mask) {
    if (index >= instances_.size()) throw std::out_of_range("AccelScene::set_mask");
    if (instances_[index].mask == mask) return;
    instances_[index].mask = mask;
    if (!structure_dirty_) records_[record_slot_[index]].mask = mask;
    instance_masks_[index] = mask;
    transforms_dirty_ = true;  // node masks are refreshed by the refit sweep
}

BlasUpdate AccelScene::update_mesh_vertices(std::uint32_t blas, std::span<const glm::vec3> vertices) {
    if (blas >= blases_.size())
        throw std::out_of_range("AccelScene::update_mesh_vertices: no bottom level " + std::to_string(blas));
    BottomLevel& b = *blases_[blas];
    if (b.kind != GeometryKind::triangles)
        throw std::invalid_argument("AccelScene::update_mesh_vertices: bottom level " + std::to_string(blas) +
                                    " holds spheres, not a triangle mesh");
    const bool was_world = takes_world_triangles(b);
    const std::size_t was_count = b.mesh.leaf_triangles().size();
    const BlasUpdate u = b.mesh.update_vertices(vertices, rebuild_ratio_);
    if (was_world != takes_world_triangles(b) || (was_world && was_count != b.mesh.leaf_triangles().size())) {
        // A rebuild changed whether (or with how many triangles) its instances take the world-triangles
        // path, whose slots are laid out by instance: lay them out again and refresh every record.
        assign_world_triangle_slots();
        for (std::uint32_t i = 0; i < instances_.size(); ++i) {
            update_instance(i);
            refresh_record(i);
        }
        transforms_dirty_ = true;
        return u;
    }
    for (std::uint32_t i = 0; i < instances_.size(); ++i)
        if (instances_[i].blas == blas) {
            update_instance(i);
            refresh_record(i);
            transforms_dirty_ = true;  // the TLAS boxes over it are refit by commit()
        }
    return u;
}

void AccelScene::assign_world_triangle_slots() {
    world_triangles_.clear();
    for (std::uint32_t i = 0; i < instances_.size(); ++i) {
        if (const BottomLevel& b = *blases_[instances_[i].blas]; takes_world_triangles(b)) {
            instances_[i].first_world_triangle = static_cast<std::uint32_t>(world_triangles_.size());
            world_triangles_.resize(world_triangles_.size() + b.mesh.leaf_triangles().size());
        }
    }
}

namespace {

// Relative tolerance of the similarity test. The sphere the fast path then tests differs from the true
// image of the BLAS sphere (an ellipsoid, strictly) by at most ~1e-12 of its radius, far below the float
// resolution of t (6e-8); and the tolerance is far above the rounding of a rotation built in double.
constexpr double kSimilarityTolerance = 1e-12;

// Whether m is a uniform scale times an orthogonal matrix (rotation, possibly mirrored): columns of equal
// length and pairwise orthogonal, to kSimilarityTolerance. Then m maps a sphere of radius r to a sphere
// of radius scale·r, scale the length of the first column (exactly |s| for m = s·I: √(s²) rounds to |s|).
bool is_similarity(const glm::dmat3& m, double& scale) {
    const double n0 = glm::dot(m[0], m[0]), n1 = glm::dot(m[1], m[1]), n2 = glm::dot(m[2], m[2]);
    if (!(n0 > 0.0) || !std::isfinite(n0)) return false;
    const double tol = kSimilarityTolerance * n0;
    if (!(std::fabs(n1 - n0) <= tol && std::fabs(n2 - n0) <= tol)) return false;
    if (!(std::fabs(glm::dot(m[0], m[1])) <= tol && std::fabs(glm::dot(m[0], m[2])) <= tol &&
          std::fabs(glm::dot(m[1], m[2])) <= tol))
        return false;
    scale = std::sqrt(n0);
    return true;
}

// std::nextafter(x, −∞) and std::nextafter(x, +∞), the same for every x, inline: the libm calls were about
// a tenth of an instance's set-up.
float float_below(float x) {
    if (std::isnan(x) || x == -std::numeric_limits<float>::infinity()) return x;
    if (x == 0.0f) return -std::numeric_limits<float>::denorm_min();
    const auto bits = std::bit_cast<std::uint32_t>(x);
    return std::bit_cast<float>(x > 0.0f ? bits - 1 : bits + 1);
}
float float_above(float x) {
    if (std::isnan(x) || x == std::numeric_limits<float>::infinity()) return x;
    if (x == 0.0f) return std::numeric_limits<float>::denorm_min();
    const auto bits = std::bit_cast<std::uint32_t>(x);
    return std::bit_cast<float>(x > 0.0f ? bits + 1 : bits - 1);
}

}  // namespace

bool AccelScene::takes_world_triangles(const BottomLevel& b) const {
    return paths_ == InstancePaths::fastest && b.kind == GeometryKind::triangles && !b.mesh.bvh().empty() &&
           b.mesh.bvh().nodes[0].is_leaf() && b.mesh.leaf_triangles().size() <= kMaxWorldTriangles;
}

// Every instance but those of a single sphere under the world-space paths: those take world_sphere under a
// similarity, and detail() derives the rest (rare: a sphere stretched into an ellipsoid).
bool AccelScene::keeps_detail(const BottomLevel& b) const {
    return !(paths_ == InstancePaths::fastest && b.kind == GeometryKind::spheres &&
             b.spheres.leaf_spheres().size() == 1);
}

void AccelScene::update_instance(std::uint32_t i) {
    const StoredInstance& s = instances_[i];
    update_instance(i, checked_world_box(i, *blases_[s.blas], transform(i)));
}

// The 8 transformed corners of the object box, in double, rounded outward to float.
Aabb AccelScene::checked_world_box(std::uint32_t i, const BottomLevel& b, const AffineTransform& m) {
    m.check_invertible();  // every instance needs an inverse, though only details keep it
    const Aabb ob = b.bounds();
    Aabb wb;
    if (!ob.empty()) {
        glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
        for (int c = 0; c < 8; ++c) {
            const glm::dvec3 p((c & 1) ? ob.hi.x : ob.lo.x, (c & 2) ? ob.hi.y : ob.lo.y, (c & 4) ? ob.hi.z : ob.lo.z);
            const glm::dvec3 w = m.point(p);
            lo = glm::min(lo, w);
            hi = glm::max(hi, w);
        }
        for (int a = 0; a < 3; ++a) {
            wb.lo[a] = float_below(static_cast<float>(lo[a]));
            wb.hi[a] = float_above(static_cast<float>(hi[a]));
        }
    }
    if (!(std::isfinite(wb.lo.x) && std::isfinite(wb.lo.y) && std::isfinite(wb.lo.z) && std::isfinite(wb.hi.x) &&
          std::isfinite(wb.hi.y) && std::isfinite(wb.hi.z)))
        throw std::domain_error("AccelScene: instance " + std::to_string(i) + " has a non-finite or empty world box");
    return wb;
}

void AccelScene::update_instance(std::uint32_t i, const Aabb& world_box) {
    const StoredInstance& s = instances_[i];
    const BottomLevel& b = *blases_[s.blas];
    const AffineTransform m = transform(i);
    if (s.detail != kNoInstanceDetail) details_[s.detail] = {&b, m.inverse().linear};
    if (takes_world_triangles(b)) {
        // Each vertex transformed in double and rounded once; a vertex shared by two triangles rounds to
        // the same float in both, so the world-space mesh stays watertight for the watertight test.
        auto to_world = [&](const glm::vec3& v) { return glm::vec3(m.point(glm::dvec3(v))); };
        const std::span<const MeshBlas::Triangle> local = b.mesh.leaf_triangles();
        for (std::size_t k = 0; k < local.size(); ++k)
            world_triangles_[s.first_world_triangle + k] = {to_world(local[k].v0), to_world(local[k].v1),
                                                            to_world(local[k].v2)};
    }
    world_boxes_[i] = world_box;
}

InstanceRecord AccelScene::derive_record(std::uint32_t i) const {
    const StoredInstance& s = instances_[i];
    const BottomLevel& b = *blases_[s.blas];
    InstanceRecord r{};
    r.path = InstancePath::object_space;
    r.mask = s.mask;
    r.flags = s.flags;
    // Rule 2's instance part: FORCE_NON_OPAQUE over FORCE_OPAQUE over the geometry's opacity.
    r.opaque = !(s.flags & instance_flag_force_non_opaque) && ((s.flags & instance_flag_force_opaque) || b.opaque);
    r.user_id = s.user_id;
    r.object_to_world_translation = s.translation;
    // The world-space paths of trace() (see InstancePath); anything else takes the general path.
    const glm::dmat3 lin = linear(i);
    double scale = 0.0;
    if (paths_ == InstancePaths::fastest && b.kind == GeometryKind::spheres && b.spheres.leaf_spheres().size() == 1 &&
        is_similarity(lin, scale)) {
        const Sphere& sp = b.spheres.leaf_spheres()[0];
        r.path = InstancePath::world_sphere;
        r.sphere.offset = lin * glm::dvec3(sp.center);
        r.sphere.radius = scale * double(sp.radius);
        return r;
    }
    r.other.detail = s.detail;
    if (takes_world_triangles(b)) {
        r.path = InstancePath::world_triangles;
        r.other.first_world_triangle = s.first_world_triangle;
        r.other.world_triangle_count = static_cast<std::uint8_t>(b.mesh.leaf_triangles().size());
        r.other.blas = &b;
        const bool mirrored = glm::determinant(lin) < 0.0;
        r.other.world_facing_flipped = mirrored != ((s.flags & instance_flag_triangle_front_clockwise) != 0);
    }
    return r;
}

void AccelScene::rebuild() {
    // Grouped by mask (bvh_builder.hpp): in the smoke scene a particle's stand-in and its billboard have
    // almost the same box, and one SAH tree over both would pair them in every leaf's parent, so a view
    // ray (stand-ins masked out) or a light ray (billboards masked out) would still walk the other half.
    tlas_ = build_grouped_bvh(world_boxes_, std::span<const std::uint8_t>(instance_masks_),
                              BvhBuildSettings{.max_leaf_size = 1});
    // Two independent halves side by side: the node masks, the SAH cost and the wide tree (each parallel
    // over subtrees), and the records, derived in leaf order (one instance per leaf: prim_indices is a
    // permutation; each k writes its own record and its instance's slot).
    records_.resize(instances_.size());
    record_slot_.resize(instances_.size());
    tbb::parallel_invoke(
        [&] {
            node_masks_.assign(tlas_.nodes.size(), 0);
            sweep_binary<false>();  // the boxes are already exact
            wide_tlas_.collapse(tlas_, node_masks_);
        },
        [&] {
            const std::vector<std::uint32_t>& leaf = tlas_.prim_indices;
            using Range = tbb::blocked_range<std::size_t>;
            tbb::parallel_for(Range(0, leaf.size(), 4096), [&](const Range& r) {
                for (std::size_t k = r.begin(); k < r.end(); ++k) {
                    records_[k] = derive_record(leaf[k]);
                    record_slot_[leaf[k]] = static_cast<std::uint32_t>(k);
                }
            });
        });
    sah_at_build_ = sah_current_;
}

void AccelScene::refit_binary() { sweep_binary<true>(); }

// One sweep, children before parents (sweep_bottom_up(), in parallel over subtrees), refits the boxes
// (kRefitBoxes; a fresh build's are exact already), ORs the instance masks and sums the SAH cost, with the
// terms and order of Bvh::sah_cost, so the rebuild test costs no extra pass.
template <bool kRefitBoxes>
void AccelScene::sweep_binary() {
    constexpr std::uint32_t kPrefetch = 16;
    auto& nodes = tlas_.nodes;
    const SahCosts costs{};
    const double weighted = sweep_bottom_up(tlas_, [&](std::uint32_t k) {
        // A leaf's instance box is read at random (leaf order is not instance order): fetched kPrefetch
        // nodes ahead of a backward pass, the misses overlap instead of stalling the sweep one after another.
        if (kRefitBoxes && k >= kPrefetch) {
            const BvhNode& ahead = nodes[k - kPrefetch];
            if (ahead.is_leaf()) __builtin_prefetch(&world_boxes_[tlas_.prim_indices[ahead.first]]);
        }
        BvhNode& n = nodes[k];
        Aabb b;
        std::uint8_t m = 0;
        if (n.is_leaf()) {
            for (std::uint32_t i = 0; i < n.count; ++i) {
                const std::uint32_t p = tlas_.prim_indices[n.first + i];
                if (kRefitBoxes) b.grow(world_boxes_[p]);
                m |= instance_masks_[p];
            }
        } else {
            if (kRefitBoxes) b = merge(nodes[n.first].bounds, nodes[n.first + 1].bounds);
            m = node_masks_[n.first] | node_masks_[n.first + 1];
        }
        if (kRefitBoxes) n.bounds = b;
        node_masks_[k] = m;
        return sah_term(n, costs);
    });
    const double root_area = nodes.empty() ? 0.0 : double(nodes[0].bounds.area());
    sah_current_ = nodes.empty() ? 0.0 : root_area > 0.0 ? weighted / root_area : tlas_.sah_cost(costs);
}

TlasUpdate AccelScene::commit() {
    if (structure_dirty_) {
        rebuild();
        structure_dirty_ = transforms_dirty_ = false;
        return TlasUpdate::rebuild;
    }
    if (!transforms_dirty_) return TlasUpdate::none;
    transforms_dirty_ = false;
    refit_binary();
    if (sah_current_ > rebuild_ratio_ * sah_at_build_) {
        rebuild();
        return TlasUpdate::rebuild;
    }
    wide_tlas_.refit(tlas_, node_masks_);
    return TlasUpdate::refit;
}

void AccelScene::prefetch_top_level() const {
    constexpr std::size_t kLine = 64;
    const std::size_t node_bytes = wide_tlas_.node_count() * sizeof(WideBvhNode);
    const std::size_t index_bytes = tlas_.prim_indices.size() * sizeof(std::uint32_t);
    if (node_bytes + index_bytes + records_.size() * kLine > kPrefetchTopLevelMaxBytes) return;
    auto sweep = [](const void* data, std::size_t bytes) {
        const char* p = static_cast<const char*>(data);
        for (std::size_t b = 0; b < bytes; b += kLine) __builtin_prefetch(p + b);
    };
    sweep(wide_tlas_.nodes(), node_bytes);
    sweep(tlas_.prim_indices.data(), index_bytes);
    for (const InstanceRecord& r : records_) __builtin_prefetch(&r);  // 64-byte aligned: its first line
}

}  // namespace smoketrace
