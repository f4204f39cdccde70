#pragma once
// What a run costs the host: every result reports peak memory and host seconds.
#include <cstdint>

namespace rtsim {

uint64_t peak_memory_bytes();  // peak resident set size of this process so far

}  // namespace rtsim
