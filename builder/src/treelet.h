#pragma once
// Treelet restructuring (after Karras and Aila 2013): a post-pass over a binary
// tree that, at every inner node, takes the treelet of its up to `leaves` largest
// descendants and rebuilds the inner nodes above them in the topology of least SAH
// cost (exhaustively, by dynamic programming over subsets). The greedy top-down
// builder fixes each split before it sees the ones below; this lets a later, better
// grouping replace it. A treelet is only rebuilt when no taller than before (SAH
// alone grows chains that rays pay for). Treelet leaves that are tree leaves may
// also merge into one leaf of at most max_leaf_size triangles when that is
// cheaper; no reference is added or lost.
//
// Cost: the same as metrics' sah_cost (inner node 2*T1 x area, leaf T2 x summed
// weight x area). Deterministic: a treelet only touches its root's subtree, and the
// two subtrees of a node are done (in parallel) before the node, so the result does
// not depend on the thread count.
#include <rtsim/builder/bvh.h>

#include <cstdint>
#include <vector>

namespace rtsim::detail {

struct TreeletConfig {
  float t1 = 1.0f;
  float t2 = 1.0f;
  uint32_t leaves = 7;       // treelet size, 3..8
  uint32_t passes = 2;       // bottom-up passes over the tree
  uint32_t max_leaf_size = 4;  // treelet leaves that fit together may become one leaf
  const std::vector<float>* weights = nullptr;  // per triangle; nullptr = all 1
};

struct TreeletStats {
  uint64_t restructured = 0;  // treelets rebuilt, over all passes
};

// `bvh` must be binary and depth-first flattened (every builder's output). Returns
// it depth-first flattened again.
Bvh restructure_treelets(const Bvh& bvh, const TreeletConfig& config, TreeletStats* stats = nullptr);

}  // namespace rtsim::detail
