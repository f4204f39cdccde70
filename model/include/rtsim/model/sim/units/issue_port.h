#pragma once
// The issue port of a unit's pipeline, as both timed levels model it: work enters
// in the order it is reserved, one item per interval, from the first moment the
// port is free; its result is out a latency after its last item entered.
#include <algorithm>
#include <cmath>
#include <cstdint>

namespace rtsim::sim {

// The interval between items of a unit that takes `per_cycle` a cycle (at least 1 ps).
inline uint64_t issue_interval_ps(double per_cycle, uint64_t cycle_ps) {
  return std::max<uint64_t>(1, uint64_t(std::llround(double(cycle_ps) / per_cycle)));
}

// When reserved work enters and leaves: it takes the port over [start, end) and its
// result is out at ready.
struct Issue {
  uint64_t start, end, ready;
};

class IssuePort {
 public:
  // `items` items (at least one) of `interval_ps` each, from t on.
  Issue reserve(uint64_t t, uint64_t items, uint64_t interval_ps, uint64_t latency_ps) {
    const uint64_t start = std::max(t, free_ps_);
    free_ps_ = start + items * interval_ps;
    return Issue{start, free_ps_, start + (items - 1) * interval_ps + latency_ps};
  }
  uint64_t free_ps() const { return free_ps_; }  // when it takes the next item

 private:
  uint64_t free_ps_ = 0;
};

}  // namespace rtsim::sim
