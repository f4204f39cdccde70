#include <rtsim/model/sim/ray_engine.h>
#include <rtsim/model/sim/units/shading_unit.h>

namespace rtsim::sim {

ShadingUnit::ShadingUnit(const HardwareConfig& config)
    : interval_ps_(issue_interval_ps(config.shading_rays_per_cycle, config.cycle_ps())),
      latency_ps_(uint64_t(config.shading_latency) * config.cycle_ps()) {}

Issue ShadingUnit::take(uint64_t now, uint64_t t) {
  const Issue issue = port_.reserve(t, 1, interval_ps_, latency_ps_);
  accounting.reserve(now, issue.start, issue.end);
  return issue;
}

void ShadingUnit::shade(const Workload& workload, const Ray& ray, uint32_t ray_index, const HitRecord& hit,
                        std::vector<Ray>& out) {
  out.clear();
  spawn_secondary_rays(*workload.scene, workload.plan, workload.settings, ray, ray_index, hit, out);
  ++shaded;
  spawned += out.size();
}

void ShadingUnit::restart(uint64_t t) {
  accounting.restart(t);
  shaded = spawned = 0;
}

}  // namespace rtsim::sim
