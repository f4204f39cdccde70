// median: object-median splits on the longest axis, the patent's plain "BVH"
// baseline (no cost model).
#include "builders.h"

#include "../median_builder.h"

namespace rtsim::builders {

Bvh build_median(const Scene& scene, const BuildParams& params, BuildReport& r) {
  const auto start = std::chrono::steady_clock::now();
  Bvh bvh = detail::build_median(scene, params.max_leaf_size);
  r.build_seconds = seconds_since(start);
  r.references = bvh.prim_refs.size();
  r.peak_memory_bytes = bvh.nodes.capacity() * sizeof(BvhNode) + scene.triangle_count() * (4 + 12);
  return bvh;
}

}  // namespace rtsim::builders
