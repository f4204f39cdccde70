#pragma once
// The DRAM device as its controller sees it, channel by channel: the bank state
// machines (each bank's open row and when each command may next go to it), the rules
// between the banks of a bank group and of a rank (tRRD_S/L, tFAW, tCCD_S/L, tWTR_S/L),
// the command bus and the data bus (tBURST, tRTRS). It answers when a command is legal
// (earliest_*) and carries commands out (activate, precharge, column, refresh), each
// reported to the command observer and counted. It chooses nothing: the scheduler, the
// refresh manager and the page policy propose, the controller (DramModel) issues.
//
// Commands are placed one of two ways:
// - in order (the cycle level's queued path): each after the channel's previous one;
// - ahead (the loosely-timed path, place_ahead()): at the earliest time the rules allow
//   among the commands already placed, before or after them, by calendars of the
//   activates, column commands and command-bus slots taken, so that banks serve in
//   parallel as a reordering controller lets them.
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/dram/protocol.h>

#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

namespace rtsim::sim {

// A part's timings in picoseconds, for accesses of one L2 line each.
struct DramTimings {
  DramTimings(const DramConfig& config, uint32_t access_bytes);
  uint64_t edge(uint64_t t) const { return (t + tck - 1) / tck * tck; }  // next DRAM clock edge

  uint32_t bursts;  // per access: ceil(line / burst_bytes)
  uint32_t banks_per_group;
  uint64_t tck, transfer;  // transfer: tBURST of one access
  uint64_t cl, cwl, rcd, rcd_write, rp, ras, rrd_s, rrd_l, faw;
  uint64_t column_s, column_l;  // bursts x tCCD_S / tCCD_L
  uint64_t read_to_pre, write_to_pre, write_to_read_s, write_to_read_l, rtrs;
  uint64_t refi, rfc, page_timeout;
};

// What the DRAM did: requests (the controller counts them) and commands (the device).
struct DramCounters {
  uint64_t reads = 0, writes = 0;
  uint64_t bytes = 0, bytes_written = 0;  // bytes: read from DRAM
  uint64_t row_hits = 0, row_closed = 0, row_conflicts = 0;  // reads and writes
  uint64_t activates = 0, precharges = 0, refreshes = 0;
  uint64_t turnarounds = 0;  // data bus switched between reading and writing
  uint64_t queue_full_refusals = 0;
  uint64_t bus_busy_ps = 0;
  uint64_t read_latency_sum_ps = 0, read_latency_max_ps = 0;
  uint64_t write_latency_sum_ps = 0, write_latency_max_ps = 0;
};

class DramDevice {
 public:
  struct Bank {
    int64_t open_row = -1;
    uint64_t read_ready_ps = 0;   // activate + tRCD
    uint64_t write_ready_ps = 0;  // activate + tRCDWR
    uint64_t pre_ready_ps = 0;    // tRAS, tRTP, write recovery
    uint64_t act_ready_ps = 0;    // precharge + tRP
    uint64_t last_use_ps = 0;     // last activate or column command (timeout policy)
    bool conflict_pending = false;  // precharged for a request needing another row
    // Activated for a request of this direction (0 read, 1 write) whose column command
    // has not issued yet; -1 once one has (or the row closed).
    int8_t opened_for = -1;
    // lt, closed policy: the column command after which the row auto-precharges unless
    // the bank's next request hits it and arrived by then (UINT64_MAX: none pending).
    uint64_t auto_close_after_ps = UINT64_MAX;
  };
  struct Group {
    uint64_t column_ready_ps = 0;      // tCCD_L
    uint64_t activate_ready_ps = 0;    // tRRD_L
    uint64_t read_after_write_ps = 0;  // tWTR_L
  };
  struct Rank {
    uint64_t column_ready_ps = 0;      // tCCD_S
    uint64_t activate_ready_ps = 0;    // tRRD_S
    uint64_t read_after_write_ps = 0;  // tWTR_S
    uint64_t recent_acts_ps[4] = {0, 0, 0, 0};  // ring of the last four activates (tFAW)
    uint32_t oldest_act = 0;
    uint32_t acts_seen = 0;            // activates so far, up to 4
    uint64_t refresh_end_ps = 0;       // REF + tRFC
    std::vector<std::pair<uint64_t, uint32_t>> lt_acts;  // placed ahead: activates (time, group), sorted
  };
  // Placed ahead: a column command, by time. A request's column takes the earliest time
  // its bank allows at which the data bus, tCCD and tWTR allow it among these.
  struct ColumnUse {
    uint64_t time_ps;
    uint32_t rank, group;
    bool write;
  };
  struct Channel {
    uint32_t index = 0;
    std::vector<Bank> banks;    // rank x banks
    std::vector<Group> groups;  // rank x bank groups
    std::vector<Rank> ranks;
    uint64_t command_free_ps = 0;          // in order: the next free command-bus slot
    std::vector<uint64_t> reserved_slots;  // ahead: command-bus slots taken, sorted
    std::vector<ColumnUse> lt_columns;     // ahead: sorted by time
    uint64_t bus_free_ps = 0;              // data bus
    bool bus_used = false, bus_last_write = false;
    uint32_t bus_last_rank = 0;
  };

