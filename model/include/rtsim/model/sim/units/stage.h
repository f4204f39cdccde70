#pragma once
// A stage: an optional unit on the rays' path, one instance per core, built only
// when a run configures it. The ray-reordering unit (ray_reorder.h) is the first.
//
// The dispatcher (ray_dispatch.h) builds the stages and passes each core's rays
// through them, which is where every level meets them. Everything else reaches a
// stage through this interface alone: the machine report (the stage's own stats,
// each instance's cycle accounting and the machine roll-up), the energy model, the
// timeline and the accounting's off switch. So a new stage is its own header and
// source, its lines in RayDispatcher, and its rows in the parameter table; no
// report, energy or level file names it.
#include <rtsim/model/core/ray.h>
#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/config.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace rtsim::sim {

class StatsRegistry;

// What the energy model prices on-chip work with (energy.cpp): the energy
// parameters and the process factor from the 65 nm figures, for logic and for SRAM.
struct EnergyPrices {
  const EnergyConfig& energy;
  double logic;  // process_energy_factor(65, energy.process_nm, energy.vdd)
  double sram;   // energy.sram_scale x logic
};

// A stage's dynamic energy this frame (energy.<name>.pj) and who caused it.
struct StageEnergy {
  double pj = 0;
  // What each ray type caused of it, in any one unit (rays, tests): the energy
  // model shares pj out in proportion.
  std::array<double, kRayTypeCount> caused{};
  std::string what;                           // "energy of <what>": the stat's description
  std::string what_per_ray;                   // "energy of <what_per_ray> / rays"
};

// The work one instance counts (core<c>.<name>.<unit>).
struct StageWork {
  uint64_t count;
  const char* unit;     // "rays"
  const char* meaning;  // the stat's description
};

class Stage {
 public:
  virtual ~Stage() = default;
  // Its name (stats <name>.*, core<c>.<name>.*, machine.<name>.*, energy.<name>.*)
  // and the cycle buckets an instance can be in.
  virtual const UnitTraits& traits() const = 0;
  virtual uint32_t instances() const = 0;
  virtual UnitAccounting& accounting(uint32_t instance) = 0;  // timed levels
  virtual StageWork work(uint32_t instance) const = 0;
  // Its stats over all instances (timed: the levels with a clock).
  virtual void report(StatsRegistry& stats, const HardwareConfig& config, bool timed) const = 0;
  virtual StageEnergy energy(const HardwareConfig& config, const EnergyPrices& prices) const = 0;

  // The timed levels, at the frame's end: each instance's picoseconds per bucket.
  std::vector<CycleSplit> finish_accounting(uint64_t end_ps) {
    std::vector<CycleSplit> out;
    for (uint32_t i = 0; i < instances(); ++i) {
      accounting(i).finish(end_ps);
      out.push_back(accounting(i).ps());
    }
    return out;
  }
  void switch_off_accounting() {
    for (uint32_t i = 0; i < instances(); ++i) accounting(i).switch_off();
  }
};

// A stage the dispatcher can build: its traits, and the parameter lines that build
// it (the stats reference turns every stage on with them, so docs/stats.md lists
// their stats).
struct StageDescription {
  const UnitTraits* traits;
  const char* config_lines;
};

}  // namespace rtsim::sim
