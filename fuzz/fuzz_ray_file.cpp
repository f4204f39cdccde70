// Ray files (read_ray_file takes a path).
#include "fuzz_support.h"

#include <rtsim/model/core/ray_file.h>

RTSIM_FUZZ_TARGET(ray_file) {
  using namespace rtsim::fuzz;
  const std::filesystem::path file = scratch_dir() / "fuzz.rays";
  write_bytes(file, data, size);
  expect_only_input_errors([&] { rtsim::read_ray_file(file); });
  return 0;
}
