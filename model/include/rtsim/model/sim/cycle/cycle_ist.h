#pragma once
// Cycle level IST unit: a bounded queue of leaf jobs, all in flight at once.
// A job fetches the leaf's prim refs (first triangle) and one triangle at a time
// through the unit's L1 triangle cache; each triangle enters the test pipeline
// (throughput tests_per_cycle, latency test_latency) and process_triangle() runs
// at its end. Closest-hit jobs test the whole leaf, any-hit jobs stop at a hit
// (the core decides). The finished leaf goes back to its TRV slot.
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/memory_system.h>
#include <rtsim/model/sim/sc_time_util.h>

#include <tlm_utils/simple_initiator_socket.h>

namespace rtsim::sim {

class CycleTrv;

class CycleIst : public sc_core::sc_module {
 public:
  tlm_utils::simple_initiator_socket<CycleIst> memory;
  CycleIst(sc_core::sc_module_name name, const HardwareConfig& config);

  void serve(CycleTrv* trv) { clients_.push_back(trv); }
  bool can_accept() const { return !free_jobs_.empty(); }
  void accept(CycleTrv* from, uint32_t slot, RayTraversal* traversal, uint64_t t);

  Occupancy occupancy;
  uint64_t tests = 0;

 private:
  SC_HAS_PROCESS(CycleIst);
  struct Job {
    CycleTrv* trv = nullptr;
    uint32_t slot = 0;
    RayTraversal* traversal = nullptr;
    uint32_t pending = 0;
  };
  struct Item {
    enum Kind : uint8_t { Fetch, MemoryBack, TestDone } kind;
    uint32_t job;
  };
  void on_event();
  void handle(const Item& item);
  void fetch(uint32_t job, uint64_t address, uint32_t bytes, DataKind kind);
  tlm::tlm_sync_enum nb_transport_bw(tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                     sc_core::sc_time& delay);

  const HardwareConfig& config_;
  uint64_t interval_ps_, latency_ps_;
  std::vector<Job> jobs_;
  std::vector<uint32_t> free_jobs_;
  std::vector<CycleTrv*> clients_;
  TimedQueue<Item> queue_;
  uint64_t pipe_free_ps_ = 0;
  PayloadPool payloads_;
};

}  // namespace rtsim::sim
