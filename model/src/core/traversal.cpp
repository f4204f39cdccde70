#include <rtsim/model/core/traversal.h>
#include <rtsim/model/core/huge_pages.h>
#include <rtsim/workloads/error.h>

#include <algorithm>
#include <cmath>
#include <new>
#include <string>

namespace rtsim {

namespace {
// Asks the host to bring [p, p + bytes) into its caches; a hint only. The first
// three lines take no loop: a leaf's size varies, and a loop's exit would be
// mispredicted as often.
inline void prefetch(const void* p, size_t bytes) {
  const char* c = static_cast<const char*>(p);
  const size_t last = bytes - 1;
  __builtin_prefetch(c);
  __builtin_prefetch(c + std::min<size_t>(64, last));
  __builtin_prefetch(c + std::min<size_t>(128, last));
  for (size_t off = 192; off < bytes; off += 64) __builtin_prefetch(c + off);
  __builtin_prefetch(c + last);
}
}  // namespace

const char* ray_type_name(RayType type) {
  switch (type) {
    case RayType::Primary: return "primary";
    case RayType::Ao: return "ao";
    case RayType::Shadow: return "shadow";
    case RayType::Reflection: return "reflection";
    case RayType::Refraction: return "refraction";
    case RayType::Diffuse1: return "diffuse1";
    case RayType::Diffuse2: return "diffuse2";
    case RayType::Diffuse3: return "diffuse3";
    case RayType::Diffuse4: return "diffuse4";
    case RayType::Diffuse5: return "diffuse5";
    case RayType::Diffuse6: return "diffuse6";
    case RayType::Diffuse7: return "diffuse7";
    case RayType::Diffuse8: return "diffuse8";
  }
  return "unknown";
}

const char* access_kind_name(AccessKind kind) {
  switch (kind) {
    case AccessKind::Node: return "node";
    case AccessKind::PrimRef: return "prim_ref";
    case AccessKind::Triangle: return "triangle";
    case AccessKind::Stack: return "stack";
    case AccessKind::Uv: return "uv";
    case AccessKind::Texel: return "texel";
    case AccessKind::Instance: return "instance";
  }
  return "unknown";
}

TraversalContext::TraversalContext(const Scene& scene, const Bvh& bvh, const MemoryImage& image,
                                   const TraversalConfig& config)
    : scene_(&scene),
      bvh_(&bvh),
      image_(&image),
      config_(config),
      own_box_records_(image.format().encoding == BoxEncoding::OwnBoxFp32),
      stack_base_((image.end_address() + 4095) & ~uint64_t(4095)) {
  if (config_.stack_limit < 1)
    throw InputError("traversal.stack_limit", "must be at least 1");
  if (config_.triangles_per_step < 1)
    throw InputError("traversal.triangles_per_step", "must be at least 1");
  if (config_.stack_entry_bytes < 1)
    throw InputError("traversal.stack_entry_bytes", "must be at least 1");
  // The image checked the tree's links (children after their parent), so no BVH
  // handed to the core can make a ray loop forever.
  // Three slots of padding: a leaf's last triangles are tested four lanes at a time.
  reserve_on_huge_pages(triangles_, image.slot_count() + 3);
  triangles_.resize(image.slot_count() + 3, PackedTriangle{vec3(0.0f), vec3(0.0f), vec3(0.0f)});
  for (uint32_t s = 0; s < image.slot_count(); ++s) {
    const uint32_t t = image.slot_triangle(s);
    triangles_[s] = PackedTriangle{scene.vertex(t, 0), scene.vertex(t, 1), scene.vertex(t, 2)};
  }
  if (image.two_level()) place_instances();
  if (own_box_records_ || bvh.empty()) return;
  const uint32_t width = image.format().width;
  const uint32_t quads = (width + 3) / 4;
  pair_records_ = width <= 2;
  targets_offset_ = sizeof(RecordHead) + (pair_records_ ? sizeof(BoxPairLanes) : quads * sizeof(BoxQuadLanes));
  block_bytes_ = (targets_offset_ + width * sizeof(ChildTarget) + 15) & ~size_t(15);
  const size_t chunks = image.record_count() * block_bytes_ / sizeof(Chunk);
  reserve_on_huge_pages(blocks_, chunks);
  blocks_.assign(chunks, Chunk{});
  for (uint32_t n = 0; n < bvh.nodes.size(); ++n) {
    if (!image.has_record(n)) continue;
    const uint32_t r = image.record_ordinal(n);
    const BvhNode& node = bvh.nodes[n];
    const uint32_t children = node.is_leaf() ? 0 : node.children;
    unsigned char* block = reinterpret_cast<unsigned char*>(blocks_.data()) + size_t(r) * block_bytes_;
    new (block) RecordHead{image.node_address(n), n, children};
    BoxPairLanes* pair = pair_records_ ? new (block + sizeof(RecordHead)) BoxPairLanes{} : nullptr;
    BoxQuadLanes* lanes = pair_records_ ? nullptr : new (block + sizeof(RecordHead)) BoxQuadLanes[quads]{};
    ChildTarget* targets = new (block + targets_offset_) ChildTarget[width]{};
    const Aabb* boxes = children ? image.record_boxes(n) : nullptr;
    for (uint32_t k = 0; k < children; ++k) {
      const uint32_t c = node.index + k;
      const BvhNode& child = bvh.nodes[c];
      if (pair) pair->set(int(k), boxes[k]);
      else lanes[k / 4].set(int(k % 4), boxes[k]);
      targets[k] = bvh.is_instance_leaf(c) ? ChildTarget{c, image.leaf_first(c), kInstanceLeaf}
                   : child.is_leaf()        ? ChildTarget{c, image.leaf_first(c), child.count}
                                            : ChildTarget{c, image.record_ordinal(c), 0};
    }
  }
  root_record_ = image.record_ordinal(0);
}

void TraversalContext::place_instances() {
  const Scene& scene = *scene_;
  instances_.resize(scene.instances.size());
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const glm::mat4 inverse = scene.world_to_object(uint32_t(i));
    InstancePlacement& p = instances_[i];
    p.linear = glm::mat3(inverse);
    p.offset = vec3(inverse[3]);
    p.root_node = bvh_->blas_roots[scene.instances[i].mesh];
    p.root_record = (p.root_node != Bvh::kNoBlas && image_->has_record(p.root_node))
                        ? image_->record_ordinal(p.root_node) : 0;
  }
}

