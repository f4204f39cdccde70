#include <rtsim/model/sim/ray_engine.h>
#include <rtsim/model/sim/memory_system.h>
#include <rtsim/model/sim/ray_probe.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rtsim::sim {

void append_line_accesses_merging(const MemoryAccess& a, RayType type, uint32_t line_bytes,
                                  std::vector<LineAccess>& out) {
  for_each_line(a, line_bytes, [&](uint64_t line, uint32_t bytes) {
    for (LineAccess& l : out)
      if (l.line == line && l.write == a.write && requester_of(l.kind) == requester_of(a.kind)) {
        l.bytes = std::min(line_bytes, l.bytes + bytes);
        return;
      }
    out.push_back(LineAccess{line, bytes, a.kind, type, a.write});
  });
}

void RayEngine::EventCalendar::push(const Event& e) {
  const uint64_t bucket = e.time_ps / bucket_ps_;
  if (in_buckets_ == 0 && overflow_.empty()) base_ = bucket;  // events never go back in time
  if (bucket < base_ + kWindow) {
    std::vector<Event>& b = buckets_[bucket % kWindow];
    b.push_back(e);
    if (heaps_) std::push_heap(b.begin(), b.end());  // the earliest on top (operator< is inverted)
    ++in_buckets_;
  } else {
    overflow_.push(e);
  }
}

void RayEngine::EventCalendar::migrate() {
  while (!overflow_.empty() && overflow_.top().time_ps / bucket_ps_ < base_ + kWindow) {
    std::vector<Event>& b = buckets_[(overflow_.top().time_ps / bucket_ps_) % kWindow];
    b.push_back(overflow_.top());
    if (heaps_) std::push_heap(b.begin(), b.end());
    ++in_buckets_;
    overflow_.pop();
  }
}

bool RayEngine::EventCalendar::pop(Event* out) {
  if (empty()) return false;
  if (in_buckets_ == 0) {
    base_ = overflow_.top().time_ps / bucket_ps_;
    migrate();
  }
  for (;;) {
    std::vector<Event>& b = buckets_[base_ % kWindow];
    if (!b.empty()) {
      // A bucket holds the events of one cycle; the earliest (time, then sequence)
      // goes first. Few rays in flight leave a handful per bucket, found fastest by a
      // scan; thousands leave hundreds, kept as a heap. Both give the same order.
      if (heaps_) {
        std::pop_heap(b.begin(), b.end());
        *out = b.back();
      } else {
        size_t best = 0;
        for (size_t i = 1; i < b.size(); ++i)
          if (b[best] < b[i]) best = i;  // operator< is inverted for the max-heap
        *out = b[best];
        b[best] = b.back();
      }
      b.pop_back();
      --in_buckets_;
      return true;
    }
    ++base_;
    migrate();
  }
}

uint64_t frame_ray_bound(const Workload& workload) {
  const uint64_t initial = workload.initial_rays.size();
  if (!workload.spawn_secondary || !workload.scene) return initial;
  return max_frame_rays(*workload.scene, workload.plan, initial);
}

RayEngine::RayEngine(const HardwareConfig& config, const Workload& workload, bool timed)
    : config_(config), shape_(MachineShape::of(config)), workload_(&workload), timed_(timed),
      cycle_ps_(config.cycle_ps()),
      dispatcher_(IssuePolicy::from(config), workload.initial_rays, workload.width, workload.height,
                  workload.spawn_secondary, workload.context, frame_ray_bound(workload)),
      visit_order_(free_slot_order(shape_.trv_units(), config.trv_ray_slots)),
      trv_(shape_.trv_units(), TrvUnit(config_)), ist_(shape_.ist_units(), IstUnit(config_)),
      shading_(workload.spawn_secondary ? shape_.cores : 0, ShadingUnit(config_)),
      raygen_(shape_.cores, RayGenUnit(config_)),
      events_(cycle_ps_, /*heaps=*/shape_.slots() > 512) {
  const uint32_t count = shape_.slots();
  slots_.reserve(count);
  for (uint32_t id = 0; id < count; ++id)
    slots_.emplace_back(*workload.context, id, id / config.trv_ray_slots, shape_);
  arrive_ps_.assign(count, 0);
}

CounterTotals RayEngine::total() const {
  CounterTotals t;
  for (auto& c : per_type_) t.add(c);
  return t;
}

void RayEngine::reset_counters() {
  for (TrvUnit& u : trv_) u.restart(frame_start_ps_);
  for (IstUnit& u : ist_) u.restart(frame_start_ps_);
  for (ShadingUnit& u : shading_) u.restart(frame_start_ps_);
  per_type_ = {};
}

