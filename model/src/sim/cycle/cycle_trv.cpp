#include <rtsim/model/sim/cycle/cycle_system.h>
#include <rtsim/model/sim/cycle/cycle_trv.h>

#include <rtsim/model/sim/ray_probe.h>

#include <cmath>

namespace rtsim::sim {

namespace {
constexpr uint64_t kWriteToken = uint64_t(1) << 32;  // a posted write: nobody waits for its answer
}

CycleTrv::CycleTrv(sc_core::sc_module_name name, const HardwareConfig& config,
                   const TraversalContext& context, uint32_t unit, CycleSystem& system)
    : sc_module(name), memory("memory"), model(config),
      config_(config), system_(system), unit_(unit),
      ist_(system.ist_for(unit)),  // the IST units are built first
      queue_(system.scheduler, [this] { on_event(); }) {
  slots_.reserve(config.trv_ray_slots);
  for (uint32_t s = 0; s < config.trv_ray_slots; ++s)
    slots_.emplace_back(context, unit * config.trv_ray_slots + s);
  memory.register_nb_transport_bw(this, &CycleTrv::nb_transport_bw);
}

void CycleTrv::reset_counters() { model.restart(now_ps()); }

void CycleTrv::start_ray(uint32_t s, uint32_t ray_index, const Ray& ray, uint64_t t) {
  Slot& slot = slots_[s];
  slot.traversal.reset(ray);
  slot.ray = ray_index;
  slot.phase = Phase::WaitStack;
  slot.start_ps = t;
  RayProbe* probe = system_.workload.probe;
  slot.probed = probe && probe->is(ray);
  if (slot.probed) probe->begin(t);
  model.accounting.change(t, UnitAccounting::Resident, +1);
  queue_.push(t, Item{Item::Continue, s});
}

void CycleTrv::leaf_done(uint32_t s, uint64_t t) {
  model.accounting.change(t, UnitAccounting::Downstream, -1);
  queue_.push(t, Item{Item::Continue, s});
}

void CycleTrv::ist_has_space(uint64_t t) {
  if (!waiting_for_ist_.empty()) queue_.push(t, Item{Item::IstSpace, 0});
}

void CycleTrv::on_event() {
  queue_.drain([this](const Item& item) { handle(item); });
}

uint32_t CycleTrv::send(uint32_t s, const std::vector<MemoryAccess>& accesses) {
  Slot& slot = slots_[s];
  const RayType type = slot.traversal.ray().type;
  lines_.clear();
  for (const MemoryAccess& a : accesses) {
    system_.observe(slot.traversal.ray(), a);
    append_line_accesses(a, type, config_.l1_node.line_bytes, lines_);
  }
  uint32_t reads = 0;
  const uint64_t now = now_ps();
  RayProbe* probe = system_.workload.probe;
  uint32_t request = 0;  // the probed ray's first request of these, + 1
  if (slot.probed)
    request = 1 + probe->add(accesses.data(), accesses.size(), lines_.data(), lines_.size(),
                             config_.l1_node.line_bytes, config_.l1_triangle.line_bytes,
                             config_.l1_texture.line_bytes, now);
  for (const LineAccess& line : lines_) {
    tlm::tlm_generic_payload* p =
        payloads_.request(line, type, s | (line.write ? kWriteToken : 0), request ? request++ : 0);
    const AccessExtension& ext = PayloadPool::extension(*p);
    if (!line.write) ++reads, ++slot.pending;
    tlm::tlm_phase phase = tlm::BEGIN_REQ;
    sc_core::sc_time delay = sc_core::SC_ZERO_TIME;
    if (memory->nb_transport_fw(*p, phase, delay) == tlm::TLM_COMPLETED) {
      if (!line.write) read_back(s, ext, now + to_ps(delay));
      else if (ext.probe_request) system_.workload.probe->served(ext.probe_request - 1, ext.served, now);
      payloads_.put(p);
    }
  }
  // The slot waits on its L1 from its first read to its last one's data (MemoryBack;
  // a hit's comes later than now, so after the sends is the same instant).
  if (reads) model.accounting.change(now, UnitAccounting::AtL1, +1);
  return reads;
}

void CycleTrv::probed_read_back(const AccessExtension& ext, uint64_t at) {
  system_.workload.probe->served(ext.probe_request - 1, ext.served, at);
}

tlm::tlm_sync_enum CycleTrv::nb_transport_bw(tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                             sc_core::sc_time& delay) {
  if (phase != tlm::BEGIN_RESP) return tlm::TLM_ACCEPTED;
  const AccessExtension& ext = PayloadPool::extension(p);
  if (!(ext.token & kWriteToken)) read_back(uint32_t(ext.token), ext, now_ps() + to_ps(delay));
  payloads_.put(&p);
  return tlm::TLM_COMPLETED;
}

void CycleTrv::handle(const Item& item) {
  const uint64_t now = now_ps();
  if (item.kind == Item::IstSpace) {  // the IST unit has room again
    while (!waiting_for_ist_.empty() && ist_.can_accept()) {
      const uint32_t s = waiting_for_ist_.front();
      waiting_for_ist_.pop_front();
      model.accounting.change(now, UnitAccounting::Blocked, -1);
      model.accounting.change(now, UnitAccounting::Downstream, +1);
      slots_[s].phase = Phase::InIst;
      ist_.accept(this, s, &slots_[s].traversal, slots_[s].ray, now, slots_[s].probed);
    }
    return;
  }
  Slot& slot = slots_[item.slot];
  switch (item.kind) {
    case Item::Continue:
      after_step(item.slot);
      break;
    case Item::MemoryBack:
      if (--slot.pending > 0) break;
      model.accounting.change(now, UnitAccounting::AtL1, -1);
      if (slot.phase == Phase::WaitNode) {
        // The node (or instance transform) through the box-test pipeline; the slot
        // goes on when its result is out.
        queue_.push(model.take_step(slot.traversal, now), Item{Item::NodeDone, item.slot});
      } else {
        next_action(item.slot);
      }
      break;
    case Item::NodeDone:
      after_step(item.slot);
      break;
    case Item::IstSpace: break;
  }
}

void CycleTrv::after_step(uint32_t s) {
  // The stack traffic the last step caused: spills are posted, refills waited for.
  Slot& slot = slots_[s];
  slot.phase = Phase::WaitStack;
  const std::vector<MemoryAccess>& stack = slot.traversal.stack_accesses();
  if (stack.empty() || send(s, stack) == 0) next_action(s);  // most steps move no stack entry
}

void CycleTrv::next_action(uint32_t s) {
  Slot& slot = slots_[s];
  const uint64_t now = now_ps();
  switch (slot.traversal.action()) {
    case TraversalAction::FetchNode:
    case TraversalAction::Transform:  // the instance record, then the transform in the box-test pipeline
      slot.phase = Phase::WaitNode;
      if (slot.probed) system_.workload.probe->next_step();
      send(s, slot.traversal.step_reads());
      break;
    case TraversalAction::AlphaTest:  // only ever inside an IST job (the leaf's candidates)
    case TraversalAction::TestTriangles: {
      if (ist_.can_accept() && waiting_for_ist_.empty()) {
        slot.phase = Phase::InIst;
        model.accounting.change(now, UnitAccounting::Downstream, +1);
        ist_.accept(this, s, &slot.traversal, slot.ray, now, slot.probed);
      } else {
        slot.phase = Phase::WaitIst;
        ++model.leaves_blocked;
        model.accounting.change(now, UnitAccounting::Blocked, +1);
        waiting_for_ist_.push_back(s);
      }
      break;
    }
    case TraversalAction::Done:
      slot.phase = Phase::Idle;
      model.accounting.change(now, UnitAccounting::Resident, -1);
      model.ray_done(slot.traversal.ray().type, slot.start_ps, now);
      if (slot.probed) system_.workload.probe->end(now, slot.traversal.counters());
      system_.ray_finished(*this, s, slot.ray, slot.traversal, now);
      break;
  }
}

}  // namespace rtsim::sim
