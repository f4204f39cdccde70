#pragma once
// The functional ray core: stack-based traversal of BVHs of 2..8 children per
// node and watertight triangle
// tests over a MemoryImage, written ONCE as a resumable per-ray state machine
// that also owns its memory access sequence.
//
// A ray advances in steps. Each step names the reads it needs (step_reads);
// once they have arrived, process() does the step's work, and stack_accesses()
// then lists the spills (writes) and refills (reads) that work caused:
//
//   RayTraversal trv(context, slot);
//   trv.reset(ray);
//   while (!trv.done()) {
//     issue(trv.step_reads());   // reads [0, independent) together, the rest after them
//     trv.process();             // one TRV op, or up to triangles_per_step IST ops
//     issue(trv.stack_accesses());
//   }
//
// The functional tracer (trace_ray below), the functional, lt and cycle levels
// all drive this one sequence and only time it, so TRV/IST ops, fetch counts and
// every ray's address stream are identical at every fidelity level.
//
// Steps:
//  - FetchNode: read the node's record; one TRV op, whatever the node's width.
//    Formats whose record holds its children's boxes (every format but bvh2-32,
//    node_format.h): test all the child boxes as the record decodes them, descend
//    into the nearest hit child and push the other hit children farthest first
//    (equal distances keep child order). Leaf children are reached through their
//    parent's record (no fetch of their own); the root is fetched first. bvh2-32:
//    each node's record holds its own box: test it; a hit leaf goes to IST, a hit
//    inner node pushes its children, nearer first by the ray direction along the
//    node's longest axis.
//  - TestTriangles: the next triangles_per_step triangles of the leaf (memory
//    order) are read together and tested in order; in indexed storage the leaf's
//    first step reads its prim-ref list first, and the triangles, whose addresses
//    it holds, after it. Any-hit rays stop at their first hit, so they may have
//    read up to triangles_per_step - 1 triangles they do not test.
//  - AlphaTest (scenes with alpha-tested materials): a triangle step's hits on
//    alpha-tested triangles are candidates, not hits. Each candidate nearer than
//    the closest committed hit goes, nearest first, to the any-hit stage: it reads
//    the triangle's UV record, then (its address needs the coordinates) the texel
//    they pick, and tests its alpha (Scene::alpha_sample). An opaque texel commits
//    the hit; a transparent one lets the ray go on (the next candidate, the rest
//    of the leaf, the stack). The step's opaque hits commit at once, as before.
//  - Transform (two-level trees, instanced scenes): a TLAS leaf holds one
//    instance. The step reads its 64-byte record and is one XFM op: the ray's
//    origin and direction go through the instance's world-to-object transform
//    (the direction is not renormalised, so t keeps its meaning and the closest
//    hit so far still culls). The ray then walks the instance's BLAS from its
//    root record. The ray slot remembers the stack depth at which it entered
//    (a register, not a stack entry): when a pop would go below it, the BLAS is
//    done and the world ray is restored (no op, no fetch) before the TLAS entry
//    is popped. One short stack holds both levels' entries.
// Closest-hit rays skip popped entries whose entry distance lies beyond the
// closest hit so far (no fetch, no op). Any-hit rays finish at their first hit
// (an alpha-tested one: at the first that passes its test).
//
// The short stack: the top stack_limit entries live on chip; a push onto a full
// stack spills the bottom on-chip entry to the ray slot's spill area (a write),
// and a pop that leaves a spilled entry at the bottom of the on-chip part reads it
// back (a refill).
#include <rtsim/builder/bvh.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/model/core/fetch.h>
#include <rtsim/model/core/intersect.h>
#include <rtsim/model/core/ray.h>
#include <rtsim/workloads/scene.h>

#include <algorithm>
#include <cstdint>
#include <vector>

