#include <rtsim/model/sim/cycle/unit_scheduler.h>

#include <algorithm>

namespace rtsim::sim {

UnitScheduler::UnitScheduler(sc_core::sc_module_name name) : sc_module(name) {
  SC_METHOD(run);
  sensitive << next_;
  dont_initialize();
}

uint32_t UnitScheduler::add(std::function<void()> due) {
  due_.push_back(std::move(due));
  wake_ps_.push_back(UINT64_MAX);
  round_.push_back(0);
  return uint32_t(due_.size() - 1);
}

void UnitScheduler::arm(uint64_t time_ps, uint64_t now) {
  armed_ps_ = time_ps;
  next_.notify(from_ps(time_ps - now));
}

void UnitScheduler::run() {
  // The first round and the next time come from a scan of every unit (they are
  // tens); the rounds between, from the wakes asked for now.
  const uint64_t now = now_ps();
  running_ = true;
  // Branch-free: which units are due is close to random from step to step.
  // round_ holds a place for every unit (add()); the round is its first `due`.
  const uint32_t units = uint32_t(wake_ps_.size());
  const uint64_t* wake = wake_ps_.data();
  uint32_t* round = round_.data();
  size_t due = 0;
  for (uint32_t u = 0; u < units; ++u) {
    round[due] = u;
    due += wake[u] <= now;
  }
  while (due > 0) {
    next_round_.clear();
    for (size_t i = 0; i < due; ++i) wake_ps_[round[i]] = UINT64_MAX;
    for (size_t i = 0; i < due; ++i) due_[round[i]]();
    // A unit is woken for now at most once a round (wake() keeps the earliest).
    std::sort(next_round_.begin(), next_round_.end());  // build order
    due = next_round_.size();
    std::copy(next_round_.begin(), next_round_.end(), round);
  }
  running_ = false;
  const uint64_t next = *std::min_element(wake_ps_.begin(), wake_ps_.end());
  armed_ps_ = UINT64_MAX;
  if (next != UINT64_MAX) arm(next, now);
}

}  // namespace rtsim::sim
