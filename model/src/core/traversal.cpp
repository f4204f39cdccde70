#include <rtsim/model/core/traversal.h>
#include <rtsim/workloads/error.h>

#include <algorithm>
#include <cmath>
#include <string>

namespace rtsim {

const char* ray_type_name(RayType type) {
  switch (type) {
    case RayType::Primary: return "primary";
    case RayType::Ao: return "ao";
    case RayType::Shadow: return "shadow";
    case RayType::Reflection: return "reflection";
    case RayType::Refraction: return "refraction";
  }
  return "unknown";
}

const char* fetch_kind_name(FetchKind kind) {
  switch (kind) {
    case FetchKind::Node: return "node";
    case FetchKind::PrimRef: return "prim_ref";
    case FetchKind::Triangle: return "triangle";
  }
  return "unknown";
}

TraversalContext::TraversalContext(const Scene& scene, const Bvh& bvh, const MemoryImage& image,
                                   const TraversalConfig& config)
    : scene_(&scene),
      bvh_(&bvh),
      image_(&image),
      config_(config),
      wide_nodes_(image.config().node_layout == NodeLayout::Bvh2Wide64) {
  if (config_.stack_limit < 1)
    throw InputError("traversal.stack_limit", "must be at least 1");
  // Children always follow their parent in the flat array, which rules out
  // cycles: no BVH handed to the core can make a ray loop forever.
  const size_t node_count = bvh.nodes.size();
  const size_t tri_count = scene.triangle_count();
  for (size_t i = 0; i < node_count; ++i) {
    const BvhNode& n = bvh.nodes[i];
    if (n.is_leaf()) {
      if (uint64_t(n.index) + n.count > bvh.prim_refs.size())
        throw InputError("bvh: node " + std::to_string(i),
                         "leaf prim range past the end of prim_refs");
    } else if (n.index <= i || uint64_t(n.index) + 1 >= node_count) {
      throw InputError("bvh: node " + std::to_string(i),
                       "inner node's children must follow it and exist");
    }
  }
  for (size_t r = 0; r < bvh.prim_refs.size(); ++r)
    if (bvh.prim_refs[r] >= tri_count)
      throw InputError("bvh: prim_ref " + std::to_string(r), "triangle index out of range");
  triangles_.resize(tri_count);
  for (uint32_t t = 0; t < tri_count; ++t) {
    triangles_[t] = PackedTriangle{scene.vertex(t, 0), scene.vertex(t, 1), scene.vertex(t, 2)};
  }
}

RayTraversal::RayTraversal(const TraversalContext& context)
    : context_(&context), nodes_(context.bvh().nodes.data()) {
  stack_.reserve(std::min<uint32_t>(context.config().stack_limit, 64) + 1);
}

void RayTraversal::reset(const Ray& ray) { reset(ray, traversal_mode_for(ray.type)); }

void RayTraversal::reset(const Ray& ray, TraversalMode mode) {
  ray_ = ray;
  mode_ = mode;
  hit_ = HitRecord{};
  counters_ = RayCounters{};
  stack_.clear();
  leaf_first_ = leaf_count_ = leaf_cursor_ = 0;
  current_node_ = 0;
  tfar_ = ray.tmax;
  const bool usable = is_finite(ray.origin) && is_finite(ray.direction) &&
                      ray.direction != vec3(0.0f) && std::isfinite(ray.tmin) &&
                      !std::isnan(ray.tmax) && ray.tmin <= ray.tmax;
  if (!usable || context_->bvh().empty()) {
    action_ = TraversalAction::Done;
    return;
  }
  box_ray_ = RayBoxPrecompute(ray.origin, ray.direction);
  tri_ray_ = RayTrianglePrecompute(ray.origin, ray.direction);
  // The root record is always fetched: in the wide layout it holds the child
  // boxes (the root's own box is never needed), in the single-box layout its box.
  action_ = TraversalAction::FetchNode;
}

uint64_t RayTraversal::node_address() const { return context_->image().node_address(current_node_); }
uint32_t RayTraversal::node_bytes() const { return context_->image().node_bytes(); }
uint64_t RayTraversal::prim_refs_address() const {
  return context_->image().prim_ref_address(leaf_first_);
}
uint32_t RayTraversal::triangle(uint32_t k) const {
  return context_->bvh().prim_refs[leaf_first_ + k];
}
uint64_t RayTraversal::triangle_address(uint32_t k) const {
  return context_->image().triangle_address(triangle(k));
}
uint32_t RayTraversal::triangle_bytes() const { return context_->image().triangle_bytes(); }

void RayTraversal::push(uint32_t node, float tnear) {
  const uint32_t limit = context_->config().stack_limit;
  if (stack_.size() >= limit) {
    ++counters_.stack_overflows;
    if (context_->config().overflow_policy == StackOverflowPolicy::DropOldest)
      stack_.erase(stack_.begin());
  }
  stack_.push_back({node, tnear});
  counters_.max_stack_depth = std::max(counters_.max_stack_depth, uint32_t(stack_.size()));
}

void RayTraversal::enter(uint32_t node) {
  current_node_ = node;
  const BvhNode& n = nodes_[node];
  if (context_->wide_nodes() && n.is_leaf()) {
    // The leaf's range came with its parent's record: straight to IST.
    leaf_first_ = n.index;
    leaf_count_ = n.count;
    leaf_cursor_ = 0;
    action_ = TraversalAction::TestTriangles;
  } else {
    action_ = TraversalAction::FetchNode;
  }
}

void RayTraversal::pop_next() {
  const uint32_t limit = context_->config().stack_limit;
  while (!stack_.empty()) {
    const StackEntry entry = stack_.back();
    if (stack_.size() > limit) ++counters_.stack_refills;
    stack_.pop_back();
    // Closest-hit: a subtree entered beyond the closest hit cannot hold a nearer one.
    if (entry.tnear > tfar_) continue;
    enter(entry.node);
    return;
  }
  action_ = TraversalAction::Done;
}

void RayTraversal::process_node() {
  ++counters_.trv_ops;
  ++counters_.node_fetches;
  counters_.node_bytes += context_->image().node_bytes();
  if (context_->wide_nodes())
    process_wide_node();
  else
    process_single_box_node();
}

void RayTraversal::process_wide_node() {
  const BvhNode& n = nodes_[current_node_];
  if (n.is_leaf()) {  // only a root that is a leaf is ever fetched as a node
    leaf_first_ = n.index;
    leaf_count_ = n.count;
    leaf_cursor_ = 0;
    action_ = TraversalAction::TestTriangles;
    return;
  }
  const uint32_t c0 = n.index, c1 = n.index + 1;
  float t0 = 0.0f, t1 = 0.0f;
  counters_.box_tests += 2;
  const bool hit0 = intersect_box(box_ray_, nodes_[c0].bounds, ray_.tmin, tfar_, &t0);
  const bool hit1 = intersect_box(box_ray_, nodes_[c1].bounds, ray_.tmin, tfar_, &t1);
  if (hit0 && hit1) {
    // Nearest child first; ties go to the first child so the order is fixed.
    if (t1 < t0) {
      push(c0, t0);
      enter(c1);
    } else {
      push(c1, t1);
      enter(c0);
    }
  } else if (hit0) {
    enter(c0);
  } else if (hit1) {
    enter(c1);
  } else {
    pop_next();
  }
}

void RayTraversal::process_single_box_node() {
  const BvhNode& n = nodes_[current_node_];
  float t_entry = 0.0f;
  ++counters_.box_tests;
  if (!intersect_box(box_ray_, n.bounds, ray_.tmin, tfar_, &t_entry)) {
    pop_next();
    return;
  }
  if (n.is_leaf()) {
    leaf_first_ = n.index;
    leaf_count_ = n.count;
    leaf_cursor_ = 0;
    action_ = TraversalAction::TestTriangles;
    return;
  }
  // No child boxes in this record: order the children by the ray's direction
  // along the node's longest axis (builders put the lower half first).
  const vec3 extent = n.bounds.extent();
  const int axis = extent.x > extent.y ? (extent.x > extent.z ? 0 : 2) : (extent.y > extent.z ? 1 : 2);
  const bool reversed = ray_.direction[axis] < 0.0f;
  const uint32_t first = reversed ? n.index + 1 : n.index;
  const uint32_t second = reversed ? n.index : n.index + 1;
  push(second, t_entry);
  current_node_ = first;
  action_ = TraversalAction::FetchNode;
}

void RayTraversal::process_triangle() {
  if (leaf_cursor_ == 0) {
    ++counters_.prim_ref_fetches;
    counters_.prim_ref_bytes += leaf_count_ * 4u;
  }
  ++counters_.ist_ops;
  ++counters_.triangle_fetches;
  counters_.triangle_bytes += context_->image().triangle_bytes();
  const uint32_t prim = context_->bvh().prim_refs[leaf_first_ + leaf_cursor_];
  const PackedTriangle& tri = context_->triangle(prim);
  TriangleHit th;
  if (intersect_triangle(tri_ray_, tri.v0, tri.v1, tri.v2, ray_.tmin, tfar_, &th,
                         &counters_.ist_exact_steps)) {
    hit_.t = th.t;
    hit_.prim = prim;
    hit_.u = th.u;
    hit_.v = th.v;
    tfar_ = th.t;
    if (mode_ == TraversalMode::AnyHit) {
      action_ = TraversalAction::Done;
      return;
    }
  }
  if (++leaf_cursor_ == leaf_count_) pop_next();
}

const HitRecord& trace_ray(RayTraversal& traversal, const Ray& ray, FetchSink* sink) {
  traversal.reset(ray);
  if (!sink) {
    for (;;) {
      switch (traversal.action()) {
        case TraversalAction::FetchNode: traversal.process_node(); break;
        case TraversalAction::TestTriangles: traversal.process_triangle(); break;
        case TraversalAction::Done: return traversal.hit();
      }
    }
  }
  for (;;) {
    switch (traversal.action()) {
      case TraversalAction::FetchNode:
        sink->on_fetch({traversal.node_address(), traversal.node_bytes(), FetchKind::Node, ray.type});
        traversal.process_node();
        break;
      case TraversalAction::TestTriangles: {
        const uint32_t k = traversal.leaf_cursor();
        if (k == 0)
          sink->on_fetch({traversal.prim_refs_address(), traversal.prim_refs_bytes(),
                          FetchKind::PrimRef, ray.type});
        sink->on_fetch({traversal.triangle_address(k), traversal.triangle_bytes(),
                        FetchKind::Triangle, ray.type});
        traversal.process_triangle();
        break;
      }
      case TraversalAction::Done: return traversal.hit();
    }
  }
}

}  // namespace rtsim