namespace rtsim {

// What happens when a push finds the stack full (the hardware has a short stack).
enum class StackOverflowPolicy : uint8_t {
  SpillToMemory,  // the entry goes to a backing store: results stay exact; spills/fills counted
  DropOldest,     // the bottom entry is lost: the ray may miss hits; drops counted
};

struct TraversalConfig {
  // Entries the ray's stack holds on chip. The functional default is deeper than
  // any BVH the builders make (max depth 64), so it never overflows; if it does,
  // the counters say so.
  uint32_t stack_limit = 128;
  StackOverflowPolicy overflow_policy = StackOverflowPolicy::SpillToMemory;
  uint32_t stack_entry_bytes = 8;   // node index + entry distance
  uint32_t triangles_per_step = 4;  // triangles of a leaf read together (overlapping fetches)
};

// Per-ray counts. Definitions as in shared/DESIGN.md.
struct RayCounters {
  uint32_t trv_ops = 0;           // BVH nodes processed (fetch, box tests, stack update)
  uint32_t box_tests = 0;         // ray-box slab tests
  uint32_t ist_ops = 0;           // ray-triangle tests
  uint32_t ist_exact_steps = 0;   // steps of those tests redone in double (see intersect.h)
  uint32_t node_fetches = 0;      // node records read (before caches)
  uint32_t prim_ref_fetches = 0;  // leaf prim-ref lists read (first step of a leaf, indexed storage)
  uint32_t triangle_fetches = 0;  // triangle records read (>= ist_ops: any-hit rays stop early)
  uint32_t node_bytes = 0, prim_ref_bytes = 0, triangle_bytes = 0;
  uint32_t max_stack_depth = 0;   // most entries on the stack at once
  uint32_t stack_overflows = 0;   // pushes that found the stack full (spilled or dropped)
  uint32_t stack_refills = 0;     // pops that brought a spilled entry back
  // The any-hit stage (alpha-tested triangles): tests run, and those whose texel
  // let the ray through; each reads one UV record and one texel.
  uint32_t anyhit_tests = 0, anyhit_rejects = 0;
  uint32_t uv_bytes = 0, texel_bytes = 0;
  // Two-level trees: the TLAS's share of trv_ops, node_fetches and node_bytes (the
  // rest is the BLASes'), and the Transform steps (XFM ops), each reading one
  // instance record. XFM ops are counted apart from trv_ops.
  uint32_t tlas_trv_ops = 0, tlas_node_fetches = 0, tlas_node_bytes = 0;
  uint32_t xfm_ops = 0, instance_bytes = 0;
  uint32_t ops() const { return trv_ops + ist_ops; }
  uint64_t bytes() const {
    return uint64_t(node_bytes) + prim_ref_bytes + triangle_bytes + uv_bytes + texel_bytes + instance_bytes;
  }
};

// Triangle data as the IST unit sees it: three vertices, 36 bytes.
struct PackedTriangle {
  vec3 v0, v1, v2;
};
static_assert(sizeof(PackedTriangle) == 9 * sizeof(float), "the IST lanes read triangles as runs of nine floats");

// Everything shared by all rays of one (scene, BVH, memory layout). The scene,
// BVH and image must outlive it.
class TraversalContext {
 public:
  // The host's copy of a record that holds its children's boxes, laid out for the
  // hot loop in one block per record, in address order: its head, its children's
  // decoded boxes four to a BoxQuadLanes (one 4-lane slab test per quad; a binary
  // format's two in one BoxPairLanes, half the bytes), then
  // where each child leads (its own record, or its leaf's triangle slots). A node
  // step reads one block instead of the tree, the image and its box table, and
  // the ray can prefetch it as soon as it knows its next node: the engines
  // interleave many rays, so the prefetch has a whole round to land.
  struct RecordHead {
    uint64_t address;          // of the record in the memory image
    uint32_t node;             // the node it belongs to
    uint32_t children;         // boxes it holds (0: a root that is a leaf)
  };
  struct ChildTarget {
    uint32_t node;             // the child's node index
    uint32_t target;           // inner child: its record; leaf: its first triangle slot; instance leaf: the instance
    uint32_t leaf_count;       // 0: inner child; kInstanceLeaf: a TLAS leaf
  };
  static constexpr uint32_t kInstanceLeaf = ~0u;
  // Two-level trees: what the Transform step applies and where the BLAS starts.
  struct InstancePlacement {
    glm::mat3 linear;          // world to object, linear part
    vec3 offset;               // world to object, translation
    uint32_t root_node;        // the BLAS root
    uint32_t root_record;      // its record (child-box formats)
  };

