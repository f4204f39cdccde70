#include <rtsim/model/sim/memory_system.h>
#include <rtsim/model/sim/sc_time_util.h>
#include <rtsim/model/sim/timeline.h>

#include <cmath>

namespace rtsim::sim {

using sc_core::sc_time;
using sc_core::SC_PS;

PayloadPool::~PayloadPool() {
  for (auto* p : all_) delete p;  // the payload frees its extension
}

void PayloadPool::grow() {
  auto* p = new Pooled;
  p->set_command(tlm::TLM_READ_COMMAND);
  p->access = new AccessExtension;
  p->set_extension(p->access);
  all_.push_back(p);
  free_.push_back(p);
}

FunctionalMemory::FunctionalMemory(const HardwareConfig& c, bool texture_caches)
    : shape(MachineShape::of(c)), noc(c, shape, false), dram(c.dram, c.l2.line_bytes) {
  for (uint32_t u = 0; u < shape.trv_units(); ++u)
    l1_node.push_back(std::make_unique<CacheModel>(c.l1_node_of(shape.core_of_trv(u)), "l1_node"));
  for (uint32_t u = 0; u < shape.ist_units(); ++u)
    l1_triangle.push_back(std::make_unique<CacheModel>(c.l1_triangle_of(shape.core_of_ist(u)), "l1_triangle"));
  for (uint32_t u = 0; texture_caches && u < shape.ist_units(); ++u)
    l1_texture.push_back(std::make_unique<CacheModel>(c.l1_texture, "l1_texture"));
  texture_line_bytes_ = c.l1_texture.line_bytes;
  for (uint32_t s = 0; s < shape.l2_slices; ++s)
    l2.push_back(std::make_unique<CacheModel>(c.l2_slice(), "l2"));
}

uint32_t FunctionalMemory::line_bytes(Requester who) const {
  if (who == Requester::Texture) return texture_line_bytes_;
  return (who == Requester::Trv ? l1_node : l1_triangle).front()->config().line_bytes;
}

bool FunctionalMemory::to_l2(uint32_t core, const LineAccess& a) {
  const uint32_t s = shape.slice_of(a.line);
  noc.to_slice(core, s, a.write ? a.bytes : 0, 0);
  const CacheModel::Result r = l2[s]->access(a);
  noc.to_core(s, core, a.write ? 0 : l2[s]->config().line_bytes, 0);
  if (r.writeback.dirty) dram.count_access(r.writeback.line, true);
  if (r.fetch) dram.count_access(a.line, false);
  return !r.fetch;
}

void FunctionalMemory::reset_counters() {
  for (auto& c : l1_node) c->reset_counters();
  for (auto& c : l1_triangle) c->reset_counters();
  for (auto& c : l1_texture) c->reset_counters();
  for (auto& c : l2) c->reset_counters();
  noc.reset_counters();
  dram.reset_counters();
}

void FunctionalMemorySink::on_access(const MemoryAccess& a, RayType type) {
  append_line_accesses(a, type, memory_->line_bytes(requester_of(a.kind)), lines_);
  if (probe_) accesses_.push_back(a);
}

void FunctionalMemorySink::on_step_end() {
  if (!probe_) {
    for (const LineAccess& line : lines_) memory_->access(requester_of(line.kind), 0, line, 0);
    lines_.clear();
    return;
  }
  probe_->next_step();
  uint32_t request = probe_->add(accesses_.data(), accesses_.size(), lines_.data(), lines_.size(),
                                 memory_->line_bytes(Requester::Trv), memory_->line_bytes(Requester::Ist),
                                 memory_->line_bytes(Requester::Texture), 0);
  for (const LineAccess& line : lines_) {
    ServedBy served = ServedBy::None;
    memory_->access_probed(requester_of(line.kind), 0, line, 0, &served);
    probe_->served(request++, served, 0);
  }
  lines_.clear();
  accesses_.clear();
}

// ---------------------------------------------------------------- loosely timed

LtCache::LtCache(sc_core::sc_module_name name, const CacheConfig& config, uint64_t cycle_ps)
    : sc_module(name), target("target"), next("next"), model(config, std::string(name), cycle_ps) {
  target.register_b_transport(this, &LtCache::b_transport);
  writeback_extension_ = new AccessExtension;
  writeback_.set_extension(writeback_extension_);
  writeback_.set_command(tlm::TLM_WRITE_COMMAND);
  writeback_.set_data_ptr(nullptr);
  writeback_extension_->kind = AccessKind::Stack;
}

void LtCache::b_transport(int, tlm::tlm_generic_payload& p, sc_time& delay) {
  auto* ext = p.get_extension<AccessExtension>();
  const bool write = p.is_write();
  const LineAccess a{model.line_of(p.get_address()), p.get_data_length(), ext->kind,
                     ext->ray_type, write};
  const uint64_t kernel = now_ps();
  const uint64_t arrival = kernel + to_ps(delay);
  const uint64_t start = model.reserve_port(arrival);
  const CacheModel::Result r = model.access(a, start);
  const uint64_t tag_checked = start + model.hit_latency_ps();
  uint64_t ready = tag_checked;
  if (r.outcome == CacheModel::Outcome::Hit || (r.outcome == CacheModel::Outcome::Miss && !r.fetch))
    ext->served = write && level_ == 1 ? ServedBy::L1Write : served_hit(level_);
  if (r.outcome == CacheModel::Outcome::Merged) {
    ready = std::max(ready, r.ready_ps);
    ext->served = served_merge(level_);
    // A read of the L1 above waits for the fill under way: from DRAM, then this slice's fill.
    if (level_ == 2) {
      move_read(*ext, kernel, tag_checked, UnitAccounting::AtDram);
      move_read(*ext, kernel, std::max(tag_checked, ready - std::min(ready, model.fill_latency_ps())),
                UnitAccounting::AtL2);
    }
  }
  if (r.fetch) {
    // The miss needs an MSHR: the earliest to free when all are busy.
    uint64_t send = tag_checked;
    while (!mshr_free_.empty() && mshr_free_.top() <= send) mshr_free_.pop();
    if (mshr_free_.size() >= model.config().mshrs) {
      send = mshr_free_.top();
      mshr_free_.pop();
      model.note_mshr_wait();
    }
    if (level_ == 1 && unit_) {  // the unit's read leaves its L1 for the crossbar
      unit_->change(kernel, send, UnitAccounting::AtNoc, +1);
      ext->owner = unit_, ext->location = UnitAccounting::AtNoc;
    } else if (level_ == 2) {
      move_read(*ext, kernel, send, UnitAccounting::AtDram);
    }
    // Ask the next level for the whole line with the same payload, then restore it.
    const uint64_t address = p.get_address();
    const unsigned length = p.get_data_length();
    p.set_address(a.line);
    p.set_data_length(model.config().line_bytes);
    sc_time next_delay = from_ps(send - kernel);
    next->b_transport(p, next_delay);
    p.set_address(address);
    p.set_data_length(length);
    const uint64_t back = kernel + to_ps(next_delay);
    if (level_ == 2) move_read(*ext, kernel, back, UnitAccounting::AtL2);  // DRAM's data is here
    ext->owner = nullptr;  // the crossbar ended the read's way at its L1
    ready = back + model.fill_latency_ps();
    model.set_arrival(a.line, ready);
    mshr_free_.push(ready);
    if (timeline_)
      timeline_->span(track_, access_kind_name(a.kind), tag_checked, ready,
                      std::string("\"type\":\"") + ray_type_name(a.ray_type) + "\",\"served\":\"" +
                          served_by_name(ext->served) + "\"");
  }
  if (!write) model.note_read_latency(a.ray_type, ready - arrival);
  if (r.writeback.dirty) {
    // Posted: the dirty line goes down at the tag check; nobody waits for it.
    writeback_.set_address(r.writeback.line);
    writeback_.set_data_length(model.config().line_bytes);
    writeback_extension_->ray_type = r.writeback.writer;
    writeback_.set_response_status(tlm::TLM_INCOMPLETE_RESPONSE);
    sc_time wb_delay = from_ps(tag_checked - kernel);
    next->b_transport(writeback_, wb_delay);
  }
  delay = from_ps(ready - kernel);
  p.set_response_status(tlm::TLM_OK_RESPONSE);
}

LtCrossbar::LtCrossbar(sc_core::sc_module_name name, Crossbar& model, const MachineShape& shape)
    : sc_module(name), target("target"), to_slice("to_slice"), model_(model), shape_(shape) {
  target.register_b_transport(this, &LtCrossbar::b_transport);
}

void LtCrossbar::bind_l1(tlm_utils::simple_initiator_socket<LtCache>& l1, uint32_t core) {
  l1.bind(target);  // target ports are numbered in bind order
  core_of_port_.push_back(core);
}

void LtCrossbar::b_transport(int id, tlm::tlm_generic_payload& p, sc_time& delay) {
  const uint32_t core = core_of_port_[size_t(id)];
  const uint32_t slice = shape_.slice_of(p.get_address());
  const bool write = p.is_write();
  const uint64_t now = now_ps();
  const uint64_t there = model_.to_slice(core, slice, write ? p.get_data_length() : 0, now + to_ps(delay));
  AccessExtension& ext = *p.get_extension<AccessExtension>();
  move_read(ext, now, there, UnitAccounting::AtL2);
  sc_time slice_delay = from_ps(there - now);
  to_slice[slice]->b_transport(p, slice_delay);
  const uint64_t answered = now + to_ps(slice_delay);
  const uint64_t back = model_.to_core(slice, core, write ? 0 : p.get_data_length(), answered);
  move_read(ext, now, answered, UnitAccounting::AtNoc);
  end_read(ext, now, back);
  delay = from_ps(back - now);
}

LtDram::LtDram(sc_core::sc_module_name name, const DramConfig& config, uint32_t access_bytes)
    : sc_module(name), target("target"), model(config, access_bytes) {
  target.register_b_transport(this, &LtDram::b_transport);
}

void LtDram::b_transport(int, tlm::tlm_generic_payload& p, sc_time& delay) {
  const uint64_t now = now_ps() + to_ps(delay);
  RowOutcome outcome = RowOutcome::Hit;
  const uint64_t done = model.lt_access(p.get_address(), p.is_write(), now, &outcome);
  p.get_extension<AccessExtension>()->served = served_by_dram(outcome);
  delay += from_ps(done - now);
  p.set_response_status(tlm::TLM_OK_RESPONSE);
}

LtSystem::LtSystem(sc_core::sc_module_name name, const HardwareConfig& config,
                   const Workload& workload, std::function<void(uint64_t)> progress)
    : sc_module(name), engine(config, workload, true), shape(MachineShape::of(config)),
      noc_model(config, shape, true), config_(config), progress_(std::move(progress)) {
  const uint64_t cycle_ps = config.cycle_ps();
  dram = std::make_unique<LtDram>("dram", config.dram, config.l2.line_bytes);
  noc = std::make_unique<LtCrossbar>("noc", noc_model, shape);
  for (uint32_t s = 0; s < shape.l2_slices; ++s) {
    const std::string instance = MachineShape::slice_name(s);
    l2.push_back(std::make_unique<LtCache>(MachineShape::module_name(instance).c_str(),
                                           config.l2_slice(), cycle_ps));
    noc->to_slice.bind(l2.back()->target);
    l2.back()->next.bind(dram->target);
  }
  for (uint32_t u = 0; u < shape.trv_units(); ++u) {
    const std::string instance = shape.l1_node_name(u);
    l1_node.push_back(std::make_unique<LtCache>(MachineShape::module_name(instance).c_str(),
                                                config.l1_node_of(shape.core_of_trv(u)), cycle_ps));
    l1_node.back()->set_level(1, &engine.trv_units()[u].accounting);
    trv_ports_.push_back(std::make_unique<tlm_utils::simple_initiator_socket<LtSystem>>(
        MachineShape::module_name(shape.trv_name(u) + "_memory").c_str()));
    trv_ports_.back()->bind(l1_node.back()->target);
    noc->bind_l1(l1_node.back()->next, shape.core_of_trv(u));
  }
  for (uint32_t u = 0; u < shape.ist_units(); ++u) {
    const std::string instance = shape.l1_triangle_name(u);
    l1_triangle.push_back(std::make_unique<LtCache>(MachineShape::module_name(instance).c_str(),
                                                    config.l1_triangle_of(shape.core_of_ist(u)), cycle_ps));
    // No unit's accounting: the lt IST unit holds a leaf only from its data's arrival
    // (ray_engine.h), so its reads' misses are no wait of its own (the TRV unit waits
    // on the IST unit meanwhile).
    l1_triangle.back()->set_level(1);
    ist_ports_.push_back(std::make_unique<tlm_utils::simple_initiator_socket<LtSystem>>(
        MachineShape::module_name(shape.ist_name(u) + "_memory").c_str()));
    ist_ports_.back()->bind(l1_triangle.back()->target);
    noc->bind_l1(l1_triangle.back()->next, shape.core_of_ist(u));
  }
  // The any-hit stages' texture caches, only for a scene with alpha-tested materials.
  // Like the triangle caches, no unit's accounting: the IST unit holds the test from
  // its data's arrival.
  for (uint32_t u = 0; workload.context->image().has_alpha_data() && u < shape.ist_units(); ++u) {
    const std::string instance = shape.l1_texture_name(u);
    l1_texture.push_back(std::make_unique<LtCache>(MachineShape::module_name(instance).c_str(),
                                                   config.l1_texture, cycle_ps));
    l1_texture.back()->set_level(1);
    texture_ports_.push_back(std::make_unique<tlm_utils::simple_initiator_socket<LtSystem>>(
        MachineShape::module_name(shape.ist_name(u) + "_texture_memory").c_str()));
    texture_ports_.back()->bind(l1_texture.back()->target);
    noc->bind_l1(l1_texture.back()->next, shape.core_of_ist(u));
  }
  tlm_utils::tlm_quantumkeeper::set_global_quantum(
      from_ps(uint64_t(config.lt_quantum_cycles) * cycle_ps));
  quantum_.reset();
  extension_ = new AccessExtension;
  payload_.set_extension(extension_);
  payload_.set_data_ptr(buffer_);
  SC_THREAD(thread);
}

uint32_t LtSystem::line_bytes(Requester who) const {
  if (who == Requester::Texture) return config_.l1_texture.line_bytes;
  return who == Requester::Trv ? config_.l1_node.line_bytes : config_.l1_triangle.line_bytes;
}

uint64_t LtSystem::access(Requester who, uint32_t unit, const LineAccess& a, uint64_t issue_ps) {
  const uint64_t now = now_ps();
  // The engine runs events in time order, at or ahead of the kernel.
  const uint64_t issue = std::max(issue_ps, now);
  sc_time delay = from_ps(issue - now);
  payload_.set_address(a.line);
  payload_.set_data_length(a.bytes);
  payload_.set_command(a.write ? tlm::TLM_WRITE_COMMAND : tlm::TLM_READ_COMMAND);
  payload_.set_response_status(tlm::TLM_INCOMPLETE_RESPONSE);
  extension_->kind = a.kind;
  extension_->ray_type = a.ray_type;
  extension_->owner = nullptr;
  extension_->served = ServedBy::None;
  auto& port = who == Requester::Trv ? trv_ports_[unit] : who == Requester::Ist ? ist_ports_[unit] : texture_ports_[unit];
  (*port)->b_transport(payload_, delay);
  return now + to_ps(delay);
}

uint64_t LtSystem::access_probed(Requester who, uint32_t unit, const LineAccess& a, uint64_t issue_ps,
                                 ServedBy* served) {
  const uint64_t done = access(who, unit, a, issue_ps);
  *served = extension_->served;
  return done;
}

void LtSystem::reset_counters() {
  for (auto& c : l1_node) c->model.reset_counters();
  for (auto& c : l1_triangle) c->model.reset_counters();
  for (auto& c : l1_texture) c->model.reset_counters();
  for (auto& c : l2) c->model.reset_counters();
  noc_model.reset_counters();
  dram->model.reset_counters();
}

void LtSystem::thread() {
  engine.run(
      *this,
      [this](uint64_t event_ps) {
        // Temporal decoupling: the engine runs ahead of the kernel by up to a
        // quantum, then lets the kernel catch up. Only how often it yields
        // depends on the quantum: every time comes from the events themselves.
        const uint64_t now = now_ps();
        if (event_ps <= now) return;
        quantum_.set(from_ps(event_ps - now));
        if (quantum_.need_sync()) quantum_.sync();
      },
      [this](bool last) {
        const auto& d = dram->model.counters();
        frame_history.push_back({engine.total().rays, d.bytes, d.bytes_written,
                                 engine.end_ps() - engine.start_ps()});
        if (!last) reset_counters();
      },
      progress_);
}

}  // namespace rtsim::sim
