#include <rtsim/model/sim/ray_engine.h>

#include <algorithm>
#include <cmath>

namespace rtsim::sim {

uint64_t UnitTime::occupied_ps() const {
  std::vector<std::pair<uint64_t, uint64_t>> s = spans;
  std::sort(s.begin(), s.end());
  uint64_t total = 0, cur_start = 0, cur_end = 0;
  bool open = false;
  for (auto& [a, b] : s) {
    if (!open || a > cur_end) {
      if (open) total += cur_end - cur_start;
      cur_start = a, cur_end = b, open = true;
    } else {
      cur_end = std::max(cur_end, b);
    }
  }
  if (open) total += cur_end - cur_start;
  return total;
}

namespace {
// Pipeline slot reservation for requests that arrive out of time order (the
// round-robin visits slots in a fixed order, not by time): a request may take a
// slot up to `window` before the unit's running reservation end, while the end
// still advances by one interval per request, so throughput stays capped.
uint64_t reserve(uint64_t& pipe_free, uint64_t data, uint64_t interval, uint64_t window) {
  const uint64_t start = std::max(data, pipe_free > window ? pipe_free - window : 0);
  pipe_free = std::max(pipe_free, start) + interval;
  return start;
}
uint64_t interval_ps(double per_cycle, uint64_t cycle_ps) {
  return uint64_t(std::llround(double(cycle_ps) / per_cycle));
}
}  // namespace

RayEngine::RayEngine(const HardwareConfig& config, const Workload& workload, bool timed)
    : config_(config), workload_(&workload), timed_(timed),
      cycle_ps_(uint64_t(std::llround(config.clock_period_ps()))),
      rays_(workload.initial_rays), ready_ps_(rays_.size(), 0),
      trv_free_(config.trv_units, 0), ist_free_(config.ist_units, 0),
      trv_time_(config.trv_units), ist_time_(config.ist_units), trv_nodes_(config.trv_units, 0),
      ist_tests_(config.ist_units, 0) {
  trv_interval_ps_ = interval_ps(config.trv_nodes_per_cycle, cycle_ps_);
  ist_interval_ps_ = interval_ps(config.ist_tests_per_cycle, cycle_ps_);
  shading_interval_ps_ = interval_ps(config.shading_rays_per_cycle, cycle_ps_);
  raygen_interval_ps_ = interval_ps(config.raygen_rays_per_cycle, cycle_ps_);
  // Within one quantum the loosely-timed model does not resolve the order of events.
  trv_window_ps_ = ist_window_ps_ = uint64_t(config.lt_quantum_cycles) * cycle_ps_;
  slots_.reserve(size_t(config.trv_units) * config.trv_ray_slots);
  for (uint32_t i = 0; i < config.trv_units * config.trv_ray_slots; ++i)
    slots_.emplace_back(*workload.context);
  // Spilled stack entries live past the scene's memory image, one area per slot.
  stack_base_ = (workload.context->image().end_address() + 4095) & ~uint64_t(4095);
}

CounterTotals RayEngine::total() const {
  CounterTotals t;
  for (auto& c : per_type_) t.add(c);
  return t;
}

uint64_t RayEngine::fetch(MemoryPort& port, Requester who, uint32_t unit, uint64_t address,
                          uint32_t bytes, DataKind kind, RayType type, uint64_t issue_ps) {
  // One access per L1 line the fetch touches; they go out together.
  const uint64_t line_bytes = line_bytes_[size_t(who)];
  const uint64_t end = address + bytes;
  if ((address & ~(line_bytes - 1)) + line_bytes >= end)  // the common case: one line
    return std::max(issue_ps, port.read(who, unit, LineAccess{address & ~(line_bytes - 1), bytes,
                                                              kind, type}, issue_ps));
  uint64_t done = issue_ps;
  for (uint64_t line = address & ~(line_bytes - 1); line < end; line += line_bytes) {
    const uint64_t lo = std::max(line, address), hi = std::min(line + line_bytes, end);
    done = std::max(done, port.read(who, unit, LineAccess{line, uint32_t(hi - lo), kind, type},
                                    issue_ps));
  }
  return done;
}

uint64_t RayEngine::stack_traffic(MemoryPort& port, Slot& slot, uint32_t slot_index,
                                  uint32_t unit) {
  // Entries that overflowed the short stack were written out, refilled ones read
  // back: both go through the TRV unit's L1 as kind 'other'.
  const RayCounters& c = slot.traversal.counters();
  uint64_t done = slot.time_ps;
  const uint32_t entry = config_.trv_stack_entry_bytes;
  const uint64_t area = stack_base_ + uint64_t(slot_index) * 256 * entry;
  while (slot.seen_overflows < c.stack_overflows || slot.seen_refills < c.stack_refills) {
    const bool spill = slot.seen_overflows < c.stack_overflows;
    (spill ? slot.seen_overflows : slot.seen_refills)++;
    const uint64_t address =
        area + uint64_t(std::min<uint32_t>(slot.traversal.stack_size(), 255)) * entry;
    stack_spill_bytes_ += entry;
    done = std::max(done, fetch(port, Requester::Trv, unit, address, entry, DataKind::Other,
                                slot.traversal.ray().type, slot.time_ps));
  }
  return done;
}

void RayEngine::finish(Slot& slot, uint32_t unit) {
  const RayTraversal& trv = slot.traversal;
  per_type_[size_t(trv.ray().type)].add(trv.counters(), trv.hit().hit());
  if (timed_) trv_time_[unit].add_span(slot.start_ps, slot.time_ps);
  slot.active = false;
  end_ps_ = std::max(end_ps_, slot.time_ps);
  if (!workload_->spawn_secondary) return;
  spawned_.clear();
  spawn_secondary_rays(*workload_->scene, workload_->plan, workload_->settings, trv.ray(),
                       slot.ray, trv.hit(), spawned_);
  const uint64_t start =
      reserve(shading_free_, slot.time_ps, shading_interval_ps_, trv_window_ps_);
  shading_time_.busy_ps += shading_interval_ps_;
  const uint64_t ready = start + uint64_t(config_.shading_latency) * cycle_ps_;
  shading_time_.add_span(start, ready);
  end_ps_ = std::max(end_ps_, ready);
  for (const Ray& r : spawned_) {
    rays_.push_back(r);
    ready_ps_.push_back(ready);
  }
}

void RayEngine::run(MemoryPort& port, const std::function<void(uint64_t)>& sync,
                    const std::function<void(uint64_t)>& progress) {
  line_bytes_[size_t(Requester::Trv)] = port.l1_line_bytes(Requester::Trv);
  line_bytes_[size_t(Requester::Ist)] = port.l1_line_bytes(Requester::Ist);
  const uint32_t slots_per_unit = config_.trv_ray_slots;
  const uint64_t box_latency = uint64_t(config_.trv_box_test_latency) * cycle_ps_;
  const uint64_t test_latency = uint64_t(config_.ist_test_latency) * cycle_ps_;
  size_t next_ray = 0;
  uint64_t done_rays = 0, reported = 0;
  bool any_active = true;
  while (any_active || next_ray < rays_.size()) {
    any_active = false;
    uint64_t earliest = UINT64_MAX;
    for (uint32_t s = 0; s < slots_.size(); ++s) {
      Slot& slot = slots_[s];
      const uint32_t unit = s / slots_per_unit;
      if (!slot.active) {
        if (next_ray >= rays_.size()) continue;
        slot.ray = uint32_t(next_ray);
        slot.traversal.reset(rays_[next_ray]);
        slot.seen_overflows = slot.seen_refills = 0;
        if (timed_) {
          const uint64_t issue =
              reserve(raygen_next_, std::max(slot.time_ps, ready_ps_[next_ray]),
                      raygen_interval_ps_, trv_window_ps_);
          slot.time_ps = slot.start_ps = issue;
        }
        ++next_ray;
        slot.active = true;
      }
      RayTraversal& trv = slot.traversal;
      const RayType type = trv.ray().type;
      switch (trv.action()) {
        case TraversalAction::FetchNode: {
          const uint64_t data = fetch(port, Requester::Trv, unit, trv.node_address(),
                                      trv.node_bytes(), DataKind::Node, type, slot.time_ps);
          if (timed_) {
            const uint64_t start =
                reserve(trv_free_[unit], data, trv_interval_ps_, trv_window_ps_);
            trv_time_[unit].busy_ps += trv_interval_ps_;
            slot.time_ps = start + box_latency;
          }
          trv.process_node();
          ++trv_nodes_[unit];
          break;
        }
        case TraversalAction::TestTriangles: {
          const uint32_t ist = unit % config_.ist_units;
          const uint32_t k = trv.leaf_cursor();
          uint64_t data = fetch(port, Requester::Ist, ist, trv.triangle_address(k),
                                trv.triangle_bytes(), DataKind::Triangle, type, slot.time_ps);
          if (k == 0)
            data = std::max(data, fetch(port, Requester::Ist, ist, trv.prim_refs_address(),
                                        trv.prim_refs_bytes(), DataKind::Other, type,
                                        slot.time_ps));
          if (timed_) {
            const uint64_t start =
                reserve(ist_free_[ist], data, ist_interval_ps_, ist_window_ps_);
            ist_time_[ist].busy_ps += ist_interval_ps_;
            ist_time_[ist].add_span(slot.time_ps, start + test_latency);
            slot.time_ps = start + test_latency;
          }
          trv.process_triangle();
          ++ist_tests_[ist];
          break;
        }
        case TraversalAction::Done: break;
      }
      const RayCounters& counters = trv.counters();
      if (slot.seen_overflows != counters.stack_overflows ||
          slot.seen_refills != counters.stack_refills)
        slot.time_ps = stack_traffic(port, slot, s, unit);
      if (trv.done()) {
        finish(slot, unit);
        ++done_rays;
      } else {
        any_active = true;
        earliest = std::min(earliest, slot.time_ps);
      }
    }
    if (timed_ && earliest != UINT64_MAX) sync(earliest);
    if (done_rays - reported >= 4096) {
      progress(done_rays);
      reported = done_rays;
    }
  }
  progress(done_rays);
  for (auto& s : slots_) end_ps_ = std::max(end_ps_, s.time_ps);
  for (uint64_t t : trv_free_) end_ps_ = std::max(end_ps_, t);
  for (uint64_t t : ist_free_) end_ps_ = std::max(end_ps_, t);
}

}  // namespace rtsim::sim