  TraversalContext(const Scene& scene, const Bvh& bvh, const MemoryImage& image,
                   const TraversalConfig& config = {});
  const Scene& scene() const { return *scene_; }
  const Bvh& bvh() const { return *bvh_; }
  const MemoryImage& image() const { return *image_; }
  const TraversalConfig& config() const { return config_; }
  // Triangle data by memory slot (see MemoryImage): the leaf's triangles in order.
  const PackedTriangle& slot_data(uint32_t slot) const { return triangles_[slot]; }
  // The nine floats of slot `slot` and of the slots after it; readable for
  // four slots from any slot (three slots of zero padding at the end).
  const float* slot_vertices(uint32_t slot) const { return reinterpret_cast<const float*>(triangles_.data() + slot); }
  bool own_box_records() const { return own_box_records_; }  // bvh2-32
  bool pair_records() const { return pair_records_; }  // binary child-box formats: BoxPairLanes
  // Child-box formats only: record r's block, and where in a block its children's
  // targets start (its head is at 0, its boxes right after the head).
  const unsigned char* record_block(uint32_t r) const {
    return reinterpret_cast<const unsigned char*>(blocks_.data()) + size_t(r) * block_bytes_;
  }
  size_t record_block_bytes() const { return block_bytes_; }
  size_t record_targets_offset() const { return targets_offset_; }
  uint32_t root_record() const { return root_record_; }
  bool two_level() const { return !instances_.empty(); }
  const InstancePlacement& instance(uint32_t i) const { return instances_[i]; }
  // Spill area of ray slot `slot`: past the memory image, kStackAreaEntries entries each.
  static constexpr uint32_t kStackAreaEntries = 256;
  uint64_t stack_area(uint32_t slot) const {
    return stack_base_ + uint64_t(slot) * kStackAreaEntries * config_.stack_entry_bytes;
  }

 private:
  void place_instances();
  const Scene* scene_;
  const Bvh* bvh_;
  const MemoryImage* image_;
  TraversalConfig config_;
  bool own_box_records_;
  bool pair_records_ = false;
  uint64_t stack_base_;
  std::vector<PackedTriangle> triangles_;  // by slot
  // Record blocks (child-box formats), block_bytes_ each, 16-byte aligned.
  struct alignas(16) Chunk {
    unsigned char bytes[16];
  };
  std::vector<Chunk> blocks_;
  size_t block_bytes_ = 0, targets_offset_ = 0;
  uint32_t root_record_ = 0;
  std::vector<InstancePlacement> instances_;  // two-level trees
};

enum class TraversalAction : uint8_t { FetchNode, TestTriangles, AlphaTest, Transform, Done };

class RayTraversal {
 public:
  // idle (done()) until reset; stack_slot picks the spill area (the hardware ray slot).
  explicit RayTraversal(const TraversalContext& context, uint32_t stack_slot = 0);

  // Starts a ray (counters and hit cleared, stack storage reused). A ray with a
  // NaN/Inf origin or direction, a zero direction, or an empty [tmin, tmax]
  // finishes at once with no hit and no ops.
  void reset(const Ray& ray);
  void reset(const Ray& ray, TraversalMode mode);

  TraversalAction action() const { return action_; }
  bool done() const { return action_ == TraversalAction::Done; }

  // The reads the next step needs, in issue order. The first
  // step_independent_reads() go out together; the rest need them first (the
  // triangles whose addresses a prim-ref list holds). Valid until process().
  const std::vector<MemoryAccess>& step_reads() const;
  uint32_t step_independent_reads() const;
  // The reads have arrived: one TRV op (FetchNode), one IST step (TestTriangles),
  // one any-hit test (AlphaTest) or one XFM op (Transform).
  void process();
  // Spill writes and refill reads the last process() caused, in order.
  const std::vector<MemoryAccess>& stack_accesses() const { return stack_accesses_; }
  uint32_t last_step_tests() const { return last_tests_; }  // IST ops of the last process()
  uint32_t last_step_box_tests() const { return last_box_tests_; }  // box tests of the last process()
  // FetchNode: the boxes the record holds and process() will test (the node's
  // child count; 1 in bvh2-32; 0 for a root that is a leaf). Timing uses it.
  uint32_t step_box_tests() const;

