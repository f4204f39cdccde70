#include <rtsim/model/sim/units/trv_unit.h>

namespace rtsim::sim {

TrvUnit::TrvUnit(const HardwareConfig& config)
    : config_(&config), interval_ps_(issue_interval_ps(config.trv_nodes_per_cycle, config.cycle_ps())),
      box_latency_ps_(uint64_t(config.trv_box_test_latency) * config.cycle_ps()),
      xfm_latency_ps_(uint64_t(config.xfm_latency) * config.cycle_ps()) {}

uint32_t TrvUnit::count(const RayTraversal& traversal) {
  const uint32_t n = config_->trv_step_passes(traversal.step_box_tests(),
                                              traversal.action() == TraversalAction::Transform);
  passes += n;
  passes_by_type[size_t(traversal.ray().type)] += n;
  return n;
}

uint64_t TrvUnit::take_step(RayTraversal& traversal, uint64_t t) {
  // A node takes one pass per trv.boxes_per_pass child boxes; an instance transform
  // xfm.passes, with its own latency.
  const bool transform = traversal.action() == TraversalAction::Transform;
  const uint32_t n = count(traversal);
  const Issue issue = box_tests_.reserve(t, n, interval_ps_, transform ? xfm_latency_ps_ : box_latency_ps_);
  accounting.reserve(t, issue.start, issue.end);
  busy_ps_by_type[size_t(traversal.ray().type)] += issue.end - issue.start;
  traversal.process();
  return issue.ready;
}

void TrvUnit::restart(uint64_t t) {
  accounting.restart(t);
  passes = leaves_blocked = 0;
  passes_by_type = busy_ps_by_type = ray_ps_by_type = {};
}

}  // namespace rtsim::sim
