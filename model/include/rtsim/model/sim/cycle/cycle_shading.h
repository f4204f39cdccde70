#pragma once
// Cycle level shading, one per core: takes the core's finished rays, and after its latency (throughput
// shading.rays_per_cycle) spawns the secondary rays the scene's effects call
// for through the core's spawn_secondary_rays. Elaborated only when some effect
// needs secondary rays.
#include <rtsim/model/core/ray_generation.h>
#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/cycle/unit_scheduler.h>

namespace rtsim::sim {

class CycleSystem;
struct Workload;

class CycleShading : public sc_core::sc_module {
 public:
  CycleShading(sc_core::sc_module_name name, const HardwareConfig& config, const Workload& workload,
               CycleSystem& system, uint32_t core);
  void shade(uint32_t ray_index, const Ray& ray, const HitRecord& hit, uint64_t t);
  bool idle() const { return in_flight_ == 0; }  // its own count: the accounting may be off
  void reset_counters();
  uint64_t shaded = 0, spawned = 0;
  UnitAccounting accounting;

 private:
  struct Item {
    uint32_t ray_index;
    Ray ray;
    HitRecord hit;
  };
  void on_event();
  const Workload& workload_;
  CycleSystem& system_;
  uint32_t core_;
  uint64_t interval_ps_, latency_ps_, free_ps_ = 0;
  uint32_t in_flight_ = 0;  // rays taken and not yet shaded
  TimedQueue<Item> queue_;
  std::vector<Ray> out_;
};

}  // namespace rtsim::sim
