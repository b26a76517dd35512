#pragma once
// The two-level scene: bottom-level structures (BLAS) placed by instances, and the top-level BVH
// (TLAS) over the instances' world boxes.
//
// Per frame the application changes transforms and masks, then calls commit(), which brings the TLAS
// up to date with the least work that keeps it good:
//   * nothing changed                         → none    (no TLAS work at all)
//   * transforms, masks or a mesh's vertices changed → refit (boxes and masks recomputed bottom-up, O(n))
//   * instances added or removed, or the refit tree's SAH cost has grown past
//     kTlasRebuildSahRatio × its cost right after the last full build → rebuild (binned SAH).
#include <smoketrace/accel/bvh.hpp>
#include <smoketrace/accel/instance.hpp>
#include <smoketrace/accel/sphere_set.hpp>
#include <smoketrace/accel/triangle_mesh.hpp>
#include <smoketrace/accel/wide_bvh.hpp>

#include <glm/matrix.hpp>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace smoketrace {

enum class GeometryKind : std::uint8_t { triangles, spheres };

// One bottom-level structure: a triangle mesh or a set of exact spheres, with DXR's geometry opacity.
struct BottomLevel {
    GeometryKind kind = GeometryKind::triangles;
    MeshBlas mesh;        // kind == triangles
    SphereBlas spheres;   // kind == spheres
    bool opaque = true;   // D3D12_RAYTRACING_GEOMETRY_FLAG_OPAQUE

    static BottomLevel from_mesh(const TriangleMesh& m, bool opaque);
    static BottomLevel from_spheres(const std::vector<Sphere>& s, bool opaque);
    [[nodiscard]] Aabb bounds() const { return kind == GeometryKind::triangles ? mesh.bounds() : spheres.bounds(); }
};

// The TLAS's rebuild threshold: the policy shared with mesh BLASes (kRebuildSahRatio, bvh.hpp).
inline constexpr double kTlasRebuildSahRatio = kRebuildSahRatio;

enum class TlasUpdate : std::uint8_t { none, refit, rebuild };
[[nodiscard]] const char* to_string(TlasUpdate u);

// How trace() tests an instance, decided when its transform is set (AccelScene::update_instance).
enum class InstancePath : std::uint8_t {
    object_space,     // the general path: the ray taken into object space, the BLAS traversed there
    world_sphere,     // one sphere under a similarity transform: the sphere tested in world space
    world_triangles,  // a one-leaf mesh of a few triangles: its triangles kept transformed, tested in world space
};

// Whether an AccelScene may use the world-space paths (the default) or takes every instance through the
// object-space path.
enum class InstancePaths : std::uint8_t { fastest, object_space_only };

// Meshes of up to this many triangles in one BLAS leaf (a billboard quad, a ground quad) take the
// world_triangles path: per instance, their vertices transformed once per transform change save every
// ray the object-space ray and its triangle set-up, about as much work as the two triangle tests.
inline constexpr std::uint32_t kMaxWorldTriangles = 4;

// What trace() reads per instance, one cache line per instance, kept in TLAS leaf order (AccelScene::
// leaf_record()). A walk that reaches a record has mostly not read its neighbours yet, so each record is
// likely a cache miss: a visit must need no second line. What only the general path reads beyond it, the
// bottom level and the inverse transform, is an InstanceDetail (AccelScene::detail()), kept apart and only
// for instances that may take that path, so that a million world spheres carry no inverse they never read.
struct alignas(64) InstanceRecord {
    std::uint8_t mask;
    // Rule 2 as far as the instance decides it: the geometry's opacity after the instance's FORCE_OPAQUE /
    // FORCE_NON_OPAQUE, so that trace() need not chase the bottom level to decide it.
    bool opaque;
    InstancePath path;
    std::uint8_t flags;
    std::uint32_t user_id;
    glm::dvec3 object_to_world_translation;  // subtracted first, then the linear inverse applied
    // The centre relative to the translation (linear · centre), not the world centre: trace() subtracts the
    // translation from the ray origin first, exactly as the general path does, so a small sphere far from the
    // world origin is as precise as there; and scale · radius.
    struct SphereFields {
        glm::dvec3 offset;
        double radius;
    };
    struct OtherFields {
        // Where AccelScene keeps this instance's InstanceDetail, or kNoInstanceDetail: the general path reads
        // it here (AccelScene::detail(i, record)), on the line the walk has already fetched.
        std::uint32_t detail;
        // world_triangles only: how many (in the BLAS's leaf order, from AccelScene::world_triangles()
        // [first_world_triangle]), and whether a world-space front face is an object-space back face (a
        // mirroring transform) — XOR TRIANGLE_FRONT_CLOCKWISE, so that rule 4 sees the facing the general
        // path would.
        std::uint32_t first_world_triangle;
        std::uint8_t world_triangle_count;
        bool world_facing_flipped;
        // world_triangles only: for a hit's primitive index, on this line rather than behind detail().
        const BottomLevel* blas;
    };
    // The path's own fields, in the same bytes: `sphere` for world_sphere, `other` for the other paths. (Their
    // types are named outside the union: standard C++ declares no type inside an anonymous one.)
    union {
        SphereFields sphere;
        OtherFields other;
    };
};
static_assert(sizeof(InstanceRecord) == 64, "a record is one cache line");

