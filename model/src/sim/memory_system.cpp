#include <rtsim/model/sim/memory_system.h>
#include <rtsim/model/sim/sc_time_util.h>

#include <cmath>

namespace rtsim::sim {

using sc_core::sc_time;
using sc_core::SC_PS;

PayloadPool::~PayloadPool() {
  for (auto* p : all_) delete p;  // the payload frees its extension
}

tlm::tlm_generic_payload* PayloadPool::get() {
  if (free_.empty()) {
    auto* p = new tlm::tlm_generic_payload;
    p->set_command(tlm::TLM_READ_COMMAND);
    p->set_extension(new AccessExtension);
    all_.push_back(p);
    free_.push_back(p);
  }
  auto* p = free_.back();
  free_.pop_back();
  return p;
}

FunctionalMemory::FunctionalMemory(const HardwareConfig& c)
    : l2(c.l2, "l2"), dram(c.dram, c.l2.line_bytes) {
  for (uint32_t u = 0; u < c.trv_units; ++u)
    l1_node.push_back(std::make_unique<CacheModel>(c.l1_node, "l1_node"));
  for (uint32_t u = 0; u < c.ist_units; ++u)
    l1_triangle.push_back(std::make_unique<CacheModel>(c.l1_triangle, "l1_triangle"));
}

uint32_t FunctionalMemory::l1_line_bytes(Requester who) const {
  return (who == Requester::Trv ? l1_node : l1_triangle).front()->config().line_bytes;
}

uint64_t FunctionalMemory::read(Requester who, uint32_t unit, const LineAccess& a,
                                uint64_t issue_ps) {
  CacheModel& l1 = *(who == Requester::Trv ? l1_node : l1_triangle)[unit];
  if (l1.access(a)) return issue_ps;
  const LineAccess to_l2{l2.line_of(a.line), l1.config().line_bytes, a.kind, a.ray_type};
  if (!l2.access(to_l2)) dram.count_access(to_l2.line);
  return issue_ps;
}

// ---------------------------------------------------------------- loosely timed

LtCache::LtCache(sc_core::sc_module_name name, const CacheConfig& config, uint64_t cycle_ps)
    : sc_module(name), target("target"), next("next"), model(config, std::string(name)),
      latency_(from_ps(uint64_t(config.hit_latency_cycles) * cycle_ps)) {
  target.register_b_transport(this, &LtCache::b_transport);
}

void LtCache::b_transport(int, tlm::tlm_generic_payload& p, sc_time& delay) {
  auto* ext = p.get_extension<AccessExtension>();
  const LineAccess a{model.line_of(p.get_address()), p.get_data_length(), ext->kind,
                     ext->ray_type};
  delay += latency_;  // tag check: a hit returns the data, a miss goes on from here
  if (!model.access(a)) {
    // Ask the next level for the whole line with the same payload, then restore it.
    const uint64_t address = p.get_address();
    const unsigned length = p.get_data_length();
    p.set_address(a.line);
    p.set_data_length(model.config().line_bytes);
    next->b_transport(p, delay);
    p.set_address(address);
    p.set_data_length(length);
  }
  p.set_response_status(tlm::TLM_OK_RESPONSE);
}

LtDram::LtDram(sc_core::sc_module_name name, const DramConfig& config, uint32_t access_bytes,
               uint64_t window_ps)
    : sc_module(name), target("target"), model(config, access_bytes), window_ps_(window_ps) {
  target.register_b_transport(this, &LtDram::b_transport);
}

void LtDram::b_transport(int, tlm::tlm_generic_payload& p, sc_time& delay) {
  const uint64_t now = now_ps() + to_ps(delay);
  const uint64_t done = model.lt_access(p.get_address(), p.is_write(), now);
  delay += from_ps(done - now);
  p.set_response_status(tlm::TLM_OK_RESPONSE);
}

LtSystem::LtSystem(sc_core::sc_module_name name, const HardwareConfig& config,
                   const Workload& workload, std::function<void(uint64_t)> progress)
    : sc_module(name), engine(config, workload, true), config_(config),
      progress_(std::move(progress)) {
  const uint64_t cycle_ps = uint64_t(std::llround(config.clock_period_ps()));
  l2 = std::make_unique<LtCache>("l2", config.l2, cycle_ps);
  // Requests reach DRAM out of time order by up to a quantum (temporal decoupling).
  dram = std::make_unique<LtDram>("dram", config.dram, config.l2.line_bytes,
                                  uint64_t(config.lt_quantum_cycles) * cycle_ps);
  l2->next.bind(dram->target);
  for (uint32_t u = 0; u < config.trv_units; ++u) {
    const std::string id = std::to_string(u);
    l1_node.push_back(std::make_unique<LtCache>(("l1_node" + id).c_str(), config.l1_node, cycle_ps));
    trv_ports_.push_back(std::make_unique<tlm_utils::simple_initiator_socket<LtSystem>>(
        ("trv" + id + "_memory").c_str()));
    trv_ports_.back()->bind(l1_node.back()->target);
    l1_node.back()->next.bind(l2->target);
  }
  for (uint32_t u = 0; u < config.ist_units; ++u) {
    const std::string id = std::to_string(u);
    l1_triangle.push_back(
        std::make_unique<LtCache>(("l1_triangle" + id).c_str(), config.l1_triangle, cycle_ps));
    ist_ports_.push_back(std::make_unique<tlm_utils::simple_initiator_socket<LtSystem>>(
        ("ist" + id + "_memory").c_str()));
    ist_ports_.back()->bind(l1_triangle.back()->target);
    l1_triangle.back()->next.bind(l2->target);
  }
  tlm_utils::tlm_quantumkeeper::set_global_quantum(
      from_ps(uint64_t(config.lt_quantum_cycles) * cycle_ps));
  quantum_.reset();
  extension_ = new AccessExtension;
  payload_.set_extension(extension_);
  payload_.set_data_ptr(buffer_);
  payload_.set_command(tlm::TLM_READ_COMMAND);
  SC_THREAD(thread);
}

uint32_t LtSystem::l1_line_bytes(Requester who) const {
  return who == Requester::Trv ? config_.l1_node.line_bytes : config_.l1_triangle.line_bytes;
}

uint64_t LtSystem::read(Requester who, uint32_t unit, const LineAccess& a, uint64_t issue_ps) {
  const uint64_t now = now_ps();
  // A slot may lag the kernel by less than a quantum: it then issues "now".
  const uint64_t issue = std::max(issue_ps, now);
  sc_time delay = from_ps(issue - now);
  payload_.set_address(a.line);
  payload_.set_data_length(a.bytes);
  payload_.set_response_status(tlm::TLM_INCOMPLETE_RESPONSE);
  extension_->kind = a.kind;
  extension_->ray_type = a.ray_type;
  auto& port = who == Requester::Trv ? trv_ports_[unit] : ist_ports_[unit];
  (*port)->b_transport(payload_, delay);
  return now + to_ps(delay);
}

void LtSystem::thread() {
  engine.run(
      *this,
      [this](uint64_t earliest_ps) {
        // Temporal decoupling: the engine runs ahead of the kernel until its
        // earliest slot is a quantum ahead, then lets the kernel catch up.
        const uint64_t now = now_ps();
        if (earliest_ps <= now) return;
        quantum_.set(from_ps(earliest_ps - now));
        if (quantum_.need_sync()) quantum_.sync();
      },
      progress_);
}

}  // namespace rtsim::sim
