#pragma once
// A binary BVH (BVH2) in a flat array. Node 0 is the root. An inner node's two
// children sit next to each other at `index` and `index + 1`; a leaf's triangles
// are prim_refs[index .. index + count). SBVH may reference a triangle from
// several leaves; every other builder references each exactly once.
#include <rtsim/workloads/geometry.h>

#include <cstdint>
#include <string>
#include <vector>

namespace rtsim {

struct BvhNode {
  Aabb bounds;
  uint32_t index = 0;  // inner: first child; leaf: first prim_ref
  uint32_t count = 0;  // 0 = inner node; > 0 = leaf with `count` triangles
  bool is_leaf() const { return count > 0; }
};

struct Bvh {
  std::vector<BvhNode> nodes;
  std::vector<uint32_t> prim_refs;  // triangle indices into the Scene
  const BvhNode& root() const { return nodes.front(); }
  bool empty() const { return nodes.empty(); }
};

// Content hash of the tree (nodes and references): names a tree in result files.
uint64_t bvh_content_hash(const Bvh& bvh);

}  // namespace rtsim
