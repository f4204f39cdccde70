#pragma once
// A TRV unit's work, written once for every level: its node steps (and instance
// transforms) through the box-test pipeline, its counts and its cycle accounting.
// The levels differ only in how they sequence it: the functional level counts the
// steps untimed; lt calls take_step from its event calendar when a step's reads are
// back; cycle from the unit's TimedQueue when its L1 has answered (cycle_trv.h).
// How a ray's reads wait for memory, and where a leaf goes, stay the level's.
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/units/issue_port.h>

#include <array>

namespace rtsim::sim {

class TrvUnit {
 public:
  explicit TrvUnit(const HardwareConfig& config);

  // The step is a node or an instance transform whose data is here: the core takes
  // it (process()), and it takes config.trv_step_passes passes. Untimed.
  void take_step(RayTraversal& traversal) { count(traversal); traversal.process(); }
  // Timed: the same, its passes reserved in the box-test pipeline from t on; returns
  // when its result is out (box_test_latency, or xfm.latency for a transform).
  uint64_t take_step(RayTraversal& traversal, uint64_t t);
  // A ray that entered a slot at start_ps left it at end_ps.
  void ray_done(RayType type, uint64_t start_ps, uint64_t end_ps) {
    ray_ps_by_type[size_t(type)] += end_ps - start_ps;
  }
  // A new frame from t: the counts start again (the pipeline keeps its reservations).
  void restart(uint64_t t);
  uint64_t pipeline_free_ps() const { return box_tests_.free_ps(); }

  UnitAccounting accounting;  // timed levels
  uint64_t passes = 0;        // box-test pipeline passes (trv.boxes_per_pass)
  uint64_t leaves_blocked = 0;  // cycle: leaves that found the IST queue full and waited
  std::array<uint64_t, kRayTypeCount> passes_by_type{};
  std::array<uint64_t, kRayTypeCount> busy_ps_by_type{};  // timed: pipeline time of each type's steps
  std::array<uint64_t, kRayTypeCount> ray_ps_by_type{};   // timed: rays' time from start to finish

 private:
  uint32_t count(const RayTraversal& traversal);  // the step's passes, counted
  const HardwareConfig* config_;  // its owner's, which outlives it
  uint64_t interval_ps_, box_latency_ps_, xfm_latency_ps_;
  IssuePort box_tests_;
};

}  // namespace rtsim::sim