RayTraversal::RayTraversal(const TraversalContext& context, uint32_t stack_slot)
    : context_(&context), nodes_(context.bvh().nodes.data()),
      stack_area_(context.stack_area(stack_slot)),
      blocks_(context.own_box_records() || context.bvh().empty() ? nullptr : context.record_block(0)),
      triangles_(&context.slot_data(0)),
      slot_addresses_(context.image().slot_addresses()),
      block_bytes_(context.record_block_bytes()),
      targets_offset_(context.record_targets_offset()),
      node_bytes_(context.image().node_bytes()),
      stack_limit_(context.config().stack_limit),
      triangles_per_step_(context.config().triangles_per_step),
      own_box_records_(context.own_box_records()),
      pair_records_(context.pair_records()),
      two_level_(context.two_level()) {
  stack_.resize(std::min<uint32_t>(stack_limit_, 64) + 1);
  reads_.reserve(2 + context.config().triangles_per_step);
  alpha_scene_ = context.image().has_alpha_data();
  if (alpha_scene_) candidates_.reserve(context.config().triangles_per_step);
}

void RayTraversal::reset(const Ray& ray) { reset(ray, traversal_mode_for(ray.type)); }

void RayTraversal::reset(const Ray& ray, TraversalMode mode) {
  ray_ = ray;
  mode_ = mode;
  hit_ = HitRecord{};
  counters_ = RayCounters{};
  depth_ = 0;
  stack_accesses_.clear();
  candidates_.clear();
  candidate_ = 0;
  instance_ = kNoInstance;
  in_blas_ = false;
  blas_stack_base_ = 0;
  leaf_slot_ = leaf_count_ = leaf_cursor_ = last_tests_ = last_box_tests_ = 0;
  current_node_ = 0;
  current_record_ = context_->root_record();
  tfar_ = ray.tmax;
  const bool usable = is_finite(ray.origin) && is_finite(ray.direction) &&
                      ray.direction != vec3(0.0f) && std::isfinite(ray.tmin) &&
                      !std::isnan(ray.tmax) && ray.tmin <= ray.tmax;
  if (!usable || context_->bvh().empty()) {
    action_ = TraversalAction::Done;
    return;
  }
  set_ray_space(ray.origin, ray.direction);
  // The root record is always fetched: it holds the child boxes (the root's own
  // box is never needed), or in bvh2-32 its own box.
  action_ = TraversalAction::FetchNode;
}

