#pragma once
// Exclusive cycle accounting of one unit (a TRV, IST or shading unit): at every
// moment the unit is in exactly one state, so the states' cycles add up to the
// run's cycles (time.cycles). The state is the first of these that holds:
//
//   busy          its pipeline accepts work (box-test passes, triangle tests, shading)
//   waiting_dram  a read it waits for is at the DRAM (an L2 miss on its way)
//   waiting_l2    ... at an L2 slice (queued for a port or an MSHR, its tag check, its fill)
//   waiting_noc   ... on the crossbar, either way
//   waiting_l1    ... at its own L1 (port, hit latency, MSHR, fill)
//   blocked       a ray waits for room in a full downstream queue (TRV: the IST queue)
//   waiting_ist   its rays' leaves are being tested by its IST unit (TRV)
//   latency       work is in its own pipeline, none of it accepted this cycle
//   idle          no work resident
//
// Deepest level first, as Intel's top-down method charges a stalled cycle to the
// farthest cache level with a miss outstanding: a cycle in which one ray waits for
// DRAM and another for an L1 hit is a DRAM cycle. The timeline (timeline.h) draws
// exactly these states, so its spans add up to these figures.
//
// Where a read is changes when the unit or the memory system says so, often dated
// ahead of the caller's time (a crossbar transit is known when it starts). A change
// is never dated before its caller's `now`, so once the unit's clock passes a time
// no change before it can still come: dated changes wait in a small heap until then.
#include <array>
#include <initializer_list>
#include <cstdint>
#include <string>
#include <vector>

namespace rtsim::sim {

class Timeline;

// The buckets, in report order (busy first and idle last: see bucket_cycles).
enum class CycleBucket : uint8_t {
  Busy, WaitingL1, WaitingNoc, WaitingL2, WaitingDram, Blocked, WaitingIst, Latency, Idle
};
constexpr int kCycleBucketCount = 9;
constexpr std::array<CycleBucket, kCycleBucketCount> kAllCycleBuckets = {
    CycleBucket::Busy,        CycleBucket::WaitingL1, CycleBucket::WaitingNoc,
    CycleBucket::WaitingL2,   CycleBucket::WaitingDram, CycleBucket::Blocked,
    CycleBucket::WaitingIst,  CycleBucket::Latency,   CycleBucket::Idle};
// "busy", "waiting_l1", ..., "idle": the stat <unit>.<name>_cycles and the timeline's span.
const char* cycle_bucket_name(CycleBucket bucket);
// What a cycle of the bucket is, for the stat's description and docs/stats.md.
const char* cycle_bucket_meaning(CycleBucket bucket);

// A kind of unit: its name and the buckets it can be in.
struct UnitTraits {
  const char* name;  // "trv": the roll-up machine.<name>.*
  std::array<bool, kCycleBucketCount> buckets;  // by CycleBucket
  bool has(CycleBucket b) const { return buckets[size_t(b)]; }
};
// The bucket set of a kind, named rather than by position.
inline std::array<bool, kCycleBucketCount> bucket_set(std::initializer_list<CycleBucket> list) {
  std::array<bool, kCycleBucketCount> out{};
  for (CycleBucket b : list) out[size_t(b)] = true;
  return out;
}
// The units every machine has; optional stages (units/stage.h) bring their own traits.
enum class UnitKind : uint8_t { Trv, Ist, Shading };
constexpr UnitKind kAllUnitKinds[] = {UnitKind::Trv, UnitKind::Ist, UnitKind::Shading};
const UnitTraits& unit_traits(UnitKind kind);

using CycleSplit = std::array<uint64_t, kCycleBucketCount>;  // by CycleBucket

// Picoseconds per bucket to whole cycles that add up to the rounded total: each
// bucket gets round(sum of it and the buckets before it) - round(sum before it). So
// busy is round(busy ps) and idle is the total minus the rounded rest.
CycleSplit bucket_cycles(const CycleSplit& ps, double cycle_ps);

class UnitAccounting {
 public:
  // What the unit's state is made of: counts of its work in each condition.
  enum Counter : uint8_t {
    Resident,    // rays (TRV), leaves (IST) or rays being shaded in the unit
    AtL1,        // reads of the unit at its L1, from request to data
    AtNoc,       // its L1's misses on the crossbar (either way)
    AtL2,        // ... at an L2 slice
    AtDram,      // ... at the DRAM
    Blocked,     // rays waiting for room downstream
    Downstream,  // TRV: rays whose leaf the IST unit has
    kCounters
  };
  // Work resident with none of the conditions above is in the unit's own pipeline
  // (latency), or between two of its steps at one instant: no count of its own.

