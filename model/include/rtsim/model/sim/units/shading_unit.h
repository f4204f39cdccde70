#pragma once
// A core's shading unit, written once for every level: a finished ray enters it
// (shading.rays_per_cycle, shading.latency) and leaves with the secondary rays the
// scene's effects call for. The functional level shades untimed; lt takes a ray when
// its TRV slot finishes it; cycle when its TRV unit hands it over (cycle_shading.h).
// Built only when finished rays spawn more rays.
#include <rtsim/model/core/ray_generation.h>
#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/units/issue_port.h>

#include <vector>

namespace rtsim::sim {

struct Workload;

class ShadingUnit {
 public:
  explicit ShadingUnit(const HardwareConfig& config);

  // Timed: the ray that finished at t (>= now) enters the unit's pipeline, in which
  // it is resident until its result is out (Issue::ready).
  Issue take(uint64_t now, uint64_t t);
  // The secondary rays the finished ray spawns, into `out` (cleared first); counted.
  void shade(const Workload& workload, const Ray& ray, uint32_t ray_index, const HitRecord& hit,
             std::vector<Ray>& out);
  void restart(uint64_t t);  // a new frame from t: the counts start again

  UnitAccounting accounting;  // timed levels
  uint64_t shaded = 0, spawned = 0;

 private:
  uint64_t interval_ps_, latency_ps_;
  IssuePort port_;
};

}  // namespace rtsim::sim
