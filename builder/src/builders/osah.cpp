// osah: the patent's "occlusion SAH" comparison tree. Triangles seen by the
// camera's primary rays (Embree) are "visible"; in nodes holding both visible and
// hidden triangles the child probability mixes the visible fraction into the area
// ratio (weighted_sah_core.h).
#include "builders.h"

#include <rtsim/builder/occlusion.h>
#include <rtsim/workloads/embree_scene.h>
#include <rtsim/workloads/error.h>

namespace rtsim::builders {

Bvh build_osah(const Scene& scene, const BuildParams& params, BuildReport& r) {
  const size_t n = scene.triangle_count();
  const auto start = std::chrono::steady_clock::now();
  if (!params.visibility.empty()) {
    if (params.visibility.size() != n)
      throw InputError("visibility", "expected " + std::to_string(n) + " entries, got " +
                                         std::to_string(params.visibility.size()));
    r.visibility.resize(n);
    for (size_t i = 0; i < n; ++i) r.visibility[i] = params.visibility[i] ? 1 : 0;
  } else {
    const Camera& camera = scene.camera(params.camera);
    with_threads(params.threads, [&] {
      EmbreeScene embree(scene);
      r.visibility = estimate_visibility(scene, embree, camera, params.osah_width, params.osah_height);
    });
  }
  for (uint8_t v : r.visibility) r.visible_triangles += v;
  r.estimate_seconds = seconds_since(start);
  detail::CoreConfig config = core_config(params);
  config.visible = &r.visibility;
  return run_core(scene, config, r);
}

}  // namespace rtsim::builders
