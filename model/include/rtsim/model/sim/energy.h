#pragma once
// Energy of a run from its event counts: every cache access, every byte through
// the crossbar, every DRAM command, every TRV pass and IST test costs the energy
// its parameter (energy.*, with the sources in model/src/sim/config.cpp) says.
// Dynamic energy, and apart from it the DRAM's background (standby) energy; leakage
// of the accelerator is not modelled.
//   energy.<component>.pj, energy.total_pj, energy.pj_per_ray, energy.rays_per_joule (dynamic)
//   energy.dram_background.pj, energy.pj_per_ray_with_background
//   energy.per_type.<ray type>.pj_per_ray: a component's energy shared out by the
//   bytes (caches, crossbar, DRAM) or ops (TRV, IST) each ray type caused there.
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/sim/cache_model.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/stats.h>
#include <rtsim/model/sim/units/stage.h>

#include <array>
#include <cstdint>
#include <vector>

namespace rtsim::sim {

// The components energy is reported by (energy.<component>.pj), in report order.
constexpr std::array<const char*, 7> kEnergyComponents = {"trv", "ist", "l1_node", "l1_triangle",
                                                          "l2",  "noc", "dram"};

struct EnergyCounts {
  // Each cache level's accesses (requests plus the dirty lines it wrote down) times
  // cache_access_pj of the instance's size, summed over its instances, and the
  // bytes each ray type asked of it.
  double l1_node_pj = 0, l1_triangle_pj = 0, l2_pj = 0;
  TrafficMatrix l1_node_bytes, l1_triangle_bytes, l2_bytes, dram_bytes;
  uint64_t noc_bytes = 0;
  uint64_t dram_activates = 0, dram_read_bursts = 0, dram_write_bursts = 0, dram_refreshes = 0;
  double dram_background_pj = 0;  // dram.background_mw x channels x simulated time
  std::array<CounterTotals, kRayTypeCount> per_type{};  // box tests and triangle tests by type
  // The stages the run built (units/stage.h): each prices its own work.
  std::vector<const Stage*> stages;
  // The any-hit stages and their L1 texture caches, if built (alpha-tested scenes);
  // their tests by type are per_type[t].anyhit_tests.
  bool anyhit_built = false;
  double l1_texture_pj = 0;
  TrafficMatrix l1_texture_bytes;
};

void report_energy(StatsRegistry& stats, const HardwareConfig& config, const EnergyCounts& counts);

}  // namespace rtsim::sim
