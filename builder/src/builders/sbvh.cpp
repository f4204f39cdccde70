// sbvh: SAH with spatial splits and reference unsplitting (Stich, Friedrich and
// Dietrich 2009) in the same core; the reference budget bounds the growth.
#include "builders.h"

namespace rtsim::builders {

Bvh build_sbvh(const Scene& scene, const BuildParams& params, BuildReport& report) {
  detail::CoreConfig config = core_config(params);
  config.spatial_splits = true;
  config.treelet_passes = params.treelet_passes;
  config.treelet_leaves = params.treelet_leaves;
  return run_core(scene, config, report);
}

}  // namespace rtsim::builders
