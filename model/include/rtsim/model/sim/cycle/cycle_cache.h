#pragma once
// Cycle level cache (an L1 or the L2): TLM-2.0 approximately-timed target and
// initiator. A request is served at its next free port slot (cache.ports per
// cycle); a hit completes on the forward path with the hit latency annotated.
// Read misses hold an MSHR; reads of a line already missing merge into it; with
// every MSHR busy a request waits (back-pressure) until a fill frees one. A fill
// installs the line fill_latency after the next level's data arrives. Writes
// (stack spills, write-backs from above) are write-allocate without a fill; a
// dirty line that leaves goes down as a write. Everything this cache sends down
// leaves in order through one outbound queue: when the next level refuses a
// request (a full DRAM queue: BEGIN_REQ without END_REQ) the queue waits for
// its END_REQ, and that waiting is counted (downstream_stall).
#include <rtsim/model/sim/cache_model.h>
#include <rtsim/model/sim/dram_reference.h>
#include <rtsim/model/sim/memory_system.h>
#include <rtsim/model/sim/cycle/unit_scheduler.h>

#include <tlm_utils/multi_passthrough_target_socket.h>
#include <tlm_utils/simple_initiator_socket.h>

#include <deque>
#include <unordered_map>

namespace rtsim::sim {

class CycleCache : public sc_core::sc_module {
 public:
  tlm_utils::multi_passthrough_target_socket<CycleCache> target;
  tlm_utils::simple_initiator_socket<CycleCache> next;
  CycleCache(sc_core::sc_module_name name, const CacheConfig& config, uint64_t cycle_ps,
             UnitScheduler& scheduler);
  CacheModel model;
  uint64_t downstream_stall_ps = 0;  // the outbound queue's head waited for the next level
  uint64_t downstream_refusals = 0;  // requests the next level did not take at once
  void reset_counters();
  // Level 1 (a unit's L1: its misses are `unit`'s reads, for its accounting) or 2.
  void set_level(int level, UnitAccounting* unit = nullptr) {
    level_ = level, unit_ = unit;
    served_[0] = served_hit(level);
    served_[1] = level == 1 ? ServedBy::L1Write : ServedBy::L2Hit;
  }
  // Draws every miss, from its tag check to its fill, on the timeline.
  void draw_on(Timeline* timeline, uint32_t track) { timeline_ = timeline, track_ = track; }

 private:
  tlm::tlm_sync_enum nb_transport_fw(int id, tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                     sc_core::sc_time& delay);
  tlm::tlm_sync_enum nb_transport_bw(tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                     sc_core::sc_time& delay);
  // Serves a request that arrived at arrival_ps at t_ps; false when it must wait for an MSHR.
  bool serve(int id, tlm::tlm_generic_payload* p, uint64_t arrival_ps, uint64_t t_ps, bool* completed,
             uint64_t* done_ps);
  void send_down(uint64_t line, bool write, AccessKind kind, RayType type, uint64_t at_ps);
  void try_send();
  void on_event();
  void on_fill(uint64_t line);

  struct Waiter {
    int id;
    tlm::tlm_generic_payload* p;
    uint64_t arrival_ps;  // when it reached this cache (its latency counts from there)
    bool merged;          // it found the line's miss under way
  };
  // A line on its way from the next level, and the requests waiting for it.
  struct Miss {
    std::vector<Waiter> waiters;
    uint64_t since_ps = 0;             // its tag check (the timeline's span)
    ServedBy below = ServedBy::None;   // the level below that answered it
  };
  struct Item {
    enum Kind : uint8_t { Fill, Send } kind;
    uint64_t line;
  };
  std::unordered_map<uint64_t, Miss> waiting_;  // missing line -> its miss
  std::deque<Waiter> blocked_;                                  // waiting for an MSHR
  std::deque<tlm::tlm_generic_payload*> outbound_;              // to the next level, in order
  bool awaiting_end_req_ = false;
  uint64_t refused_since_ps_ = 0;
  TimedQueue<Item> queue_;
  PayloadPool payloads_;
  sc_core::sc_time hit_delay_;  // the hit latency
  int level_ = 2;
  UnitAccounting* unit_ = nullptr;
  ServedBy served_[2] = {ServedBy::L2Hit, ServedBy::L2Hit};  // a read's hit, a write's (by level)
  Timeline* timeline_ = nullptr;
  uint32_t track_ = 0;
};

// Cycle level DRAM: the DramModel (FR-FCFS, refresh, writes) behind a TLM-2.0
// AT target. A request enters its channel's bounded queue when it arrives
// (END_REQ at once); when the queue is full the request is held without END_REQ,
// which stops the sender, and enters as soon as an issue frees an entry. Each
// request's response (reads and writes) goes back at its done time; its latency
// counts from the sender's first try.
class CycleDram : public sc_core::sc_module {
 public:
  tlm_utils::multi_passthrough_target_socket<CycleDram> target;
  CycleDram(sc_core::sc_module_name name, const DramConfig& config, uint32_t access_bytes,
            UnitScheduler& scheduler);
  DramModel model;  // serves the requests, or (dram.model = dramsim3) counts the reference's
  // The end of the run: idle-time refreshes into the counts, or the reference's counts.
  void settle(uint64_t end_ps);

 private:
  tlm::tlm_sync_enum nb_transport_fw(int id, tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                     sc_core::sc_time& delay);
  void on_event();
  void admit(uint32_t request, uint64_t now_ps);
  struct Item {
    enum Kind : uint8_t { Decide, Respond } kind;
    uint32_t request;
  };
  struct InFlight {
    int id = 0;
    tlm::tlm_generic_payload* p = nullptr;
    RowOutcome outcome = RowOutcome::Hit;  // known once its column command issues
  };
  uint32_t slot_for(int id, tlm::tlm_generic_payload* p);
  TimedQueue<Item> queue_;
  std::vector<InFlight> in_flight_;
  std::vector<uint32_t> free_slots_;
  std::deque<uint32_t> held_;  // arrived, channel queue full: not yet END_REQ
  uint64_t decide_at_ = UINT64_MAX;
  std::vector<DramCompletion> issued_;
  std::unique_ptr<DramReference> reference_;  // dram.model = dramsim3
  std::vector<uint64_t> arrival_ps_;          // reference: per slot, for its latency
  bool can_accept(tlm::tlm_generic_payload& p) const;
};

}  // namespace rtsim::sim