void RayTraversal::set_ray_space(const vec3& origin, const vec3& direction) {
  box_ray_ = RayBoxLanes(RayBoxPrecompute(origin, direction));
  tri_ray_ = RayTrianglePrecompute(origin, direction);
  tri_lanes_ = RayTriangleLanes(tri_ray_);
  direction_ = direction;
}

uint64_t RayTraversal::spill_address(uint32_t position) const {
  const uint32_t last = TraversalContext::kStackAreaEntries - 1;
  return stack_area_ + uint64_t(std::min(position, last)) * context_->config().stack_entry_bytes;
}

void RayTraversal::make_room_to_push() {
  if (depth_ >= stack_limit_) {
    ++counters_.stack_overflows;
    if (context_->config().overflow_policy == StackOverflowPolicy::DropOldest) {
      std::move(stack_.begin() + 1, stack_.begin() + depth_, stack_.begin());
      --depth_;
      if (in_blas_ && blas_stack_base_ > 0) --blas_stack_base_;  // the lost entry lay below the BLAS's
    } else {
      // The bottom on-chip entry (position depth - limit) goes to memory.
      stack_accesses_.push_back({spill_address(depth_ - stack_limit_), context_->config().stack_entry_bytes,
                                 AccessKind::Stack, true});
    }
  }
  if (depth_ == stack_.size()) stack_.resize(stack_.size() * 2);
}

inline void RayTraversal::push(uint32_t node, uint32_t target, uint32_t leaf_count, float tnear) {
  // A push onto a stack with room, the common case, is a store and an increment.
  if (depth_ >= stack_limit_ || depth_ == stack_.size()) make_room_to_push();
  // Stored field by field: an entry built on the stack and copied in whole would
  // be read back wider than it was written (a stalled store forward).
  StackEntry& entry = stack_[depth_++];
  entry.node = node, entry.target = target, entry.leaf_count = leaf_count, entry.tnear = tnear;
  // The pushed child's first line is started on its way now (a hint): by the time
  // the ray pops it, it has had the near subtree's steps to arrive. Measured: +2-5%
  // on dragon (its tree exceeds the host's caches); its whole block was slower.
  if (!own_box_records_) {
    if (leaf_count == 0) __builtin_prefetch(block(target));
    else if (leaf_count != TraversalContext::kInstanceLeaf) __builtin_prefetch(triangles_ + target);
  }
  counters_.max_stack_depth = std::max(counters_.max_stack_depth, depth_);
}

void RayTraversal::enter_leaf(uint32_t node) {
  if (context_->bvh().is_instance_leaf(node)) {
    enter_instance(node, context_->image().leaf_first(node));
    return;
  }
  current_node_ = node;
  leaf_slot_ = context_->image().leaf_first(node);
  leaf_count_ = nodes_[node].count;
  leaf_cursor_ = 0;
  action_ = TraversalAction::TestTriangles;
}

void RayTraversal::enter(uint32_t node, uint32_t target, uint32_t leaf_count) {
  current_node_ = node;
  if (own_box_records_) {
    action_ = TraversalAction::FetchNode;
  } else if (leaf_count == TraversalContext::kInstanceLeaf) {
    enter_instance(node, target);
  } else if (leaf_count > 0) {
    // The leaf's range came with its parent's record: straight to IST.
    leaf_slot_ = target;
    leaf_count_ = leaf_count;
    leaf_cursor_ = 0;
    action_ = TraversalAction::TestTriangles;
    prefetch(triangles_ + leaf_slot_, leaf_count_ * sizeof(PackedTriangle));
    prefetch(slot_addresses_ + leaf_slot_, leaf_count_ * sizeof(uint64_t));
  } else {
    current_record_ = target;
    action_ = TraversalAction::FetchNode;
    // The block's size, not its child count: reading that now would wait for it.
    prefetch(block(current_record_), block_bytes_);
  }
}

