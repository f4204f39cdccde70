#pragma once
// Lays a built BVH and the scene's triangles out in the accelerator's external
// memory, so that every node and triangle fetch has a real byte address.
//
// Regions, each starting at its base and aligned to `region_alignment`:
//   nodes      node i at nodes_base + i * node_bytes   (BVH2 64-byte: both child
//              boxes in the parent; single-box 32-byte: one box per node)
//   prim_refs  leaf triangle-index lists, 4 bytes each
//   triangles  triangle j (by scene index) at triangles_base + j * triangle_bytes
#include <rtsim/builder/bvh.h>

#include <cstdint>
#include <string>

namespace rtsim {

enum class NodeLayout {
  Bvh2Wide64,    // 64 bytes: child boxes of both children (6 x 2 floats x 2 = 48 B) + links
  SingleBox32,   // 32 bytes: own box (24 B) + link and count
};

struct MemoryLayoutConfig {
  NodeLayout node_layout = NodeLayout::Bvh2Wide64;
  uint32_t triangle_bytes = 36;  // 3 vertices x 3 floats; 48 with padding/precomputed data
  uint64_t base_address = 0x1000'0000;
  uint64_t region_alignment = 4096;
};

class MemoryImage {
 public:
  MemoryImage(const Bvh& bvh, size_t scene_triangle_count, const MemoryLayoutConfig& config = {});

  uint32_t node_bytes() const { return node_bytes_; }
  uint32_t triangle_bytes() const { return config_.triangle_bytes; }
  uint64_t node_address(uint32_t node) const { return nodes_base_ + uint64_t(node) * node_bytes_; }
  uint64_t prim_ref_address(uint32_t ref) const { return prim_refs_base_ + uint64_t(ref) * 4; }
  uint64_t triangle_address(uint32_t tri) const {
    return triangles_base_ + uint64_t(tri) * config_.triangle_bytes;
  }
  uint64_t nodes_base() const { return nodes_base_; }
  uint64_t prim_refs_base() const { return prim_refs_base_; }
  uint64_t triangles_base() const { return triangles_base_; }
  uint64_t end_address() const { return end_; }
  const MemoryLayoutConfig& config() const { return config_; }
  std::string describe() const;  // one line per region: base, size

 private:
  MemoryLayoutConfig config_;
  uint32_t node_bytes_;
  uint64_t nodes_base_, prim_refs_base_, triangles_base_, end_;
};

}  // namespace rtsim
