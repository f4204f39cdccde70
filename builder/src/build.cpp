// build_bvh: the builder named in the parameters, from the registry
// (builder_registry.cpp), then the collapse pass for wide node formats.
#include <rtsim/builder/build.h>
#include <rtsim/builder/builder_registry.h>
#include <rtsim/builder/collapse.h>
#include <rtsim/workloads/error.h>

#include "builders/builders.h"

#include <chrono>

namespace rtsim {

std::vector<std::string> builder_names() {
  std::vector<std::string> names;
  for (const BuilderInfo& b : builder_registry()) names.push_back(b.name);
  return names;
}

void apply_node_format(BuildParams& params, const NodeFormat& format) {
  params.width = format.encoding == BoxEncoding::OwnBoxFp32 ? 2 : format.width;
  params.max_leaf_size = std::min(params.max_leaf_size, format.max_leaf_triangles);
}

BvhLimits limits_for(const BuildParams& params) {
  const BuilderInfo& info = builder_info(params.builder);
  BvhLimits limits;
  limits.max_leaf_size = params.max_leaf_size;
  limits.max_depth = params.max_depth;
  limits.max_width = params.width;
  limits.split_references = info.splits_references;
  limits.reference_budget =
      info.fixed_reference_budget > 0 ? info.fixed_reference_budget : params.sbvh_reference_budget;
  return limits;
}

Bvh build_bvh(const Scene& scene, const BuildParams& params, BuildReport* report) {
  check_build_params(params);
  const BuilderInfo& info = builder_info(params.builder);
  BuildReport local;
  BuildReport& r = report ? *report : local;
  r = BuildReport{};
  r.builder = params.builder;
  const size_t n = scene.triangle_count();
  if (n == 0) throw InputError("scene '" + scene.name + "'", "has no triangles to build a BVH over");
  if (detail::levels_needed(n, params.max_leaf_size) > params.max_depth)
    throw InputError("max_depth", "too small for " + std::to_string(n) +
                                      " triangles with max_leaf_size " +
                                      std::to_string(params.max_leaf_size));
  Bvh bvh = info.build(scene, params, r);
  if (params.width == 2 || info.builds_wide) return bvh;
  CollapseParams cp;
  cp.width = params.width;
  cp.max_leaf_size = params.max_leaf_size;
  cp.t1 = params.t1;
  cp.t2 = params.t2;
  cp.weights = r.weights;
  cp.visibility = r.visibility;
  cp.osah_w = params.osah_w;
  const auto start = std::chrono::steady_clock::now();
  r.binary_nodes = bvh.nodes.size();
  bvh = collapse_bvh(bvh, cp);
  r.collapse_seconds = builders::seconds_since(start);
  return bvh;
}

}  // namespace rtsim
