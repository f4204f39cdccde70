#pragma once
// Simulated time is kept as integer picoseconds (SystemC's default resolution).
#include <systemc>

#include <cstdint>
#include <functional>
#include <queue>
#include <vector>

namespace rtsim::sim {

inline uint64_t now_ps() { return sc_core::sc_time_stamp().value(); }
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
    heap_.push(Entry{time_ps, sequence_++, item});
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
    while (!heap_.empty() && heap_.top().time_ps <= now) {
      Item item = heap_.top().item;
      heap_.pop();
      handle(item);
    }
    draining_ = false;
    if (!heap_.empty() && heap_.top().time_ps < notified_ps_) {
      notified_ps_ = heap_.top().time_ps;
      event_.notify(from_ps(notified_ps_ - now));
    }
  }
  sc_core::sc_event& event() { return event_; }
  bool empty() const { return heap_.empty(); }

 private:
  struct Entry {
    uint64_t time_ps, sequence;
    Item item;
    bool operator<(const Entry& o) const {  // priority_queue is a max-heap
      return time_ps != o.time_ps ? time_ps > o.time_ps : sequence > o.sequence;
    }
  };
  std::priority_queue<Entry> heap_;
  uint64_t sequence_ = 0;
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
