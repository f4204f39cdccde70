#pragma once
// The builders of the registry (builder_registry.cpp), one file each, and the small
// pieces they share. Each build function gets checked parameters and fills the
// report's timing and counts; build_bvh adds the collapse pass for wide formats.
#include <rtsim/builder/build.h>

#include "../weighted_sah_core.h"

#include <tbb/task_arena.h>

#include <chrono>

namespace rtsim::builders {

Bvh build_sah(const Scene& scene, const BuildParams& params, BuildReport& report);
Bvh build_sbvh(const Scene& scene, const BuildParams& params, BuildReport& report);
Bvh build_median(const Scene& scene, const BuildParams& params, BuildReport& report);
Bvh build_osah(const Scene& scene, const BuildParams& params, BuildReport& report);
Bvh build_aobvh(const Scene& scene, const BuildParams& params, BuildReport& report);
Bvh build_aosbvh(const Scene& scene, const BuildParams& params, BuildReport& report);
Bvh build_rdh(const Scene& scene, const BuildParams& params, BuildReport& report);
Bvh build_rdh_sbvh(const Scene& scene, const BuildParams& params, BuildReport& report);
Bvh build_embree(const Scene& scene, const BuildParams& params, BuildReport& report);
Bvh build_embree_sbvh(const Scene& scene, const BuildParams& params, BuildReport& report);

// ---- shared by the files above

inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The weighted-SAH core's settings from the parameters (no policy set).
detail::CoreConfig core_config(const BuildParams& params);

// Runs the core with `config` (the policy already set), timing it into the report.
Bvh run_core(const Scene& scene, const detail::CoreConfig& config, BuildReport& report);

// The AO ray length in scene units: ao_cutoff_relative x the scene diagonal, or the
// scene's own setting when the parameter is < 0 (aobvh's AO pass, rdh's sample rays).
inline float ao_cutoff(const Scene& scene, const BuildParams& params) {
  const float relative = params.ao_cutoff_relative < 0 ? scene.ao.cutoff_relative : params.ao_cutoff_relative;
  return relative * scene.diagonal();
}

// Runs fn inside an arena of the requested size (0 = all cores).
template <class F>
void with_threads(uint32_t threads, F&& fn) {
  if (threads == 0) {
    fn();
  } else {
    tbb::task_arena arena{int(threads)};
    arena.execute(fn);
  }
}

}  // namespace rtsim::builders
