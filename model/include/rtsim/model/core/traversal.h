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
// Closest-hit rays skip popped entries whose entry distance lies beyond the
// closest hit so far (no fetch, no op). Any-hit rays finish at their first hit.
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
  uint32_t ops() const { return trv_ops + ist_ops; }
  uint64_t bytes() const { return uint64_t(node_bytes) + prim_ref_bytes + triangle_bytes; }
};

// Triangle data as the IST unit sees it: three vertices, 36 bytes.
struct PackedTriangle {
  vec3 v0, v1, v2;
};

// Everything shared by all rays of one (scene, BVH, memory layout). The scene,
// BVH and image must outlive it.
class TraversalContext {
 public:
  // The host's copy of a record that holds its children's boxes, laid out for the
  // hot loop: each child's decoded box beside where it leads (its own record, or
  // its leaf's triangle slots), records in address order. A node step then reads
  // two contiguous blocks instead of the tree, the image and its box table, and
  // the ray can prefetch them as soon as it knows its next node: the engines
  // interleave many rays, so the prefetch has a whole round to land.
  struct ChildLink {
    Aabb box;                  // as the record decodes it
    uint32_t node;             // the child's node index
    uint32_t target;           // inner child: its record; leaf: its first triangle slot
    uint32_t leaf_count;       // 0: inner child
  };
  struct RecordHead {
    uint64_t address;          // of the record in the memory image
    uint32_t node;             // the node it belongs to
    uint32_t children;         // boxes it holds (0: a root that is a leaf)
  };

  TraversalContext(const Scene& scene, const Bvh& bvh, const MemoryImage& image,
                   const TraversalConfig& config = {});
  const Scene& scene() const { return *scene_; }
  const Bvh& bvh() const { return *bvh_; }
  const MemoryImage& image() const { return *image_; }
  const TraversalConfig& config() const { return config_; }
  // Triangle data by memory slot (see MemoryImage): the leaf's triangles in order.
  const PackedTriangle& slot_data(uint32_t slot) const { return triangles_[slot]; }
  bool own_box_records() const { return own_box_records_; }  // bvh2-32
  // Child-box formats only: record r's head and its children's links.
  const RecordHead& record_head(uint32_t r) const { return heads_[r]; }
  const ChildLink* record_links(uint32_t r) const { return &links_[size_t(r) * links_per_record_]; }
  uint32_t root_record() const { return root_record_; }
  size_t record_link_bytes() const { return links_per_record_ * sizeof(ChildLink); }
  // Spill area of ray slot `slot`: past the memory image, kStackAreaEntries entries each.
  static constexpr uint32_t kStackAreaEntries = 256;
  uint64_t stack_area(uint32_t slot) const {
    return stack_base_ + uint64_t(slot) * kStackAreaEntries * config_.stack_entry_bytes;
  }

 private:
  const Scene* scene_;
  const Bvh* bvh_;
  const MemoryImage* image_;
  TraversalConfig config_;
  bool own_box_records_;
  uint64_t stack_base_;
  std::vector<PackedTriangle> triangles_;  // by slot
  std::vector<RecordHead> heads_;          // by record (child-box formats)
  std::vector<ChildLink> links_;           // links_per_record_ per record
  uint32_t links_per_record_ = 0, root_record_ = 0;
};

enum class TraversalAction : uint8_t { FetchNode, TestTriangles, Done };

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
  // The reads have arrived: one TRV op (FetchNode) or one IST step (TestTriangles).
  void process();
  // Spill writes and refill reads the last process() caused, in order.
  const std::vector<MemoryAccess>& stack_accesses() const { return stack_accesses_; }
  uint32_t last_step_tests() const { return last_tests_; }  // IST ops of the last process()
  uint32_t last_step_box_tests() const { return last_box_tests_; }  // box tests of the last process()
  // FetchNode: the boxes the record holds and process() will test (the node's
  // child count; 1 in bvh2-32; 0 for a root that is a leaf). Timing uses it.
  uint32_t step_box_tests() const;

  uint32_t node() const { return current_node_; }      // FetchNode: the node; else the leaf
  uint32_t leaf_size() const { return leaf_count_; }
  uint32_t leaf_cursor() const { return leaf_cursor_; }  // next triangle of the leaf to test

  const Ray& ray() const { return ray_; }
  TraversalMode mode() const { return mode_; }
  const HitRecord& hit() const { return hit_; }
  const RayCounters& counters() const { return counters_; }
  uint32_t stack_size() const { return uint32_t(stack_.size()); }

 private:
  // A node to visit later, with where it leads (ChildLink; bvh2-32 uses the node only).
  struct StackEntry {
    uint32_t node, target, leaf_count;
    float tnear;
  };
  void push(const StackEntry& entry);
  void enter(const StackEntry& entry);  // sets action for the node to visit next
  void enter_leaf(uint32_t node);
  void pop_next();            // next non-culled stack entry, or Done
  void process_node();
  void process_triangles();
  void process_child_boxes_node();
  void process_own_box_node();
  uint64_t spill_address(uint32_t position) const;

  const TraversalContext* context_;
  const BvhNode* nodes_;
  uint64_t stack_area_;
  Ray ray_;
  RayBoxPrecompute box_ray_;
  RayTrianglePrecompute tri_ray_;
  TraversalMode mode_ = TraversalMode::ClosestHit;
  TraversalAction action_ = TraversalAction::Done;
  HitRecord hit_;
  float tfar_ = 0.0f;  // current far limit: tmax, then the closest hit
  RayCounters counters_;
  uint32_t current_node_ = 0;
  uint32_t current_record_ = 0;  // child-box formats: the FetchNode step's record
  uint32_t leaf_slot_ = 0, leaf_count_ = 0, leaf_cursor_ = 0;
  uint32_t last_tests_ = 0, last_box_tests_ = 0;
  std::vector<StackEntry> stack_;
  std::vector<MemoryAccess> stack_accesses_;
  mutable std::vector<MemoryAccess> reads_;  // built on demand by step_reads()
};

// The functional driver: runs the ray to completion, sending every access (step
// reads, then the stack traffic of the step) to `sink` when given. Returns the hit.
const HitRecord& trace_ray(RayTraversal& traversal, const Ray& ray, AccessSink* sink = nullptr);

}  // namespace rtsim
