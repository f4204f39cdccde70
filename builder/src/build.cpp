// build_bvh: the builder named in the parameters, from the registry
// (builder_registry.cpp), then the collapse pass for wide node formats.
#include <rtsim/builder/build.h>
#include <rtsim/builder/builder_registry.h>
#include <rtsim/builder/collapse.h>
#include <rtsim/builder/metrics.h>
#include <rtsim/workloads/error.h>

#include "builders/builders.h"
#include "two_level.h"

#include <chrono>
#include <optional>

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

namespace {
// The scene with its triangles (and material ids) in geometric order: what every
// builder sees. Each sum, partition, tie and sample then follows the geometry, so
// the same geometry in another face order gives the same tree. `order[i]` is the
// scene's index of the ordered scene's triangle i.
struct OrderedScene {
  Scene scene;
  std::vector<uint32_t> order;
  explicit OrderedScene(const Scene& original) : scene(original), order(geometric_order(original)) {
    const bool materials = original.material_ids.size() == original.triangles.size();
    for (size_t i = 0; i < order.size(); ++i) {
      scene.triangles[i] = original.triangles[order[i]];
      if (materials) scene.material_ids[i] = original.material_ids[order[i]];
    }
  }
  // Per-triangle values indexed by the scene's order, in the ordered scene's, and back.
  template <class T>
  std::vector<T> to_ordered(const std::vector<T>& values) const {
    if (values.size() != order.size()) return values;  // the builder reports the mismatch
    std::vector<T> out(values.size());
    for (size_t i = 0; i < order.size(); ++i) out[i] = values[order[i]];
    return out;
  }
  template <class T>
  std::vector<T> to_original(const std::vector<T>& values) const {
    if (values.size() != order.size()) return values;
    std::vector<T> out(values.size());
    for (size_t i = 0; i < order.size(); ++i) out[order[i]] = values[i];
    return out;
  }
};
}  // namespace

Bvh build_bvh(const Scene& scene, const BuildParams& params, BuildReport* report) {
  check_build_params(params);
  const BuilderInfo& info = builder_info(params.builder);
  BuildReport local;
  BuildReport& r = report ? *report : local;
  r = BuildReport{};
  r.builder = params.builder;
  if (scene.instanced()) return detail::build_two_level(scene, params, r);
  const size_t n = scene.triangle_count();
  if (n == 0) throw InputError("scene '" + scene.name + "'", "has no triangles to build a BVH over");
  if (detail::levels_needed(n, params.max_leaf_size) > params.max_depth)
    throw InputError("max_depth", "too small for " + std::to_string(n) +
                                      " triangles with max_leaf_size " +
                                      std::to_string(params.max_leaf_size));
  const auto order_start = std::chrono::steady_clock::now();
  std::optional<OrderedScene> ordered_slot;
  builders::with_threads(params.threads, [&] { ordered_slot.emplace(scene); });
  const OrderedScene& ordered = *ordered_slot;
  BuildParams ordered_params = params;
  ordered_params.occlusion_values = ordered.to_ordered(params.occlusion_values);
  ordered_params.visibility = ordered.to_ordered(params.visibility);
  r.order_seconds = builders::seconds_since(order_start);
  Bvh bvh = info.build(ordered.scene, ordered_params, r);
  if (info.splits_references) r.spatial_splits = count_spatial_splits(bvh);
  if (params.width > 2 && !info.builds_wide) {
    CollapseParams cp;
    cp.width = params.width;
    cp.max_leaf_size = params.max_leaf_size;
    cp.t1 = params.t1;
    cp.t2 = params.t2;
    cp.weights = r.weights;
    const auto start = std::chrono::steady_clock::now();
    r.binary_nodes = bvh.nodes.size();
    bvh = collapse_bvh(bvh, cp);
    r.collapse_seconds = builders::seconds_since(start);
  }
  for (uint32_t& prim : bvh.prim_refs) prim = ordered.order[prim];
  r.weights = ordered.to_original(r.weights);
  r.visibility = ordered.to_original(r.visibility);
  return bvh;
}

}  // namespace rtsim
