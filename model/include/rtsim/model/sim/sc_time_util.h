#pragma once
// Simulated time is kept as integer picoseconds (SystemC's default resolution).
#include <systemc>

#include <cstdint>

namespace rtsim::sim {

// The kernel's inline accessor: sc_time_stamp() is an out-of-line library call,
// and the cycle-level units ask for the time on every item they handle.
inline uint64_t now_ps() { return sc_core::sc_get_curr_simcontext()->time_stamp().value(); }
inline uint64_t to_ps(const sc_core::sc_time& t) { return t.value(); }
inline sc_core::sc_time from_ps(uint64_t ps) { return sc_core::sc_time::from_value(ps); }

}  // namespace rtsim::sim
