// rdh: the ray-distribution heuristic (after Bittner and Havran 2009). Low-resolution
// sample rays of the workload itself (primary rays from the camera, AO rays from their
// hits; ray_samples.h) replace the area ratio by the fraction of sample rays that
// reach each candidate child, blended with k pseudo-rays spread by area, so that
// where no sample ray passes the tree is the SAH tree (weighted_sah_core.h).
// rdh-sbvh: the same rule with SBVH's spatial splits.
#include "builders.h"

#include <rtsim/builder/ray_samples.h>
#include <rtsim/workloads/embree_scene.h>

namespace rtsim::builders {

namespace {
Bvh build_ray_distribution(const Scene& scene, const BuildParams& params, BuildReport& r,
                           bool spatial_splits) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<const Camera*> cameras;
  if (params.rdh_cameras == "all") {
    for (const Camera& c : scene.cameras) cameras.push_back(&c);
  } else if (params.rdh_cameras == "camera") {
    cameras.push_back(&scene.camera(params.camera));
  }  // "none": no camera, AO rays from the whole surface (ray_samples.h)
  RaySampleParams sp;
  sp.resolution = params.rdh_resolution;
  sp.ao_rays = params.rdh_ao_rays;
  sp.ao_cutoff = ao_cutoff(scene, params);
  sp.seed = params.seed;
  RaySamples rays;
  if (sp.resolution > 0) {
    with_threads(params.threads, [&] {
      EmbreeScene embree(scene);
      rays = sample_rays(scene, embree, cameras, sp);
    });
  }
  r.rdh_rays = rays.size();
  r.estimate_seconds = seconds_since(start);
  detail::CoreConfig config = core_config(params);
  config.rays = &rays;
  config.rdh_prior = params.rdh_prior;
  config.spatial_splits = spatial_splits;
  Bvh bvh = run_core(scene, config, r);
  r.peak_memory_bytes += uint64_t(rays.size()) * 7 * sizeof(float);
  return bvh;
}
}  // namespace

Bvh build_rdh(const Scene& scene, const BuildParams& params, BuildReport& report) {
  return build_ray_distribution(scene, params, report, false);
}

Bvh build_rdh_sbvh(const Scene& scene, const BuildParams& params, BuildReport& report) {
  return build_ray_distribution(scene, params, report, true);
}

}  // namespace rtsim::builders