void RayTraversal::enter_instance(uint32_t node, uint32_t instance) {
  current_node_ = node;
  instance_ = instance;
  action_ = TraversalAction::Transform;
}

void RayTraversal::process_transform() {
  ++counters_.xfm_ops;
  counters_.instance_bytes += MemoryImage::kInstanceRecordBytes;
  const TraversalContext::InstancePlacement& p = context_->instance(instance_);
  set_ray_space(p.linear * ray_.origin + p.offset, p.linear * ray_.direction);
  in_blas_ = true;
  blas_stack_base_ = depth_;
  current_node_ = p.root_node;
  current_record_ = p.root_record;
  action_ = TraversalAction::FetchNode;
  if (!own_box_records_) prefetch(block(current_record_), block_bytes_);
}

void RayTraversal::leave_instance() {
  set_ray_space(ray_.origin, ray_.direction);
  in_blas_ = false;
  instance_ = kNoInstance;
}

void RayTraversal::pop_next() {
  for (;;) {
    // The BLAS's entries are all popped: back in the TLAS, with the world ray.
    if (in_blas_ && depth_ <= blas_stack_base_) leave_instance();
    if (depth_ == 0) break;
    const StackEntry entry = stack_[--depth_];
    if (depth_ >= stack_limit_) {
      // A spilled entry comes back to the bottom of the on-chip part.
      ++counters_.stack_refills;
      stack_accesses_.push_back({spill_address(depth_ - stack_limit_),
                                 context_->config().stack_entry_bytes, AccessKind::Stack, false});
    }
    // Closest-hit: a subtree entered beyond the closest hit cannot hold a nearer one.
    if (entry.tnear > tfar_) continue;
    enter(entry.node, entry.target, entry.leaf_count);
    return;
  }
  action_ = TraversalAction::Done;
}

void RayTraversal::process() {
  stack_accesses_.clear();
  last_tests_ = last_box_tests_ = 0;
  if (action_ == TraversalAction::FetchNode) process_node();
  else if (action_ == TraversalAction::TestTriangles) process_triangles();
  else if (action_ == TraversalAction::AlphaTest) process_alpha_test();
  else if (action_ == TraversalAction::Transform) process_transform();
}

void RayTraversal::process_node() {
  ++counters_.trv_ops;
  ++counters_.node_fetches;
  counters_.node_bytes += node_bytes_;
  if (!in_blas_ && two_level_) {
    ++counters_.tlas_trv_ops;
    ++counters_.tlas_node_fetches;
    counters_.tlas_node_bytes += node_bytes_;
  }
  if (own_box_records_)
    process_own_box_node();
  else
    process_child_boxes_node();
}

