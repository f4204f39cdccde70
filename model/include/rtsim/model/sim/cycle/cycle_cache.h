#pragma once
// Cycle level cache (an L1 or the L2): TLM-2.0 approximately-timed target and
// initiator (BEGIN_REQ forward, BEGIN_RESP backward; a hit completes on the
// forward path with its latency annotated). Misses hold an MSHR; requests to a
// line already missing merge into it; with every MSHR busy a request waits
// (back-pressure) until a fill frees one. Fills are processed at their time by
// an SC_METHOD woken only when a fill is due.
#include <rtsim/model/sim/cache_model.h>
#include <rtsim/model/sim/memory_system.h>
#include <rtsim/model/sim/sc_time_util.h>

#include <tlm_utils/multi_passthrough_target_socket.h>
#include <tlm_utils/simple_initiator_socket.h>

#include <deque>
#include <unordered_map>

namespace rtsim::sim {

class CycleCache : public sc_core::sc_module {
 public:
  tlm_utils::multi_passthrough_target_socket<CycleCache> target;
  tlm_utils::simple_initiator_socket<CycleCache> next;
  CycleCache(sc_core::sc_module_name name, const CacheConfig& config, uint64_t cycle_ps);
  CacheModel model;

 private:
  SC_HAS_PROCESS(CycleCache);
  tlm::tlm_sync_enum nb_transport_fw(int id, tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                     sc_core::sc_time& delay);
  tlm::tlm_sync_enum nb_transport_bw(tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                     sc_core::sc_time& delay);
  // Returns false when the request must wait for an MSHR.
  bool handle(int id, tlm::tlm_generic_payload* p, uint64_t delay_ps);
  void on_fill();

  struct Waiter {
    int id;
    tlm::tlm_generic_payload* p;
  };
  uint64_t hit_ps_;
  std::unordered_map<uint64_t, std::vector<Waiter>> waiting_;  // missing line -> requests
  std::deque<Waiter> blocked_;                                  // waiting for an MSHR
  TimedQueue<uint64_t> fills_;                                  // line arrivals
  PayloadPool payloads_;
};

// Cycle level DRAM: the FR-FCFS DramModel behind a TLM-2.0 AT target. Arrivals
// enter the channel queue at their time; a full queue holds them back
// (back-pressure) and counts it; each read's response goes back at its done time.
class CycleDram : public sc_core::sc_module {
 public:
  tlm_utils::multi_passthrough_target_socket<CycleDram> target;
  CycleDram(sc_core::sc_module_name name, const DramConfig& config, uint32_t access_bytes);
  DramModel model;

 private:
  SC_HAS_PROCESS(CycleDram);
  tlm::tlm_sync_enum nb_transport_fw(int id, tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                     sc_core::sc_time& delay);
  void on_event();
  struct Item {
    enum Kind : uint8_t { Arrive, Decide, Respond } kind;
    uint32_t request;
  };
  struct InFlight {
    int id = 0;
    tlm::tlm_generic_payload* p = nullptr;
  };
  uint32_t slot_for(int id, tlm::tlm_generic_payload* p);
  TimedQueue<Item> queue_;
  std::vector<InFlight> in_flight_;
  std::vector<uint32_t> free_slots_;
  std::deque<uint32_t> held_;  // arrived, channel queue full
  uint64_t decide_at_ = UINT64_MAX;
  std::vector<DramCompletion> issued_;
};

}  // namespace rtsim::sim
