#include <rtsim/model/sim/cycle/cycle_shading.h>
#include <rtsim/model/sim/cycle/cycle_system.h>

#include <cmath>

namespace rtsim::sim {

CycleShading::CycleShading(sc_core::sc_module_name name, const HardwareConfig& config,
                           const Workload& workload, CycleSystem& system, uint32_t core)
    : sc_module(name), model(config),
      workload_(workload), system_(system), core_(core), queue_(system.scheduler, [this] { on_event(); }) {}

void CycleShading::reset_counters() { model.restart(now_ps()); }

void CycleShading::shade(uint32_t ray_index, const Ray& ray, const HitRecord& hit, uint64_t t) {
  // The ray is resident from its hand-over to its result.
  const Issue issue = model.take(t, t);
  model.accounting.change(t, UnitAccounting::Resident, +1);
  ++in_flight_;
  queue_.push(issue.ready, Item{ray_index, ray, hit});
}

void CycleShading::on_event() {
  queue_.drain([this](const Item& item) {
    model.shade(workload_, item.ray, item.ray_index, item.hit, out_);
    model.accounting.change(now_ps(), UnitAccounting::Resident, -1);
    --in_flight_;
    system_.spawned(core_, out_, now_ps());
  });
}

}  // namespace rtsim::sim
