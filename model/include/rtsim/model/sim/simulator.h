#pragma once
// One entry point for the three fidelity levels:
//   functional  no SystemC kernel: the ray engine + functional caches; exact counts,
//               an analytic cycle estimate
//   lt          TLM-2.0 blocking transport with the quantum keeper
//   cycle       approximately timed, event-driven units and memory
// SystemC allows one elaboration per process: lt and cycle can run once per
// process (tests and benchmarks run them in child processes).
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/stats.h>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace rtsim::sim {

struct SimulationRequest {
  const Scene* scene = nullptr;
  const Bvh* bvh = nullptr;
  const Camera* camera = nullptr;     // primary rays from it, when rays is empty
  EffectSettings settings;            // resolution, seed, AO samples, effects
  std::vector<Ray> rays;              // non-empty: replay these, spawn nothing
  HardwareConfig config;
  Fidelity fidelity = Fidelity::Functional;
  std::function<void(uint64_t rays_done)> progress;
};

struct SimulationResult {
  StatsRegistry stats;        // deterministic: no host figures in here
  uint64_t rays = 0;          // rays simulated (all types)
  uint64_t simulated_ps = 0;
  uint64_t cycles = 0;
  double host_seconds = 0;    // wall time of the simulation proper (not loading/building)
  double cpu_seconds = 0;     // CPU time of the same (the fair figure on a loaded machine)
  uint64_t peak_memory_bytes = 0;
  std::array<CounterTotals, kRayTypeCount> per_type{};
  EffectPlan plan;
};

// Throws InputError for an invalid configuration or request; std::runtime_error
// if a SystemC level is asked for a second time in one process.
SimulationResult simulate(const SimulationRequest& request);

// Host figures, kept out of stats.json so that it stays byte-identical across runs.
std::string host_json(const SimulationResult& result);

}  // namespace rtsim::sim
