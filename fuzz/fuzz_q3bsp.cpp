// Quake 3 IBSP v46 from bytes (parse_q3bsp is a pure function of the bytes).
#include "fuzz_support.h"

#include <rtsim/workloads/mesh_loader.h>

RTSIM_FUZZ_TARGET(q3bsp) {
  const std::vector<uint8_t> bytes(data, data + size);
  rtsim::MeshOptions options;
  options.bsp_patch_level = 3;  // keep patch tessellation cheap per input
  rtsim::fuzz::expect_only_input_errors([&] { rtsim::parse_q3bsp(bytes, "fuzz.bsp", options); });
  return 0;
}
