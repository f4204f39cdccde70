// embree, embree-sbvh: Embree's rtcBuildBVH (medium quality binned SAH; high quality
// with spatial splits) as the reference builders, converted into our Bvh. They
// build wide trees themselves (maxBranchingFactor).
#include "builders.h"

#include "../embree_builder.h"

namespace rtsim::builders {

namespace {
Bvh build_with_embree(const Scene& scene, const BuildParams& params, BuildReport& r,
                      bool spatial_splits) {
  detail::EmbreeBuildConfig ec;
  ec.spatial_splits = spatial_splits;
  ec.t1 = params.t1;
  ec.t2 = params.t2;
  ec.max_leaf_size = params.max_leaf_size;
  ec.max_depth = params.max_depth;
  ec.threads = params.threads;
  ec.width = params.width;
  detail::EmbreeBuildStats es;
  const auto start = std::chrono::steady_clock::now();
  Bvh bvh = detail::build_with_embree(scene, ec, &es);
  r.build_seconds = seconds_since(start);
  r.references = bvh.prim_refs.size();
  r.peak_memory_bytes = es.working_bytes;
  return bvh;
}
}  // namespace

Bvh build_embree(const Scene& scene, const BuildParams& params, BuildReport& report) {
  return build_with_embree(scene, params, report, false);
}

Bvh build_embree_sbvh(const Scene& scene, const BuildParams& params, BuildReport& report) {
  return build_with_embree(scene, params, report, true);
}

}  // namespace rtsim::builders
