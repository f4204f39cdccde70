#include <rtsim/model/sim/cycle/cycle_ist.h>
#include <rtsim/model/sim/cycle/cycle_trv.h>

#include <cmath>

namespace rtsim::sim {

CycleIst::CycleIst(sc_core::sc_module_name name, const HardwareConfig& config)
    : sc_module(name), memory("memory"), config_(config), jobs_(config.ist_queue_entries) {
  const uint64_t cycle_ps = uint64_t(std::llround(config.clock_period_ps()));
  interval_ps_ = uint64_t(std::llround(double(cycle_ps) / config.ist_tests_per_cycle));
  latency_ps_ = uint64_t(config.ist_test_latency) * cycle_ps;
  for (uint32_t j = config.ist_queue_entries; j-- > 0;) free_jobs_.push_back(j);
  memory.register_nb_transport_bw(this, &CycleIst::nb_transport_bw);
  SC_METHOD(on_event);
  sensitive << queue_.event();
  dont_initialize();
}

void CycleIst::accept(CycleTrv* from, uint32_t slot, RayTraversal* traversal, uint64_t t) {
  const uint32_t j = free_jobs_.back();
  free_jobs_.pop_back();
  jobs_[j] = Job{from, slot, traversal, 0};
  occupancy.enter(t);
  queue_.push(t, Item{Item::Fetch, j});
}

void CycleIst::on_event() {
  queue_.drain([this](const Item& item) { handle(item); });
}

void CycleIst::fetch(uint32_t j, uint64_t address, uint32_t bytes, DataKind kind) {
  const uint64_t line_bytes = config_.l1_triangle.line_bytes;
  const uint64_t end = address + bytes;
  for (uint64_t line = address & ~(line_bytes - 1); line < end; line += line_bytes) {
    const uint64_t lo = std::max(line, address), hi = std::min(line + line_bytes, end);
    tlm::tlm_generic_payload* p = payloads_.get();
    AccessExtension& ext = PayloadPool::extension(*p);
    ext.kind = kind, ext.ray_type = jobs_[j].traversal->ray().type, ext.token = j;
    p->set_address(line);
    p->set_data_length(uint32_t(hi - lo));
    ++jobs_[j].pending;
    tlm::tlm_phase phase = tlm::BEGIN_REQ;
    sc_core::sc_time delay = sc_core::SC_ZERO_TIME;
    if (memory->nb_transport_fw(*p, phase, delay) == tlm::TLM_COMPLETED) {
      queue_.push(now_ps() + to_ps(delay), Item{Item::MemoryBack, j});
      payloads_.put(p);
    }
  }
}

tlm::tlm_sync_enum CycleIst::nb_transport_bw(tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                             sc_core::sc_time& delay) {
  if (phase != tlm::BEGIN_RESP) return tlm::TLM_ACCEPTED;
  queue_.push(now_ps() + to_ps(delay),
              Item{Item::MemoryBack, uint32_t(PayloadPool::extension(p).token)});
  payloads_.put(&p);
  return tlm::TLM_COMPLETED;
}

void CycleIst::handle(const Item& item) {
  const uint64_t now = now_ps();
  Job& job = jobs_[item.job];
  switch (item.kind) {
    case Item::Fetch: {
      RayTraversal& trv = *job.traversal;
      const uint32_t k = trv.leaf_cursor();
      if (k == 0) fetch(item.job, trv.prim_refs_address(), trv.prim_refs_bytes(), DataKind::Other);
      fetch(item.job, trv.triangle_address(k), trv.triangle_bytes(), DataKind::Triangle);
      break;
    }
    case Item::MemoryBack:
      if (--job.pending > 0) break;
      {
        const uint64_t start = std::max(now, pipe_free_ps_);
        pipe_free_ps_ = start + interval_ps_;
        occupancy.busy_ps += interval_ps_;
        queue_.push(start + latency_ps_, Item{Item::TestDone, item.job});
      }
      break;
    case Item::TestDone: {
      RayTraversal& trv = *job.traversal;
      trv.process_triangle();
      ++tests;
      if (trv.action() == TraversalAction::TestTriangles && trv.leaf_cursor() > 0) {
        queue_.push(now, Item{Item::Fetch, item.job});  // next triangle of this leaf
        break;
      }
      // Leaf finished: back to TRV, and the entry is free for a waiting leaf.
      job.trv->leaf_done(job.slot, now);
      free_jobs_.push_back(item.job);
      occupancy.leave(now);
      for (CycleTrv* client : clients_) client->ist_has_space(now);
      break;
    }
  }
}

}  // namespace rtsim::sim
