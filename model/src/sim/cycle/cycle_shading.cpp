#include <rtsim/model/sim/cycle/cycle_shading.h>
#include <rtsim/model/sim/cycle/cycle_system.h>

#include <cmath>

namespace rtsim::sim {

CycleShading::CycleShading(sc_core::sc_module_name name, const HardwareConfig& config,
                           const Workload& workload, CycleSystem& system, uint32_t core)
    : sc_module(name), workload_(workload), system_(system), core_(core),
      queue_(system.scheduler, [this] { on_event(); }) {
  const double cycle_ps = config.clock_period_ps();
  interval_ps_ = uint64_t(std::llround(cycle_ps / config.shading_rays_per_cycle));
  latency_ps_ = uint64_t(config.shading_latency) * uint64_t(std::llround(cycle_ps));
}

void CycleShading::reset_counters() {
  shaded = spawned = 0;
  accounting.restart(now_ps());
}

void CycleShading::shade(uint32_t ray_index, const Ray& ray, const HitRecord& hit, uint64_t t) {
  const uint64_t start = std::max(t, free_ps_);
  free_ps_ = start + interval_ps_;
  accounting.reserve(t, start, free_ps_);
  accounting.change(t, UnitAccounting::Resident, +1);
  ++in_flight_;

  queue_.push(start + latency_ps_, Item{ray_index, ray, hit});
}

void CycleShading::on_event() {
  queue_.drain([this](const Item& item) {
    out_.clear();
    spawn_secondary_rays(*workload_.scene, workload_.plan, workload_.settings, item.ray,
                         item.ray_index, item.hit, out_);
    ++shaded;
    spawned += out_.size();
    accounting.change(now_ps(), UnitAccounting::Resident, -1);
    --in_flight_;
    system_.spawned(core_, out_, now_ps());
  });
}

}  // namespace rtsim::sim