template <class Port>
uint64_t RayEngine::issue(Port& port, Slot& slot, const std::vector<MemoryAccess>& list,
                          size_t begin, size_t end, uint64_t t) {
  if (begin == end) return t;
  const RayType type = slot.traversal.ray().type;
  if (slot.watched) {
    if (slot.probed) return issue_probed(port, slot, list, begin, end, t);
    if (workload_->observer)
      for (size_t i = begin; i < end; ++i) workload_->observer(slot.traversal.ray(), list[i]);
  } else if (end - begin == 1) {
    // The common step: one access (a node record). Its lines are distinct, so
    // nothing merges: they go straight to the port.
    const MemoryAccess& a = list[begin];
    const Requester who = requester_of(a.kind);
    const uint32_t unit = who == Requester::Trv ? slot.unit : slot.ist;
    const uint64_t line_bytes = line_bytes_[size_t(who)];
    const uint64_t line = a.address & ~(line_bytes - 1);
    // Within one line (most records): a path of its own, as for_each_line's loop
    // cost 5% of the functional level's instructions on binary nodes (callgrind).
    if (a.address + a.bytes <= line + line_bytes) {
      const uint64_t done = port.access(who, unit, LineAccess{line, a.bytes, a.kind, type, a.write}, t);
      return a.write ? t : std::max(t, done);
    }
    uint64_t ready = t;  // a record wider than a line, or one that straddles two
    for_each_line(a, line_bytes, [&](uint64_t l, uint32_t bytes) {
      const uint64_t done = port.access(who, unit, LineAccess{l, bytes, a.kind, type, a.write}, t);
      if (!a.write) ready = std::max(ready, done);
    });
    return ready;
  }
  lines_.clear();
  for (size_t i = begin; i < end; ++i)
    append_line_accesses(list[i], type, line_bytes_[size_t(requester_of(list[i].kind))], lines_);
  uint64_t ready = t;
  for (const LineAccess& line : lines_) {
    const Requester who = requester_of(line.kind);
    const uint32_t unit = who == Requester::Trv ? slot.unit : slot.ist;
    const uint64_t done = port.access(who, unit, line, t);
    if (!line.write) ready = std::max(ready, done);
  }
  return ready;
}

template <class Port>
uint64_t RayEngine::issue_probed(Port& port, Slot& slot, const std::vector<MemoryAccess>& list,
                                 size_t begin, size_t end, uint64_t t) {
  const RayType type = slot.traversal.ray().type;
  if (workload_->observer)
    for (size_t i = begin; i < end; ++i) workload_->observer(slot.traversal.ray(), list[i]);
  lines_.clear();
  for (size_t i = begin; i < end; ++i)
    append_line_accesses(list[i], type, line_bytes_[size_t(requester_of(list[i].kind))], lines_);
  RayProbe& probe = *workload_->probe;
  uint32_t request = probe.add(list.data() + begin, end - begin, lines_.data(), lines_.size(),
                               line_bytes_[size_t(Requester::Trv)], line_bytes_[size_t(Requester::Ist)],
                               line_bytes_[size_t(Requester::Texture)], t);
  uint64_t ready = t;
  for (const LineAccess& line : lines_) {
    const Requester who = requester_of(line.kind);
    const uint32_t unit = who == Requester::Trv ? slot.unit : slot.ist;
    ServedBy served = ServedBy::None;
    const uint64_t done = port.access_probed(who, unit, line, t, &served);
    probe.served(request++, served, line.write ? t : done);
    if (!line.write) ready = std::max(ready, done);
  }
  return ready;
}

bool RayEngine::start_next_ray(Slot& slot, uint64_t now_ps, uint64_t* start_ps) {
  uint32_t ray = 0;
  const uint32_t core = slot.core;
  if (!dispatcher_.next(core, now_ps, &ray)) {
    // Rays a stage on the path (units/stage.h) releases later: ray generation wakes then.
    if (const uint64_t wake = dispatcher_.take_wake(core); timed_ && wake != UINT64_MAX)
      schedule(wake, core, EventKind::Dispatch);
    return false;
  }
  slot.ray = ray;
  slot.traversal.reset(dispatcher_.rays()[ray]);
  slot.active = true;
  const uint64_t start = raygen_[core].issue(now_ps);
  slot.start_ps = start;
  *start_ps = start;
  RayProbe* probe = workload_->probe;
  slot.probed = probe && probe->is(slot.traversal.ray());
  slot.watched = slot.probed || bool(workload_->observer);
  if (slot.probed) probe->begin(timed_ ? start : 0);
  if (timed_) trv_[slot.unit].accounting.change(now_ps, start, UnitAccounting::Resident, +1);
  return true;
}

