#pragma once
// The functional ray core: stack-based BVH2 traversal and watertight triangle
// tests over a MemoryImage, written ONCE as a resumable per-ray state machine.
//
// The functional level drives it in a tight loop (trace_ray below). The SystemC
// TRV / IST units drive the same object step by step: they look at action(),
// issue the fetch it names through their caches, and when the data has arrived
// call process_node() (TRV) or process_triangle() (IST). Because every count is
// taken inside this class, TRV/IST ops and fetch counts are identical at every
// fidelity level.
//
//   RayTraversal trv(context);
//   trv.reset(ray);                      // mode from the ray type, or given
//   while (!trv.done()) {
//     if (trv.action() == TraversalAction::FetchNode) {
//       fetch(trv.node_address(), trv.node_bytes());        // TRV + L1 node cache
//       trv.process_node();                                  // one TRV op
//     } else {                                               // TestTriangles
//       if (trv.leaf_cursor() == 0) fetch(trv.prim_refs_address(), trv.prim_refs_bytes());
//       fetch(trv.triangle_address(trv.leaf_cursor()), trv.triangle_bytes());
//       trv.process_triangle();                              // one IST op
//     }
//   }
//   trv.hit(); trv.counters();
//
// Node semantics follow the MemoryImage layout:
//  - Bvh2Wide64: an inner node's 64-byte record holds both child boxes and links.
//    One TRV op = fetch the record, test the two child boxes, descend into the
//    nearer hit child and push the farther one. Leaf children are reached through
//    their parent's record (no fetch of their own); the root is fetched first.
//  - SingleBox32: each node's 32-byte record holds its own box. One TRV op =
//    fetch the node, test its box; a hit leaf goes to IST, a hit inner node pushes
//    its children, nearer first by the ray direction along the node's longest axis.
// Closest-hit rays skip popped entries whose entry distance lies beyond the
// closest hit so far (no fetch, no op). Any-hit rays finish at their first hit.
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
  // Entries the ray's stack holds before overflowing. The functional default is
  // deeper than any BVH the builders make (max depth 64), so it never overflows;
  // if it does, the counters say so.
  uint32_t stack_limit = 128;
  StackOverflowPolicy overflow_policy = StackOverflowPolicy::SpillToMemory;
};

// Per-ray counts. Definitions as in shared/DESIGN.md.
struct RayCounters {
  uint32_t trv_ops = 0;           // BVH nodes processed (fetch, box tests, stack update)
  uint32_t box_tests = 0;         // ray-box slab tests
  uint32_t ist_ops = 0;           // ray-triangle tests
  uint32_t ist_exact_steps = 0;   // steps of those tests redone in double (see intersect.h)
  uint32_t node_fetches = 0;      // node records read (before caches)
  uint32_t prim_ref_fetches = 0;  // leaf prim-ref lists read (one per leaf visit)
  uint32_t triangle_fetches = 0;  // triangles read (one per IST op)
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
// BVH and image must outlive it. Checks the BVH's links once (InputError "bvh: ...").
class TraversalContext {
 public:
  TraversalContext(const Scene& scene, const Bvh& bvh, const MemoryImage& image,
                   const TraversalConfig& config = {});
  const Scene& scene() const { return *scene_; }
  const Bvh& bvh() const { return *bvh_; }
  const MemoryImage& image() const { return *image_; }
  const TraversalConfig& config() const { return config_; }
  const PackedTriangle& triangle(uint32_t prim) const { return triangles_[prim]; }
  bool wide_nodes() const { return wide_nodes_; }

 private:
  const Scene* scene_;
  const Bvh* bvh_;
  const MemoryImage* image_;
  TraversalConfig config_;
  bool wide_nodes_;
  std::vector<PackedTriangle> triangles_;
};

enum class TraversalAction : uint8_t { FetchNode, TestTriangles, Done };

class RayTraversal {
 public:
  explicit RayTraversal(const TraversalContext& context);  // idle: done() until reset

  // Starts a ray (counters and hit cleared, stack storage reused). A ray with a
  // NaN/Inf origin or direction, a zero direction, or an empty [tmin, tmax]
  // finishes at once with no hit and no ops.
  void reset(const Ray& ray);
  void reset(const Ray& ray, TraversalMode mode);

  TraversalAction action() const { return action_; }
  bool done() const { return action_ == TraversalAction::Done; }

  // --- FetchNode: the node record TRV must read next.
  uint32_t node() const { return current_node_; }
  uint64_t node_address() const;
  uint32_t node_bytes() const;
  // The record has arrived: one TRV op (box tests, stack update); moves to the next action.
  void process_node();

  // --- TestTriangles: the current leaf, tested one triangle at a time in order.
  uint32_t leaf_node() const { return current_node_; }
  uint32_t leaf_size() const { return leaf_count_; }
  uint32_t leaf_cursor() const { return leaf_cursor_; }  // next triangle to test
  uint64_t prim_refs_address() const;                    // the whole leaf's prim-ref list
  uint32_t prim_refs_bytes() const { return leaf_count_ * 4u; }
  uint32_t triangle(uint32_t k) const;  // scene triangle index of the leaf's k-th ref
  uint64_t triangle_address(uint32_t k) const;
  uint32_t triangle_bytes() const;
  // Triangle leaf_cursor() has arrived: one IST op (the first of a leaf also
  // counts the prim-ref fetch). After the last triangle, or an any-hit hit,
  // moves to the next action.
  void process_triangle();

  const Ray& ray() const { return ray_; }
  TraversalMode mode() const { return mode_; }
  const HitRecord& hit() const { return hit_; }
  const RayCounters& counters() const { return counters_; }
  uint32_t stack_size() const { return uint32_t(stack_.size()); }

 private:
  struct StackEntry {
    uint32_t node;
    float tnear;
  };
  void push(uint32_t node, float tnear);
  void enter(uint32_t node);  // sets action for a node to visit next
  void pop_next();            // next non-culled stack entry, or Done
  void process_wide_node();
  void process_single_box_node();

  const TraversalContext* context_;
  const BvhNode* nodes_;
  Ray ray_;
  RayBoxPrecompute box_ray_;
  RayTrianglePrecompute tri_ray_;
  TraversalMode mode_ = TraversalMode::ClosestHit;
  TraversalAction action_ = TraversalAction::Done;
  HitRecord hit_;
  float tfar_ = 0.0f;  // current far limit: tmax, then the closest hit
  RayCounters counters_;
  uint32_t current_node_ = 0;
  uint32_t leaf_first_ = 0, leaf_count_ = 0, leaf_cursor_ = 0;
  std::vector<StackEntry> stack_;
};

// The functional driver: runs the ray to completion, sending every fetch (node,
// prim refs, triangle) to `sink` when given. Returns the hit.
const HitRecord& trace_ray(RayTraversal& traversal, const Ray& ray, FetchSink* sink = nullptr);

}  // namespace rtsim
