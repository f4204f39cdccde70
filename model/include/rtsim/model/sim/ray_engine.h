#pragma once
// The ray engine of the functional and loosely-timed levels. It drives the
// functional core's per-ray state machine (RayTraversal) in every ray slot of
// every TRV unit and sends the accesses the core names through a MemoryPort.
//
//  - functional: rounds. Every active slot takes one step per round, slots in a
//    fixed order; an access costs nothing. The access sequence, and so every
//    cache and DRAM count, depends on the configuration only, never on latencies:
//    the traffic of an idealised machine in which every access takes equally long.
//  - lt: time order. Each step is an event at the time its slot is ready; reads
//    go out at that time through the port (blocking transport, latency annotated
//    by the caches and DRAM) and the step's work is reserved in its unit's
//    pipeline when the data is there. Events run strictly in time order, so every
//    reservation (pipelines, cache ports, DRAM banks and buses) is made in time
//    order and nothing depends on the lt quantum, which only sets how often the
//    engine's thread yields to the SystemC kernel.
// Units are numbered as in machine.h (TRV unit g of core g / trv.units); every
// core has its own ray generation and shading.
// Both levels: a TRV step = one node through the unit's box-test pipeline
// (trv.nodes_per_cycle, trv.box_test_latency); an IST step = its triangles through
// the IST pipeline (ist.tests_per_cycle, ist.test_latency) of its core's IST unit
// (MachineShape::ist_of_trv); stack spills are posted writes, refills reads the ray waits for;
// a finished ray goes to its core's shading (shading.rays_per_cycle,
// shading.latency), whose spawned rays are ready after it; each core's ray
// generation issues at raygen.rays_per_cycle in the RayDispatcher's order.
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/core/ray_generation.h>
#include <rtsim/model/core/traversal.h>
#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/cache_model.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/machine.h>
#include <rtsim/model/sim/ray_dispatch.h>
#include <rtsim/model/sim/stats.h>
#include <rtsim/model/sim/units/ist_unit.h>
#include <rtsim/model/sim/units/raygen_unit.h>
#include <rtsim/model/sim/units/shading_unit.h>
#include <rtsim/model/sim/units/trv_unit.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <queue>
#include <vector>