void RayEngine::finish(Slot& slot, uint64_t now, uint64_t t) {
  const RayTraversal& trv = slot.traversal;
  per_type_[size_t(trv.ray().type)].add(trv.counters(), trv.hit().hit());
  if (slot.probed) workload_->probe->end(t, trv.counters());
  if (timed_) {
    trv_[slot.unit].accounting.change(now, t, UnitAccounting::Resident, -1);
    trv_[slot.unit].ray_done(trv.ray().type, slot.start_ps, t);
  }
  slot.active = false;
  ++done_rays_;
  end_ps_ = std::max(end_ps_, t);
  if (!workload_->spawn_secondary) return;
  const uint32_t core = slot.core;
  ShadingUnit& shading = shading_[core];
  shading.shade(*workload_, trv.ray(), slot.ray, trv.hit(), spawned_);
  uint64_t ready = 0;
  if (timed_) {
    // The ray is resident from its turn in the pipeline to its result.
    const Issue issue = shading.take(now, t);
    ready = issue.ready;
    shading.accounting.change(now, issue.start, UnitAccounting::Resident, +1);
    shading.accounting.change(now, ready, UnitAccounting::Resident, -1);
    end_ps_ = std::max(end_ps_, ready);
  }
  if (spawned_.empty()) return;
  dispatcher_.add_spawned(core, spawned_, ready);
  if (timed_) schedule(ready, core, EventKind::Dispatch);
}

void RayEngine::schedule(uint64_t t, uint32_t slot, EventKind kind) {
  events_.push(Event{t, sequence_++, slot, kind});
}

void RayEngine::run(MemoryPort& port, const std::function<void(uint64_t)>& sync,
                    const std::function<void(bool)>& frame_end,
                    const std::function<void(uint64_t)>& progress) {
  line_bytes_[size_t(Requester::Trv)] = port.line_bytes(Requester::Trv);
  line_bytes_[size_t(Requester::Ist)] = port.line_bytes(Requester::Ist);
  line_bytes_[size_t(Requester::Texture)] = port.line_bytes(Requester::Texture);
  const uint32_t frames = std::max<uint32_t>(1, workload_->frames);
  for (uint32_t frame = 0; frame < frames; ++frame) {
    if (frame > 0) {
      frame_start_ps_ = end_ps_;
      reset_counters();  // the accounting starts again at the new frame's start
      dispatcher_.restart(frame_start_ps_);
    }
    if (timed_) run_timed(port, sync, progress);
    else if (auto* functional = dynamic_cast<FunctionalMemory*>(&port)) run_rounds(*functional, progress);
    else run_rounds(port, progress);
    frame_end(frame + 1 == frames);
  }
  if (timed_) {
    for (TrvUnit& u : trv_) u.accounting.finish(end_ps_);
    for (IstUnit& u : ist_) u.accounting.finish(end_ps_);
    for (ShadingUnit& u : shading_) u.accounting.finish(end_ps_);
  }
  progress(done_rays_);
}

template <class Port>
void RayEngine::run_rounds(Port& port, const std::function<void(uint64_t)>& progress) {
  uint64_t reported = done_rays_;
  bool any_active = true;
  while (any_active || !dispatcher_.empty()) {
    any_active = false;
    for (uint32_t id : visit_order_) {
      Slot& slot = slots_[id];
      uint64_t start = 0;
      if (!slot.active && !start_next_ray(slot, UINT64_MAX, &start)) continue;
      RayTraversal& trv = slot.traversal;
      if (!trv.done()) {
        if (slot.probed) workload_->probe->next_step();
        const std::vector<MemoryAccess>& reads = trv.step_reads();
        issue(port, slot, reads, 0, reads.size(), 0);
        if (trv.action() == TraversalAction::FetchNode || trv.action() == TraversalAction::Transform)
          trv_[slot.unit].take_step(trv);
        else
          ist_[slot.ist].take_step(trv);
        const std::vector<MemoryAccess>& stack = trv.stack_accesses();
        if (!stack.empty()) issue(port, slot, stack, 0, stack.size(), 0);
      }
      if (trv.done()) finish(slot, 0, 0);
      else any_active = true;
    }
    if (done_rays_ - reported >= 4096) {
      progress(done_rays_);
      reported = done_rays_;
    }
  }
}

