// Hardware configurations (TOML text: preset, overrides, cross-parameter checks).
#include "fuzz_support.h"

#include <rtsim/model/sim/config.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  rtsim::fuzz::expect_only_input_errors([&] {
    const rtsim::HardwareConfig config = rtsim::parse_hardware_config(text, "fuzz.toml");
    rtsim::validate(config);
    (void)rtsim::to_json(config);
  });
  return 0;
}