void RayTraversal::process_child_boxes_node() {
  const unsigned char* record = block(current_record_);
  const uint32_t children = head(current_record_).children;
  if (children == 0) {  // only a root that is a leaf is ever fetched as a node
    enter_leaf(current_node_);
    return;
  }
  // The child boxes as the record decodes them (quantized formats: conservative).
  const unsigned char* boxes = record + sizeof(TraversalContext::RecordHead);
  const auto* targets = reinterpret_cast<const TraversalContext::ChildTarget*>(record + targets_offset_);
  float t_entry[(kMaxBvhWidth + 3) / 4 * 4];
  uint32_t hit_mask = 0;
  if (pair_records_) {
    hit_mask = intersect_box_lanes(box_ray_, *reinterpret_cast<const BoxPairLanes*>(boxes), ray_.tmin, tfar_, t_entry);
  } else {
    const auto* quads = reinterpret_cast<const BoxQuadLanes*>(boxes);
    for (uint32_t k = 0; k < children; k += 4)
      hit_mask |= intersect_box_lanes(box_ray_, quads[k / 4], ray_.tmin, tfar_, &t_entry[k]) << k;
  }
  hit_mask &= (1u << children) - 1;  // a count that is no multiple of 4 leaves unused lanes
  counters_.box_tests += children;
  last_box_tests_ = children;
  if (hit_mask == 0) {
    pop_next();
    return;
  }
  // The hit children by entry distance, equal distances in child order (so the
  // order is fixed). One or two hits, the common cases, take no sort.
  const uint32_t first = uint32_t(__builtin_ctz(hit_mask));
  const uint32_t others = hit_mask & (hit_mask - 1);
  if (others == 0) {
    const TraversalContext::ChildTarget& only = targets[first];
    enter(only.node, only.target, only.leaf_count);
    return;
  }
  if ((others & (others - 1)) == 0) {
    const uint32_t second = uint32_t(__builtin_ctz(others));
    const bool second_nearer = t_entry[first] > t_entry[second];
    const uint32_t near = second_nearer ? second : first, far = second_nearer ? first : second;
    const TraversalContext::ChildTarget& later = targets[far];
    push(later.node, later.target, later.leaf_count, t_entry[far]);
    const TraversalContext::ChildTarget& next = targets[near];
    enter(next.node, next.target, next.leaf_count);
    return;
  }
  // Three or more: insertion by distance, as indices (the entries are built only
  // where they are stored).
  uint32_t order[kMaxBvhWidth];
  uint32_t hit_count = 0;
  for (; hit_mask; hit_mask &= hit_mask - 1) {
    const uint32_t k = uint32_t(__builtin_ctz(hit_mask));
    const float t = t_entry[k];
    uint32_t* at = order + hit_count++;
    for (; at != order && t_entry[at[-1]] > t; --at) at[0] = at[-1];
    *at = k;
  }
  // Nearest child next; the others pushed farthest first, so they pop nearest first.
  for (uint32_t h = hit_count; h-- > 1;) {
    const TraversalContext::ChildTarget& c = targets[order[h]];
    push(c.node, c.target, c.leaf_count, t_entry[order[h]]);
  }
  const TraversalContext::ChildTarget& nearest = targets[order[0]];
  enter(nearest.node, nearest.target, nearest.leaf_count);
}

void RayTraversal::process_own_box_node() {
  const BvhNode& n = nodes_[current_node_];
  float t_entry = 0.0f;
  ++counters_.box_tests;
  last_box_tests_ = 1;
  if (!intersect_box(box_ray_.scalar, context_->image().record_boxes(current_node_)[0], ray_.tmin,
                     tfar_, &t_entry)) {
    pop_next();
    return;
  }
  if (n.is_leaf()) {
    enter_leaf(current_node_);
    return;
  }
  // No child boxes in this record: order the children by the ray's direction
  // along the node's longest axis (builders put the lower half first).
  const vec3 extent = n.bounds.extent();
  const int axis = extent.x > extent.y ? (extent.x > extent.z ? 0 : 2) : (extent.y > extent.z ? 1 : 2);
  const bool reversed = direction_[axis] < 0.0f;
  const uint32_t first = reversed ? n.index + 1 : n.index;
  const uint32_t second = reversed ? n.index : n.index + 1;
  push(second, 0, 0, t_entry);
  current_node_ = first;
  action_ = TraversalAction::FetchNode;
}

void RayTraversal::commit(float t, uint32_t slot, float u, float v) {
  hit_.t = t;
  hit_.prim = context_->image().slot_triangle(slot);
  hit_.u = u;
  hit_.v = v;
  hit_.instance = instance_;
  tfar_ = t;
}