  uint32_t node() const { return current_node_; }      // FetchNode: the node; else the leaf
  // Two-level trees: the instance whose BLAS the ray is in (or the Transform step's); kNoInstance in the TLAS.
  uint32_t instance() const { return instance_; }
  bool in_blas() const { return in_blas_; }
  uint32_t leaf_size() const { return leaf_count_; }
  uint32_t leaf_cursor() const { return leaf_cursor_; }  // next triangle of the leaf to test

  const Ray& ray() const { return ray_; }
  TraversalMode mode() const { return mode_; }
  const HitRecord& hit() const { return hit_; }
  const RayCounters& counters() const { return counters_; }
  uint32_t stack_size() const { return depth_; }

 private:
  // A node to visit later, with where it leads (ChildTarget; bvh2-32 uses the node only).
  struct StackEntry {
    uint32_t node, target, leaf_count;
    float tnear;
  };
  void push(uint32_t node, uint32_t target, uint32_t leaf_count, float tnear);
  [[gnu::cold, gnu::noinline]] void make_room_to_push();  // a spill, a drop or more storage
  void enter(uint32_t node, uint32_t target, uint32_t leaf_count);  // sets the next action
  void enter_leaf(uint32_t node);
  void pop_next();            // next non-culled stack entry, or Done
  void process_node();
  void process_triangles();
  void process_child_boxes_node();
  void process_own_box_node();
  void process_alpha_test();
  void process_transform();
  void enter_instance(uint32_t node, uint32_t instance);  // a TLAS leaf: Transform next
  void leave_instance();      // back to the world ray, in the TLAS
  void set_ray_space(const vec3& origin, const vec3& direction);
  void commit(float t, uint32_t slot, float u, float v);
  void after_candidates();    // the next candidate to test, or on with the leaf
  void test_candidate(uint32_t index);  // AlphaTest of candidates_[index] comes next
  uint64_t spill_address(uint32_t position) const;
  const unsigned char* block(uint32_t record) const { return blocks_ + size_t(record) * block_bytes_; }
  const TraversalContext::RecordHead& head(uint32_t record) const {
    return *reinterpret_cast<const TraversalContext::RecordHead*>(block(record));
  }

  // A hit on an alpha-tested triangle waiting for its any-hit test.
  struct Candidate {
    float t, u, v;
    uint32_t slot;
  };

