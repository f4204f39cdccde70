#pragma once
// Quality of a built tree, as the `rtsim build` report shows it.
//
// SAH cost (normalised by the root box area): the expected cost of a ray that hits
// the root box, cost(leaf) = T2 * count, cost(inner) = 2*T1 + sum_i P_i cost(child_i),
// P_i = A(child_i) / A(node), over the node's 2..8 children: a visit of a wide node
// is one TRV op and costs 2*T1 like a binary one (the hardware tests its child boxes
// together). Unrolled, this is
//   (sum_inner 2*T1*A(n) + sum_leaf T2*count(l)*A(l)) / A(root).
// (A node of zero area - all geometry on a line or point - counts P_i = 1, as in
// the builders.)
// Weighted cost: the same recursion with the builder's weights and probability
// rule (AO-BVH: weight sums) - the quantity that builder minimised. Equals the SAH
// cost for every other builder (OSAH's visibility split is a rule of where to
// split, not a cost it minimises over the tree).
// Two-level trees (Bvh::two_level): the same unrolled sum in world space, over the
// TLAS's inner nodes and every placement of every BLAS node (its object box placed
// by the instance, transformed_box), divided by the TLAS root's area - the cost of
// the tree the rays walk. The instance transform (XFM) is not a T1/T2 cost and is
// left out. Depths run from the TLAS root through the instance into its BLAS; the
// leaf counts are the BLASes' (each stored once); EPO is not computed.
// EPO (end-point overlap, Aila, Karras, Laine 2013): for every node n the area of
// the triangles NOT referenced below n that lie inside n's box, weighted by the
// node's cost c(n) (2*T1 for inner nodes, T2*count for leaves), summed and divided
// by the total triangle area. Triangles are clipped exactly against the box
// (Sutherland-Hodgman).
#include <rtsim/builder/build.h>
#include <rtsim/builder/bvh.h>
#include <rtsim/workloads/scene.h>

#include <cstdint>
#include <string>
#include <vector>

namespace rtsim {

struct BvhMetrics {
  std::string builder;
  double sah_cost = 0;
  double weighted_cost = 0;
  double epo = -1;  // < 0: not computed
  uint32_t width = 2;  // most children of a node
  uint64_t nodes = 0, inner_nodes = 0, leaves = 0;
  uint64_t references = 0, triangles = 0;
  std::vector<uint64_t> leaf_size_histogram;  // [k] = leaves holding k references
  uint32_t max_depth = 0;
  double average_leaf_depth = 0;
  double estimate_seconds = 0, build_seconds = 0, metrics_seconds = 0;
  uint64_t peak_memory_bytes = 0;
  uint64_t spatial_splits = 0, forced_splits = 0, median_splits = 0, sanitised_values = 0;
  uint64_t treelets_restructured = 0;
  // Two-level trees: instances (TLAS leaves), TLAS nodes, triangles as placed.
  uint64_t instances = 0, tlas_nodes = 0, placed_triangles = 0;
};

// weights empty = all 1.
double sah_cost(const Bvh& bvh, float t1, float t2, const std::vector<float>& weights = {});
// A two-level tree's world-space cost (above); `scene` is the instanced scene.
double two_level_sah_cost(const Bvh& bvh, const Scene& scene, float t1, float t2,
                          const std::vector<float>& weights = {});
double end_point_overlap(const Bvh& bvh, const Scene& scene, float t1, float t2);

// Inner nodes whose children share a triangle: where a spatial split sent parts of
// one triangle to two children (a triangle referenced by several leaves branches
// at exactly those nodes). Needs children after their parent (validated trees).
uint64_t count_spatial_splits(const Bvh& bvh);

BvhMetrics compute_metrics(const Bvh& bvh, const Scene& scene, const BuildParams& params,
                           const BuildReport& report, bool with_epo = true);

// One JSON object (field names as in BvhMetrics, units in the names).
std::string metrics_json(const BvhMetrics& m);

}  // namespace rtsim
