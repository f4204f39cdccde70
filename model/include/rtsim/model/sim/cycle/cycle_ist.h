#pragma once
// Cycle level IST unit: a bounded queue of leaf jobs, all in flight at once.
// A job takes the leaf a step at a time (ist.triangles_in_flight triangles):
// the step's reads go out together through the unit's L1 triangle cache, the
// triangles behind a prim-ref list once the list is back; then the step's tests
// enter the test pipeline of the unit's model (IstUnit, units/ist_unit.h, as at the
// lt level).
// Closest-hit jobs test the whole leaf, any-hit jobs stop at a hit (the core
// decides). A hit on an alpha-tested triangle goes to the unit's any-hit stage:
// its UV and texel reads go through the unit's L1 texture cache (texture_memory,
// built only for such scenes), then one alpha test issues into the same pipeline.
// The finished leaf goes back to its TRV slot.
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/memory_system.h>
#include <rtsim/model/sim/cycle/unit_scheduler.h>
#include <rtsim/model/sim/units/ist_unit.h>

#include <tlm_utils/simple_initiator_socket.h>

namespace rtsim::sim {

class CycleTrv;
class CycleSystem;

class CycleIst : public sc_core::sc_module {
 public:
  tlm_utils::simple_initiator_socket<CycleIst> memory;
  // To the L1 texture cache; null unless the scene has alpha-tested materials.
  std::unique_ptr<tlm_utils::simple_initiator_socket<CycleIst>> texture_memory;
  CycleIst(sc_core::sc_module_name name, const HardwareConfig& config, CycleSystem& system);

  void serve(CycleTrv* trv) { clients_.push_back(trv); }
  bool can_accept() const { return !free_jobs_.empty(); }
  void accept(CycleTrv* from, uint32_t slot, RayTraversal* traversal, uint32_t ray, uint64_t t,
              bool probed);
  void reset_counters();

  IstUnit model;  // the unit's work, counts and accounting

 private:
  struct Job {
    CycleTrv* trv = nullptr;
    uint32_t slot = 0, ray = 0;
    RayTraversal* traversal = nullptr;
    uint32_t pending = 0;
    bool dependent_sent = false;  // the reads behind the prim-ref list went out
    bool probed = false;          // the ray --trace-ray follows
  };
  struct Item {
    enum Kind : uint8_t { Fetch, MemoryBack, TestDone } kind;
    uint32_t job;
  };
  void on_event();
  void handle(const Item& item);
  void send(uint32_t job, const std::vector<MemoryAccess>& reads, size_t begin, size_t end);
  void read_back(uint32_t job, const AccessExtension& ext, uint64_t at) {
    if (ext.probe_request) probed_read_back(ext, at);
    queue_.push(at, Item{Item::MemoryBack, job});
  }
  void probed_read_back(const AccessExtension& ext, uint64_t at);
  void tests_start(uint32_t job);
  tlm::tlm_sync_enum nb_transport_bw(tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                     sc_core::sc_time& delay);

  const HardwareConfig& config_;
  CycleSystem& system_;
  std::vector<Job> jobs_;
  std::vector<uint32_t> free_jobs_;
  std::vector<CycleTrv*> clients_;
  TimedQueue<Item> queue_;
  std::vector<LineAccess> lines_;
  PayloadPool payloads_;
};

}  // namespace rtsim::sim
