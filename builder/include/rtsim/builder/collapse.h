#pragma once
// The collapse pass: turns a binary BVH into a BVH of up to `width` children per
// node, choosing which binary nodes to keep, which to dissolve into their parent
// and where to make leaves by dynamic programming over the binary tree (the
// SAH-optimal collapse of Ylitie, Karras and Laine, HPG 2017), with the cost
// model of the builder that made the binary tree:
//
//   cost = sum over wide inner nodes  r(n) * 2*T1       (one node visit = one TRV op)
//        + sum over wide leaves       r(l) * T2 * W(l)  (W: sum of the leaf's weights)
//
// r(n) is the probability that a ray reaching the root reaches binary node n, the
// product along its path of the child probabilities A(child)/A(parent). With
// weights (AO-BVH) W is the weight sum, so an AO-weighted tree stays AO-weighted
// when it is made wide; without, W is the triangle count and the cost is the SAH
// cost of metrics.h.
//
// For each binary node n and i = 1..width, C(n, i) is the least cost of covering
// n's subtree with at most i wide-tree slots (subtrees whose roots become children
// of the same wide node):
//   C(n, 1) = min(leaf(n), r(n) * 2*T1 + D(n, width))    leaf(n): n's triangles as one
//   C(n, i) = min(C(n, i-1), D(n, i))                     leaf, if they fit max_leaf_size
//   D(n, j) = min over k in 1..j-1 of C(left, k) + C(right, j-k)
// Deterministic: ties keep the first option in the order written.
#include <rtsim/builder/bvh.h>

#include <cstdint>
#include <vector>

namespace rtsim {

struct CollapseParams {
  uint32_t width = 4;          // 2..kMaxBvhWidth
  uint32_t max_leaf_size = 4;  // the node format's leaf capacity
  float t1 = 1.0f, t2 = 1.0f;
  // The builder's rule (empty = SAH): per-triangle leaf weights (aobvh, aosbvh).
  std::vector<float> weights;
};

struct CollapseReport {
  double cost = 0;  // the cost above (the tree's own probability rule), root = 1
  uint64_t binary_nodes = 0, wide_nodes = 0;
};

// Throws InputError("max_leaf_size", ...) when a binary leaf holds more
// triangles than max_leaf_size (build the binary tree with the format's limit),
// or ("width", ...) for a width outside 2..8. A single-leaf tree is returned as is.
Bvh collapse_bvh(const Bvh& binary, const CollapseParams& params, CollapseReport* report = nullptr);

}  // namespace rtsim
