#pragma once
// The one top-down weighted-SAH builder. SAH, OSAH, AO-BVH and SBVH are policies
// over it (see build.cpp):
//   - per-primitive weight w_i: the "triangle count" of a node is the sum of its
//     weights (SAH: all 1; AO-BVH: occlusion-derived weights, normalised to mean 1);
//   - child-probability rule: P_i = A_i / A (surface area), or for OSAH's visibility
//     split in mixed nodes (visible and hidden triangles) of the upper levels
//     P_i = w * V_i / V + (1 - w) * A_i / A, with its acceptance rule;
//   - optional spatial splits (SBVH) with reference unsplitting and a reference budget;
//   - optional sample rays (RDH, Bittner & Havran 2009): each node carries the
//     sample rays whose segment meets its box, and P_i = (A_i / A + n_i / k) /
//     (1 + n / k) for the n rays of the node, n_i of them meeting child box i, and
//     k = rdh_prior pseudo-rays distributed by surface area (n = 0: exactly the
//     SAH). Object and spatial candidates alike; reference unsplitting and the
//     SBVH root rebuild keep their surface-area costs.
// Split cost: 2*T1 + T2 * (P_L * W_L + P_R * W_R); leaf cost: T2 * W.
//
// Determinism: every reduction runs over fixed chunks in a fixed order, partitions
// are sequential per node, and node indices are assigned by a depth-first flatten
// after the (parallel) recursion. The tree is therefore bit-identical for any
// thread count. (And for any face order: build_bvh hands the triangles over in
// geometric order.)
#include <rtsim/builder/bvh.h>
#include <rtsim/builder/ray_samples.h>
#include <rtsim/workloads/scene.h>

#include <cstdint>
#include <vector>

namespace rtsim::detail {

struct CoreConfig {
  float t1 = 1.0f;
  float t2 = 1.0f;
  uint32_t max_leaf_size = 4;
  uint32_t max_depth = 64;
  uint32_t bins = 32;  // 0 = full sweep over sorted centroids
  uint32_t threads = 0;
  // Policy: per-triangle weights (sanitised, > 0 and finite), nullptr = all 1.
  const std::vector<float>* weights = nullptr;
  // Policy: per-triangle visibility (OSAH), nullptr = none. Vinkler, Havran and
  // Sochor's visibility split with P_i = osah_w * V_i / V + (1 - osah_w) * A_i / A in
  // mixed nodes at depth < visibility_depth, taken when its less-visible child is
  // the larger (visibility_any_split: always), SAH/SBVH elsewhere; visible_first
  // orders the children (choose_split in the .cpp).
  const std::vector<uint8_t>* visible = nullptr;
  float osah_w = 0.9f;
  uint32_t visibility_depth = 0;
  bool visibility_any_split = false;
  bool visible_first = false;
  // Policy: spatial splits (SBVH).
  bool spatial_splits = false;
  float sbvh_alpha = 1e-5f;
  uint32_t spatial_min_depth = 0;    // spatial splits only at depth >= this
  float reference_budget = 2.0f;     // total references <= budget * N
  uint32_t split_limit = 7;          // times one reference may be split again (max 7)
  // Policy: treelet restructuring after the build (treelet.h); 0 passes = none.
  uint32_t treelet_passes = 0;
  uint32_t treelet_leaves = 7;
  // Policy: sample rays (RDH), nullptr = none; rdh_prior = k pseudo-rays (> 0).
  const RaySamples* rays = nullptr;
  float rdh_prior = 8.0f;
};

struct CoreStats {
  uint64_t references = 0;      // prim_refs in the final tree
  uint64_t forced_splits = 0;   // nodes over max_leaf_size split although a leaf was cheaper
  uint64_t median_splits = 0;   // object/index-median fallbacks (no usable SAH split or depth limit)
  uint64_t visibility_splits = 0;  // OSAH (authors' rule): nodes given the visibility split
  uint64_t working_bytes = 0;   // peak bytes of the builder's own arrays
  uint64_t ray_node_pairs = 0;  // rdh: sample rays summed over the nodes they meet
  uint64_t treelets_restructured = 0;
};

// Throws InputError for an empty scene or parameters that cannot be met.
Bvh build_weighted_sah(const Scene& scene, const CoreConfig& config, CoreStats* stats = nullptr);

// Depth levels needed below a node of n references so that leaves hold at most
// max_leaf references (balanced splits).
uint32_t levels_needed(uint64_t n, uint32_t max_leaf);

}  // namespace rtsim::detail
