// sah: the classic surface-area heuristic, the weighted core with all weights 1.
// Also the core helpers every weighted-SAH policy shares.
#include "builders.h"

namespace rtsim::builders {

detail::CoreConfig core_config(const BuildParams& p) {
  detail::CoreConfig c;
  c.t1 = p.t1;
  c.t2 = p.t2;
  c.max_leaf_size = p.max_leaf_size;
  c.max_depth = p.max_depth;
  c.bins = p.bins;
  c.threads = p.threads;
  c.osah_w = p.osah_w;
  c.sbvh_alpha = p.sbvh_alpha;
  c.spatial_min_depth = p.sbvh_min_depth;
  c.reference_budget = p.sbvh_reference_budget;
  c.split_limit = p.sbvh_split_limit;
  return c;
}

Bvh run_core(const Scene& scene, const detail::CoreConfig& config, BuildReport& report) {
  detail::CoreStats stats;
  const auto start = std::chrono::steady_clock::now();
  Bvh bvh = detail::build_weighted_sah(scene, config, &stats);
  report.build_seconds = seconds_since(start);
  report.references = stats.references;
  report.treelets_restructured = stats.treelets_restructured;
  report.forced_splits = stats.forced_splits;
  report.median_splits = stats.median_splits;
  report.visibility_splits = stats.visibility_splits;
  report.peak_memory_bytes = std::max<uint64_t>(report.peak_memory_bytes, stats.working_bytes);
  return bvh;
}

Bvh build_sah(const Scene& scene, const BuildParams& params, BuildReport& report) {
  return run_core(scene, core_config(params), report);
}

}  // namespace rtsim::builders
