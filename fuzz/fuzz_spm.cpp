// SuperTuxKart .spm meshes from bytes.
#include "fuzz_support.h"

#include <rtsim/workloads/mesh_loader.h>

RTSIM_FUZZ_TARGET(spm) {
  const std::vector<uint8_t> bytes(data, data + size);
  rtsim::fuzz::expect_only_input_errors([&] { rtsim::parse_spm(bytes, "fuzz.spm"); });
  return 0;
}