  // A count changes by delta at `at` (>= now; `now` is the caller's time). Inline and
  // small: a unit changes its counts several times a step, and mostly no condition
  // starts or ends (another ray already waits there), so the state stays; the rare
  // rest is out of line.
  void change(uint64_t now, uint64_t at, Counter counter, int delta) {
    if (off_) return;
    if (at > now) return date(at, delta > 0 ? kCounters : counter, delta > 0 ? counter : kCounters);
    if (next_dated_ <= now) apply_dated(now);
    apply(now, counter, delta);
  }
  void change(uint64_t now, Counter counter, int delta) {
    if (off_) return;
    if (next_dated_ <= now) apply_dated(now);
    apply(now, counter, delta);
  }
  // One of the work's moves from one condition to another at `at` (kCounters: none,
  // for work that arrives or leaves), e.g. a read from the crossbar to an L2 slice.
  void move(uint64_t now, uint64_t at, Counter from, Counter to) {
    if (off_) return;
    if (at > now) return date(at, from, to);
    if (next_dated_ <= now) apply_dated(now);
    if (from != kCounters) apply(now, from, -1);
    if (to != kCounters) apply(now, to, +1);
  }
  // The pipeline accepts work in [start, end): reservations come in order, each at
  // or after the previous one's end (a pipeline serves one at a time), and start at
  // or after `now`.
  void reserve(uint64_t now, uint64_t start, uint64_t end) {
    if (off_ || end <= start) return;
    // Contiguous reservations (a pipeline kept full) are one interval.
    if (start == busy_end_ && busy_.size() > busy_head_) {
      busy_.back().second = busy_end_ = end;
      return;
    }
    add_reservation(now, start, end);
  }
  // stats.accounting = off: every change is ignored from now on (none has come yet).
  void switch_off() { off_ = true; }
  bool on() const { return !off_; }
  // A new frame from t: the figures start again, the work resident stays.
  void restart(uint64_t t);
  // Accounts up to `end` (the run's end): every dated change up to it applies.
  void finish(uint64_t end);
  const CycleSplit& ps() const { return ps_; }  // picoseconds per bucket since restart
  uint32_t count(Counter c) const { return counts_[c]; }

  // Draws the states on a timeline track (busy and waiting spans; idle is not drawn).
  void draw_on(Timeline* timeline, uint32_t track) { timeline_ = timeline, track_ = track; }

 private:
  // Accounted in one go once this many reservations wait (a state that holds for
  // long keeps the list short).
  static constexpr size_t kBusyBacklog = 256;
  // A move dated ahead. Moves at one time may apply in any order: the counts after
  // them, and so the state, are the same.
  struct Dated {
    uint64_t at;
    Counter from, to;
    bool operator>(const Dated& o) const { return at > o.at; }
  };
  // The state the counts give when the pipeline is not busy: bit b of waiting_ is
  // set while the condition of the b-th state of the priority list holds
  // (kStateOfBit), and the first set bit decides.
  static constexpr CycleBucket kStateOfBit[] = {
      CycleBucket::WaitingDram, CycleBucket::WaitingL2, CycleBucket::WaitingNoc, CycleBucket::WaitingL1,
      CycleBucket::Blocked,     CycleBucket::WaitingIst,
      CycleBucket::Latency};  // none of them: the unit's own pipeline
  static constexpr uint8_t kBitOf[kCounters] = {0xff, 3, 2, 1, 0, 4, 5};  // by Counter
  CycleBucket state() const {
    if (counts_[Resident] == 0) return CycleBucket::Idle;
    return kStateOfBit[__builtin_ctz(uint32_t(waiting_) | 0x40u)];
  }
  void apply(uint64_t now, Counter counter, int delta) {
    const uint32_t before = counts_[counter];
    const uint32_t n = counts_[counter] = before + uint32_t(delta);
    if ((before == 0) != (n == 0)) condition_flipped(now, counter, n != 0);
  }
  // A condition starts (holds) or ends: the state may change.
  __attribute__((noinline)) void condition_flipped(uint64_t now, Counter counter, bool holds);
  void date(uint64_t at, Counter from, Counter to);
  void add_reservation(uint64_t now, uint64_t start, uint64_t end);  // a new interval
  void apply_dated(uint64_t now);
  void catch_up(uint64_t now);  // every dated change up to now, and the accounting to now
  void switch_state(uint64_t at, CycleBucket next);  // accounts up to `at` in the old state
  void account(uint64_t until);  // [last_, until) in state_, busy where reserved
  void add(CycleBucket bucket, uint64_t from, uint64_t to);
  void draw_open_span(uint64_t end);

  bool off_ = false;
  std::array<uint32_t, kCounters> counts_{};
  uint8_t waiting_ = 0;                      // the conditions that hold, by kStateOfBit
  CycleBucket state_ = CycleBucket::Idle;    // the non-busy state since last_
  std::vector<Dated> dated_;  // a min-heap
  uint64_t next_dated_ = UINT64_MAX;  // the earliest dated move's time (UINT64_MAX: none)
  std::vector<std::pair<uint64_t, uint64_t>> busy_;  // reservations not yet accounted
  size_t busy_head_ = 0;
  uint64_t busy_end_ = 0;  // where the latest reservation ends
  uint64_t last_ = 0;  // accounted up to here
  CycleSplit ps_{};
  Timeline* timeline_ = nullptr;
  uint32_t track_ = 0;
  CycleBucket open_ = CycleBucket::Idle;  // the timeline span being drawn
  uint64_t open_since_ = 0;
};

}  // namespace rtsim::sim
