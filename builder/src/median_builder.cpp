// The object-median builder: a second plain-BVH baseline (the patent does not say
// which heuristic its comparative BVH used). Splits at the median centroid along
// the widest centroid axis until a node fits a leaf; no cost model at all.
#include "median_builder.h"

#include <algorithm>
#include <numeric>

namespace rtsim::detail {

namespace {
struct MedianBuilder {
  const Scene& scene;
  uint32_t max_leaf;
  std::vector<uint32_t> order;
  std::vector<vec3> centroids;
  Bvh bvh;

  // Builds the node at `node_index` over order[begin, begin+count).
  void build(uint32_t node_index, uint32_t begin, uint32_t count) {
    Aabb box, centre_box;
    for (uint32_t i = begin; i < begin + count; ++i) {
      box.extend(scene.triangle_bounds(order[i]));
      centre_box.extend(centroids[order[i]]);
    }
    bvh.nodes[node_index].bounds = box;
    if (count <= max_leaf) {
      bvh.nodes[node_index].index = begin;
      bvh.nodes[node_index].count = count;
      return;
    }
    const vec3 extent = centre_box.extent();
    int axis = 0;
    if (extent.y > extent[axis]) axis = 1;
    if (extent.z > extent[axis]) axis = 2;
    const uint32_t half = count / 2;
    auto first = order.begin() + begin;
    // Ties broken by geometry: the result does not depend on the face order.
    std::nth_element(first, first + half, first + count, [&](uint32_t a, uint32_t b) {
      const float ca = centroids[a][axis], cb = centroids[b][axis];
      return ca != cb ? ca < cb : triangle_geometric_less(scene, a, b);
    });
    const uint32_t child = uint32_t(bvh.nodes.size());
    bvh.nodes[node_index].index = child;
    bvh.nodes[node_index].count = 0;
    bvh.nodes[node_index].children = 2;
    bvh.nodes.emplace_back();
    bvh.nodes.emplace_back();
    build(child, begin, half);
    build(child + 1, begin + half, count - half);
  }
};
}  // namespace

Bvh build_median(const Scene& scene, uint32_t max_leaf_size) {
  const uint32_t n = uint32_t(scene.triangle_count());
  MedianBuilder b{scene, std::max<uint32_t>(1, max_leaf_size), {}, {}, {}};
  b.order.resize(n);
  std::iota(b.order.begin(), b.order.end(), 0u);
  b.centroids.resize(n);
  for (uint32_t i = 0; i < n; ++i) b.centroids[i] = scene.triangle_bounds(i).centre();
  b.bvh.nodes.reserve(2 * n);
  b.bvh.nodes.emplace_back();
  b.build(0, 0, n);
  b.bvh.prim_refs = std::move(b.order);
  return std::move(b.bvh);
}

}  // namespace rtsim::detail
