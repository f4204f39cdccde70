#pragma once
// Lays a built BVH and the triangles it references out in the accelerator's
// external memory, so that every node and triangle fetch has a real byte address.
// The layout is decided here, from the tree alone: the input file's face order
// never reaches an address.
//
// Regions, each starting at its base and aligned to `region_alignment`:
//   nodes      one record per node that the format fetches on its own, in
//              `node_order` (formats whose records hold their children's boxes,
//              node_format.h: inner nodes only, so leaves take no node slot;
//              bvh2-32: every node). Formats with one child base pointer keep a
//              node's inner children adjacent: depth-first order then places a
//              node's children together and descends into them in turn.
//   instances  (two-level trees, instanced scenes) one 64-byte record per
//              instance: its world-to-object 3x4 transform (48 B), its BLAS's
//              root address (8 B), its index and mask (8 B) - the size of a DXR
//              instance descriptor. The TLAS's node records come first in
//              `nodes`, then each BLAS's, tree by tree.
//   prim_refs  (indexed storage) each leaf's list of 4-byte triangle record
//              indices, leaves in the same order as the node records
//   triangles  triangle records. Indexed: one record per triangle, placed where
//              the leaf order first reaches it. Inline: each leaf's records
//              contiguous, in leaf order, no prim refs (a triangle referenced by
//              several leaves, as SBVH does, is stored once per leaf).
//   uvs        (scenes with alpha-tested materials) one UV record per triangle
//              record, in the same order: three (s, t) pairs, 24 bytes
//   textures   the alpha textures in the scene's order, RGBA8 (4 bytes a
//              texel), row-major, each starting on a 64-byte line
// Within a leaf, triangles are ordered by their geometry
// (triangle_geometric_less), and the IST unit reads and tests them in that order.
//
// Every record is encoded in its format (encode_child_boxes) and the image keeps
// the boxes decoded from those bytes: the traversal tests what the hardware would
// read, quantization included.
#include <rtsim/builder/bvh.h>
#include <rtsim/builder/node_format.h>
#include <rtsim/workloads/scene.h>

#include <cstdint>
#include <string>
#include <vector>

namespace rtsim {

// Order of node records and of leaf data in memory.
enum class NodeOrder {
  DepthFirst,    // pre-order, first child's subtree before the second's (siblings
                 // adjacent first, for formats with one child base pointer)
  BreadthFirst,  // level by level
};

enum class TriangleStorage {
  Indexed,  // leaf -> prim-ref list -> triangle record (records shared between leaves)
  Inline,   // leaf -> its own contiguous triangle records
};

enum class TrianglePacking {
  Packed,  // records at a stride of triangle_bytes
  Line,    // a record that would cross a line_bytes boundary starts at the next line
};

struct MemoryLayoutConfig {
  std::string node_format = "bvh2-64";  // a name from node_formats()
  NodeOrder node_order = NodeOrder::DepthFirst;
  TriangleStorage triangle_storage = TriangleStorage::Indexed;
  TrianglePacking triangle_packing = TrianglePacking::Packed;
  uint32_t triangle_bytes = 36;  // 3 vertices x 3 floats; 48 or 64 with padding/precomputed data
  uint32_t line_bytes = 64;      // the line TrianglePacking::Line keeps records within
  uint64_t base_address = 0x1000'0000;
  uint64_t region_alignment = 4096;
};

// Bytes the image occupies, by region.
struct MemoryFootprint {
  uint64_t node_records = 0, node_bytes = 0;
  uint64_t prim_refs = 0, prim_ref_bytes = 0;
  uint64_t triangle_records = 0, triangle_bytes = 0;  // triangle bytes include packing padding
  uint64_t uv_bytes = 0, texture_bytes = 0;  // alpha testing only
  // Two-level trees: instance records, and how many node records are the TLAS's.
  uint64_t instance_records = 0, instance_bytes = 0, tlas_node_records = 0;
  uint64_t total_bytes() const {
    return node_bytes + instance_bytes + prim_ref_bytes + triangle_bytes + uv_bytes + texture_bytes;
  }
};

class MemoryImage {
 public:
  // Throws InputError ("memory.*") for a bad configuration, a tree the format
  // cannot hold (more children or leaf triangles than it has room for), or a
  // tree whose links are broken (a child before its parent, a leaf range past
  // prim_refs, a triangle index past the scene).
  MemoryImage(const Scene& scene, const Bvh& bvh, const MemoryLayoutConfig& config = {});

