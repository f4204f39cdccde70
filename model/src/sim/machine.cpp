#include <rtsim/model/sim/machine.h>
#include <rtsim/model/sim/timeline.h>

#include <rtsim/model/core/traversal.h>
#include <rtsim/workloads/host.h>

#include <algorithm>
#include <cmath>

namespace rtsim::sim {

uint64_t model_memory_bytes(const HardwareConfig& c, std::string* factors) {
  struct Term {
    uint64_t bytes;
    std::string keys;
  };
  std::vector<Term> terms;
  auto lines = [](const CacheConfig& cache) { return cache.line_bytes ? cache.size_bytes / cache.line_bytes : 0; };
  uint64_t l1_node = 0, l1_triangle = 0;
  // The texture caches are built only for alpha-tested scenes; counted always, so
  // that a machine is refused or not whatever the scene.
  terms.push_back({saturating_mul(saturating_mul(uint64_t(c.cores) * c.ist_units, lines(c.l1_texture)),
                                  kCacheLineHostBytes),
                   "cores " + std::to_string(c.cores) + " x ist.units " + std::to_string(c.ist_units) +
                       " L1 texture caches of l1_texture.size_bytes " + std::to_string(c.l1_texture.size_bytes)});
  for (uint32_t core = 0; core < c.cores; ++core) {
    l1_node = saturating_add(l1_node, saturating_mul(c.trv_units, lines(c.l1_node_of(core))));
    l1_triangle = saturating_add(l1_triangle, saturating_mul(c.ist_units, lines(c.l1_triangle_of(core))));
  }
  terms.push_back({saturating_mul(l1_node, kCacheLineHostBytes),
                   "cores " + std::to_string(c.cores) + " x trv.units " + std::to_string(c.trv_units) +
                       " L1 node caches of l1_node.size_bytes " + std::to_string(c.l1_node.size_bytes)});
  terms.push_back({saturating_mul(l1_triangle, kCacheLineHostBytes),
                   "cores " + std::to_string(c.cores) + " x ist.units " + std::to_string(c.ist_units) +
                       " L1 triangle caches of l1_triangle.size_bytes " + std::to_string(c.l1_triangle.size_bytes)});
  terms.push_back({saturating_mul(lines(c.l2), kCacheLineHostBytes),
                   "l2.size_bytes " + std::to_string(c.l2.size_bytes)});
  // A slot: its traversal state, its stack (trv.stack_entries, at most the spill
  // area) and the engine's per-slot bookkeeping.
  const uint64_t per_slot = sizeof(RayTraversal) + 2 * sizeof(MemoryAccess) * 16 +
                            uint64_t(TraversalContext::kStackAreaEntries) * 16 + 64;
  terms.push_back({saturating_mul(saturating_mul(uint64_t(c.cores) * c.trv_units, c.trv_ray_slots), per_slot),
                   "cores " + std::to_string(c.cores) + " x trv.units " + std::to_string(c.trv_units) +
                       " x trv.ray_slots " + std::to_string(c.trv_ray_slots) + " ray slots"});
  uint64_t total = 0;
  const Term* largest = &terms.front();
  for (const Term& t : terms) {
    total = saturating_add(total, t.bytes);
    if (t.bytes > largest->bytes) largest = &t;
  }
  if (factors) *factors = largest->keys + ": " + memory_text(largest->bytes);
  return total;
}

MachineShape MachineShape::of(const HardwareConfig& c) {
  MachineShape m;
  m.cores = c.cores;
  m.trv_per_core = c.trv_units;
  m.ist_per_core = c.ist_units;
  m.slots_per_trv = c.trv_ray_slots;
  m.l2_slices = c.l2_slices;
  m.l2_line_bytes = c.l2.line_bytes;
  return m;
}

std::string MachineShape::trv_name(uint32_t trv) const {
  return core_name(core_of_trv(trv)) + ".trv" + std::to_string(trv % trv_per_core);
}
std::string MachineShape::ist_name(uint32_t ist) const {
  return core_name(core_of_ist(ist)) + ".ist" + std::to_string(ist % ist_per_core);
}
std::string MachineShape::l1_node_name(uint32_t trv) const {
  return core_name(core_of_trv(trv)) + ".l1_node" + std::to_string(trv % trv_per_core);
}
std::string MachineShape::l1_texture_name(uint32_t ist) const {
  return core_name(core_of_ist(ist)) + ".l1_texture" + std::to_string(ist % ist_per_core);
}
std::string MachineShape::l1_triangle_name(uint32_t ist) const {
  return core_name(core_of_ist(ist)) + ".l1_triangle" + std::to_string(ist % ist_per_core);
}
std::string MachineShape::module_name(const std::string& instance) {
  std::string s = instance;
  std::replace(s.begin(), s.end(), '.', '_');
  return s;
}

Crossbar::Crossbar(const HardwareConfig& c, const MachineShape& m, bool timed)
    : timed_(timed), flit_bytes_(c.noc_flit_bytes), header_bytes_(c.noc_header_bytes),
      cycle_ps_(c.cycle_ps()),
      latency_ps_(uint64_t(c.noc_latency_cycles) * cycle_ps_),
      core_in_flits_(m.cores, 0), slice_in_flits_(m.l2_slices, 0) {
  // Reservations reach a DRAM access ahead of the calls (microseconds).
  constexpr uint64_t kHorizonPs = 8'000'000;
  if (!timed_ || flit_bytes_ == 0) return;  // no port timing
  core_out_.assign(m.cores, PortSlots(cycle_ps_, kHorizonPs));
  core_in_.assign(m.cores, PortSlots(cycle_ps_, kHorizonPs));
  slice_in_.assign(m.l2_slices, PortSlots(cycle_ps_, kHorizonPs));
  slice_out_.assign(m.l2_slices, PortSlots(cycle_ps_, kHorizonPs));
}

uint64_t Crossbar::send(PortSlots* out_port, PortSlots* in_port, uint32_t to, uint32_t data_bytes,
                        uint64_t t, int direction) {
  const uint32_t bytes = header_bytes_ + data_bytes;
  const uint64_t flits = flit_bytes_ ? std::max<uint64_t>(1, (bytes + flit_bytes_ - 1) / flit_bytes_) : 0;
  ++messages_[direction];
  bytes_[direction] += bytes;
  flits_[direction] += flits;
  (direction == 0 ? slice_in_flits_ : core_in_flits_)[to] += flits;
  if (!timed_) return t;
  if (flits == 0) {
    if (timeline_)
      timeline_->span((direction == 0 ? slice_tracks_ : core_tracks_)[to], direction == 0 ? "request" : "answer",
                      t, t + latency_ps_, "\"bytes\":" + std::to_string(bytes));
    return t + latency_ps_;
  }
  PortSlots& out = *out_port;
  PortSlots& in = *in_port;
  // Each flit in the first cycle from t on in which both ports are free.
  uint64_t slot = t / cycle_ps_, last = slot;
  for (uint64_t f = 0; f < flits; ++f) {
    for (;;) {
      const uint64_t a = out.first_free(slot), b = in.first_free(a);
      if (b == a) break;
      slot = b;
    }
    slot = out.first_free(slot);
    if (!out.forgotten(slot)) out.take(slot);
    if (!in.forgotten(slot)) in.take(slot);
    last = slot++;
  }
  const uint64_t unblocked = t + flits * cycle_ps_;
  const uint64_t sent = std::max(unblocked, (last + 1) * cycle_ps_);
  const uint64_t wait = sent - unblocked;
  wait_ps_ += wait;
  wait_max_ps_ = std::max(wait_max_ps_, wait);
  if (timeline_)
    timeline_->span((direction == 0 ? slice_tracks_ : core_tracks_)[to], direction == 0 ? "request" : "answer", t,
                    sent + latency_ps_,
                    "\"bytes\":" + std::to_string(bytes) + ",\"queued_cycles\":" + std::to_string(wait / cycle_ps_));
  return sent + latency_ps_;
}

uint64_t Crossbar::to_slice(uint32_t core, uint32_t slice, uint32_t data_bytes, uint64_t t) {
  const bool ports = !core_out_.empty();
  return send(ports ? &core_out_[core] : nullptr, ports ? &slice_in_[slice] : nullptr, slice,
              data_bytes, t, 0);
}

uint64_t Crossbar::to_core(uint32_t slice, uint32_t core, uint32_t data_bytes, uint64_t t) {
  const bool ports = !core_in_.empty();
  return send(ports ? &slice_out_[slice] : nullptr, ports ? &core_in_[core] : nullptr, core,
              data_bytes, t, 1);
}

void Crossbar::reset_counters() {
  std::fill(core_in_flits_.begin(), core_in_flits_.end(), 0);
  std::fill(slice_in_flits_.begin(), slice_in_flits_.end(), 0);
  for (int d = 0; d < 2; ++d) messages_[d] = bytes_[d] = flits_[d] = 0;
  wait_ps_ = wait_max_ps_ = 0;
}

void Crossbar::report(StatsRegistry& s, const std::string& prefix, uint64_t sim_ps) const {
  const double cycles = double(sim_ps) / double(cycle_ps_);
  const char* names[2] = {"to_slices", "to_cores"};
  const char* what[2] = {"requests and write data, L1s to L2 slices",
                         "responses and read data, L2 slices to L1s"};
  for (int d = 0; d < 2; ++d) {
    const std::string p = prefix + "." + names[d];
    s.set(p + ".messages", messages_[d], "messages", std::string("crossbar messages: ") + what[d]);
    s.set(p + ".bytes", bytes_[d], "bytes", "bytes of those messages, headers included");
    if (flit_bytes_ == 0) continue;
    s.set(p + ".flits", flits_[d], "flits", "port cycles those messages took (noc.flit_bytes each)");
    if (!timed_ || cycles <= 0) continue;
    const std::vector<uint64_t>& ports = d == 0 ? slice_in_flits_ : core_in_flits_;
    uint64_t max = 0, sum = 0;
    for (uint64_t f : ports) max = std::max(max, f), sum += f;
    s.set_real(p + ".max_port_utilisation", std::min(1.0, double(max) / cycles), "ratio",
               "the busiest receiving port's flit cycles / simulated cycles");
    s.set_real(p + ".mean_port_utilisation",
               std::min(1.0, double(sum) / double(ports.size()) / cycles), "ratio",
               "receiving ports' flit cycles / (ports x simulated cycles)");
  }
  s.set(prefix + ".latency_cycles", latency_ps_ / cycle_ps_, "cycles", "crossbar traversal, one way");
  if (timed_ && flit_bytes_ != 0) {
    const uint64_t messages = messages_[0] + messages_[1];
    s.set_real(prefix + ".wait_cycles_mean",
               messages ? double(wait_ps_) / double(cycle_ps_) / double(messages) : 0, "cycles",
               "mean cycles a message waited for its two ports (queueing)");
    s.set_real(prefix + ".wait_cycles_max", double(wait_max_ps_) / double(cycle_ps_), "cycles",
               "longest wait of a message for its ports");
  }
}

}  // namespace rtsim::sim
