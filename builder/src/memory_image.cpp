#include <rtsim/builder/memory_image.h>
#include <rtsim/workloads/error.h>

#include <algorithm>
#include <cstdio>
#include <deque>

namespace rtsim {

namespace {
uint64_t align_up(uint64_t value, uint64_t alignment) {
  return alignment == 0 ? value : (value + alignment - 1) / alignment * alignment;
}
bool is_power_of_two(uint64_t v) { return v != 0 && (v & (v - 1)) == 0; }

// Nodes in the configured order. Children always follow their parent in the
// flat array (checked), so no walk can loop.
// A two-level tree: the TLAS's nodes, then each BLAS's (by mesh), each tree in this order.
void node_order(const Bvh& bvh, uint32_t root, NodeOrder order, bool siblings_adjacent,
                std::vector<uint32_t>& out) {
  if (order == NodeOrder::DepthFirst && !siblings_adjacent) {
    std::vector<uint32_t> stack{root};
    while (!stack.empty()) {
      const uint32_t n = stack.back();
      stack.pop_back();
      out.push_back(n);
      const BvhNode& node = bvh.nodes[n];
      for (uint32_t c = node.index + node.children; c-- > node.index;) stack.push_back(c);
    }
  } else if (order == NodeOrder::DepthFirst) {
    // A node's children together, then each child's family in turn.
    out.push_back(root);
    std::vector<uint32_t> stack{root};
    while (!stack.empty()) {
      const uint32_t n = stack.back();
      stack.pop_back();
      const BvhNode& node = bvh.nodes[n];
      for (uint32_t c = node.index; c < node.index + node.children; ++c) out.push_back(c);
      for (uint32_t c = node.index + node.children; c-- > node.index;) stack.push_back(c);
    }
  } else {
    std::deque<uint32_t> queue{root};
    while (!queue.empty()) {
      const uint32_t n = queue.front();
      queue.pop_front();
      out.push_back(n);
      const BvhNode& node = bvh.nodes[n];
      for (uint32_t c = node.index; c < node.index + node.children; ++c) queue.push_back(c);
    }
  }
}

std::vector<uint32_t> node_order(const Bvh& bvh, NodeOrder order, bool siblings_adjacent) {
  std::vector<uint32_t> out;
  out.reserve(bvh.nodes.size());
  node_order(bvh, 0, order, siblings_adjacent, out);
  for (uint32_t root : bvh.blas_roots)
    if (root != Bvh::kNoBlas) node_order(bvh, root, order, siblings_adjacent, out);
  return out;
}
}  // namespace

MemoryImage::MemoryImage(const Scene& scene, const Bvh& bvh, const MemoryLayoutConfig& config)
    : config_(config), format_(&node_format(config.node_format)),
      boxes_per_record_(format_->encoding == BoxEncoding::OwnBoxFp32 ? 1 : format_->width) {
  if (config_.triangle_bytes < 36)
    throw InputError("memory.triangle_bytes", "must be at least 36 (three float3 vertices)");
  if (config_.triangle_packing == TrianglePacking::Line &&
      (!is_power_of_two(config_.line_bytes) || config_.line_bytes < config_.triangle_bytes))
    throw InputError("memory.triangle_packing",
                     "'line' needs a power-of-two line of at least memory.triangle_bytes (" +
                         std::to_string(config_.triangle_bytes) + " B), got " +
                         std::to_string(config_.line_bytes));
  const size_t node_count = bvh.nodes.size();
  const size_t tri_count = scene.triangle_count();
  for (size_t i = 0; i < node_count; ++i) {
    const BvhNode& n = bvh.nodes[i];
    if (n.is_leaf()) {
      if (uint64_t(n.index) + n.count > bvh.prim_refs.size())
        throw InputError("bvh: node " + std::to_string(i), "leaf prim range past the end of prim_refs");
      if (n.count > format_->max_leaf_triangles)
        throw InputError("memory.node_format",
                         format_->name + " leaves hold at most " +
                             std::to_string(format_->max_leaf_triangles) + " triangles; node " +
                             std::to_string(i) + " holds " + std::to_string(n.count) +
                             " (build with --max-leaf-size " +
                             std::to_string(format_->max_leaf_triangles) + " or less)");
    } else if (n.children < 2 || n.index <= i || uint64_t(n.index) + n.children > node_count) {
      throw InputError("bvh: node " + std::to_string(i),
                       "inner node's children must follow it and exist");
    } else if (n.children > format_->width) {
      throw InputError("memory.node_format",
                       format_->name + " holds " + std::to_string(format_->width) +
                           " children per node; node " + std::to_string(i) + " has " +
                           std::to_string(n.children) + " (build the tree for this format)");
    }
  }
  // A two-level tree's TLAS leaves hold instances; its BLAS roots start trees.
  std::vector<uint8_t> instance_ref(bvh.two_level() ? bvh.prim_refs.size() : 0, 0);
  std::vector<uint8_t> is_root(node_count, 0);
  if (node_count) is_root[0] = 1;
  if (bvh.two_level()) {
    if (bvh.tlas_nodes == 0 || bvh.tlas_nodes > node_count || bvh.blas_roots.size() != scene.meshes.size())
      throw InputError("bvh", "a two-level tree whose TLAS or BLAS roots do not fit the scene's meshes");
    for (uint32_t n = 0; n < bvh.tlas_nodes; ++n) {
      const BvhNode& node = bvh.nodes[n];
      if (!node.is_leaf()) continue;
      for (uint32_t k = node.index; k < node.index + node.count; ++k) {
        instance_ref[k] = 1;
        if (bvh.prim_refs[k] >= scene.instances.size() ||
            bvh.blas_roots[scene.instances[bvh.prim_refs[k]].mesh] == Bvh::kNoBlas)
          throw InputError("bvh: prim_ref " + std::to_string(k), "TLAS leaf names no placed instance");
      }
    }
    for (uint32_t root : bvh.blas_roots) {
      if (root == Bvh::kNoBlas) continue;
      if (root < bvh.tlas_nodes || root >= node_count)
        throw InputError("bvh", "BLAS root " + std::to_string(root) + " lies outside the BLAS nodes");
      is_root[root] = 1;
    }
  }
  for (size_t r = 0; r < bvh.prim_refs.size(); ++r)
    if (!(bvh.two_level() && instance_ref[r]) && bvh.prim_refs[r] >= tri_count)
      throw InputError("bvh: prim_ref " + std::to_string(r), "triangle index out of range");

  record_address_.assign(node_count, kNoRecord);
  record_ordinal_.assign(node_count, ~0u);
  leaf_first_.assign(node_count, 0);
  nodes_base_ = align_up(config_.base_address, config_.region_alignment);
  if (node_count == 0) {
    prim_refs_base_ = triangles_base_ = end_ = nodes_base_;
    return;
  }
  const std::vector<uint32_t> order =
      node_order(bvh, config_.node_order, format_->contiguous_children);

  // Node records: a record that holds its children's boxes makes leaves part of
  // their parent's record, so only inner nodes (and a root that is a leaf) are
  // fetched on their own.
  const uint32_t node_bytes = format_->record_bytes;
  uint64_t records = 0;
  for (uint32_t n : order) {
    const bool own_record = !format_->leaves_in_parent || !bvh.nodes[n].is_leaf() || is_root[n];
    if (!own_record) continue;
    record_ordinal_[n] = uint32_t(records);
    record_address_[n] = nodes_base_ + records++ * node_bytes;
  }
  encode_records(bvh);

  // Instance records (two-level trees) after the nodes, one per instance in the
  // scene's order; a TLAS leaf's leaf_first is its instance.
  const uint64_t nodes_end = nodes_base_ + records * node_bytes;
  uint64_t instances_end = nodes_end;
  if (bvh.two_level()) {
    instances_base_ = align_up(nodes_end, config_.region_alignment);
    instances_end = instances_base_ + scene.instances.size() * kInstanceRecordBytes;
    footprint_.instance_records = scene.instances.size();
    footprint_.instance_bytes = scene.instances.size() * kInstanceRecordBytes;
    for (uint32_t n = 0; n < bvh.tlas_nodes; ++n) {
      if (bvh.nodes[n].is_leaf()) leaf_first_[n] = bvh.prim_refs[bvh.nodes[n].index];
      if (has_record(n)) ++footprint_.tlas_node_records;
    }
  }
  // Leaf slots in the same order; a leaf's triangles sorted by geometry.
  for (uint32_t n : order) {
    const BvhNode& node = bvh.nodes[n];
    if (!node.is_leaf() || bvh.is_instance_leaf(n)) continue;
    leaf_first_[n] = uint32_t(slot_triangle_.size());
    const auto begin = slot_triangle_.size();
    slot_triangle_.insert(slot_triangle_.end(), bvh.prim_refs.begin() + node.index,
                          bvh.prim_refs.begin() + node.index + node.count);
    std::sort(slot_triangle_.begin() + begin, slot_triangle_.end(),
              [&](uint32_t a, uint32_t b) { return triangle_geometric_less(scene, a, b); });
  }
  const uint64_t slots = slot_triangle_.size();
  prim_refs_base_ = align_up(instances_end, config_.region_alignment);
  const uint64_t prim_ref_bytes = indexed() ? slots * 4 : 0;
  triangles_base_ = align_up(prim_refs_base_ + prim_ref_bytes, config_.region_alignment);

  // Triangle records: one per triangle (indexed, where the leaf order first
  // reaches it) or one per slot (inline).
  uint64_t cursor = triangles_base_, triangle_records = 0;
  std::vector<uint64_t> record_number;  // of each slot's record, for its UV record
  const auto place = [&]() {
    const uint64_t line = config_.line_bytes;
    if (config_.triangle_packing == TrianglePacking::Line &&
        cursor / line != (cursor + config_.triangle_bytes - 1) / line)
      cursor = align_up(cursor, line);
    const uint64_t at = cursor;
    cursor += config_.triangle_bytes;
    ++triangle_records;
    return at;
  };
  slot_address_.resize(slots);
  record_number.resize(slots);
  if (indexed()) {
    std::vector<uint64_t> record_of(tri_count, kNoRecord), number_of(tri_count, 0);
    for (uint64_t s = 0; s < slots; ++s) {
      const uint32_t t = slot_triangle_[s];
      if (record_of[t] == kNoRecord) number_of[t] = triangle_records, record_of[t] = place();
      slot_address_[s] = record_of[t];
      record_number[s] = number_of[t];
    }
  } else {
    for (uint64_t s = 0; s < slots; ++s) record_number[s] = triangle_records, slot_address_[s] = place();
  }
  end_ = cursor;
  // Alpha testing: the any-hit stage reads a triangle's texture coordinates (one
  // UV record per triangle record, in the same order) and a texel of its texture.
  const uint64_t triangles_end = end_;
  if (!scene.alpha_textures.empty()) {
    uvs_base_ = align_up(end_, config_.region_alignment);
    slot_uv_address_.resize(slots);
    for (uint64_t s = 0; s < slots; ++s) slot_uv_address_[s] = uvs_base_ + record_number[s] * kUvRecordBytes;
    textures_base_ = align_up(uvs_base_ + triangle_records * kUvRecordBytes, config_.region_alignment);
    uint64_t at = textures_base_;
    for (const AlphaTexture& t : scene.alpha_textures) {
      texture_.push_back({at, t.width});
      at = align_up(at + uint64_t(t.width) * t.height * kTexelBytes, 64);
    }
    footprint_.uv_bytes = triangle_records * kUvRecordBytes;
    footprint_.texture_bytes = at - textures_base_;
    end_ = at;
  }
  footprint_.node_records = records;
  footprint_.node_bytes = records * node_bytes;
  footprint_.prim_refs = indexed() ? slots : 0;
  footprint_.prim_ref_bytes = prim_ref_bytes;
  footprint_.triangle_records = triangle_records;
  footprint_.triangle_bytes = triangles_end - triangles_base_;
}

void MemoryImage::encode_records(const Bvh& bvh) {
  // Each record goes through its format's bytes; the image keeps what they decode to.
  std::vector<uint8_t> bytes(format_->record_bytes);
  size_t records = 0;
  for (uint32_t o : record_ordinal_) records += o != ~0u;
  record_boxes_.assign(records * boxes_per_record_, Aabb{});
  Aabb exact[kMaxBvhWidth];
  for (size_t n = 0; n < bvh.nodes.size(); ++n) {
    if (record_ordinal_[n] == ~0u) continue;
    const BvhNode& node = bvh.nodes[n];
    uint32_t count = 1;
    if (format_->encoding == BoxEncoding::OwnBoxFp32) {
      exact[0] = node.bounds;
    } else if (node.is_leaf()) {
      continue;  // a root leaf: its record holds only the leaf's range
    } else {
      count = node.children;
      for (uint32_t k = 0; k < count; ++k) exact[k] = bvh.nodes[node.index + k].bounds;
    }
    encode_child_boxes(*format_, exact, count, bytes.data());
    decode_child_boxes(*format_, bytes.data(), count,
                       &record_boxes_[size_t(record_ordinal_[n]) * boxes_per_record_]);
  }
}

std::string MemoryImage::describe() const {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "nodes      0x%010llx  %llu B (%llu records of %u B)\n"
                "prim_refs  0x%010llx  %llu B\n"
                "triangles  0x%010llx  %llu B (%llu records of %u B)\n",
                (unsigned long long)nodes_base_, (unsigned long long)footprint_.node_bytes,
                (unsigned long long)footprint_.node_records, format_->record_bytes,
                (unsigned long long)prim_refs_base_, (unsigned long long)footprint_.prim_ref_bytes,
                (unsigned long long)triangles_base_, (unsigned long long)footprint_.triangle_bytes,
                (unsigned long long)footprint_.triangle_records, config_.triangle_bytes);
  std::string out = buf;
  if (footprint_.instance_records) {
    std::snprintf(buf, sizeof buf,
                  "instances  0x%010llx  %llu B (%llu records of %u B; %llu of the node records are the TLAS's)\n",
                  (unsigned long long)instances_base_, (unsigned long long)footprint_.instance_bytes,
                  (unsigned long long)footprint_.instance_records, kInstanceRecordBytes,
                  (unsigned long long)footprint_.tlas_node_records);
    out += buf;
  }
  if (footprint_.uv_bytes) {
    std::snprintf(buf, sizeof buf,
                  "uvs        0x%010llx  %llu B (%u B per triangle record)\n"
                  "textures   0x%010llx  %llu B (%zu alpha textures, %u B per texel)\n",
                  (unsigned long long)uvs_base_, (unsigned long long)footprint_.uv_bytes, kUvRecordBytes,
                  (unsigned long long)textures_base_, (unsigned long long)footprint_.texture_bytes,
                  texture_.size(), kTexelBytes);
    out += buf;
  }
  return out;
}

}  // namespace rtsim
