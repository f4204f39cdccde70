#pragma once
// DRAM timing model, free of any simulation kernel so that the event-driven
// SystemC memory and the microbenchmark tests drive the same code.
//
// Channels x ranks x banks, each bank with its open row. A read of one access
// (an L2 line) costs, from the moment it is issued to the bank:
//   row hit   tCL + tBURST
//   closed    tRCD + tCL + tBURST
//   conflict  tRP + tRCD + tCL + tBURST   (tRP waits for tRAS after the activate)
// where tBURST = bursts per access x burst_cycles. Each channel has one data bus,
// busy tBURST per access, and a bounded request queue scheduled FR-FCFS: row
// commands (precharge/activate) for a bank's oldest waiting request go out at once
// unless a queued request still hits the bank's open row, so they overlap other
// banks' transfers; a column read is issued at the latest moment that still keeps
// the data bus busy, the oldest request with an open row first.
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/stats.h>

#include <cstdint>
#include <string>
#include <vector>

namespace rtsim::sim {

struct DramAddress {
  uint32_t channel = 0, rank = 0, bank = 0, column = 0;
  uint64_t row = 0;
};

class DramAddressMap {
 public:
  DramAddressMap(const DramConfig& config, uint32_t access_bytes);
  DramAddress decode(uint64_t address) const;

 private:
  struct Field {
    int which;  // 0 row, 1 rank, 2 bank, 3 column, 4 channel
    uint32_t shift, bits;
  };
  std::vector<Field> fields_;
  uint32_t offset_bits_;
};

enum class RowOutcome : uint8_t { Hit = 0, Closed = 1, Conflict = 2 };

struct DramRequest {
  uint64_t address = 0;
  uint64_t arrival_ps = 0;
  uint64_t tag = 0;  // the caller's id, returned with the completion
  bool write = false;
};

struct DramCompletion {
  uint64_t tag = 0;
  uint64_t done_ps = 0;  // last data beat delivered
  RowOutcome outcome = RowOutcome::Hit;
};

class DramModel {
 public:
  // access_bytes: bytes of one read (the L2 line).
  DramModel(const DramConfig& config, uint32_t access_bytes);

  uint32_t channel_of(uint64_t address) const { return map_.decode(address).channel; }
  bool can_accept(uint64_t address) const;
  void enqueue(const DramRequest& request);  // precondition: can_accept
  // Issues every request whose time has come at now_ps; appends their completions
  // (done_ps >= now_ps) in issue order.
  void advance(uint64_t now_ps, std::vector<DramCompletion>& issued);
  // Earliest time advance() has something to do; UINT64_MAX when every queue is empty.
  uint64_t next_decision_ps() const;
  bool idle() const;

  // Loosely timed access: a fixed closed-row latency, and the channel's data bus
  // reserved for tBURST so that a stream never exceeds the peak bandwidth.
  // window_ps: requests may arrive out of time order by up to this much (the lt
  // quantum); they may then take a bus slot that far before the reservation end.
  uint64_t lt_access(uint64_t address, bool write, uint64_t now_ps);
  // Functional level: counts the access, no time.
  void count_access(uint64_t address, bool write);
  void reset_counters() { counters_ = Counters{}; }

  uint64_t latency_ps(RowOutcome outcome) const;  // isolated access
  uint64_t transfer_ps() const { return transfer_ps_; }
  double peak_bytes_per_second() const;
  uint32_t access_bytes() const { return access_bytes_; }

  struct Counters {
    uint64_t reads = 0, bytes = 0;
    uint64_t row_hits = 0, row_closed = 0, row_conflicts = 0;
    uint64_t latency_sum_ps = 0, latency_max_ps = 0;
    uint64_t bus_busy_ps = 0;
    uint64_t queue_full_rejections = 0;
  };
  const Counters& counters() const { return counters_; }
  void note_rejection() { ++counters_.queue_full_rejections; }
  // Latency percentile from a 1 ns histogram (exact below 16 us).
  double latency_percentile_ns(double fraction) const;
  // Writes <prefix>.reads, .bytes, .row_hits, ... into stats. timed: row and latency
  // figures are meaningful (cycle/lt), sim_ps: simulated time for bandwidth.
  void report(StatsRegistry& stats, const std::string& prefix, bool row_timing, bool timed,
              uint64_t sim_ps) const;

 private:
  struct Bank {
    int64_t open_row = -1;
    uint64_t act_ps = 0;        // last activate
    uint64_t col_ready_ps = 0;  // earliest next column command
    uint64_t act_ready_ps = 0;  // earliest next activate
  };
  struct Pending {
    DramRequest request;
    DramAddress where;
    bool prepared = false;  // its row is open (or being opened) for it
    RowOutcome outcome = RowOutcome::Hit;
  };
  struct Channel {
    std::vector<Bank> banks;
    std::vector<Pending> queue;  // arrival order
    uint64_t bus_free_ps = 0;
    uint64_t command_free_ps = 0;
    uint64_t next_decision_ps = UINT64_MAX;
  };
  void prepare_rows(Channel& ch, uint64_t now);
  void schedule(Channel& ch, uint64_t now, std::vector<DramCompletion>& issued);
  void record_latency(uint64_t latency_ps);

  DramConfig config_;
  DramAddressMap map_;
  uint32_t access_bytes_;
  uint64_t tck_, transfer_ps_;
  std::vector<Channel> channels_;
  Counters counters_;
  std::vector<uint64_t> latency_histogram_ns_;  // last bucket collects everything above
};

}  // namespace rtsim::sim