namespace rtsim::sim {

class RayProbe;
class Timeline;
enum class ServedBy : uint8_t;

// Which unit's L1 an access goes through: nodes and stack entries the TRV
// unit's node cache (instance records too), prim refs and triangles the IST unit's triangle cache, UVs
// and texels (the IST unit's any-hit stage) its texture cache.
enum class Requester : uint8_t { Trv = 0, Ist = 1, Texture = 2 };
constexpr int kRequesterCount = 3;
inline Requester requester_of(AccessKind kind) {
  // By AccessKind's value (fetch.h): node, prim_ref, triangle, stack, uv, texel,
  // instance (the TRV unit's transform reads it through the node cache).
  constexpr Requester kOf[kAccessKindCount] = {Requester::Trv,     Requester::Ist,     Requester::Ist,
                                               Requester::Trv,     Requester::Texture, Requester::Texture,
                                               Requester::Trv};
  return kOf[size_t(kind)];
}

// Where a unit's line accesses go (unit: the global TRV or IST unit number).
// Returns when a read's data is there, or when a write was taken (writes are
// posted). Functional: issue_ps.
class MemoryPort {
 public:
  virtual ~MemoryPort() = default;
  virtual uint64_t access(Requester who, uint32_t unit, const LineAccess& access,
                          uint64_t issue_ps) = 0;
  // The same for the probed ray (--trace-ray), saying which level served it.
  virtual uint64_t access_probed(Requester who, uint32_t unit, const LineAccess& access,
                                 uint64_t issue_ps, ServedBy* served) = 0;
  virtual uint32_t line_bytes(Requester who) const = 0;
};

// Calls f(line, bytes) for each L1 line `access` touches, in address order: the
// line's address and how many of the access's bytes fall in it.
template <typename F>
inline void for_each_line(const MemoryAccess& access, uint64_t line_bytes, F&& f) {
  const uint64_t end = access.address + access.bytes;
  for (uint64_t line = access.address & ~(line_bytes - 1); line < end; line += line_bytes)
    f(line, uint32_t(std::min(line + line_bytes, end) - std::max(line, access.address)));
}

// Appends the L1 line accesses of `access` to `out`, merging it into a line the
// list already holds (one request per line and step, as a unit coalesces them).
// Inline for a step's usual first access, one line: every level asks it per step.
void append_line_accesses_merging(const MemoryAccess& access, RayType type, uint32_t line_bytes,
                                  std::vector<LineAccess>& out);
inline void append_line_accesses(const MemoryAccess& access, RayType type, uint32_t line_bytes,
                                 std::vector<LineAccess>& out) {
  const uint64_t line = access.address & ~uint64_t(line_bytes - 1);
  if (out.empty() && access.bytes > 0 && access.address + access.bytes <= line + line_bytes) {
    LineAccess& l = out.emplace_back();  // fields in place (no stalled store forward)
    l.line = line, l.bytes = access.bytes, l.kind = access.kind, l.ray_type = type, l.write = access.write;
    return;
  }
  append_line_accesses_merging(access, type, line_bytes, out);
}

// Sees every access the core names, with the ray that issues it, in the order
// the ray issues them (tests compare the address streams of the levels).
using AccessObserver = std::function<void(const Ray& ray, const MemoryAccess& access)>;

// The rays of one run: the initial set (primary rays or a ray file) and, when
// the scene's effects call for them, the secondary rays shading spawns.
struct Workload {
  const Scene* scene = nullptr;
  const TraversalContext* context = nullptr;
  std::vector<Ray> initial_rays;
  uint32_t width = 0, height = 0;  // image the rays' pixel ids refer to
  bool spawn_secondary = false;  // false: replay the initial rays only (no shading)
  EffectPlan plan;
  EffectSettings settings;
  uint32_t frames = 1;           // the same rays this many times; stats of the last
  AccessObserver observer;       // optional
  RayProbe* probe = nullptr;     // optional: the ray whose every request is traced
  Timeline* timeline = nullptr;  // optional (lt, cycle): the run drawn as spans
};

// The most rays a frame of the workload holds (its initial rays and, where shading
// spawns, max_frame_rays), for the dispatcher to reserve.
uint64_t frame_ray_bound(const Workload& workload);

// What each frame of a multi-frame run cost: the first shows the cold caches, the
// last the steady state (the run's stats are the last frame's).
struct FrameFigures {
  uint64_t rays = 0, dram_bytes_read = 0, dram_bytes_written = 0;
  uint64_t simulated_ps = 0;
};

class RayEngine {
 public:
  RayEngine(const HardwareConfig& config, const Workload& workload, bool timed);
  // Its units keep a reference to config_, its slots to the workload's tree: it stays put.
  RayEngine(const RayEngine&) = delete;
  RayEngine& operator=(const RayEngine&) = delete;

  // Runs every frame to completion. `sync(t)` is called before each lt event at
  // time t (the quantum keeper hooks in); `frame_end(last)` after each frame (the
  // memory system records the frame and, unless it was the last, clears its counters).
  void run(MemoryPort& port, const std::function<void(uint64_t)>& sync,
           const std::function<void(bool last)>& frame_end,
           const std::function<void(uint64_t rays_done)>& progress);

  uint64_t start_ps() const { return frame_start_ps_; }  // the last frame's start
  uint64_t end_ps() const { return end_ps_; }
  const std::vector<Ray>& rays() const { return dispatcher_.rays(); }
  const RayDispatcher& dispatcher() const { return dispatcher_; }
  RayDispatcher& dispatcher() { return dispatcher_; }
  const std::array<CounterTotals, kRayTypeCount>& per_type() const { return per_type_; }
  CounterTotals total() const;
  // The units, written once for every level (units/*.h): per TRV unit, per IST
  // unit, per core (shading only when finished rays spawn more). lt: their cycle
  // accounting is finished at end_ps() by run().
  std::vector<TrvUnit>& trv_units() { return trv_; }
  std::vector<IstUnit>& ist_units() { return ist_; }
  std::vector<ShadingUnit>& shading_units() { return shading_; }
  bool anyhit_stage() const { return workload_->context->image().has_alpha_data(); }  // built
  const MachineShape& shape() const { return shape_; }
  bool spawned_rays_are_shaded() const { return workload_->spawn_secondary; }  // shading exists

