#pragma once
// The scheduler of the queued (cycle-level) path: FR-FCFS over one channel's queue.
// In the direction being served, row hits first (each bank's oldest), then row
// commands (PRE for a conflict, ACT) for each bank's oldest request, unless a request
// of that direction still hits the bank's open row. Reads are served before writes
// until writes fill the queue to the high watermark; then writes drain to the low one
// (below it they also go while no read waits). A row activated for a request of the
// other direction is finished first, so that no activate is closed unused. Nothing new
// goes to a rank from its refresh due time on.
#include <rtsim/model/sim/dram/device.h>
#include <rtsim/model/sim/dram/refresh.h>

#include <cstdint>
#include <vector>

namespace rtsim::sim {

// A request in a channel's queue.
struct DramPending {
  DramRequest request;
  DramAddress where;
  uint64_t ready_ps;  // first DRAM clock edge at or after the enqueue time
  RowOutcome outcome = RowOutcome::Hit;
};

// One channel's queue (the controller's), reads and writes together, enqueue order.
struct DramQueue {
  std::vector<DramPending> entries;
  uint32_t reads = 0, writes = 0;
};

class FrFcfsScheduler {
 public:
  FrFcfsScheduler(const DramConfig& config, uint32_t channels, size_t banks_per_channel);
  // A new decision on channel c: what the last one saw of its banks is forgotten.
  void begin(uint32_t c);
  // The queue's best command (offered to `best`).
  void offer_requests(DramDevice& device, DramDevice::Channel& ch, const DramQueue& queue,
                      const DramRefreshManager& refresh, DramCandidate& best);
  // Since begin(c): whether a queued request, of either direction, hits the bank's open row.
  bool has_queued_hit(uint32_t c, size_t bank) const {
    const State& s = channels_[c];
    return s.any_hit_mark[bank] == s.stamp;
  }

 private:
  struct State {
    bool draining_writes = false;
    bool drain_to_low = false;  // the drain started at the high watermark
    // Per-decision marks (bank -> stamp), so no clearing or allocation per decision.
    std::vector<uint32_t> active_hit_mark, any_hit_mark, column_mark, row_mark;
    uint32_t stamp = 0;
  };
  void update_drain_mode(State& s, const DramQueue& queue) const;
  uint32_t drain_high_, drain_low_;  // writes queued
  std::vector<State> channels_;
};

}  // namespace rtsim::sim