  const TraversalContext* context_;
  const BvhNode* nodes_;
  uint64_t stack_area_;
  // The context's constants that every step reads, copied here once so that a
  // step's first loads do not wait on context -> image -> field.
  const unsigned char* blocks_ = nullptr;  // child-box formats: record block 0
  const PackedTriangle* triangles_ = nullptr;  // by slot
  const uint64_t* slot_addresses_ = nullptr;   // by slot
  size_t block_bytes_ = 0, targets_offset_ = 0;
  uint32_t node_bytes_ = 0, stack_limit_ = 0, triangles_per_step_ = 0;
  bool own_box_records_ = false, pair_records_ = false, two_level_ = false;
  Ray ray_;
  RayBoxLanes box_ray_;
  RayTrianglePrecompute tri_ray_;
  RayTriangleLanes tri_lanes_;
  vec3 direction_{0.0f};      // the ray's direction in the current space (world, or the BLAS's object space)
  TraversalMode mode_ = TraversalMode::ClosestHit;
  TraversalAction action_ = TraversalAction::Done;
  HitRecord hit_;
  float tfar_ = 0.0f;  // current far limit: tmax, then the closest hit
  RayCounters counters_;
  uint32_t current_node_ = 0;
  uint32_t current_record_ = 0;  // child-box formats: the FetchNode step's record
  uint32_t leaf_slot_ = 0, leaf_count_ = 0, leaf_cursor_ = 0;
  uint32_t last_tests_ = 0, last_box_tests_ = 0;
  // The stack: entries [0, depth_) of stack_, which grows (rarely) only
  // when a push finds it full, so a push is a store and an increment.
  std::vector<StackEntry> stack_;
  uint32_t depth_ = 0;
  std::vector<Candidate> candidates_;  // of the last triangle step, nearest first
  uint32_t candidate_ = 0;             // the one AlphaTest tests
  AlphaSample candidate_sample_;       // its texel, found once for the step's reads and its test
  bool alpha_scene_ = false;           // the scene has alpha-tested triangles
  uint32_t instance_ = kNoInstance;    // two-level trees: the instance being entered or walked
  bool in_blas_ = false;
  uint32_t blas_stack_base_ = 0;       // stack depth when the BLAS was entered
  std::vector<MemoryAccess> stack_accesses_;
  mutable std::vector<MemoryAccess> reads_;  // built on demand by step_reads()
};

// The step queries are inline: every engine asks them once or twice per step.
inline const std::vector<MemoryAccess>& RayTraversal::step_reads() const {
  // Fields are stored in place: a whole access built on the stack and copied
  // in would be read back wider than it was written (a stalled store forward).
  const auto add = [this](uint64_t address, uint32_t bytes, AccessKind kind) {
    MemoryAccess& a = reads_.emplace_back();
    a.address = address, a.bytes = bytes, a.kind = kind;
  };
  reads_.clear();
  const MemoryImage& image = context_->image();
  if (action_ == TraversalAction::FetchNode) {
    add(own_box_records_ ? image.node_address(current_node_) : head(current_record_).address,
        image.node_bytes(), AccessKind::Node);
  } else if (action_ == TraversalAction::TestTriangles) {
    if (leaf_cursor_ == 0 && image.indexed())
      add(image.prim_refs_address(current_node_), leaf_count_ * 4u, AccessKind::PrimRef);
    const uint32_t end = std::min(leaf_count_, leaf_cursor_ + triangles_per_step_);
    for (uint32_t k = leaf_cursor_; k < end; ++k)
      add(image.slot_address(leaf_slot_ + k), image.triangle_bytes(), AccessKind::Triangle);
  } else if (action_ == TraversalAction::AlphaTest) {
    add(image.uv_address(candidates_[candidate_].slot), MemoryImage::kUvRecordBytes, AccessKind::Uv);
    const AlphaSample& s = candidate_sample_;
    add(image.texel_address(s.texture, s.x, s.y), MemoryImage::kTexelBytes, AccessKind::Texel);
  } else if (action_ == TraversalAction::Transform) {
    add(image.instance_address(instance_), MemoryImage::kInstanceRecordBytes, AccessKind::Instance);
  }
  return reads_;
}

inline uint32_t RayTraversal::step_independent_reads() const {
  // Only the triangles behind a prim-ref list wait: they need the addresses it holds.
  switch (action_) {
    case TraversalAction::FetchNode: return 1;
    case TraversalAction::TestTriangles:
      if (leaf_cursor_ == 0 && context_->image().indexed()) return 1;
      return std::min(leaf_count_ - leaf_cursor_, triangles_per_step_);
    case TraversalAction::AlphaTest: return 1;  // the texel's address needs the UVs
    case TraversalAction::Transform: return 1;
    case TraversalAction::Done: break;
  }
  return 0;
}

inline uint32_t RayTraversal::step_box_tests() const {
  if (action_ != TraversalAction::FetchNode) return 0;
  if (own_box_records_) return 1;
  return head(current_record_).children;
}

// The functional driver: runs the ray to completion, sending every access (step
// reads, then the stack traffic of the step) to `sink` when given. Returns the hit.
const HitRecord& trace_ray(RayTraversal& traversal, const Ray& ray, AccessSink* sink = nullptr);

}  // namespace rtsim
