#pragma once
#include <rtsim/builder/bvh.h>
#include <rtsim/workloads/scene.h>

#include <cstdint>

namespace rtsim::detail {

struct EmbreeBuildConfig {
  bool spatial_splits = false;  // false: RTC_BUILD_QUALITY_MEDIUM; true: HIGH + splitPrimitive
  float t1 = 1.0f, t2 = 1.0f;
  uint32_t max_leaf_size = 4;
  uint32_t max_depth = 64;
  uint32_t threads = 0;
  uint32_t width = 2;  // maxBranchingFactor: Embree's own wide builder for 4 and 8
  double capacity_factor = 2.0;  // primitive array capacity, x N (room for split references)
};

struct EmbreeBuildStats {
  uint64_t working_bytes = 0;  // primitive array + node/leaf allocations
};

// Embree's rtcBuildBVH (the reference builder), converted into our Bvh.
Bvh build_with_embree(const Scene& scene, const EmbreeBuildConfig& config,
                      EmbreeBuildStats* stats = nullptr);

}  // namespace rtsim::detail