void RayTraversal::process_triangles() {
  const MemoryImage& image = context_->image();
  if (leaf_cursor_ == 0 && image.indexed()) {
    ++counters_.prim_ref_fetches;
    counters_.prim_ref_bytes += leaf_count_ * 4u;
  }
  const uint32_t end = std::min(leaf_count_, leaf_cursor_ + triangles_per_step_);
  counters_.triangle_fetches += end - leaf_cursor_;
  counters_.triangle_bytes += (end - leaf_cursor_) * image.triangle_bytes();
  candidates_.clear();
  bool committed = false;
  // The triangles are tested four lanes at a time and their verdicts taken in
  // memory order, each against the closest hit so far, as if one by one: a lane
  // that needs a step in double takes the scalar test (which counts it).
  while (leaf_cursor_ < end) {
    const uint32_t first = leaf_slot_ + leaf_cursor_;
    const uint32_t count = std::min(4u, end - leaf_cursor_);
    const TriangleQuadVerdict lanes =
        intersect_triangle_quad(tri_lanes_, reinterpret_cast<const float*>(triangles_ + first), ray_.tmin, tfar_);
    if (((lanes.hit | lanes.exact) & ((1u << count) - 1)) == 0) {
      // No lane hits or needs the scalar test (the common case): all missed.
      counters_.ist_ops += count;
      last_tests_ += count;
      leaf_cursor_ += count;
      continue;
    }
    for (uint32_t lane = 0; lane < count; ++lane, ++leaf_cursor_) {
      ++counters_.ist_ops;
      ++last_tests_;
      const uint32_t slot = first + lane;
      const uint32_t bit = 1u << lane;
      TriangleHit th{lanes.t[lane], lanes.u[lane], lanes.v[lane]};
      bool hit = (lanes.hit & bit) && th.t <= tfar_;
      if (lanes.exact & bit) {
        const PackedTriangle& tri = triangles_[slot];
        hit = intersect_triangle(tri_ray_, tri.v0, tri.v1, tri.v2, ray_.tmin, tfar_, &th,
                                 &counters_.ist_exact_steps);
      }
      if (!hit) continue;
      if (alpha_scene_ && context_->scene().alpha_tested(image.slot_triangle(slot))) {
        candidates_.push_back({th.t, th.u, th.v, slot});  // the any-hit stage decides
        continue;
      }
      commit(th.t, slot, th.u, th.v);
      committed = true;
      if (mode_ == TraversalMode::AnyHit) {
        candidates_.clear();
        action_ = TraversalAction::Done;
        return;
      }
    }
  }
  if (!candidates_.empty()) {
    // Only candidates nearer than the step's own opaque hits can matter (a tie goes
    // to the opaque hit); they are tested nearest first, so the first that passes
    // is the nearest surface among them. Equal distances keep memory order.
    const float limit = tfar_;
    candidates_.erase(std::remove_if(candidates_.begin(), candidates_.end(),
                                     [&](const Candidate& c) { return committed ? c.t >= limit : c.t > limit; }),
                      candidates_.end());
    std::stable_sort(candidates_.begin(), candidates_.end(),
                     [](const Candidate& a, const Candidate& b) { return a.t < b.t; });
    if (!candidates_.empty()) {
      test_candidate(0);
      return;
    }
  }
  if (leaf_cursor_ == leaf_count_) pop_next();
}

void RayTraversal::process_alpha_test() {
  const Candidate c = candidates_[candidate_];
  ++counters_.anyhit_tests;
  counters_.uv_bytes += MemoryImage::kUvRecordBytes;
  counters_.texel_bytes += MemoryImage::kTexelBytes;
  if (candidate_sample_.opaque) {
    commit(c.t, c.slot, c.u, c.v);
    candidates_.clear();  // every other one lies at or beyond it
    if (mode_ == TraversalMode::AnyHit) {
      action_ = TraversalAction::Done;
      return;
    }
  } else {
    ++counters_.anyhit_rejects;
    ++candidate_;
  }
  after_candidates();
}

void RayTraversal::test_candidate(uint32_t index) {
  const Candidate& c = candidates_[index];
  candidate_ = index;
  candidate_sample_ = context_->scene().alpha_sample(context_->image().slot_triangle(c.slot), c.u, c.v);
  action_ = TraversalAction::AlphaTest;
}

void RayTraversal::after_candidates() {
  if (candidate_ < candidates_.size()) {
    test_candidate(candidate_);
    return;
  }
  candidates_.clear();
  if (leaf_cursor_ < leaf_count_) action_ = TraversalAction::TestTriangles;
  else pop_next();
}

const HitRecord& trace_ray(RayTraversal& traversal, const Ray& ray, AccessSink* sink) {
  traversal.reset(ray);
  if (!sink) {
    while (!traversal.done()) traversal.process();
    return traversal.hit();
  }
  while (!traversal.done()) {
    for (const MemoryAccess& a : traversal.step_reads()) sink->on_access(a, ray.type);
    traversal.process();
    for (const MemoryAccess& a : traversal.stack_accesses()) sink->on_access(a, ray.type);
    sink->on_step_end();
  }
  return traversal.hit();
}

}  // namespace rtsim
