#pragma once
// DRAM timing model, free of any simulation kernel so that the event-driven
// SystemC memory, the loosely-timed memory and the microbenchmark tests drive the
// same code. docs/dram.md describes what it models and where the numbers come from.
//
// Channels x ranks x bank groups x banks, each bank with its open row. Commands
// (ACT, PRE, RD, WR, REF) go out on a per-channel command bus, one per tCK at DRAM
// clock edges, each at the earliest time every rule allows: tRCD, tRP, tRAS, tRRD_S/L,
// tFAW, tCCD_S/L, tWTR_S/L, tWR, tRTP, the data bus with its turnaround gap (tRTRS)
// and all-bank refresh (every tREFI per rank, rank blocked tRFC). An access of one
// L2 line is one column command of ceil(line / burst_bytes) bursts: it holds the data
// bus for tBURST = bursts x burst_cycles and its bank group's column path for
// bursts x tCCD_L (bursts x tCCD_S for the rank).
//
// Two ways in:
// - the cycle level queues requests (bounded per channel, reads and writes together)
//   and advance() makes FR-FCFS decisions: row hits of the serviced direction first,
//   oldest first, then row commands for each bank's oldest request; reads are served
//   before writes until writes fill the queue to the high watermark, then writes drain
//   to the low one (or while no read waits);
// - the loosely-timed level asks lt_access() for one request at a time, answered at
//   once and served first come first served per channel with the same bank state and
//   rules: data in the order of the calls, never before an earlier call's arrival;
//   a later request's precharge/activate may take a free command slot before an
//   earlier one's column command, as a controller overlaps banks.
// A model serves one of the two ways, not both.
// Refreshes and timeout precharges that fall into idle time are applied lazily, by
// simulated time, when the channel is next used.
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/stats.h>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace rtsim::sim {

struct DramAddress {
  uint32_t channel = 0, rank = 0;
  uint32_t bank_group = 0;
  uint32_t bank = 0;  // within the rank, 0 .. banks-1; bank_group = bank / banks_per_group
  uint32_t column = 0;
  uint64_t row = 0;
};

// dram.address_mapping's field names, most significant first ("row:rank:...:channel").
std::vector<std::string> dram_mapping_fields(const std::string& mapping);
// Bits that hold `values` distinct values (0 for 1): a field's width in a bit-field mapping.
uint32_t dram_field_bits(uint64_t values);

class DramAddressMap {
 public:
  DramAddressMap(const DramConfig& config, uint32_t access_bytes);
  DramAddress decode(uint64_t address) const;

 private:
  enum Which : uint8_t { Row, Rank, Bank, Column, Channel, BankGroup };
  struct Field {
    Which which;
    uint64_t radix;  // values the field takes (0: all that is left)
  };
  std::vector<Field> fields_;
  uint32_t offset_bits_;
  uint32_t banks_per_group_;
  bool group_field_ = false;  // without one, the group is the bank number's top bits
};

enum class RowOutcome : uint8_t { Hit = 0, Closed = 1, Conflict = 2 };
enum class PagePolicy : uint8_t { Open, Closed, Timeout };
PagePolicy parse_page_policy(const std::string& name);  // throws InputError naming dram.page_policy

struct DramRequest {
  uint64_t address = 0;
  // When the requester FIRST tried to send it; earlier than the enqueue time when a
  // full queue held it back. Latency is measured from here.
  uint64_t arrival_ps = 0;
  uint64_t tag = 0;  // the caller's id, returned with the completion
  bool write = false;
};

struct DramCompletion {
  uint64_t tag = 0;
  uint64_t done_ps = 0;  // last data beat on the bus (reads: delivered, writes: written)
  RowOutcome outcome = RowOutcome::Hit;
  bool write = false;
};

// One request as it reaches the DRAM, for request traces (memory_trace.h).
struct DramRequestRecord {
  uint64_t time_ps = 0;  // when the requester first tried to send it (functional level: 0)
  uint64_t address = 0;
  bool write = false;
  DramAddress where;  // the address map's decode of it
};

enum class DramCommandKind : uint8_t { Activate, Precharge, Read, Write, Refresh };
const char* dram_command_name(DramCommandKind kind);  // "ACT", "PRE", "RD", "WR", "REF"

// One command as the device sees it. Refresh is per rank (bank_group, bank, row 0).
// Commands reach the observer when decided. On the queued path that is time order per
// channel, except that an auto-precharge (closed page policy, not on the command bus)
// is reported with its column command while carrying its own, later, time; the lt
// path places commands ahead, so sort by time to replay a log.
struct DramCommand {
  DramCommandKind kind = DramCommandKind::Activate;
  uint64_t time_ps = 0;
  uint32_t channel = 0, rank = 0, bank_group = 0, bank = 0;  // bank within the rank
  uint64_t row = 0;
};

class DramModel {
 public:
  // access_bytes: bytes of one access (the L2 line).
  DramModel(const DramConfig& config, uint32_t access_bytes);

  // ---- cycle level: bounded queues and FR-FCFS decisions
  uint32_t channel_of(uint64_t address) const { return map_.decode(address).channel; }
  bool can_accept(uint64_t address) const;
  // Precondition: can_accept. now_ps: the enqueue time (>= the previous advance time);
  // the request takes part in decisions from the DRAM clock edge at or after it.
  void enqueue(const DramRequest& request, uint64_t now_ps);
  // Enqueued at its arrival time (it was not held back).
  void enqueue(const DramRequest& request) { enqueue(request, request.arrival_ps); }
  // Enqueues when there is room, else counts the refusal; returns whether it went in.
  bool try_enqueue(const DramRequest& request, uint64_t now_ps);
  void note_rejection() { ++counters_.queue_full_refusals; }  // a refusal seen by the caller
  // Makes every decision due at or before now_ps; appends the completions of the
  // column commands issued (done_ps >= their issue time), in issue order. Writes
  // complete too (posted: the requester need not wait for them).
  void advance(uint64_t now_ps, std::vector<DramCompletion>& issued);
  // Earliest time advance() has something to do; UINT64_MAX when every queue is empty.
  uint64_t next_decision_ps() const;
  bool idle() const;  // every queue empty (idle-time refreshes are applied lazily)
  // Applies the refreshes and timeout precharges of idle time up to now_ps, so that
  // counters cover them (e.g. before report() at the end of a run).
  void settle(uint64_t now_ps);

  // ---- loosely timed: one request at a time, answered at once, FCFS per channel.
  // Calls should come in (nearly) non-decreasing now_ps; returns the time its last
  // data beat is on the bus.
  // `outcome`, if given, says whether the request found its row open, closed or another open.
  uint64_t lt_access(uint64_t address, bool write, uint64_t now_ps, RowOutcome* outcome = nullptr);
  // ---- functional level: counts the access, no time (write defaults to a read, as
  // the functional memory only reads today).
  void count_access(uint64_t address, bool write = false);

  void set_command_observer(std::function<void(const DramCommand&)> observer) {
    observer_ = std::move(observer);
  }
  // Sees every request that reaches the model (enqueue, lt_access, count_access), in
  // the order they reach it.
  void set_request_observer(std::function<void(const DramRequestRecord&)> observer) {
    request_observer_ = std::move(observer);
  }
  const DramAddressMap& address_map() const { return map_; }

  uint64_t latency_ps(RowOutcome outcome) const;  // isolated read from a DRAM clock edge
  uint64_t transfer_ps() const { return transfer_ps_; }  // tBURST of one access
  double peak_bytes_per_second() const;
  uint32_t access_bytes() const { return access_bytes_; }
  const DramConfig& config() const { return config_; }

  struct Counters {
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
  const Counters& counters() const { return counters_; }
  // A reference model (dram_reference.h) served the requests: its requests and
  // commands go into these counters so that report() and energy read them as ours.
  void count_reference_request(bool write, uint64_t latency_ps) {
    count_request(write, RowOutcome::Closed, latency_ps);
  }
  void set_reference_commands(uint64_t row_hits, uint64_t activates, uint64_t precharges,
                              uint64_t refreshes, uint64_t bus_busy_ps);
  // Writes: the reference answers them at once (posted) and measures their wait to the
  // write command itself; latencies (ps) with their counts replace ours.
  void set_reference_write_latencies(const std::vector<std::pair<uint64_t, uint64_t>>& latency_count);
  // Clears counters and latency histograms; bank, row, refresh and queue state stay
  // (statistics of the last of several frames).
  void reset_counters();
  // Latency percentile from a 1 ns histogram (exact below 16 us), of reads or writes.
  double latency_percentile_ns(double fraction, bool write = false) const;
  // Writes <prefix>.reads, .bytes, .writes, .row_hits, ... into stats. row_timing: row
  // and command figures are meaningful (cycle/lt), timed: latency and bandwidth are
  // (cycle/lt); sim_ps: simulated time for bandwidth.
  void report(StatsRegistry& stats, const std::string& prefix, bool row_timing, bool timed,
              uint64_t sim_ps) const;

 private:
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
    uint64_t refresh_due_ps = UINT64_MAX;
    uint64_t refresh_end_ps = 0;       // REF + tRFC
    std::vector<std::pair<uint64_t, uint32_t>> lt_acts;  // lt: activates placed (time, group), sorted
  };
  struct Pending {
    DramRequest request;
    DramAddress where;
    uint64_t ready_ps;  // first DRAM clock edge at or after the enqueue time
    RowOutcome outcome = RowOutcome::Hit;
  };
  enum class Action : uint8_t { Column, Activate, Precharge, Refresh };
  struct Choice {
    uint64_t time_ps = UINT64_MAX;
    uint8_t priority = 255;  // lower first among commands legal at the same edge
    size_t age = SIZE_MAX;   // queue position
    Action action = Action::Column;
    uint32_t rank = 0, bank = 0;  // bank within the rank
    bool conflict = false;        // a precharge for a request needing another row
  };

  struct Channel {
    uint32_t index = 0;
    std::vector<Bank> banks;    // rank x banks
    std::vector<Group> groups;  // rank x bank groups
    std::vector<Rank> ranks;
    std::vector<Pending> queue;  // enqueue order
    uint32_t reads_queued = 0, writes_queued = 0;
    bool draining_writes = false;
    bool drain_to_low = false;     // the drain started at the high watermark
    uint64_t command_free_ps = 0;  // next free command-bus slot (queued path)
    std::vector<uint64_t> reserved_slots;  // lt: command-bus slots taken, sorted
    uint64_t lt_latest_ps = 0;              // lt: the latest arrival seen
    uint32_t lt_calls_since_prune = 0;
    // lt: column commands placed, sorted by time. A request's column takes the
    // earliest time its bank allows at which the data bus, tCCD and tWTR allow it
    // among these, before or after columns placed earlier: banks serve in parallel
    // (a row miss on one bank does not hold up a hit on another), as an FR-FCFS
    // controller lets them, while each bank keeps its own order.
    struct ColumnUse {
      uint64_t time_ps;
      uint32_t rank, group;
      bool write;
    };
    std::vector<ColumnUse> lt_columns;
    uint64_t bus_free_ps = 0;      // data bus
    bool bus_used = false, bus_last_write = false;
    uint32_t bus_last_rank = 0;
    uint64_t next_decision_ps = UINT64_MAX;
    Choice choice;              // the last decision, valid until the state changes
    bool choice_valid = false;
    // Per-decision marks (bank -> stamp), so no clearing or allocation per decision.
    std::vector<uint32_t> active_hit_mark, any_hit_mark, column_mark, row_mark;
    uint32_t stamp = 0;
  };
  uint64_t edge(uint64_t t) const { return (t + tck_ - 1) / tck_ * tck_; }
  Bank& bank_of(Channel& ch, uint32_t rank, uint32_t bank) {
    return ch.banks[size_t(rank) * config_.banks + bank];
  }
  Group& group_of(Channel& ch, uint32_t rank, uint32_t bank) {
    return ch.groups[size_t(rank) * config_.bank_groups + bank / banks_per_group_];
  }
  uint64_t earliest_activate(Channel& ch, uint32_t rank, uint32_t bank, uint64_t t);
  uint64_t earliest_precharge(Channel& ch, uint32_t rank, uint32_t bank, uint64_t t);
  uint64_t earliest_column(Channel& ch, uint32_t rank, uint32_t bank, bool write, uint64_t t);
  // lt: the first time >= t at which an activate fits among the rank's placed ones.
  uint64_t lt_activate_fit(const Rank& r, uint32_t group, uint64_t t) const;
  // lt: the first time >= t at which a column fits among the placed ones (or t).
  uint64_t lt_column_fit(const Channel& ch, uint32_t rank, uint32_t group, bool write,
                         uint64_t t) const;
  uint64_t earliest_refresh(Channel& ch, uint32_t rank, uint64_t t);
  // The first free command-bus slot at or after t, and taking it.
  uint64_t command_slot(const Channel& ch, uint64_t t) const;
  void take_command_slot(Channel& ch, uint64_t t);
  void activate(Channel& ch, uint32_t rank, uint32_t bank, uint64_t row, uint64_t t);
  void precharge(Channel& ch, uint32_t rank, uint32_t bank, uint64_t t, bool command_bus);
  uint64_t column(Channel& ch, uint32_t rank, uint32_t bank, bool write, uint64_t t);
  void refresh(Channel& ch, uint32_t rank, uint64_t t);
  void emit(DramCommandKind kind, uint64_t t, const Channel& ch, uint32_t rank, uint32_t bank,
            uint64_t row);

  void update_drain_mode(Channel& ch) const;
  // The best command and its time. requests: queued requests take part (else only
  // refreshes and timeout precharges); refreshes due and timeouts expiring after
  // their horizon are left out.
  Choice decide(Channel& ch, bool requests);
  Choice decide_until(Channel& ch, bool requests, uint64_t refresh_horizon,
                      uint64_t timeout_horizon);
  void consider(Choice& best, const Choice& c) const;
  // decide_until's three kinds of candidate, each offered to `best`: the queued
  // requests' column and row commands (FR-FCFS), the refreshes due, and the
  // timeout policy's precharges. `stamp` marks the banks seen this decision.
  void consider_requests(Channel& ch, uint32_t stamp, Choice& best);
  void consider_refreshes(Channel& ch, uint64_t refresh_horizon, Choice& best);
  void consider_page_timeouts(Channel& ch, uint32_t stamp, uint64_t timeout_horizon, Choice& best);
  void execute(Channel& ch, const Choice& c, std::vector<DramCompletion>& issued);
  // Makes the decisions due before `until` (inclusive).
  void run(Channel& ch, uint64_t until, std::vector<DramCompletion>& issued);
  void count_request(bool write, RowOutcome outcome, uint64_t latency_ps);

  DramConfig config_;
  DramAddressMap map_;
  PagePolicy policy_;
  uint32_t access_bytes_;
  uint32_t bursts_;  // per access
  uint32_t banks_per_group_;
  uint32_t drain_high_, drain_low_;  // writes queued
  bool lt_ = false;                  // driven by lt_access: commands are placed ahead
  // Timing in ps.
  uint64_t tck_, transfer_ps_, cl_, cwl_, rcd_, rcd_write_, rp_, ras_, rrd_s_, rrd_l_, faw_;
  uint64_t column_s_, column_l_;  // bursts x tCCD_S / tCCD_L
  uint64_t read_to_pre_, write_to_pre_, write_to_read_s_, write_to_read_l_, rtrs_;
  uint64_t refi_, rfc_, page_timeout_;
  std::vector<Channel> channels_;
  std::vector<DramCompletion> pending_completions_;  // issued while catching up in enqueue
  std::function<void(const DramCommand&)> observer_;
  std::function<void(const DramRequestRecord&)> request_observer_;
  Counters counters_;
  std::vector<uint64_t> read_histogram_ns_, write_histogram_ns_;  // last bucket: above
};

}  // namespace rtsim::sim
