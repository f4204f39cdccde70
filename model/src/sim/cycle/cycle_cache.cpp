#include <rtsim/model/sim/cycle/cycle_cache.h>

namespace rtsim::sim {

using tlm::tlm_generic_payload;

CycleCache::CycleCache(sc_core::sc_module_name name, const CacheConfig& config, uint64_t cycle_ps)
    : sc_module(name), target("target"), next("next"), model(config, std::string(name)),
      hit_ps_(uint64_t(config.hit_latency_cycles) * cycle_ps) {
  target.register_nb_transport_fw(this, &CycleCache::nb_transport_fw);
  next.register_nb_transport_bw(this, &CycleCache::nb_transport_bw);
  SC_METHOD(on_fill);
  sensitive << fills_.event();
  dont_initialize();
}

tlm::tlm_sync_enum CycleCache::nb_transport_fw(int id, tlm_generic_payload& p,
                                               tlm::tlm_phase& phase, sc_core::sc_time& delay) {
  if (phase != tlm::BEGIN_REQ) return tlm::TLM_ACCEPTED;
  const uint64_t d = to_ps(delay);
  auto* ext = p.get_extension<AccessExtension>();
  const LineAccess a{model.line_of(p.get_address()), p.get_data_length(), ext->kind, ext->ray_type};
  const CacheModel::Outcome outcome = model.request(a);
  if (outcome == CacheModel::Outcome::Hit) {
    delay = from_ps(d + hit_ps_);
    phase = tlm::BEGIN_RESP;
    p.set_response_status(tlm::TLM_OK_RESPONSE);
    return tlm::TLM_COMPLETED;
  }
  if (outcome == CacheModel::Outcome::Blocked) {
    blocked_.push_back({id, &p});
    return tlm::TLM_ACCEPTED;
  }
  waiting_[a.line].push_back({id, &p});
  if (outcome == CacheModel::Outcome::Miss) {
    tlm_generic_payload* q = payloads_.get();
    AccessExtension* own = &PayloadPool::extension(*q);
    own->kind = a.kind, own->ray_type = a.ray_type, own->token = a.line;
    q->set_address(a.line);
    q->set_data_length(model.config().line_bytes);
    tlm::tlm_phase fw = tlm::BEGIN_REQ;
    sc_core::sc_time fw_delay = from_ps(d + hit_ps_);
    if (next->nb_transport_fw(*q, fw, fw_delay) == tlm::TLM_COMPLETED) {
      fills_.push(now_ps() + to_ps(fw_delay), a.line);
      payloads_.put(q);
    }
  }
  return tlm::TLM_ACCEPTED;
}

tlm::tlm_sync_enum CycleCache::nb_transport_bw(tlm_generic_payload& q, tlm::tlm_phase& phase,
                                               sc_core::sc_time& delay) {
  if (phase != tlm::BEGIN_RESP) return tlm::TLM_ACCEPTED;
  fills_.push(now_ps() + to_ps(delay), q.get_extension<AccessExtension>()->token);
  payloads_.put(&q);
  return tlm::TLM_COMPLETED;
}

void CycleCache::on_fill() {
  fills_.drain([this](uint64_t line) {
    model.fill(line);
    auto it = waiting_.find(line);
    if (it != waiting_.end()) {
      std::vector<Waiter> waiters = std::move(it->second);
      waiting_.erase(it);
      for (const Waiter& w : waiters) {
        tlm::tlm_phase phase = tlm::BEGIN_RESP;
        sc_core::sc_time zero = sc_core::SC_ZERO_TIME;
        w.p->set_response_status(tlm::TLM_OK_RESPONSE);
        target[w.id]->nb_transport_bw(*w.p, phase, zero);
      }
    }
    // An MSHR is free again: requests that found them all busy try again, in order.
    while (!blocked_.empty() && model.mshrs_in_use() < model.config().mshrs) {
      Waiter w = blocked_.front();
      blocked_.pop_front();
      tlm::tlm_phase phase = tlm::BEGIN_REQ;
      sc_core::sc_time zero = sc_core::SC_ZERO_TIME;
      if (nb_transport_fw(w.id, *w.p, phase, zero) == tlm::TLM_COMPLETED) {
        target[w.id]->nb_transport_bw(*w.p, phase, zero);
      }
    }
  });
}

// ------------------------------------------------------------------------ DRAM

CycleDram::CycleDram(sc_core::sc_module_name name, const DramConfig& config, uint32_t access_bytes)
    : sc_module(name), target("target"), model(config, access_bytes) {
  target.register_nb_transport_fw(this, &CycleDram::nb_transport_fw);
  SC_METHOD(on_event);
  sensitive << queue_.event();
  dont_initialize();
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

tlm::tlm_sync_enum CycleDram::nb_transport_fw(int id, tlm_generic_payload& p, tlm::tlm_phase& phase,
                                              sc_core::sc_time& delay) {
  if (phase != tlm::BEGIN_REQ) return tlm::TLM_ACCEPTED;
  queue_.push(now_ps() + to_ps(delay), Item{Item::Arrive, slot_for(id, &p)});
  return tlm::TLM_ACCEPTED;
}

void CycleDram::on_event() {
  const uint64_t now = now_ps();
  queue_.drain([&](const Item& item) {
    if (item.kind == Item::Arrive) {
      held_.push_back(item.request);
    } else if (item.kind == Item::Respond) {
      InFlight f = in_flight_[item.request];
      free_slots_.push_back(item.request);
      tlm::tlm_phase phase = tlm::BEGIN_RESP;
      sc_core::sc_time zero = sc_core::SC_ZERO_TIME;
      f.p->set_response_status(tlm::TLM_OK_RESPONSE);
      target[f.id]->nb_transport_bw(*f.p, phase, zero);
    } else if (item.kind == Item::Decide) {
      decide_at_ = UINT64_MAX;
    }
  });
  // Held arrivals enter their channel's queue in order while it has room.
  for (size_t i = 0; i < held_.size();) {
    const uint32_t r = held_[i];
    const uint64_t address = in_flight_[r].p->get_address();
    if (model.can_accept(address)) {
      model.enqueue({address, now, r});
      held_.erase(held_.begin() + long(i));
    } else {
      model.note_rejection();
      ++i;
    }
  }
  issued_.clear();
  model.advance(now, issued_);
  for (const DramCompletion& c : issued_) queue_.push(c.done_ps, Item{Item::Respond, uint32_t(c.tag)});
  if (!issued_.empty() && !held_.empty()) {
    // Issues freed queue entries: try the held requests again right away.
    queue_.push(now, Item{Item::Decide, 0});
    decide_at_ = now;
  }
  const uint64_t next = model.next_decision_ps();
  if (next != UINT64_MAX && next < decide_at_) {
    decide_at_ = std::max(next, now + 1);
    queue_.push(decide_at_, Item{Item::Decide, 0});
  }
}

}  // namespace rtsim::sim
