#pragma once
// Cycle level ray generation, one per core: hands the core's rays, in the
// RayDispatcher's issue order, to the core's free TRV slots at the times its model
// (RayGenUnit, units/raygen_unit.h, as at the lt level) gives, never before a ray
// is ready (spawned rays: after shading).
#include <rtsim/model/core/ray.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/ray_dispatch.h>
#include <rtsim/model/sim/cycle/unit_scheduler.h>
#include <rtsim/model/sim/units/raygen_unit.h>

#include <deque>

namespace rtsim::sim {

class CycleTrv;

class CycleRayGen : public sc_core::sc_module {
 public:
  CycleRayGen(sc_core::sc_module_name name, const HardwareConfig& config,
              RayDispatcher& dispatcher, uint32_t core, UnitScheduler& scheduler);
  void slot_free(CycleTrv* trv, uint32_t slot, uint64_t t);
  void add_rays(const std::vector<Ray>& rays, uint64_t ready_ps);  // from the core's shading
  uint64_t issued() const { return issued_; }
  void restart(uint64_t t);  // the next frame (after the dispatcher's restart)
  void reset_counters() { blocked_ps = 0; }
  uint64_t blocked_ps = 0;  // rays ready but no free TRV slot (blocked downstream)

 private:
  void on_event();
  RayDispatcher& dispatcher_;
  uint32_t core_;
  uint64_t issued_ = 0;
  RayGenUnit model_;
  std::deque<std::pair<CycleTrv*, uint32_t>> free_slots_;
  TimedQueue<int> wake_;
  uint64_t no_slot_since_ = UINT64_MAX;
};

}  // namespace rtsim::sim
