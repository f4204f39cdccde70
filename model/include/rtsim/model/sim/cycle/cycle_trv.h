#pragma once
// Cycle level TRV unit: ray slots, each driving the functional core's
// RayTraversal. A slot sends the reads its step names through the unit's L1
// node cache (TLM-2.0 socket); when they are back the node enters the box-test
// pipeline of the unit's model (TrvUnit, units/trv_unit.h, as at the lt level),
// and the slot goes on when the result is out. Leaves go to the IST unit (a full
// IST queue stalls the slot). The stack traffic of a step follows it: spills are
// posted writes, refills reads the slot waits for.
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/memory_system.h>
#include <rtsim/model/sim/cycle/unit_scheduler.h>
#include <rtsim/model/sim/units/trv_unit.h>

#include <tlm_utils/simple_initiator_socket.h>

#include <deque>

namespace rtsim::sim {

class CycleIst;
class CycleSystem;

class CycleTrv : public sc_core::sc_module {
 public:
  tlm_utils::simple_initiator_socket<CycleTrv> memory;
  CycleTrv(sc_core::sc_module_name name, const HardwareConfig& config,
           const TraversalContext& context, uint32_t unit, CycleSystem& system);
  uint32_t unit() const { return unit_; }

  uint32_t slots() const { return uint32_t(slots_.size()); }
  void start_ray(uint32_t slot, uint32_t ray_index, const Ray& ray, uint64_t t);
  void leaf_done(uint32_t slot, uint64_t t);  // from IST
  void ist_has_space(uint64_t t);             // from IST: retry blocked leaves
  void reset_counters();

  TrvUnit model;  // the unit's work, counts and accounting

 private:
  enum class Phase : uint8_t { Idle, WaitNode, WaitStack, InIst, WaitIst };
  struct Slot {
    RayTraversal traversal;
    uint32_t ray = 0;
    uint32_t pending = 0;
    Phase phase = Phase::Idle;
    bool probed = false;  // the ray --trace-ray follows
    uint64_t start_ps = 0;
    Slot(const TraversalContext& c, uint32_t id) : traversal(c, id) {}
  };
  struct Item {
    enum Kind : uint8_t { Continue, MemoryBack, NodeDone, IstSpace } kind;
    uint32_t slot;
  };
  void on_event();
  void handle(const Item& item);
  void after_step(uint32_t slot);  // stack traffic of the last step, then the next action
  void next_action(uint32_t slot);
  // Sends the accesses through the L1; returns how many reads the slot waits for.
  uint32_t send(uint32_t slot, const std::vector<MemoryAccess>& accesses);
  // A read's data is back at `at` (inline: every read of the unit comes here).
  void read_back(uint32_t slot, const AccessExtension& ext, uint64_t at) {
    if (ext.probe_request) probed_read_back(ext, at);
    queue_.push(at, Item{Item::MemoryBack, slot});
  }
  void probed_read_back(const AccessExtension& ext, uint64_t at);
  tlm::tlm_sync_enum nb_transport_bw(tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                     sc_core::sc_time& delay);

  const HardwareConfig& config_;
  CycleSystem& system_;
  uint32_t unit_;  // global TRV unit number (machine.h)
  CycleIst& ist_;  // the IST unit of its core that tests its leaves
  std::vector<Slot> slots_;
  TimedQueue<Item> queue_;
  std::deque<uint32_t> waiting_for_ist_;  // slots whose leaf found the IST queue full
  std::vector<LineAccess> lines_;
  PayloadPool payloads_;
};

}  // namespace rtsim::sim
