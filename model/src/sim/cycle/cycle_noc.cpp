#include <rtsim/model/sim/cycle/cycle_cache.h>
#include <rtsim/model/sim/cycle/cycle_noc.h>

namespace rtsim::sim {

CycleCrossbar::CycleCrossbar(sc_core::sc_module_name name, Crossbar& model, const MachineShape& shape)
    : sc_module(name), target("target"), to_slice("to_slice"), model_(model), shape_(shape) {
  target.register_nb_transport_fw(this, &CycleCrossbar::nb_transport_fw);
  to_slice.register_nb_transport_bw(this, &CycleCrossbar::nb_transport_bw);
}

void CycleCrossbar::bind_l1(tlm_utils::simple_initiator_socket<CycleCache>& l1, uint32_t core) {
  l1.bind(target);  // target ports are numbered in bind order
  core_of_port_.push_back(core);
}

uint64_t CycleCrossbar::back_to_core(uint32_t slice, int port, const tlm::tlm_generic_payload& p,
                                     const sc_core::sc_time& delay) {
  return model_.to_core(slice, core_of_port_[size_t(port)], p.is_write() ? 0 : p.get_data_length(),
                        now_ps() + to_ps(delay));
}

tlm::tlm_sync_enum CycleCrossbar::nb_transport_fw(int id, tlm::tlm_generic_payload& p,
                                                  tlm::tlm_phase& phase, sc_core::sc_time& delay) {
  const uint32_t slice = shape_.slice_of(p.get_address());
  AccessExtension& ext = PayloadPool::extension(p);
  const uint64_t now = now_ps();
  if (phase == tlm::BEGIN_REQ) {
    ext.crossbar_port = id;
    const uint64_t there = model_.to_slice(core_of_port_[size_t(id)], slice,
                                           p.is_write() ? p.get_data_length() : 0, now + to_ps(delay));
    move_read(ext, now, there, UnitAccounting::AtL2);
    delay = from_ps(there - now);
  }
  const tlm::tlm_sync_enum status = to_slice[int(slice)]->nb_transport_fw(p, phase, delay);
  if (status == tlm::TLM_COMPLETED) {  // an L2 hit, answered on the forward path
    const uint64_t back = back_to_core(slice, id, p, delay);
    move_read(ext, now, now + to_ps(delay), UnitAccounting::AtNoc);
    end_read(ext, now, back);
    delay = from_ps(back - now);
  }
  return status;
}

tlm::tlm_sync_enum CycleCrossbar::nb_transport_bw(int slice, tlm::tlm_generic_payload& p,
                                                  tlm::tlm_phase& phase, sc_core::sc_time& delay) {
  AccessExtension& ext = PayloadPool::extension(p);
  const int port = ext.crossbar_port;
  if (phase == tlm::BEGIN_RESP) {
    const uint64_t now = now_ps();
    const uint64_t back = back_to_core(uint32_t(slice), port, p, delay);
    move_read(ext, now, now + to_ps(delay), UnitAccounting::AtNoc);
    end_read(ext, now, back);
    delay = from_ps(back - now);
  }
  return target[port]->nb_transport_bw(p, phase, delay);
}

}  // namespace rtsim::sim
