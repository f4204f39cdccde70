// aobvh: the patent's AO-BVH. K Embree AO rays per triangle give each triangle an
// occlusion value (occlusion.h); its weight replaces the triangle count in the
// weighted core's cost. aosbvh: the same weights with SBVH's spatial splits, to ask
// whether the two reductions add up (the patent compares them, it does not combine
// them).
#include "builders.h"

#include <rtsim/builder/occlusion.h>
#include <rtsim/workloads/embree_scene.h>
#include <rtsim/workloads/error.h>

#include <cmath>

namespace rtsim::builders {

namespace {
Bvh build_occlusion_weighted(const Scene& scene, const BuildParams& params, BuildReport& r,
                             bool spatial_splits) {
  const size_t n = scene.triangle_count();
  const auto start = std::chrono::steady_clock::now();
  std::vector<float> values;
  if (!params.occlusion_values.empty()) {
    if (params.occlusion_values.size() != n)
      throw InputError("occlusion_values", "expected " + std::to_string(n) + " entries, got " +
                                               std::to_string(params.occlusion_values.size()));
    values = params.occlusion_values;
  } else {
    OcclusionParams ao;
    ao.rays = params.ao_rays;
    ao.share = params.ao_share;
    ao.cutoff = ao_cutoff(scene, params);
    ao.both_sides = params.ao_both_sides;
    ao.seed = params.seed;
    with_threads(params.threads, [&] {
      // Only hit distances are read, so Embree's fast build gives the same values.
      EmbreeScene embree(scene, EmbreeScene::Quality::fast);
      values = estimate_occlusion(scene, embree, ao, &r.ao_rays);
    });
  }
  r.weights = occlusion_weights(values, params.ao_weight_floor, &r.sanitised_values, params.ao_normalise);
  double sum = 0;
  for (float v : values) sum += usable_occlusion(v);
  r.mean_occlusion = sum / double(n);
  r.estimate_seconds = seconds_since(start);
  detail::CoreConfig config = core_config(params);
  config.weights = &r.weights;
  config.spatial_splits = spatial_splits;
  if (spatial_splits) config.treelet_passes = params.treelet_passes, config.treelet_leaves = params.treelet_leaves;
  return run_core(scene, config, r);
}
}  // namespace

Bvh build_aobvh(const Scene& scene, const BuildParams& params, BuildReport& report) {
  return build_occlusion_weighted(scene, params, report, false);
}

Bvh build_aosbvh(const Scene& scene, const BuildParams& params, BuildReport& report) {
  return build_occlusion_weighted(scene, params, report, true);
}

}  // namespace rtsim::builders
