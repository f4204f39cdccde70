#pragma once
// Cycle level crossbar between the cores' L1 caches and the L2 slices: an
// approximately-timed pass-through. A request's BEGIN_REQ goes to the slice its
// address maps to, later by its way there; a response (BEGIN_RESP, or a hit
// completed on the forward path) comes back later by its way back (Crossbar:
// port serialisation and latency). Back-pressure phases pass unchanged. The port
// a request came in on rides in its AccessExtension.
#include <rtsim/model/sim/machine.h>
#include <rtsim/model/sim/memory_system.h>

#include <tlm_utils/multi_passthrough_initiator_socket.h>
#include <tlm_utils/multi_passthrough_target_socket.h>
#include <tlm_utils/simple_initiator_socket.h>

namespace rtsim::sim {

class CycleCache;

class CycleCrossbar : public sc_core::sc_module {
 public:
  tlm_utils::multi_passthrough_target_socket<CycleCrossbar> target;        // from the L1s
  tlm_utils::multi_passthrough_initiator_socket<CycleCrossbar> to_slice;   // index = slice
  CycleCrossbar(sc_core::sc_module_name name, Crossbar& model, const MachineShape& shape);
  void bind_l1(tlm_utils::simple_initiator_socket<CycleCache>& l1, uint32_t core);

 private:
  tlm::tlm_sync_enum nb_transport_fw(int id, tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                     sc_core::sc_time& delay);
  tlm::tlm_sync_enum nb_transport_bw(int slice, tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                     sc_core::sc_time& delay);
  uint64_t back_to_core(uint32_t slice, int port, const tlm::tlm_generic_payload& p,
                        const sc_core::sc_time& delay);
  Crossbar& model_;
  MachineShape shape_;
  std::vector<uint32_t> core_of_port_;
};

}  // namespace rtsim::sim