// What the general path reads beyond an instance's record: its bottom level, and the linear part of its
// world-to-object transform (object_to_world.inverse().linear: a world sphere's object_point too).
struct InstanceDetail {
    const BottomLevel* blas;
    glm::dmat3 world_to_object_linear;
};
inline constexpr std::uint32_t kNoInstanceDetail = ~std::uint32_t{0};

// The most prefetch_top_level() asks for: half of a 1 MiB L2 (the per-core L2 of AMD Zen 4/5, at
// least as much on recent Intel cores), leaving the rest to the walk's own buffers.
inline constexpr std::size_t kPrefetchTopLevelMaxBytes = std::size_t{512} << 10;

class AccelScene {
public:
    // `paths` = object_space_only turns the world-space paths off (every instance takes the general path):
    // for tests that hold the two against each other, and for whoever wants DXR's one mechanism only.
    explicit AccelScene(InstancePaths paths = InstancePaths::fastest) : paths_(paths) {}
    AccelScene(const AccelScene&) = delete;
    AccelScene& operator=(const AccelScene&) = delete;
    AccelScene(AccelScene&&) = default;
    AccelScene& operator=(AccelScene&&) = default;

    std::uint32_t add_bottom_level(BottomLevel blas);
    std::uint32_t add_instance(const Instance& instance);  // returns its index
    // add_instance() of each, in order, with each instance's set-up (world box, record) in parallel: the
    // same scene as the calls one by one. Returns the first one's index. Throws, adding none, when one
    // names no bottom level or has a singular or non-finite transform.
    std::uint32_t add_instances(std::span<const Instance> instances);
    // Room for this many instances in all, so that adding them (a million particles) moves nothing.
    void reserve_instances(std::size_t count);
    void remove_instance(std::uint32_t index);              // later indices move down by one
    // Throws, changing nothing, when the transform is singular or the instance's world box would not fit in
    // float (or index is out of range).
    void set_transform(std::uint32_t index, const AffineTransform& object_to_world);
    // set_transform(first + k, object_to_world[k]) for every k, in parallel: the same scene as the calls one
    // by one, whatever the thread count (a moving particle system's every frame). Throws, changing nothing,
    // when the range passes the last instance or a transform is rejected (the lowest such instance named).
    void set_transforms(std::uint32_t first, std::span<const AffineTransform> object_to_world);
    void set_mask(std::uint32_t index, std::uint8_t mask);
    // Moves the vertices of the mesh bottom level `blas` (same triangles): its tree is refit, or rebuilt
    // when the refit degraded it past the rebuild ratio (MeshBlas::update_vertices, which says which), and
    // its instances' world boxes are recomputed, so that the next commit() refits the TLAS over them.
    // Throws (leaving the scene as it was) when `blas` does not exist or holds spheres, or on a wrong
    // vertex count.
    BlasUpdate update_mesh_vertices(std::uint32_t blas, std::span<const glm::vec3> vertices);

    // Brings the TLAS up to date (see the table above) and says what it did.
    TlasUpdate commit();

    [[nodiscard]] std::size_t instance_count() const { return instances_.size(); }
    // Instance i as added or last set (set_transform(), set_mask()); by value, since the scene keeps its
    // instances compactly (see StoredInstance).
    [[nodiscard]] Instance instance(std::uint32_t i) const {
        const StoredInstance& s = instances_[i];
        return Instance{s.blas, transform(i), s.mask, s.user_id, s.flags};
    }
    // instance(i).object_to_world alone.
    [[nodiscard]] AffineTransform transform(std::uint32_t i) const { return {linear(i), instances_[i].translation}; }
    [[nodiscard]] const BottomLevel& bottom_level(std::uint32_t i) const { return *blases_[i]; }
    [[nodiscard]] const Aabb& instance_bounds(std::uint32_t i) const { return world_boxes_[i]; }

