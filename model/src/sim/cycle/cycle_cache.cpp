#include <rtsim/model/sim/cycle/cycle_cache.h>
#include <rtsim/model/sim/timeline.h>

#include <unistd.h>

#include <filesystem>

namespace rtsim::sim {

using tlm::tlm_generic_payload;

CycleCache::CycleCache(sc_core::sc_module_name name, const CacheConfig& config, uint64_t cycle_ps,
                       UnitScheduler& scheduler)
    : sc_module(name), target("target"), next("next"), model(config, std::string(name), cycle_ps),
      queue_(scheduler, [this] { on_event(); }), hit_delay_(from_ps(model.hit_latency_ps())) {
  target.register_nb_transport_fw(this, &CycleCache::nb_transport_fw);
  next.register_nb_transport_bw(this, &CycleCache::nb_transport_bw);
}

void CycleCache::reset_counters() {
  model.reset_counters();
  downstream_stall_ps = downstream_refusals = 0;
  if (awaiting_end_req_) refused_since_ps_ = now_ps();
}

bool CycleCache::serve(int id, tlm_generic_payload* p, uint64_t arrival_ps, uint64_t t_ps,
                       bool* completed, uint64_t* done_ps) {
  AccessExtension& ext = PayloadPool::extension(*p);
  const LineAccess a{model.line_of(p->get_address()), p->get_data_length(), ext.kind,
                     ext.ray_type, p->is_write()};
  const CacheModel::Result r = model.request(a);
  if (r.outcome == CacheModel::Outcome::Blocked) return false;
  const uint64_t tag_done = t_ps + model.hit_latency_ps();
  if (r.writeback.dirty)
    send_down(r.writeback.line, true, AccessKind::Stack, r.writeback.writer, tag_done);
  *completed = r.outcome == CacheModel::Outcome::Hit ||
               (r.outcome == CacheModel::Outcome::Miss && !r.fetch);  // a write miss allocates at once
  *done_ps = tag_done;
  if (*completed) {
    ext.served = served_[a.write];
    if (!a.write) model.note_read_latency(a.ray_type, tag_done - arrival_ps);
    return true;
  }
  const bool merged = r.outcome == CacheModel::Outcome::Merged;
  Miss& miss = waiting_[a.line];
  miss.waiters.push_back({id, p, arrival_ps, merged});
  // A read of the L1 above waits for DRAM from here: the miss goes down, or it joins one.
  if (level_ == 2) move_read(ext, now_ps(), merged ? t_ps : tag_done, UnitAccounting::AtDram);
  if (r.fetch) {
    miss.since_ps = tag_done;
    send_down(a.line, false, a.kind, a.ray_type, tag_done);
  }
  return true;
}

tlm::tlm_sync_enum CycleCache::nb_transport_fw(int id, tlm_generic_payload& p,
                                               tlm::tlm_phase& phase, sc_core::sc_time& delay) {
  if (phase != tlm::BEGIN_REQ) return tlm::TLM_ACCEPTED;
  const uint64_t now = now_ps();
  const uint64_t arrival = now + to_ps(delay);
  const uint64_t t = model.reserve_port(arrival);
  bool completed = false;
  uint64_t done = 0;
  if (!serve(id, &p, arrival, t, &completed, &done)) {
    blocked_.push_back({id, &p, arrival, false});  // taken, answered once an MSHR frees
  } else if (completed) {
    // A hit without a port wait (most requests) takes the hit latency: a time
    // made once, not converted on every access.
    delay = done - now == model.hit_latency_ps() ? hit_delay_ : from_ps(done - now);
    phase = tlm::BEGIN_RESP;
    p.set_response_status(tlm::TLM_OK_RESPONSE);
    return tlm::TLM_COMPLETED;
  }
  phase = tlm::END_REQ;
  return tlm::TLM_UPDATED;
}

void CycleCache::send_down(uint64_t line, bool write, AccessKind kind, RayType type, uint64_t at_ps) {
  tlm_generic_payload* q = payloads_.get();
  AccessExtension& ext = PayloadPool::extension(*q);
  ext.kind = kind, ext.ray_type = type, ext.token = line, ext.first_try_ps = at_ps;
  // An L1's read miss is its unit's read on the way below (the unit's accounting).
  ext.owner = write || level_ != 1 ? nullptr : unit_;
  ext.served = ServedBy::None;
  q->set_command(write ? tlm::TLM_WRITE_COMMAND : tlm::TLM_READ_COMMAND);
  q->set_address(line);
  q->set_data_length(model.config().line_bytes);
  outbound_.push_back(q);
  queue_.push(at_ps, Item{Item::Send, 0});
}

void CycleCache::try_send() {
  const uint64_t now = now_ps();
  while (!awaiting_end_req_ && !outbound_.empty()) {
    tlm_generic_payload* q = outbound_.front();
    AccessExtension& ext = PayloadPool::extension(*q);
    if (ext.first_try_ps > now) break;  // its Send item is due later
    tlm::tlm_phase phase = tlm::BEGIN_REQ;
    sc_core::sc_time delay = sc_core::SC_ZERO_TIME;
    outbound_.pop_front();
    if (ext.owner) {
      ext.owner->change(now, UnitAccounting::AtNoc, +1);
      ext.location = UnitAccounting::AtNoc;
    }
    const tlm::tlm_sync_enum status = next->nb_transport_fw(*q, phase, delay);
    if (status == tlm::TLM_COMPLETED) {  // the next level hit
      if (!q->is_write()) {
        waiting_[ext.token].below = ext.served;
        queue_.push(now + to_ps(delay) + model.fill_latency_ps(), Item{Item::Fill, ext.token});
      }
      payloads_.put(q);
    } else if (status == tlm::TLM_ACCEPTED && phase == tlm::BEGIN_REQ) {
      // Taken but not accepted (a full queue below): nothing more goes down until END_REQ.
      awaiting_end_req_ = true;
      refused_since_ps_ = now;
      ++downstream_refusals;
    }
  }
}

tlm::tlm_sync_enum CycleCache::nb_transport_bw(tlm_generic_payload& q, tlm::tlm_phase& phase,
                                               sc_core::sc_time& delay) {
  const uint64_t now = now_ps();
  if (phase == tlm::END_REQ) {
    awaiting_end_req_ = false;
    downstream_stall_ps += now - refused_since_ps_;
    queue_.push(now, Item{Item::Send, 0});
    return tlm::TLM_ACCEPTED;
  }
  if (phase != tlm::BEGIN_RESP) return tlm::TLM_ACCEPTED;
  if (!q.is_write()) {
    const uint64_t line = PayloadPool::extension(q).token;
    const uint64_t arrives = now + to_ps(delay);
    auto it = waiting_.find(line);
    if (it != waiting_.end()) {
      it->second.below = PayloadPool::extension(q).served;
      // The data is back from DRAM: the reads above wait for this slice's fill now.
      if (level_ == 2)
        for (const Waiter& w : it->second.waiters)
          move_read(PayloadPool::extension(*w.p), now, arrives, UnitAccounting::AtL2);
    }
    queue_.push(arrives + model.fill_latency_ps(), Item{Item::Fill, line});
  }
  payloads_.put(&q);
  return tlm::TLM_COMPLETED;
}

void CycleCache::on_fill(uint64_t line) {
  const uint64_t now = now_ps();
  const Eviction e = model.fill(line);
  if (e.dirty) send_down(e.line, true, AccessKind::Stack, e.writer, now);
  auto it = waiting_.find(line);
  if (it != waiting_.end()) {
    Miss miss = std::move(it->second);
    waiting_.erase(it);
    if (timeline_ && !miss.waiters.empty()) {
      const AccessExtension& first = PayloadPool::extension(*miss.waiters.front().p);
      timeline_->span(track_, access_kind_name(first.kind), miss.since_ps, now,
                      std::string("\"type\":\"") + ray_type_name(first.ray_type) + "\",\"waiters\":" +
                          std::to_string(miss.waiters.size()) + ",\"served\":\"" + served_by_name(miss.below) + "\"");
    }
    for (const Waiter& w : miss.waiters) {
      AccessExtension& ext = PayloadPool::extension(*w.p);
      ext.served = w.merged ? served_merge(level_) : miss.below;
      if (!w.p->is_write()) model.note_read_latency(ext.ray_type, now - w.arrival_ps);
      tlm::tlm_phase phase = tlm::BEGIN_RESP;
      sc_core::sc_time zero = sc_core::SC_ZERO_TIME;
      w.p->set_response_status(tlm::TLM_OK_RESPONSE);
      target[w.id]->nb_transport_bw(*w.p, phase, zero);
    }
  }
  // An MSHR is free again: requests that found them all busy try again, in order.
  while (!blocked_.empty() && model.mshrs_in_use() < model.config().mshrs) {
    const Waiter w = blocked_.front();
    blocked_.pop_front();
    bool completed = false;
    uint64_t done = 0;
    if (!serve(w.id, w.p, w.arrival_ps, model.reserve_port(now), &completed, &done)) {
      blocked_.push_front(w);
      break;
    }
    if (completed) {
      tlm::tlm_phase phase = tlm::BEGIN_RESP;
      sc_core::sc_time delay = from_ps(done - now);
      w.p->set_response_status(tlm::TLM_OK_RESPONSE);
      target[w.id]->nb_transport_bw(*w.p, phase, delay);
    }
  }
}

void CycleCache::on_event() {
  queue_.drain([this](const Item& item) {
    if (item.kind == Item::Fill) on_fill(item.line);
    else try_send();
  });
}

// ---------------------------------------------------------------- DRAM

CycleDram::CycleDram(sc_core::sc_module_name name, const DramConfig& config, uint32_t access_bytes,
                     UnitScheduler& scheduler)
    : sc_module(name), target("target"), model(config, access_bytes),
      queue_(scheduler, [this] { on_event(); }) {
  target.register_nb_transport_fw(this, &CycleDram::nb_transport_fw);
  if (config.model == "dramsim3")
    reference_ = make_dramsim3(config, access_bytes,
                               (std::filesystem::temp_directory_path() /
                                ("rtsim-dramsim3-" + std::to_string(::getpid()))).string());
}

bool CycleDram::can_accept(tlm_generic_payload& p) const {
  return reference_ ? reference_->can_accept(p.get_address(), p.is_write())
                    : model.can_accept(p.get_address());
}

void CycleDram::settle(uint64_t end_ps) {
  if (reference_) reference_->finish(end_ps, model);
  else model.settle(end_ps);
}

uint32_t CycleDram::slot_for(int id, tlm_generic_payload* p) {
  if (free_slots_.empty()) {
    free_slots_.push_back(uint32_t(in_flight_.size()));
    in_flight_.emplace_back();
  }
  const uint32_t s = free_slots_.back();
  free_slots_.pop_back();
  in_flight_[s] = {id, p};
  return s;
}

void CycleDram::admit(uint32_t r, uint64_t now) {
  tlm_generic_payload* p = in_flight_[r].p;
  // The latency counts from the sender's first try, so a held request's wait is in it.
  const DramRequest request{p->get_address(), std::min(now, PayloadPool::extension(*p).first_try_ps), r,
                            p->is_write()};
  if (reference_) {
    if (arrival_ps_.size() <= r) arrival_ps_.resize(r + 1);
    arrival_ps_[r] = request.arrival_ps;
    reference_->enqueue(request, now);
  } else {
    model.enqueue(request, now);
  }
  if (decide_at_ > now) {
    decide_at_ = now;
    queue_.push(now, Item{Item::Decide, 0});
  }
}

tlm::tlm_sync_enum CycleDram::nb_transport_fw(int id, tlm_generic_payload& p, tlm::tlm_phase& phase,
                                              sc_core::sc_time&) {
  if (phase != tlm::BEGIN_REQ) return tlm::TLM_ACCEPTED;
  const uint32_t r = slot_for(id, &p);
  if (held_.empty() && can_accept(p)) {
    admit(r, now_ps());
    phase = tlm::END_REQ;
    return tlm::TLM_UPDATED;
  }
  // The channel queue is full: hold the request without END_REQ, which stops the sender.
  held_.push_back(r);
  model.note_rejection();
  return tlm::TLM_ACCEPTED;
}

void CycleDram::on_event() {
  const uint64_t now = now_ps();
  queue_.drain([&](const Item& item) {
    if (item.kind == Item::Respond) {
      InFlight f = in_flight_[item.request];
      free_slots_.push_back(item.request);
      tlm::tlm_phase phase = tlm::BEGIN_RESP;
      sc_core::sc_time zero = sc_core::SC_ZERO_TIME;
      // A reference model (DRAMsim3) does not say how the row stood: plain "DRAM".
      PayloadPool::extension(*f.p).served = reference_ ? ServedBy::Dram : served_by_dram(f.outcome);
      f.p->set_response_status(tlm::TLM_OK_RESPONSE);
      target[f.id]->nb_transport_bw(*f.p, phase, zero);
    } else {
      decide_at_ = UINT64_MAX;
    }
  });
  issued_.clear();
  if (reference_) {
    reference_->advance(now, issued_);
    for (const DramCompletion& c : issued_)
      model.count_reference_request(c.write, c.done_ps - arrival_ps_[c.tag]);
  } else {
    model.advance(now, issued_);
  }
  for (const DramCompletion& c : issued_) {
    in_flight_[c.tag].outcome = c.outcome;
    queue_.push(c.done_ps, Item{Item::Respond, uint32_t(c.tag)});
  }
  // Issues freed queue entries: held requests enter in order, each sender told by END_REQ.
  while (!held_.empty() && can_accept(*in_flight_[held_.front()].p)) {
    const uint32_t r = held_.front();
    held_.pop_front();
    admit(r, now);
    tlm::tlm_phase phase = tlm::END_REQ;
    sc_core::sc_time zero = sc_core::SC_ZERO_TIME;
    target[in_flight_[r].id]->nb_transport_bw(*in_flight_[r].p, phase, zero);
  }
  const uint64_t next = reference_ ? reference_->next_decision_ps() : model.next_decision_ps();
  if (next != UINT64_MAX && next < decide_at_) {
    decide_at_ = std::max(next, now + 1);
    queue_.push(decide_at_, Item{Item::Decide, 0});
  }
}

}  // namespace rtsim::sim
