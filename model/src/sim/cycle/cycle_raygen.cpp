#include <rtsim/model/sim/cycle/cycle_raygen.h>
#include <rtsim/model/sim/cycle/cycle_trv.h>

#include <cmath>

namespace rtsim::sim {

CycleRayGen::CycleRayGen(sc_core::sc_module_name name, const HardwareConfig& config,
                         std::vector<Ray> rays)
    : sc_module(name), rays_(std::move(rays)), ready_ps_(rays_.size(), 0) {
  const double cycle_ps = config.clock_period_ps();
  interval_ps_ = uint64_t(std::llround(cycle_ps / config.raygen_rays_per_cycle));
  SC_METHOD(on_event);
  sensitive << wake_.event();
  dont_initialize();
}

void CycleRayGen::slot_free(CycleTrv* trv, uint32_t slot, uint64_t t) {
  free_slots_.emplace_back(trv, slot);
  wake_.push(t, 0);
}

void CycleRayGen::add_rays(const std::vector<Ray>& rays, uint64_t ready_ps) {
  for (const Ray& r : rays) {
    rays_.push_back(r);
    ready_ps_.push_back(ready_ps);
  }
  if (!rays.empty()) wake_.push(ready_ps, 0);
}

void CycleRayGen::on_event() {
  wake_.drain([](int) {});
  const uint64_t now = now_ps();
  while (next_ < rays_.size()) {
    const uint64_t issue = std::max({now, ready_ps_[next_], next_issue_ps_});
    if (issue > now) {
      wake_.push(issue, 0);
      break;
    }
    if (free_slots_.empty()) {  // a ready ray and nowhere to put it
      if (no_slot_since_ == UINT64_MAX) no_slot_since_ = now;
      break;
    }
    if (no_slot_since_ != UINT64_MAX) stalled_ps += now - no_slot_since_, no_slot_since_ = UINT64_MAX;
    auto [trv, slot] = free_slots_.front();
    free_slots_.pop_front();
    trv->start_ray(slot, uint32_t(next_), rays_[next_], now);
    ++next_;
    next_issue_ps_ = now + interval_ps_;
  }
}

}  // namespace rtsim::sim
