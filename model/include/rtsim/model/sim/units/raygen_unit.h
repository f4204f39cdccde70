#pragma once
// A core's ray generation unit, written once for both timed levels.
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/units/issue_port.h>

namespace rtsim::sim {

// A core's ray generation: it issues the dispatcher's next ray into a free TRV slot
// at raygen.rays_per_cycle. Both timed levels take its issue times from here; which
// slot is free, and when a ray is ready, is the level's to say.
class RayGenUnit {
 public:
  explicit RayGenUnit(const HardwareConfig& config)
      : interval_ps_(issue_interval_ps(config.raygen_rays_per_cycle, config.cycle_ps())) {}
  uint64_t earliest(uint64_t t) const { return std::max(t, port_.free_ps()); }  // the next issue, from t
  uint64_t issue(uint64_t t) { return port_.reserve(t, 1, interval_ps_, 0).start; }  // a ray issues

 private:
  uint64_t interval_ps_;
  IssuePort port_;
};

}  // namespace rtsim::sim
