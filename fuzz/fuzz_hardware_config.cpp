// Hardware configurations (TOML text: preset, overrides, cross-parameter checks).
#include "fuzz_support.h"

#include <rtsim/model/sim/config.h>

RTSIM_FUZZ_TARGET(hardware_config) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  rtsim::fuzz::expect_only_input_errors([&] {
    const rtsim::sim::HardwareConfig config = rtsim::sim::parse_hardware_config(text, "fuzz.toml");
    rtsim::sim::validate(config);
    (void)rtsim::sim::to_json(config);
  });
  return 0;
}
