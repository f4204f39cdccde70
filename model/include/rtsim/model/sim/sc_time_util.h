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

// Busy / occupied time of a unit, for utilisation figures.
struct Occupancy {
  uint64_t busy_ps = 0;       // pipeline occupied
  uint64_t occupied_ps = 0;   // at least one job resident
  uint64_t stalled_ps = 0;    // resident work blocked by a full downstream queue
  uint32_t resident = 0;
  uint64_t since_ps = 0;
  void enter(uint64_t t) {
    if (resident++ == 0) since_ps = t;
  }
  void leave(uint64_t t) {
    if (--resident == 0) occupied_ps += t - since_ps;
  }
  // A new frame: the times start again from t, work still resident stays resident.
  void restart(uint64_t t) {
    *this = Occupancy{0, 0, 0, resident, t};
  }
};

}  // namespace rtsim::sim
