#pragma once
// DRAM timing model, free of any simulation kernel so that the event-driven
// SystemC memory, the loosely-timed memory and the microbenchmark tests drive the
// same code. docs/dram.md describes what it models and where the numbers come from.
//
// Built of parts, as DRAMSys builds a controller (each in model/src/sim/dram/):
//   address_map.h  where an address lives (channel, rank, bank group, bank, row, column)
//   device.h       the bank state machines, the rank/group/bus rules, the commands, the
//                  timeout page policy's proposals
//   refresh.h      the refresh manager (all-bank REF per rank every tREFI, staggered)
//   scheduler.h    FR-FCFS over a channel's queue, read/write drain watermarks
//   DramModel      the controller: per-channel bounded queues and back-pressure, one
//                  decision per command from the parts' proposals, the loosely-timed
//                  path, request counts, latency histograms and the stats
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
//   and advance() makes the scheduler's decisions;
// - the loosely-timed level asks lt_access() for one request at a time, answered at
//   once and served first come first served per channel with the same bank state and
//   rules: data in the order of the calls, never before an earlier call's arrival;
//   a later request's precharge/activate may take a free command slot before an
//   earlier one's column command, as a controller overlaps banks.
// A model serves one of the two ways, not both.
// Refreshes and timeout precharges that fall into idle time are applied lazily, by
// simulated time, when the channel is next used.
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/dram/address_map.h>
#include <rtsim/model/sim/dram/device.h>
#include <rtsim/model/sim/dram/protocol.h>
#include <rtsim/model/sim/dram/refresh.h>
#include <rtsim/model/sim/dram/scheduler.h>
#include <rtsim/model/sim/stats.h>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace rtsim::sim {

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
    device_.set_command_observer(std::move(observer));
  }
  // Sees every request that reaches the model (enqueue, lt_access, count_access), in
  // the order they reach it.
  void set_request_observer(std::function<void(const DramRequestRecord&)> observer) {
    request_observer_ = std::move(observer);
  }
  const DramAddressMap& address_map() const { return map_; }

  uint64_t latency_ps(RowOutcome outcome) const;  // isolated read from a DRAM clock edge
  uint64_t transfer_ps() const { return device_.timings().transfer; }  // tBURST of one access
  double peak_bytes_per_second() const;
  uint32_t access_bytes() const { return access_bytes_; }
  const DramConfig& config() const { return config_; }

  using Counters = DramCounters;
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
  // The controller's own state of a channel.
  struct Channel {
    DramQueue queue;
    uint64_t next_decision_ps = UINT64_MAX;
    DramCandidate choice;       // the last decision, valid until the state changes
    bool choice_valid = false;
    uint64_t lt_latest_ps = 0;  // lt: the latest arrival seen
    uint32_t lt_calls_since_prune = 0;
  };
  // The best command on channel c and its time. requests: queued requests take part
  // (else only refreshes and timeout precharges); refreshes due and timeouts expiring
  // after their horizon are left out.
  DramCandidate decide(uint32_t c, bool requests);
  DramCandidate decide_until(uint32_t c, bool requests, uint64_t refresh_horizon,
                             uint64_t timeout_horizon);
  void execute(uint32_t c, const DramCandidate& choice, std::vector<DramCompletion>& issued);
  // Makes the decisions due before `until` (inclusive).
  void run(uint32_t c, uint64_t until, std::vector<DramCompletion>& issued);
  void count_request(bool write, RowOutcome outcome, uint64_t latency_ps);

  DramConfig config_;
  DramAddressMap map_;
  PagePolicy policy_;
  uint32_t access_bytes_;
  Counters counters_;  // before the device, which counts its commands into it
  DramDevice device_;
  DramRefreshManager refresh_;
  FrFcfsScheduler scheduler_;
  std::vector<Channel> channels_;
  std::vector<DramCompletion> pending_completions_;  // issued while catching up in enqueue
  std::function<void(const DramRequestRecord&)> request_observer_;
  std::vector<uint64_t> read_histogram_ns_, write_histogram_ns_;  // last bucket: above
};

}  // namespace rtsim::sim