void RayEngine::issue_step(MemoryPort& port, uint32_t id, uint64_t t) {
  Slot& slot = slots_[id];
  RayTraversal& trv = slot.traversal;
  if (trv.done()) {  // a ray with nothing to do (e.g. an unusable direction)
    slot.step = Slot::Step::None;
    schedule(t, id, EventKind::Complete);
    return;
  }
  if (slot.probed) workload_->probe->next_step();
  // The TRV unit waits for its node's reads, or for the IST unit that tests the leaf
  // (and runs its any-hit stage).
  const bool triangles =
      trv.action() == TraversalAction::TestTriangles || trv.action() == TraversalAction::AlphaTest;
  slot.step = triangles ? Slot::Step::Triangles : Slot::Step::Node;
  trv_[slot.unit].accounting.change(t, triangles ? UnitAccounting::Downstream : UnitAccounting::AtL1, +1);
  const std::vector<MemoryAccess>& reads = trv.step_reads();
  const size_t independent = trv.step_independent_reads();
  const uint64_t back = issue(port, slot, reads, 0, independent, t);
  schedule(back, id, independent < reads.size() ? EventKind::Dependent : EventKind::Arrive);
}

void RayEngine::run_timed(MemoryPort& port, const std::function<void(uint64_t)>& sync,
                          const std::function<void(uint64_t)>& progress) {
  uint64_t reported = done_rays_;
  idle_slots_.assign(shape_.cores, {});
  for (uint32_t id : visit_order_) idle_slots_[slots_[id].core].push_back(id);
  for (uint32_t core = 0; core < shape_.cores; ++core)
    schedule(frame_start_ps_, core, EventKind::Dispatch);
  Event e{};
  while (events_.pop(&e)) {
    const uint64_t t = e.time_ps;
    sync(t);
    if (e.kind == EventKind::Dispatch) {
      std::deque<uint32_t>& idle = idle_slots_[e.slot];
      while (!idle.empty()) {
        Slot& slot = slots_[idle.front()];
        uint64_t start = 0;
        if (!start_next_ray(slot, t, &start)) break;
        schedule(start, idle.front(), EventKind::Issue);
        idle.pop_front();
      }
      continue;
    }
    Slot& slot = slots_[e.slot];
    RayTraversal& trv = slot.traversal;
    switch (e.kind) {
      case EventKind::Issue:
        issue_step(port, e.slot, t);
        break;
      case EventKind::Dependent: {
        const std::vector<MemoryAccess>& reads = trv.step_reads();
        const uint64_t back = issue(port, slot, reads, trv.step_independent_reads(), reads.size(), t);
        schedule(back, e.slot, EventKind::Arrive);
        break;
      }
      case EventKind::Arrive: {
        // The step's data is here: a node (or instance transform) enters its TRV unit's
        // box-test pipeline; a leaf's triangles, or an alpha test, its IST unit's test
        // pipeline, which holds the step from the data's arrival to its last result.
        uint64_t ready;
        if (trv.action() == TraversalAction::FetchNode || trv.action() == TraversalAction::Transform) {
          TrvUnit& unit = trv_[slot.unit];
          unit.accounting.change(t, UnitAccounting::AtL1, -1);
          ready = unit.take_step(trv, t);
        } else {
          IstUnit& unit = ist_[slot.ist];
          ready = unit.take_step(trv, t);
          unit.accounting.change(t, UnitAccounting::Resident, +1);
          unit.accounting.change(t, ready, UnitAccounting::Resident, -1);
        }
        schedule(ready, e.slot, EventKind::Complete);
        break;
      }
      case EventKind::Complete: {
        UnitAccounting& unit = trv_[slot.unit].accounting;
        if (slot.step == Slot::Step::Triangles) unit.change(t, UnitAccounting::Downstream, -1);
        slot.step = Slot::Step::None;
        const std::vector<MemoryAccess>& stack = trv.stack_accesses();
        const uint64_t next = stack.empty() ? t : issue(port, slot, stack, 0, stack.size(), t);
        if (next > t) {  // the stack's refills are waited for
          unit.change(t, UnitAccounting::AtL1, +1);
          unit.change(t, next, UnitAccounting::AtL1, -1);
        }
        if (!trv.done()) {
          // The next step right away when nothing is waited for (saves an event).
          if (next == t) issue_step(port, e.slot, t);
          else schedule(next, e.slot, EventKind::Issue);
          break;
        }
        finish(slot, t, next);
        uint64_t start = 0;
        if (start_next_ray(slot, next, &start)) schedule(start, e.slot, EventKind::Issue);
        else idle_slots_[slot.core].push_back(e.slot);
        break;
      }
      case EventKind::Dispatch: break;
    }
    if (done_rays_ - reported >= 4096) {
      progress(done_rays_);
      reported = done_rays_;
    }
  }
  for (const Slot& slot : slots_)
    if (slot.active) throw std::logic_error("lt engine: events ran out with rays in flight");
  if (!dispatcher_.empty()) throw std::logic_error("lt engine: events ran out with rays queued");
  for (const TrvUnit& u : trv_) end_ps_ = std::max(end_ps_, u.pipeline_free_ps());
  for (const IstUnit& u : ist_) end_ps_ = std::max(end_ps_, u.pipeline_free_ps());
}

}  // namespace rtsim::sim
