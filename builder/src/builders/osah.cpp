// osah: the occlusion SAH of Vinkler, Havran and Sochor ("Visibility driven BVH
// build up for ray tracing", Computers & Graphics 36(4), 2012), the patent's OSAH
// comparison tree, with the rules their public builder applies (NTrace,
// OcclusionBVHBuilder): SBVH's spatial splits, a visibility split tried only in
// mixed nodes of the tree's upper levels and taken only when its hidden child is
// the larger, the more visible child first (weighted_sah_core.h, choose_split).
//
// Visibility: the triangles the camera's primary rays hit first, and those the AO
// rays from those hits reach (their renderer marks both; estimate_visibility).
#include "builders.h"

#include <rtsim/builder/occlusion.h>
#include <rtsim/workloads/embree_scene.h>
#include <rtsim/workloads/error.h>

#include <cmath>

namespace rtsim::builders {

namespace {
// The visibility the tree is built for: given by the caller, or cast.
void visibility_of(const Scene& scene, const BuildParams& params, BuildReport& r) {
  const size_t n = scene.triangle_count();
  if (!params.visibility.empty()) {
    if (params.visibility.size() != n)
      throw InputError("visibility", "expected " + std::to_string(n) + " entries, got " +
                                         std::to_string(params.visibility.size()));
    r.visibility.resize(n);
    for (size_t i = 0; i < n; ++i) r.visibility[i] = params.visibility[i] ? 1 : 0;
  } else {
    VisibilityParams vp;
    vp.width = params.osah_width;
    vp.height = params.osah_height;
    vp.ao_rays = scene.ao.enabled ? params.osah_ao_rays : 0;
    vp.ao_cutoff = ao_cutoff(scene, params);
    vp.seed = params.seed;
    const Camera& camera = scene.camera(params.camera);
    with_threads(params.threads, [&] {
      EmbreeScene embree(scene);
      r.visibility = estimate_visibility(scene, embree, camera, vp);
    });
  }
  for (uint8_t v : r.visibility) r.visible_triangles += v;
}
}  // namespace

Bvh build_osah(const Scene& scene, const BuildParams& params, BuildReport& r) {
  const auto start = std::chrono::steady_clock::now();
  visibility_of(scene, params, r);
  r.estimate_seconds = seconds_since(start);
  detail::CoreConfig config = core_config(params);
  config.visible = &r.visibility;
  // The upper levels: depth < fraction x log2(N) (the authors: half, truncated).
  const double levels = std::log2(double(std::max<size_t>(1, scene.triangle_count())));
  config.visibility_depth = uint32_t(std::max(0.0, std::floor(double(params.osah_depth) * levels)));
  config.visibility_any_split = params.osah_acceptance == "always";
  config.visible_first = params.osah_child_order == "visible-first";
  config.spatial_splits = params.osah_spatial;
  config.spatial_min_depth = config.visibility_depth;
  r.visibility_depth = config.visibility_depth;
  return run_core(scene, config, r);
}

}  // namespace rtsim::builders