  // counters: where the device counts its commands (the controller's figures).
  DramDevice(const DramConfig& config, uint32_t access_bytes, DramCounters& counters);
  DramDevice(const DramDevice&) = delete;
  DramDevice& operator=(const DramDevice&) = delete;

  const DramTimings& timings() const { return t_; }
  uint32_t channels() const { return uint32_t(channels_.size()); }
  Channel& channel(uint32_t c) { return channels_[c]; }
  const Channel& channel(uint32_t c) const { return channels_[c]; }
  uint32_t ranks() const { return ranks_; }
  uint32_t banks() const { return banks_; }  // per rank
  Bank& bank_state(Channel& ch, uint32_t rank, uint32_t bank) { return ch.banks[size_t(rank) * banks_ + bank]; }
  // From now on commands are placed ahead (the loosely-timed path).
  void place_ahead() { ahead_ = true; }
  bool placed_ahead() const { return ahead_; }

  // The earliest time at or after t at which the command is legal.
  uint64_t earliest_activate(Channel& ch, uint32_t rank, uint32_t bank, uint64_t t);
  uint64_t earliest_precharge(Channel& ch, uint32_t rank, uint32_t bank, uint64_t t);
  uint64_t earliest_column(Channel& ch, uint32_t rank, uint32_t bank, bool write, uint64_t t);
  uint64_t earliest_refresh(Channel& ch, uint32_t rank, uint64_t t);  // every bank closed

  // The commands, at time t (legal by the above).
  void activate(Channel& ch, uint32_t rank, uint32_t bank, uint64_t row, uint64_t t);
  // command_bus false: an auto-precharge, which takes no command-bus slot.
  void precharge(Channel& ch, uint32_t rank, uint32_t bank, uint64_t t, bool command_bus);
  uint64_t column(Channel& ch, uint32_t rank, uint32_t bank, bool write, uint64_t t);  // last data beat
  void refresh(Channel& ch, uint32_t rank, uint64_t t);

  // The timeout page policy's proposals: an open row unused for page_timeout closes,
  // unless a queued request hits it (has_queued_hit(bank index in the channel)); rows
  // whose deadline lies after `horizon` are left alone.
  template <class QueuedHit>
  void offer_page_timeouts(Channel& ch, uint64_t horizon, const QueuedHit& has_queued_hit,
                           DramCandidate& best);

  // Placed ahead: calendar entries before `oldest` are never asked for again.
  void forget_before(Channel& ch, uint64_t oldest);

  void set_command_observer(std::function<void(const DramCommand&)> observer) {
    observer_ = std::move(observer);
  }

 private:
  Group& group_of(Channel& ch, uint32_t rank, uint32_t bank) {
    return ch.groups[size_t(rank) * bank_groups_ + bank / t_.banks_per_group];
  }
  // Placed ahead: the first time >= t at which an activate fits among the rank's
  // placed ones, and a column among the channel's.
  uint64_t activate_fit(const Rank& r, uint32_t group, uint64_t t) const;
  uint64_t column_fit(const Channel& ch, uint32_t rank, uint32_t group, bool write, uint64_t t) const;
  // The first free command-bus slot at or after t, and taking it.
  uint64_t command_slot(const Channel& ch, uint64_t t) const;
  void take_command_slot(Channel& ch, uint64_t t);
  void emit(DramCommandKind kind, uint64_t t, const Channel& ch, uint32_t rank, uint32_t bank,
            uint64_t row);

  DramTimings t_;
  uint32_t ranks_, banks_, bank_groups_;  // banks and bank groups per rank
  bool ahead_ = false;
  std::vector<Channel> channels_;
  DramCounters* counters_;
  std::function<void(const DramCommand&)> observer_;
};

template <class QueuedHit>
void DramDevice::offer_page_timeouts(Channel& ch, uint64_t horizon, const QueuedHit& has_queued_hit,
                                     DramCandidate& best) {
  for (uint32_t r = 0; r < ranks_; ++r)
    for (uint32_t b = 0; b < banks_; ++b) {
      const size_t index = size_t(r) * banks_ + b;
      const Bank& k = ch.banks[index];
      if (k.open_row < 0 || has_queued_hit(index)) continue;
      const uint64_t deadline = k.last_use_ps + t_.page_timeout;
      if (deadline > horizon || deadline > best.time_ps) continue;
      DramCandidate c;
      c.time_ps = earliest_precharge(ch, r, b, deadline);
      c.priority = 3, c.action = DramCandidate::Action::Precharge, c.rank = r, c.bank = b;
      keep_best(best, c);
    }
}

}  // namespace rtsim::sim