    // For trace(): the committed top level. Valid after commit().
    [[nodiscard]] const Bvh& tlas() const { return tlas_; }
    [[nodiscard]] const std::vector<std::uint8_t>& tlas_node_masks() const { return node_masks_; }
    // The same tree collapsed to 4-wide nodes, with the masks: what trace() walks.
    [[nodiscard]] const WideBvh& wide_tlas() const { return wide_tlas_; }
    // Instance i's record. Valid after commit(): the records are the committed top level's, written by
    // each rebuild (and kept current by set_transform() and the like between rebuilds).
    [[nodiscard]] const InstanceRecord& record(std::uint32_t i) const { return records_[record_slot_[i]]; }
    // The record of the instance at TLAS leaf position k (tlas().prim_indices[k]), for a walk: the records
    // lie in leaf order, so the walk reads them in the order of the tree. Valid after commit().
    [[nodiscard]] const InstanceRecord& leaf_record(std::uint32_t k) const { return records_[k]; }
    // Instance i's bottom level and world-to-object linear map. Stored for the instances whose bottom level
    // is not a single sphere; derived for the others (a world sphere needs it only for a hit's
    // object_point; a sphere under a transform that is no similarity takes the general path), with the
    // inverse update_instance() takes, so the same bits either way. Inline and free of side effects, so
    // that a caller that never reads the result pays nothing.
    [[nodiscard]] InstanceDetail detail(std::uint32_t i) const {
        const std::uint32_t slot = instances_[i].detail;
        return slot != kNoInstanceDetail ? details_[slot] : derived_detail(i);
    }
    // detail(i) for a walk holding instance i's record (after commit()): the slot is read from the record,
    // whose line the walk has fetched already, not from the stored instance, one more miss per visit.
    [[nodiscard]] InstanceDetail detail(std::uint32_t i, const InstanceRecord& r) const {
        const bool kept = r.path != InstancePath::world_sphere && r.other.detail != kNoInstanceDetail;
        return kept ? details_[r.other.detail] : derived_detail(i);
    }
    // Asks this core's caches for what a walk of the whole top level reads first: the wide nodes, the
    // leaves' index array and each instance record's first line (a world sphere's whole record), when
    // they fit in kPrefetchTopLevelMaxBytes (else it does nothing). For a caller about to send rays over
    // all of it, such as the optical-depth pass, whose rays together reach every particle: the walk
    // chases pointers, node to node to record, and from L3 each step waits ~50 cycles, where a sweep
    // keeps many lines in flight at once.
    void prefetch_top_level() const;
    // The world_triangles instances' triangles in world space, each instance's from its
    // InstanceRecord::first_world_triangle.
    [[nodiscard]] const MeshBlas::Triangle* world_triangles() const { return world_triangles_.data(); }
    [[nodiscard]] bool committed() const { return !structure_dirty_ && !transforms_dirty_; }

    // The rebuild policy's inputs, for callers that report or tune it (the bench's tables, the tests): the
    // TLAS's SAH cost as last refit or built and right after the last build, and the ratio of the two past
    // which commit() rebuilds rather than refits.
    [[nodiscard]] double tlas_sah_cost() const { return sah_current_; }
    [[nodiscard]] double tlas_sah_cost_at_build() const { return sah_at_build_; }
    void set_rebuild_ratio(double r) { rebuild_ratio_ = r; }

private:
    [[nodiscard]] bool takes_world_triangles(const BottomLevel& b) const;
    [[nodiscard]] bool keeps_detail(const BottomLevel& b) const;
    void assign_world_triangle_slots();
    // Instance i's world box under m, every corner in double rounded outward once; throws when m is
    // singular or the box does not fit in float, so that callers check before they write.
    [[nodiscard]] static Aabb checked_world_box(std::uint32_t i, const BottomLevel& b, const AffineTransform& m);
    // Instance i's world box, detail and world triangles, from its stored transform; not its record.
    void update_instance(std::uint32_t i);
    void update_instance(std::uint32_t i, const Aabb& world_box);
    // detail(i) of an instance that keeps none: derived from its linear part.
    [[nodiscard]] InstanceDetail derived_detail(std::uint32_t i) const {
        return {blases_[instances_[i].blas].get(), glm::inverse(linear(i))};
    }
    // Instance i's record, from its stored instance, bottom level and slots.
    [[nodiscard]] InstanceRecord derive_record(std::uint32_t i) const;
    // Writes instance i's record again after a change, unless the next commit() rebuilds and writes them all.
    void refresh_record(std::uint32_t i) {
        if (!structure_dirty_) records_[record_slot_[i]] = derive_record(i);
    }
    void rebuild();
    void refit_binary();
    template <bool kRefitBoxes>
    void sweep_binary();

