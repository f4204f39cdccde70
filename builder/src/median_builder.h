#pragma once
#include <rtsim/builder/bvh.h>
#include <rtsim/workloads/scene.h>

namespace rtsim::detail {
// Object-median BVH; depth is ceil(log2(N / max_leaf_size)).
Bvh build_median(const Scene& scene, uint32_t max_leaf_size);
}  // namespace rtsim::detail
