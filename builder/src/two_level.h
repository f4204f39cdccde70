#pragma once
// build_bvh's path for instanced scenes (two_level.cpp).
#include <rtsim/builder/build.h>

namespace rtsim::detail {
Bvh build_two_level(const Scene& scene, const BuildParams& params, BuildReport& report);
}