    std::vector<std::unique_ptr<BottomLevel>> blases_;  // stable addresses for InstanceRecord::blas
    // An instance as the scene keeps it: 56 bytes where an Instance takes 120, since a particle's linear
    // part, a uniform scale, needs no matrix: at millions of particles the copies were fresh memory to fault in.
    // Any other linear part lies in linears_, in a slot the instance keeps once given (so that a transform
    // that turns from a scale to a matrix and back, frame after frame, reuses it).
    struct StoredInstance {
        glm::dvec3 translation;
        double scale;  // the linear part is scale·I (exactly, bit for bit) when `scaled`
        std::uint32_t blas;
        std::uint32_t user_id;
        std::uint32_t linear_slot;  // in linears_, or kNoLinearSlot
        // Where its InstanceDetail lies (kNoInstanceDetail when !keeps_detail()) and, if it takes the
        // world_triangles path, its first world triangle: both depend on the bottom level alone, so they are
        // fixed when it is added. Kept here, not only in the record, so that the records can be derived.
        std::uint32_t detail;
        std::uint32_t first_world_triangle;
        std::uint8_t mask;
        std::uint8_t flags;
        bool scaled;
    };
    static_assert(sizeof(StoredInstance) == 56);
    static constexpr std::uint32_t kNoLinearSlot = ~std::uint32_t{0};
    [[nodiscard]] glm::dmat3 linear(std::uint32_t i) const {
        const StoredInstance& s = instances_[i];
        return s.scaled ? glm::dmat3(s.scale) : linears_[s.linear_slot];
    }
    // Stores m's linear part in instance i: as a scale, or in its linears_ slot (given one at the end of
    // linears_ if it has none and `new_slot` is kNoLinearSlot, else `new_slot`, which the caller has made).
    void store_linear(std::uint32_t i, const glm::dmat3& m, std::uint32_t new_slot = kNoLinearSlot);

    // The arrays per instance grow unwritten (UnwrittenAllocator): add_instances() writes them in parallel.
    std::vector<StoredInstance, UnwrittenAllocator<StoredInstance>> instances_;
    std::vector<glm::dmat3> linears_;
    // records_[record_slot_[i]] is instance i's record, in TLAS leaf order: a walk meets the instances of a
    // region together, and instance order is often random in space (a particle system's), so records in
    // instance order would cost a cache miss per visit. They are derived data: each rebuild writes them all,
    // once, straight into leaf order (a million records are 64 MB of fresh memory, so they are not also
    // written in instance order when added); between rebuilds refresh_record() keeps them current, and while
    // a rebuild is pending (structure_dirty_) they and record_slot_ are stale.
    // Not zeroed when grown: every record is written whole.
    std::vector<InstanceRecord, UnwrittenAllocator<InstanceRecord, 64>> records_;
    std::vector<std::uint32_t, UnwrittenAllocator<std::uint32_t>> record_slot_;
    std::vector<InstanceDetail> details_;  // of the instances that keeps_detail(), in instance order
    std::vector<MeshBlas::Triangle> world_triangles_;  // in instance order; slots fixed when added
    std::vector<Aabb, UnwrittenAllocator<Aabb>> world_boxes_;
    // Each instance's mask again, one byte apiece: the refit sweep reads it at random (TLAS leaf order),
    // and from the 48-byte stored instances that would be a cache miss per leaf.
    std::vector<std::uint8_t, UnwrittenAllocator<std::uint8_t>> instance_masks_;
    Bvh tlas_;
    std::vector<std::uint8_t> node_masks_;  // OR of the instance masks below each TLAS node
    WideBvh wide_tlas_;                     // collapsed from tlas_ at each build, refit with it
    double sah_at_build_ = 0.0;
    double sah_current_ = 0.0;  // of the tree as last refit or built
    double rebuild_ratio_ = kTlasRebuildSahRatio;
    InstancePaths paths_ = InstancePaths::fastest;
    bool structure_dirty_ = true;
    bool transforms_dirty_ = false;
};

}  // namespace smoketrace
