#pragma once
// Cycle level shading, one per core: takes the core's finished rays into the
// unit's model (ShadingUnit, units/shading_unit.h, as at the lt level) and, when
// its result is out, hands the secondary rays it spawned to ray generation.
// Elaborated only when some effect needs secondary rays.
#include <rtsim/model/core/ray_generation.h>
#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/cycle/unit_scheduler.h>
#include <rtsim/model/sim/units/shading_unit.h>

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
  ShadingUnit model;  // the unit's work, counts and accounting

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
  uint32_t in_flight_ = 0;  // rays taken and not yet shaded
  TimedQueue<Item> queue_;
  std::vector<Ray> out_;
};

}  // namespace rtsim::sim
