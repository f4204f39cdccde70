#pragma once
// How the cycle-level units are woken. Each unit keeps its own work items in a
// TimedQueue; one SystemC process, the UnitScheduler, runs the units whose next
// item is due and moves SystemC time on to the earliest next one. The kernel
// then schedules one event per simulated time step instead of one per unit and
// step (at ~390 instructions a wake, that was a quarter of the cycle level).
// Within a time step the units run in rounds, as SystemC's delta cycles would:
// a round runs every unit due at its start, in the order the units were built;
// a unit woken for the current time during a round runs in the next one.
#include <rtsim/model/sim/sc_time_util.h>

#include <algorithm>
#include <cstdint>
#include <functional>
#include <vector>

namespace rtsim::sim {

class UnitScheduler : public sc_core::sc_module {
 public:
  explicit UnitScheduler(sc_core::sc_module_name name);
  // Registers a unit; `due` is called when a wake it asked for comes.
  uint32_t add(std::function<void()> due);
  // The unit wants to run at time_ps (now if earlier). A later wake it asked for
  // before is superseded; one at or before time_ps stands.
  void wake(uint32_t unit, uint64_t time_ps) {
    const uint64_t now = now_ps();
    time_ps = std::max(time_ps, now);
    if (time_ps >= wake_ps_[unit]) return;  // an earlier wake stands
    wake_ps_[unit] = time_ps;
    if (running_) {
      // Due now: the next round. Later: the scan after the last round finds it.
      if (time_ps == now) next_round_.push_back(unit);
    } else if (time_ps < armed_ps_) {
      arm(time_ps, now);
    }
  }

 private:
  SC_HAS_PROCESS(UnitScheduler);
  void run();
  void arm(uint64_t time_ps, uint64_t now_ps);
  std::vector<std::function<void()>> due_;
  std::vector<uint64_t> wake_ps_;   // per unit: when it wants to run (UINT64_MAX: never)
  std::vector<uint32_t> round_;       // a place per unit: the units due in the round being run
  std::vector<uint32_t> next_round_;  // the units woken for now during it
  uint64_t armed_ps_ = UINT64_MAX;  // when the kernel event runs us next
  bool running_ = false;
  sc_core::sc_event next_;
};

// A unit's time-ordered work items. drain() hands the unit every item due now;
// items pushed while it drains and due now are handled in the same drain, and
// the scheduler is asked for the unit's next item when the drain ends. Items at
// the same time keep their insertion order, so a run is deterministic.
template <typename Item>
class TimedQueue {
 public:
  TimedQueue(UnitScheduler& scheduler, std::function<void()> due)
      : scheduler_(scheduler), unit_(scheduler.add(std::move(due))) {}
  void push(uint64_t time_ps, const Item& item) {
    // Kept sorted by time, equal times in insertion order. A unit holds a few
    // dozen items, nearly all due after the ones it holds, so the place is found
    // from the back in a step or two: cheaper than a heap, whose sifts mispredict.
    size_t at = entries_.size();
    while (at > head_ && entries_[at - 1].time_ps > time_ps) --at;
    entries_.insert(entries_.begin() + ptrdiff_t(at), Entry{time_ps, item});
    if (!draining_) scheduler_.wake(unit_, time_ps);
  }
  // Calls handle(item) for every item due now, then asks for the next wake.
  template <typename Handler>
  void drain(Handler&& handle) {
    const uint64_t now = now_ps();
    draining_ = true;
    while (head_ < entries_.size() && entries_[head_].time_ps <= now) {
      Item item = entries_[head_++].item;
      handle(item);
    }
    draining_ = false;
    // The handled entries go: all at once when none is left, else when they are
    // the larger part (amortised, so a queue that never empties stays small).
    if (head_ == entries_.size()) {
      entries_.clear(), head_ = 0;
    } else {
      if (head_ > 32 && head_ * 2 > entries_.size())
        entries_.erase(entries_.begin(), entries_.begin() + ptrdiff_t(head_)), head_ = 0;
      scheduler_.wake(unit_, entries_[head_].time_ps);
    }
  }

 private:
  struct Entry {
    uint64_t time_ps;
    Item item;
  };
  UnitScheduler& scheduler_;
  uint32_t unit_;
  std::vector<Entry> entries_;  // [head_, end): pending, in (time, insertion) order
  size_t head_ = 0;
  bool draining_ = false;
};

}  // namespace rtsim::sim