 private:
  struct Slot {
    RayTraversal traversal;
    uint32_t ray = 0;
    uint32_t unit = 0, ist = 0, core = 0;  // its TRV unit, that unit's IST unit and core
    bool active = false;
    bool probed = false;          // the ray --trace-ray follows
    bool watched = false;         // probed, or an observer sees every access (the slow path)
    // lt: the step in flight, and what its TRV unit waits on until it completes
    // (a node: its reads, then its pipeline; triangles or an alpha test: the IST unit).
    enum class Step : uint8_t { None, Node, Triangles } step = Step::None;
    uint64_t start_ps = 0;
    Slot(const TraversalContext& c, uint32_t id, uint32_t u, const MachineShape& m)
        : traversal(c, id), unit(u), ist(m.ist_of_trv(u)), core(m.core_of_trv(u)) {}
  };
  // Dispatch: the core in `slot` has rays ready for its idle slots.
  enum class EventKind : uint8_t { Issue, Dependent, Arrive, Complete, Dispatch };
  struct Event {
    uint64_t time_ps, sequence;
    uint32_t slot;
    EventKind kind;
    bool operator<(const Event& o) const {  // priority_queue is a max-heap
      return time_ps != o.time_ps ? time_ps > o.time_ps : sequence > o.sequence;
    }
  };

  // Untimed rounds; Port is the concrete FunctionalMemory when it is one, so
  // that its accesses inline (the functional level's hot path).
  template <class Port>
  void run_rounds(Port& port, const std::function<void(uint64_t)>& progress);
  void run_timed(MemoryPort& port, const std::function<void(uint64_t)>& sync,
                 const std::function<void(uint64_t)>& progress);
  void reset_counters();
  // Sends accesses [begin, end) of the list through the port at t; returns when
  // the reads are back.
  template <class Port>
  uint64_t issue(Port& port, Slot& slot, const std::vector<MemoryAccess>& list, size_t begin,
                 size_t end, uint64_t t);
  template <class Port>
  uint64_t issue_probed(Port& port, Slot& slot, const std::vector<MemoryAccess>& list, size_t begin,
                        size_t end, uint64_t t);
  bool start_next_ray(Slot& slot, uint64_t now_ps, uint64_t* start_ps);
  void issue_step(MemoryPort& port, uint32_t slot, uint64_t t);  // lt: the step's first reads
  // The ray is done at t (>= now, the engine's time).
  void finish(Slot& slot, uint64_t now, uint64_t t);
  void schedule(uint64_t t, uint32_t slot, EventKind kind);

  HardwareConfig config_;
  MachineShape shape_;
  const Workload* workload_;
  bool timed_;
  uint64_t cycle_ps_;
  RayDispatcher dispatcher_;
  std::vector<Slot> slots_;              // by global slot id (unit * slots + slot)
  std::vector<uint32_t> visit_order_;   // free_slot_order
  std::vector<TrvUnit> trv_;
  std::vector<IstUnit> ist_;
  std::vector<ShadingUnit> shading_;  // per core, when finished rays spawn more
  std::vector<RayGenUnit> raygen_;    // per core
  std::array<CounterTotals, kRayTypeCount> per_type_{};
  uint64_t frame_start_ps_ = 0, end_ps_ = 0;
  uint64_t done_rays_ = 0;
  std::vector<Ray> spawned_;
  std::vector<LineAccess> lines_;
  std::array<uint32_t, kRequesterCount> line_bytes_{64, 64, 64};  // L1 line per requester, asked once per run
  // lt events
  // The lt events: a calendar of one-cycle buckets over a window of cycles, the few
  // events beyond it in a heap. Popped in (time, sequence) order, as a heap would,
  // at a fraction of its cost (most events fall within a few hundred cycles).
  class EventCalendar {
   public:
    EventCalendar(uint64_t bucket_ps, bool heaps)
        : bucket_ps_(std::max<uint64_t>(1, bucket_ps)), heaps_(heaps) {}
    void push(const Event& e);
    bool pop(Event* out);
    bool empty() const { return in_buckets_ == 0 && overflow_.empty(); }

   private:
    // 512 buckets keep their headers in the host's L1 (4096 spread them over 96
    // KiB); lt measured faster than with 4096 or 256 (docs/build-speed.md). The
    // order popped does not depend on it.
    static constexpr uint64_t kWindow = 512;  // buckets
    void migrate();                            // overflow events now inside the window
    uint64_t bucket_ps_, base_ = 0;            // base_: the bucket of the earliest event
    bool heaps_;                               // buckets as heaps (many rays in flight)
    std::vector<std::vector<Event>> buckets_ = std::vector<std::vector<Event>>(kWindow);
    size_t in_buckets_ = 0;
    std::priority_queue<Event> overflow_;
  };
  EventCalendar events_;
  uint64_t sequence_ = 0;
  std::vector<std::deque<uint32_t>> idle_slots_;  // per core, in free_slot_order
  std::vector<uint64_t> arrive_ps_;  // per slot: when the step's reads are all back
};

}  // namespace rtsim::sim