  const MemoryLayoutConfig& config() const { return config_; }
  const NodeFormat& format() const { return *format_; }
  uint32_t node_bytes() const { return format_->record_bytes; }
  uint32_t triangle_bytes() const { return config_.triangle_bytes; }
  bool indexed() const { return config_.triangle_storage == TriangleStorage::Indexed; }

  // The node's own record; only for nodes the format fetches (has_record).
  bool has_record(uint32_t node) const { return record_address_[node] != kNoRecord; }
  uint64_t node_address(uint32_t node) const { return record_address_[node]; }
  // Its place among the records, which are numbered in address order.
  uint32_t record_ordinal(uint32_t node) const { return record_ordinal_[node]; }
  uint64_t record_count() const { return footprint_.node_records; }
  // The boxes the node's record decodes to: its children's (child k is node
  // bvh.nodes[node].index + k), or for OwnBoxFp32 its own box. Only for has_record.
  const Aabb* record_boxes(uint32_t node) const {
    return &record_boxes_[size_t(record_ordinal_[node]) * boxes_per_record_];
  }

  // A leaf's triangles occupy slots [leaf_first(leaf), leaf_first(leaf) + count)
  // in memory order; slots are numbered in leaf order.
  uint32_t leaf_first(uint32_t leaf) const { return leaf_first_[leaf]; }
  uint32_t slot_count() const { return uint32_t(slot_triangle_.size()); }
  uint32_t slot_triangle(uint32_t slot) const { return slot_triangle_[slot]; }  // scene index
  uint64_t slot_address(uint32_t slot) const { return slot_address_[slot]; }     // its record
  const uint64_t* slot_addresses() const { return slot_address_.data(); }
  // Indexed storage: the leaf's prim-ref list (leaf size x 4 bytes).
  uint64_t prim_refs_address(uint32_t leaf) const { return prim_refs_base_ + uint64_t(leaf_first_[leaf]) * 4; }

  // Alpha testing (a scene with alpha textures; has_alpha_data()): the slot's
  // triangle's UV record, and texel (x, y) of alpha texture `texture`.
  static constexpr uint32_t kUvRecordBytes = 24, kTexelBytes = 4;
  bool has_alpha_data() const { return !slot_uv_address_.empty(); }
  uint64_t uv_address(uint32_t slot) const { return slot_uv_address_[slot]; }
  uint64_t texel_address(uint32_t texture, uint32_t x, uint32_t y) const {
    const TexturePlace& t = texture_[texture];
    return t.base + (uint64_t(y) * t.width + x) * kTexelBytes;
  }

  // Two-level trees (Bvh::two_level): instance i's record. A TLAS leaf's
  // leaf_first() is its instance; where each BLAS starts is the tree's (Bvh::blas_roots).
  static constexpr uint32_t kInstanceRecordBytes = 64;
  bool two_level() const { return footprint_.instance_records > 0; }
  uint64_t instance_address(uint32_t instance) const {
    return instances_base_ + uint64_t(instance) * kInstanceRecordBytes;
  }

  uint64_t nodes_base() const { return nodes_base_; }
  uint64_t prim_refs_base() const { return prim_refs_base_; }
  uint64_t triangles_base() const { return triangles_base_; }
  uint64_t end_address() const { return end_; }
  const MemoryFootprint& footprint() const { return footprint_; }
  std::string describe() const;  // one line per region: base, size

 private:
  void encode_records(const Bvh& bvh);
  static constexpr uint64_t kNoRecord = ~uint64_t(0);
  MemoryLayoutConfig config_;
  const NodeFormat* format_;
  uint32_t boxes_per_record_;
  uint64_t nodes_base_ = 0, prim_refs_base_ = 0, triangles_base_ = 0, end_ = 0;
  std::vector<uint64_t> record_address_;  // per node
  std::vector<uint32_t> record_ordinal_;  // per node with a record: its place in records
  std::vector<Aabb> record_boxes_;        // decoded, boxes_per_record_ per record
  std::vector<uint32_t> leaf_first_;      // per node (leaves only)
  std::vector<uint32_t> slot_triangle_;
  std::vector<uint64_t> slot_address_;
  std::vector<uint64_t> slot_uv_address_;  // alpha testing only
  struct TexturePlace {
    uint64_t base;
    uint32_t width;
  };
  std::vector<TexturePlace> texture_;
  uint64_t uvs_base_ = 0, textures_base_ = 0, instances_base_ = 0;
  MemoryFootprint footprint_;
};

}  // namespace rtsim
