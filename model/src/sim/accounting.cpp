#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/timeline.h>

#include <algorithm>
#include <cmath>
#include <functional>

namespace rtsim::sim {

const char* cycle_bucket_name(CycleBucket bucket) {
  switch (bucket) {
    case CycleBucket::Busy: return "busy";
    case CycleBucket::WaitingL1: return "waiting_l1";
    case CycleBucket::WaitingNoc: return "waiting_noc";
    case CycleBucket::WaitingL2: return "waiting_l2";
    case CycleBucket::WaitingDram: return "waiting_dram";
    case CycleBucket::Blocked: return "blocked";
    case CycleBucket::WaitingIst: return "waiting_ist";
    case CycleBucket::Latency: return "latency";
    case CycleBucket::Idle: return "idle";
  }
  return "?";
}

const char* cycle_bucket_meaning(CycleBucket bucket) {
  switch (bucket) {
    case CycleBucket::Busy: return "cycles the unit's pipeline accepted work";
    case CycleBucket::WaitingL1:
      return "cycles not busy with a read at the unit's L1 (port, hit latency, MSHR, fill) and none deeper";
    case CycleBucket::WaitingNoc:
      return "cycles not busy with an L1 miss on the crossbar and none at the L2 or DRAM";
    case CycleBucket::WaitingL2:
      return "cycles not busy with an L1 miss at an L2 slice (queued, tag check, fill) and none at the DRAM";
    case CycleBucket::WaitingDram: return "cycles not busy with an L2 miss of the unit's on its way from DRAM";
    case CycleBucket::Blocked:
      return "cycles not busy and waiting on no read while a ray waited for room in a full downstream queue";
    case CycleBucket::WaitingIst:
      return "cycles not busy, waiting on no read and not blocked while the unit's leaves were in its IST unit";
    case CycleBucket::Latency:
      return "cycles with work resident in the unit's own pipeline (results not out) and nothing else to wait on";
    case CycleBucket::Idle: return "cycles with no work resident";
  }
  return "?";
}

const UnitTraits& unit_traits(UnitKind kind) {
  using B = CycleBucket;
  static const UnitTraits trv{"trv", bucket_set({B::Busy, B::WaitingL1, B::WaitingNoc, B::WaitingL2, B::WaitingDram,
                                                 B::Blocked, B::WaitingIst, B::Latency, B::Idle})};
  static const UnitTraits ist{"ist", bucket_set({B::Busy, B::WaitingL1, B::WaitingNoc, B::WaitingL2, B::WaitingDram,
                                                 B::Latency, B::Idle})};
  static const UnitTraits shading{"shading", bucket_set({B::Busy, B::Latency, B::Idle})};
  switch (kind) {
    case UnitKind::Trv: return trv;
    case UnitKind::Ist: return ist;
    case UnitKind::Shading: return shading;
  }
  return trv;
}

CycleSplit bucket_cycles(const CycleSplit& ps, double cycle_ps) {
  CycleSplit out{};
  uint64_t sum_ps = 0, rounded_before = 0;
  for (int b = 0; b < kCycleBucketCount; ++b) {
    sum_ps += ps[size_t(b)];
    const uint64_t rounded = uint64_t(std::llround(double(sum_ps) / cycle_ps));
    out[size_t(b)] = rounded - rounded_before;
    rounded_before = rounded;
  }
  return out;
}

void UnitAccounting::date(uint64_t at, Counter from, Counter to) {
  dated_.push_back({at, from, to});
  std::push_heap(dated_.begin(), dated_.end(), std::greater<Dated>());
  next_dated_ = dated_.front().at;
}

void UnitAccounting::condition_flipped(uint64_t now, Counter counter, bool holds) {
  if (counter != Resident) {
    const uint8_t bit = uint8_t(1u << kBitOf[counter]);
    waiting_ = holds ? uint8_t(waiting_ | bit) : uint8_t(waiting_ & ~bit);
  }
  const CycleBucket next = state();
  if (next != state_) switch_state(now, next);
}

void UnitAccounting::add_reservation(uint64_t now, uint64_t start, uint64_t end) {
  busy_.emplace_back(start, end);
  busy_end_ = end;
  if (busy_.size() - busy_head_ > kBusyBacklog) catch_up(now);
}

void UnitAccounting::apply_dated(uint64_t now) {
  while (!dated_.empty() && dated_.front().at <= now) {
    const Dated d = dated_.front();
    std::pop_heap(dated_.begin(), dated_.end(), std::greater<Dated>());
    dated_.pop_back();
    if (d.from != kCounters) apply(d.at, d.from, -1);
    if (d.to != kCounters) apply(d.at, d.to, +1);
  }
  next_dated_ = dated_.empty() ? UINT64_MAX : dated_.front().at;
}

void UnitAccounting::switch_state(uint64_t at, CycleBucket next) {
  account(std::max(at, last_));  // a change dated before the last accounting applies from there
  state_ = next;
}

void UnitAccounting::account(uint64_t until) {
  while (last_ < until) {
    while (busy_head_ < busy_.size() && busy_[busy_head_].second <= last_) ++busy_head_;
    if (busy_head_ == busy_.size()) {
      busy_.clear(), busy_head_ = 0;
      add(state_, last_, until);
      last_ = until;
      return;
    }
    const auto [start, end] = busy_[busy_head_];
    const bool busy = start <= last_;
    const uint64_t to = std::min(until, busy ? end : start);
    add(busy ? CycleBucket::Busy : state_, last_, to);
    last_ = to;
  }
  if (busy_head_ > kBusyBacklog) busy_.erase(busy_.begin(), busy_.begin() + ptrdiff_t(busy_head_)), busy_head_ = 0;
}

void UnitAccounting::add(CycleBucket bucket, uint64_t from, uint64_t to) {
  ps_[size_t(bucket)] += to - from;
  if (!timeline_ || bucket == open_) return;
  draw_open_span(from);
  open_ = bucket, open_since_ = from;
}

void UnitAccounting::draw_open_span(uint64_t end) {
  if (open_ != CycleBucket::Idle && end > open_since_)
    timeline_->span(track_, cycle_bucket_name(open_), open_since_, end);
}

void UnitAccounting::catch_up(uint64_t now) {
  apply_dated(now);
  account(std::max(now, last_));
}

void UnitAccounting::restart(uint64_t t) {
  catch_up(t);
  ps_ = CycleSplit{};
}

void UnitAccounting::finish(uint64_t end) {
  catch_up(end);
  if (timeline_) {
    draw_open_span(last_);
    open_ = CycleBucket::Idle;
  }
}

}  // namespace rtsim::sim
