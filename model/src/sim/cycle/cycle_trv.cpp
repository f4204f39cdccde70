#include <rtsim/model/sim/cycle/cycle_system.h>
#include <rtsim/model/sim/cycle/cycle_trv.h>

#include <cmath>

namespace rtsim::sim {

CycleTrv::CycleTrv(sc_core::sc_module_name name, const HardwareConfig& config,
                   const TraversalContext& context, uint32_t unit, uint64_t stack_base,
                   CycleSystem& system)
    : sc_module(name), memory("memory"), config_(config), system_(system), unit_(unit),
      cycle_ps_(uint64_t(std::llround(config.clock_period_ps()))), stack_base_(stack_base) {
  interval_ps_ = uint64_t(std::llround(double(cycle_ps_) / config.trv_nodes_per_cycle));
  latency_ps_ = uint64_t(config.trv_box_test_latency) * cycle_ps_;
  slots_.reserve(config.trv_ray_slots);
  for (uint32_t s = 0; s < config.trv_ray_slots; ++s) slots_.emplace_back(context);
  memory.register_nb_transport_bw(this, &CycleTrv::nb_transport_bw);
  SC_METHOD(on_event);
  sensitive << queue_.event();
  dont_initialize();
}

void CycleTrv::start_ray(uint32_t s, uint32_t ray_index, const Ray& ray, uint64_t t) {
  Slot& slot = slots_[s];
  slot.traversal.reset(ray);
  slot.ray = ray_index;
  slot.seen_overflows = slot.seen_refills = 0;
  slot.phase = Phase::WaitStack;
  occupancy.enter(t);
  queue_.push(t, Item{Item::Continue, s});
}

void CycleTrv::leaf_done(uint32_t s, uint64_t t) { queue_.push(t, Item{Item::Continue, s}); }

void CycleTrv::ist_has_space(uint64_t t) {
  if (!waiting_for_ist_.empty()) queue_.push(t, Item{Item::Continue, UINT32_MAX});
}

void CycleTrv::on_event() {
  queue_.drain([this](const Item& item) { handle(item); });
}

void CycleTrv::fetch(uint32_t s, uint64_t address, uint32_t bytes, DataKind kind) {
  const uint64_t line_bytes = config_.l1_node.line_bytes;
  const uint64_t end = address + bytes;
  for (uint64_t line = address & ~(line_bytes - 1); line < end; line += line_bytes) {
    const uint64_t lo = std::max(line, address), hi = std::min(line + line_bytes, end);
    tlm::tlm_generic_payload* p = payloads_.get();
    AccessExtension& ext = PayloadPool::extension(*p);
    ext.kind = kind, ext.ray_type = slots_[s].traversal.ray().type, ext.token = s;
    p->set_address(line);
    p->set_data_length(uint32_t(hi - lo));
    ++slots_[s].pending;
    tlm::tlm_phase phase = tlm::BEGIN_REQ;
    sc_core::sc_time delay = sc_core::SC_ZERO_TIME;
    if (memory->nb_transport_fw(*p, phase, delay) == tlm::TLM_COMPLETED) {
      queue_.push(now_ps() + to_ps(delay), Item{Item::MemoryBack, s});
      payloads_.put(p);
    }
  }
}

tlm::tlm_sync_enum CycleTrv::nb_transport_bw(tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                             sc_core::sc_time& delay) {
  if (phase != tlm::BEGIN_RESP) return tlm::TLM_ACCEPTED;
  queue_.push(now_ps() + to_ps(delay),
              Item{Item::MemoryBack, uint32_t(PayloadPool::extension(p).token)});
  payloads_.put(&p);
  return tlm::TLM_COMPLETED;
}

void CycleTrv::handle(const Item& item) {
  const uint64_t now = now_ps();
  if (item.slot == UINT32_MAX) {  // the IST unit has room again
    CycleIst& ist = system_.ist_for(unit_);
    while (!waiting_for_ist_.empty() && ist.can_accept()) {
      const uint32_t s = waiting_for_ist_.front();
      waiting_for_ist_.pop_front();
      if (waiting_for_ist_.empty()) occupancy.stalled_ps += now - stalled_since_;
      slots_[s].phase = Phase::InIst;
      ist.accept(this, s, &slots_[s].traversal, now);
    }
    return;
  }
  Slot& slot = slots_[item.slot];
  switch (item.kind) {
    case Item::Continue:
      proceed(item.slot);
      break;
    case Item::MemoryBack:
      if (--slot.pending > 0) break;
      if (slot.phase == Phase::WaitNode) {
        // Box-test pipeline: one node per interval, result after its latency.
        const uint64_t start = std::max(now, pipe_free_ps_);
        pipe_free_ps_ = start + interval_ps_;
        occupancy.busy_ps += interval_ps_;
        queue_.push(start + latency_ps_, Item{Item::NodeDone, item.slot});
      } else {
        next_action(item.slot);
      }
      break;
    case Item::NodeDone:
      slot.traversal.process_node();
      ++nodes;
      proceed(item.slot);
      break;
  }
}

void CycleTrv::proceed(uint32_t s) {
  // Entries that overflowed the short stack are written out, refilled ones read back.
  Slot& slot = slots_[s];
  const RayCounters& c = slot.traversal.counters();
  const uint32_t entry = config_.trv_stack_entry_bytes;
  const uint64_t area =
      stack_base_ + (uint64_t(unit_) * config_.trv_ray_slots + s) * 256 * entry;
  bool traffic = false;
  while (slot.seen_overflows < c.stack_overflows || slot.seen_refills < c.stack_refills) {
    const bool spill = slot.seen_overflows < c.stack_overflows;
    (spill ? slot.seen_overflows : slot.seen_refills)++;
    slot.phase = Phase::WaitStack;
    fetch(s, area + uint64_t(std::min<uint32_t>(slot.traversal.stack_size(), 255)) * entry, entry,
          DataKind::Other);
    traffic = true;
  }
  if (!traffic) next_action(s);
}

void CycleTrv::next_action(uint32_t s) {
  Slot& slot = slots_[s];
  const uint64_t now = now_ps();
  switch (slot.traversal.action()) {
    case TraversalAction::FetchNode:
      slot.phase = Phase::WaitNode;
      fetch(s, slot.traversal.node_address(), slot.traversal.node_bytes(), DataKind::Node);
      break;
    case TraversalAction::TestTriangles: {
      CycleIst& ist = system_.ist_for(unit_);
      if (ist.can_accept() && waiting_for_ist_.empty()) {
        slot.phase = Phase::InIst;
        ist.accept(this, s, &slot.traversal, now);
      } else {
        slot.phase = Phase::WaitIst;
        if (waiting_for_ist_.empty()) stalled_since_ = now;  // the unit starts stalling
        waiting_for_ist_.push_back(s);
      }
      break;
    }
    case TraversalAction::Done:
      slot.phase = Phase::Idle;
      occupancy.leave(now);
      system_.ray_finished(*this, s, slot.ray, slot.traversal, now);
      break;
  }
}

}  // namespace rtsim::sim
