#include <rtsim/model/sim/cycle/cycle_ist.h>
#include <rtsim/model/sim/cycle/cycle_system.h>
#include <rtsim/model/sim/cycle/cycle_trv.h>

#include <rtsim/model/sim/ray_probe.h>

#include <cmath>

namespace rtsim::sim {

CycleIst::CycleIst(sc_core::sc_module_name name, const HardwareConfig& config, CycleSystem& system)
    : sc_module(name), memory("memory"), model(config),
      config_(config), system_(system), jobs_(config.ist_queue_entries),
      queue_(system.scheduler, [this] { on_event(); }) {
  if (system.workload.context->image().has_alpha_data()) {
    texture_memory = std::make_unique<tlm_utils::simple_initiator_socket<CycleIst>>("texture_memory");
    texture_memory->register_nb_transport_bw(this, &CycleIst::nb_transport_bw);
  }
  for (uint32_t j = config.ist_queue_entries; j-- > 0;) free_jobs_.push_back(j);
  memory.register_nb_transport_bw(this, &CycleIst::nb_transport_bw);
}

void CycleIst::reset_counters() { model.restart(now_ps()); }

void CycleIst::accept(CycleTrv* from, uint32_t slot, RayTraversal* traversal, uint32_t ray,
                      uint64_t t, bool probed) {
  const uint32_t j = free_jobs_.back();
  free_jobs_.pop_back();
  jobs_[j] = Job{from, slot, ray, traversal, 0, false, probed};
  model.accounting.change(t, UnitAccounting::Resident, +1);
  queue_.push(t, Item{Item::Fetch, j});
}

void CycleIst::on_event() {
  queue_.drain([this](const Item& item) { handle(item); });
}

void CycleIst::send(uint32_t j, const std::vector<MemoryAccess>& reads, size_t begin, size_t end) {
  Job& job = jobs_[j];
  const RayType type = job.traversal->ray().type;
  lines_.clear();
  for (size_t i = begin; i < end; ++i) {
    system_.observe(job.traversal->ray(), reads[i]);
    const bool texture = requester_of(reads[i].kind) == Requester::Texture;
    append_line_accesses(reads[i], type, texture ? config_.l1_texture.line_bytes : config_.l1_triangle.line_bytes,
                         lines_);
  }
  const uint64_t now = now_ps();
  RayProbe* probe = system_.workload.probe;
  uint32_t request = 0;  // the probed ray's first request of these, + 1
  if (job.probed)
    request = 1 + probe->add(reads.data() + begin, end - begin, lines_.data(), lines_.size(),
                             config_.l1_node.line_bytes, config_.l1_triangle.line_bytes,
                             config_.l1_texture.line_bytes, now);
  // The job waits on its L1 from its first read to its last one's data.
  if (!lines_.empty()) model.accounting.change(now, UnitAccounting::AtL1, +1);
  for (const LineAccess& line : lines_) {
    tlm::tlm_generic_payload* p = payloads_.request(line, type, j, request ? request++ : 0);
    const AccessExtension& ext = PayloadPool::extension(*p);
    ++job.pending;
    tlm::tlm_phase phase = tlm::BEGIN_REQ;
    sc_core::sc_time delay = sc_core::SC_ZERO_TIME;
    auto& socket = requester_of(line.kind) == Requester::Texture ? *texture_memory : memory;
    if (socket->nb_transport_fw(*p, phase, delay) == tlm::TLM_COMPLETED) {
      read_back(j, ext, now + to_ps(delay));
      payloads_.put(p);
    }
  }
}

void CycleIst::probed_read_back(const AccessExtension& ext, uint64_t at) {
  system_.workload.probe->served(ext.probe_request - 1, ext.served, at);
}

tlm::tlm_sync_enum CycleIst::nb_transport_bw(tlm::tlm_generic_payload& p, tlm::tlm_phase& phase,
                                             sc_core::sc_time& delay) {
  if (phase != tlm::BEGIN_RESP) return tlm::TLM_ACCEPTED;
  const AccessExtension& ext = PayloadPool::extension(p);
  read_back(uint32_t(ext.token), ext, now_ps() + to_ps(delay));
  payloads_.put(&p);
  return tlm::TLM_COMPLETED;
}

void CycleIst::tests_start(uint32_t j) {
  // The step's data is here: its tests (or alpha test) through the pipeline.
  queue_.push(model.take_step(*jobs_[j].traversal, now_ps()), Item{Item::TestDone, j});
}

void CycleIst::handle(const Item& item) {
  const uint64_t now = now_ps();
  Job& job = jobs_[item.job];
  RayTraversal& trv = *job.traversal;
  switch (item.kind) {
    case Item::Fetch: {
      if (job.probed) system_.workload.probe->next_step();
      const std::vector<MemoryAccess>& reads = trv.step_reads();
      const size_t independent = trv.step_independent_reads();
      job.dependent_sent = independent == reads.size();
      send(item.job, reads, 0, independent);
      break;
    }
    case Item::MemoryBack:
      if (--job.pending > 0) break;
      model.accounting.change(now, UnitAccounting::AtL1, -1);
      if (!job.dependent_sent) {  // the prim refs are here: now the triangles they point to
        job.dependent_sent = true;
        const std::vector<MemoryAccess>& reads = trv.step_reads();
        send(item.job, reads, trv.step_independent_reads(), reads.size());
        break;
      }
      tests_start(item.job);
      break;
    case Item::TestDone:
      if ((trv.action() == TraversalAction::TestTriangles && trv.leaf_cursor() > 0) ||
          trv.action() == TraversalAction::AlphaTest) {
        queue_.push(now, Item{Item::Fetch, item.job});  // the leaf's next triangles, or an alpha test
        break;
      }
      // Leaf finished: back to TRV, and the entry is free for a waiting leaf.
      job.trv->leaf_done(job.slot, now);
      free_jobs_.push_back(item.job);
      model.accounting.change(now, UnitAccounting::Resident, -1);
      for (CycleTrv* client : clients_) client->ist_has_space(now);
      break;
  }
}

}  // namespace rtsim::sim
