#pragma once
// An IST unit's work, written once for every level: a leaf step's triangle tests,
// or one alpha test of its any-hit stage (alpha-tested scenes), through the unit's
// test pipeline; its counts and its cycle accounting. The functional level counts
// the steps untimed; lt calls take_step when the leaf's reads are back (it models no
// IST queue: the TRV slot waits, ray_engine.h); cycle when a job of the unit's
// bounded queue has its data (cycle_ist.h).
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/units/issue_port.h>

#include <array>

namespace rtsim::sim {

class IstUnit {
 public:
  explicit IstUnit(const HardwareConfig& config);

  // The step is a leaf's triangles (TestTriangles) or an alpha test (AlphaTest) whose
  // data is here: the core takes it and its tests are counted. Untimed.
  void take_step(RayTraversal& traversal) { count(traversal, take(traversal)); }
  // Timed: the same, the tests (ist.tests_per_cycle) or the alpha test
  // (anyhit.tests_per_cycle, sharing the pipeline's issue) reserved from t on;
  // returns when the last result is out.
  uint64_t take_step(RayTraversal& traversal, uint64_t t);
  void restart(uint64_t t);  // a new frame from t: the counts start again
  uint64_t pipeline_free_ps() const { return tests_port_.free_ps(); }

  UnitAccounting accounting;  // timed levels
  uint64_t tests = 0, anyhit_tests = 0;
  std::array<uint64_t, kRayTypeCount> tests_by_type{};    // triangle tests
  std::array<uint64_t, kRayTypeCount> busy_ps_by_type{};  // timed: pipeline time of each type's tests

 private:
  // The core takes the step; true if it was an alpha test.
  static bool take(RayTraversal& traversal) {
    const bool alpha = traversal.action() == TraversalAction::AlphaTest;
    traversal.process();
    return alpha;
  }
  void count(const RayTraversal& traversal, bool alpha);  // after take()
  uint64_t test_interval_ps_, test_latency_ps_, alpha_interval_ps_, alpha_latency_ps_;
  IssuePort tests_port_;
};

}  // namespace rtsim::sim
