#pragma once
// A BVH of 2 to 8 children per node in a flat array. Node 0 is the root. An
// inner node's children sit next to each other at [index, index + children); a
// leaf's triangles are prim_refs[index .. index + count). Builders make binary
// trees; the collapse pass (collapse.h) makes wide ones. SBVH may reference a
// triangle from several leaves; every other builder references each exactly once.
#include <rtsim/workloads/geometry.h>

#include <cstdint>
#include <string>
#include <vector>

namespace rtsim {

struct BvhNode {
  Aabb bounds;
  uint32_t index = 0;  // inner: first child; leaf: first prim_ref
  uint32_t count = 0;  // 0 = inner node; > 0 = leaf with `count` triangles
  uint32_t children = 0;  // inner: 2..kMaxBvhWidth children; leaf: 0
  bool is_leaf() const { return count > 0; }
};

constexpr uint32_t kMaxBvhWidth = 8;

struct Bvh {
  std::vector<BvhNode> nodes;
  std::vector<uint32_t> prim_refs;  // triangle indices into the Scene
  // Two-level trees (an instanced scene, Scene::instances): nodes [0, tlas_nodes)
  // are the TLAS, a tree over the instances' world boxes whose leaves hold one
  // instance each (the leaf's prim_ref is the instance index). Mesh m's BLAS, over
  // its object-space triangles, starts at node blas_roots[m] (kNoBlas: a mesh
  // without triangles); its nodes follow the TLAS's in the same array, with
  // absolute child and prim_ref indices. Both empty for a one-level tree.
  static constexpr uint32_t kNoBlas = ~0u;
  uint32_t tlas_nodes = 0;
  std::vector<uint32_t> blas_roots;
  bool two_level() const { return !blas_roots.empty(); }
  bool is_instance_leaf(uint32_t node) const { return node < tlas_nodes && nodes[node].is_leaf(); }
  const BvhNode& root() const { return nodes.front(); }
  bool empty() const { return nodes.empty(); }
  uint32_t width() const;  // most children of any node (2 for a binary tree or a single leaf)
};

// Content hash of the tree (nodes and references): names a tree in result files.
uint64_t bvh_content_hash(const Bvh& bvh);

}  // namespace rtsim
