#pragma once
// Cycle level ray generation: hands rays (the initial set, then the secondary
// rays shading asks for) to free TRV slots at raygen.rays_per_cycle, never before
// a ray is ready.
#include <rtsim/model/core/ray.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/sc_time_util.h>

#include <deque>

namespace rtsim::sim {

class CycleTrv;

class CycleRayGen : public sc_core::sc_module {
 public:
  CycleRayGen(sc_core::sc_module_name name, const HardwareConfig& config, std::vector<Ray> rays);
  void slot_free(CycleTrv* trv, uint32_t slot, uint64_t t);
  void add_rays(const std::vector<Ray>& rays, uint64_t ready_ps);  // from shading
  const std::vector<Ray>& rays() const { return rays_; }
  uint64_t issued() const { return next_; }
  uint64_t stalled_ps = 0;  // rays ready but no free TRV slot

 private:
  SC_HAS_PROCESS(CycleRayGen);
  void on_event();
  std::vector<Ray> rays_;
  std::vector<uint64_t> ready_ps_;
  size_t next_ = 0;
  uint64_t interval_ps_, next_issue_ps_ = 0;
  std::deque<std::pair<CycleTrv*, uint32_t>> free_slots_;
  TimedQueue<int> wake_;
  uint64_t no_slot_since_ = UINT64_MAX;
};

}  // namespace rtsim::sim
