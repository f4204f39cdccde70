// Settings the benchmark programs read from the environment, one reader each.
#pragma once

#include <cstdlib>
#include <string>

namespace rtsim {

// RTSIM_BENCH_BUILDER: the builder of the trees a benchmark traverses (default sah).
// An unknown name is reported by build_bvh, naming the builders it knows.
inline std::string bench_builder() {
  const char* name = std::getenv("RTSIM_BENCH_BUILDER");
  return name ? name : "sah";
}

}  // namespace rtsim
