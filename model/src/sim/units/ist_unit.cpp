#include <rtsim/model/sim/units/ist_unit.h>

namespace rtsim::sim {

IstUnit::IstUnit(const HardwareConfig& config)
    : test_interval_ps_(issue_interval_ps(config.ist_tests_per_cycle, config.cycle_ps())),
      test_latency_ps_(uint64_t(config.ist_test_latency) * config.cycle_ps()),
      alpha_interval_ps_(issue_interval_ps(config.anyhit_tests_per_cycle, config.cycle_ps())),
      alpha_latency_ps_(uint64_t(config.anyhit_test_latency) * config.cycle_ps()) {}

void IstUnit::count(const RayTraversal& traversal, bool alpha) {
  if (alpha) {
    ++anyhit_tests;
    return;
  }
  const uint32_t n = traversal.last_step_tests();
  tests += n;
  tests_by_type[size_t(traversal.ray().type)] += n;
}

uint64_t IstUnit::take_step(RayTraversal& traversal, uint64_t t) {
  // The step's data is here: the core tests its triangles (an any-hit ray may stop
  // early), and the tests it made go through the pipeline; the any-hit stage's one
  // alpha test issues into the same pipeline at its own rate and latency.
  const bool alpha = take(traversal);
  count(traversal, alpha);
  const Issue issue = alpha ? tests_port_.reserve(t, 1, alpha_interval_ps_, alpha_latency_ps_)
                            : tests_port_.reserve(t, traversal.last_step_tests(), test_interval_ps_,
                                                  test_latency_ps_);
  accounting.reserve(t, issue.start, issue.end);
  busy_ps_by_type[size_t(traversal.ray().type)] += issue.end - issue.start;
  return issue.ready;
}

void IstUnit::restart(uint64_t t) {
  accounting.restart(t);
  tests = anyhit_tests = 0;
  tests_by_type = busy_ps_by_type = {};
}

}  // namespace rtsim::sim
