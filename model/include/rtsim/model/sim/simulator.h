#pragma once
// One entry point for the three fidelity levels:
//   functional  no SystemC kernel: the ray engine in rounds + functional caches;
//               exact counts, traffic of an equal-latency interleaving, an analytic
//               cycle estimate
//   lt          the ray engine in time order, TLM-2.0 blocking transport through
//               timed caches and DRAM, the quantum keeper for temporal decoupling
//   cycle       approximately timed, event-driven units and memory
// All three take every memory access from the one traversal core, so each ray's
// address stream is the same at every level; what differs is the interleaving of
// rays (see docs/memory-traffic.md for what agrees and what does not).
// SystemC allows one elaboration per process: lt and cycle can run once per
// process (tests and benchmarks run them in child processes).
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/ray_engine.h>
#include <rtsim/model/sim/ray_probe.h>
#include <rtsim/model/sim/stats.h>
#include <rtsim/model/sim/timeline.h>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace rtsim::sim {

class DramTraceWriter;
class CacheTraceWriter;

struct SimulationRequest {
  const Scene* scene = nullptr;
  const Bvh* bvh = nullptr;
  const Camera* camera = nullptr;     // primary rays from it, when rays is empty
  EffectSettings settings;            // resolution, seed, AO samples, effects
  std::vector<Ray> rays;              // non-empty: replay these, spawn nothing
  HardwareConfig config;
  Fidelity fidelity = Fidelity::Functional;
  uint32_t frames = 1;                // the same rays this many times, caches warm; stats of the last
  std::function<void(uint64_t rays_done)> progress;
  AccessObserver observer;            // optional: every access the core names, per ray
  // Optional: the ray whose every request is traced (--trace-ray; ray_probe.h).
  std::optional<RayTarget> trace_ray;
  Timeline* timeline = nullptr;       // optional, lt and cycle: the run drawn (timeline.h); closed by the caller
  // Optional (memory_trace.h): every request reaching the DRAM, and every access
  // entering the cache the writer names (all its instances), over every frame.
  DramTraceWriter* dram_trace = nullptr;
  CacheTraceWriter* cache_trace = nullptr;
};

// The memory layout and traversal settings a hardware configuration implies
// (memory.*, trv.stack_*, ist.triangles_in_flight): trace and simulate share them.
MemoryLayoutConfig memory_layout_for(const HardwareConfig& config);
TraversalConfig traversal_config_for(const HardwareConfig& config);

struct SimulationResult {
  StatsRegistry stats;        // deterministic: no host figures in here
  uint64_t rays = 0;          // rays simulated (all types)
  uint64_t simulated_ps = 0;   // the last frame
  uint64_t cycles = 0;
  double host_seconds = 0;    // wall time of the simulation proper (not loading/building)
  double cpu_seconds = 0;     // CPU time of the same (the fair figure on a loaded machine)
  uint64_t peak_memory_bytes = 0;
  std::array<CounterTotals, kRayTypeCount> per_type{};
  EffectPlan plan;
  std::vector<FrameFigures> frame_history;  // one per frame (stats are the last's)
  uint64_t frame_start_ps = 0;              // when the last frame began (probe and timeline times)
  nlohmann::json ray_trace;                 // trace_ray's requests and totals (ray_trace_json); else null
};

// Throws InputError for an invalid configuration or request; std::runtime_error
// if a SystemC level is asked for a second time in one process.
SimulationResult simulate(const SimulationRequest& request);

// Host figures, kept out of stats.json so that it stays byte-identical across runs.
std::string host_json(const SimulationResult& result);

}  // namespace rtsim::sim
