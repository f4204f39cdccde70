#pragma once
// Simulated time is kept as integer picoseconds (SystemC's default resolution).
#include <systemc>

#include <cstdint>
#include <functional>
#include <vector>

namespace rtsim::sim {

// The kernel's inline accessor: sc_time_stamp() is an out-of-line library call,
// and the cycle-level units ask for the time on every item they handle.
inline uint64_t now_ps() { return sc_core::sc_get_curr_simcontext()->time_stamp().value(); }
inline uint64_t to_ps(const sc_core::sc_time& t) { return t.value(); }
inline sc_core::sc_time from_ps(uint64_t ps) { return sc_core::sc_time::from_value(ps); }

// The event-driven core of every cycle-level unit: a time-ordered queue of the
// unit's own work items and one SC_METHOD that wakes only at the next item's time
// (no per-cycle clock). Items at the same time keep their insertion order, so a
// run is deterministic.
template <typename Item>
class TimedQueue {
 public:
  void push(uint64_t time_ps, const Item& item) {
    // Kept sorted by time, equal times in insertion order. A unit holds a few
    // dozen items, nearly all due after the ones it holds, so the place is found
    // from the back in a step or two: cheaper than a heap, whose sifts mispredict.
    size_t at = entries_.size();
    while (at > head_ && entries_[at - 1].time_ps > time_ps) --at;
    entries_.insert(entries_.begin() + ptrdiff_t(at), Entry{time_ps, item});
    // While draining, items due now are picked up by the running loop and the
    // event is re-armed at its end: no kernel notification needed.
    if (!draining_ && time_ps < notified_ps_) {
      notified_ps_ = time_ps;
      const uint64_t now = now_ps();
      event_.notify(from_ps(time_ps > now ? time_ps - now : 0));
    }
  }
  // Calls handle(item) for every item due now, then re-arms the event.
  template <typename Handler>
  void drain(Handler&& handle) {
    const uint64_t now = now_ps();
    notified_ps_ = UINT64_MAX;
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
    } else if (head_ > 32 && head_ * 2 > entries_.size()) {
      entries_.erase(entries_.begin(), entries_.begin() + ptrdiff_t(head_)), head_ = 0;
    }
    if (head_ < entries_.size() && entries_[head_].time_ps < notified_ps_) {
      notified_ps_ = entries_[head_].time_ps;
      event_.notify(from_ps(notified_ps_ - now));
    }
  }
  sc_core::sc_event& event() { return event_; }
  bool empty() const { return head_ == entries_.size(); }

 private:
  struct Entry {
    uint64_t time_ps;
    Item item;
  };
  std::vector<Entry> entries_;  // [head_, end): pending, in (time, insertion) order
  size_t head_ = 0;
  uint64_t notified_ps_ = UINT64_MAX;
  bool draining_ = false;
  sc_core::sc_event event_;
};

// Busy / occupied time of a unit, for utilisation figures.
struct Occupancy {
  uint64_t busy_ps = 0;       // pipeline occupied
  uint64_t occupied_ps = 0;   // at least one job resident
  uint64_t stalled_ps = 0;    // resident work blocked by a full downstream queue
  uint32_t resident = 0;
  uint64_t since_ps = 0;
  void enter(uint64_t t) {
    if (resident++ == 0) since_ps = t;
  }
  void leave(uint64_t t) {
    if (--resident == 0) occupied_ps += t - since_ps;
  }
  // A new frame: the times start again from t, work still resident stays resident.
  void restart(uint64_t t) {
    *this = Occupancy{0, 0, 0, resident, t};
  }
};

}  // namespace rtsim::sim
