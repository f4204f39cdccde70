#include <rtsim/model/sim/cycle/cycle_raygen.h>
#include <rtsim/model/sim/cycle/cycle_trv.h>
#include <rtsim/model/sim/ray_engine.h>

#include <cmath>

namespace rtsim::sim {

CycleRayGen::CycleRayGen(sc_core::sc_module_name name, const HardwareConfig& config,
                         RayDispatcher& dispatcher, uint32_t core, UnitScheduler& scheduler)
    : sc_module(name), dispatcher_(dispatcher), core_(core),
      model_(config),
      wake_(scheduler, [this] { on_event(); }) {}

void CycleRayGen::slot_free(CycleTrv* trv, uint32_t slot, uint64_t t) {
  free_slots_.emplace_back(trv, slot);
  if (no_slot_since_ != UINT64_MAX) blocked_ps += t - no_slot_since_, no_slot_since_ = UINT64_MAX;
  wake_.push(t, 0);
}

void CycleRayGen::add_rays(const std::vector<Ray>& rays, uint64_t ready_ps) {
  if (rays.empty()) return;
  dispatcher_.add_spawned(core_, rays, ready_ps);
  wake_.push(ready_ps, 0);
}

void CycleRayGen::restart(uint64_t t) {
  issued_ = 0;
  wake_.push(t, 0);
}

void CycleRayGen::on_event() {
  wake_.drain([](int) {});
  const uint64_t now = now_ps();
  for (;;) {
    const uint64_t ready = dispatcher_.next_ready_ps(core_);
    if (ready == UINT64_MAX) break;  // nothing queued for this core
    const uint64_t issue = model_.earliest(std::max(now, ready));
    if (issue > now) {
      wake_.push(issue, 0);
      break;
    }
    if (free_slots_.empty()) {  // a ready ray and nowhere to put it
      if (no_slot_since_ == UINT64_MAX) no_slot_since_ = now;
      break;
    }
    uint32_t ray = 0;
    if (!dispatcher_.next(core_, now, &ray)) {
      // Rays a stage on the path (units/stage.h) releases later: wake then.
      if (const uint64_t wake = dispatcher_.take_wake(core_); wake != UINT64_MAX) wake_.push(wake, 0);
      break;
    }
    auto [trv, slot] = free_slots_.front();
    free_slots_.pop_front();
    trv->start_ray(slot, ray, dispatcher_.rays()[ray], now);
    ++issued_;
    model_.issue(now);
  }
}

}  // namespace rtsim::sim
