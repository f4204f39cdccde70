#pragma once
// The ray engine of the functional and loosely-timed levels: it drives the
// functional core's per-ray state machine (RayTraversal) for every ray slot of
// every TRV unit in a fixed round-robin order, one step (one node or one
// triangle) per slot per round, and sends every fetch through a MemoryPort.
//
// The step order depends on the configuration only, never on latencies, so the
// functional level (no time) and the loosely-timed level (time from the port's
// latencies and the units' pipeline formulas below) issue the very same access
// sequence: their cache and DRAM counts are identical; only time differs.
//
// Loosely-timed unit timing (per TRV unit u, IST unit i = u mod ist.units):
//   node step:     data = port latency; start = max(data, pipe_free[u] - window);
//                  pipe_free[u] = max(pipe_free[u], start) + 1/nodes_per_cycle;
//                  ray ready = start + box latency. The window (one lt quantum)
//                  lets steps visited out of time order fill earlier pipeline slots
//                  while the unit's throughput stays capped: within a quantum the
//                  loosely-timed model does not resolve the order of events.
//   triangle step: the same with the IST unit's pipeline and test latency
//   finished ray:  shading start = max(ready, shading free); spawned rays are ready
//                  shading latency later; ray generation issues at raygen rate.
#include <rtsim/model/core/ray_generation.h>
#include <rtsim/model/core/traversal.h>
#include <rtsim/model/sim/cache_model.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/stats.h>
#include <rtsim/model/core/functional_tracer.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

namespace rtsim::sim {

enum class Requester : uint8_t { Trv = 0, Ist = 1 };

// Where a unit's fetch goes. Returns the time the data is there (functional: now).
class MemoryPort {
 public:
  virtual ~MemoryPort() = default;
  virtual uint64_t read(Requester who, uint32_t unit, const LineAccess& access,
                        uint64_t issue_ps) = 0;
  virtual uint32_t l1_line_bytes(Requester who) const = 0;
};

// The rays of one run: the initial set (primary rays or a ray file) and, when
// the scene's effects call for them, the secondary rays shading spawns.
struct Workload {
  const Scene* scene = nullptr;
  const TraversalContext* context = nullptr;
  std::vector<Ray> initial_rays;
  bool spawn_secondary = false;  // false: replay the initial rays only (no shading)
  EffectPlan plan;
  EffectSettings settings;
};

// Per-unit timing record (lt) used for busy / idle / stalled figures.
struct UnitTime {
  uint64_t busy_ps = 0;                               // pipeline occupied
  std::vector<std::pair<uint64_t, uint64_t>> spans;   // [start, end) rays were resident
  uint64_t occupied_ps() const;                       // union of spans
  // Records [a, b); neighbouring overlapping spans merge at once to stay small.
  void add_span(uint64_t a, uint64_t b) {
    if (!spans.empty() && a <= spans.back().second && b >= spans.back().first) {
      spans.back().first = std::min(spans.back().first, a);
      spans.back().second = std::max(spans.back().second, b);
    } else {
      spans.emplace_back(a, b);
    }
  }
};

class RayEngine {
 public:
  RayEngine(const HardwareConfig& config, const Workload& workload, bool timed);

  // Runs every ray to completion. `sync(t)` is called after each round with the
  // earliest time any slot has reached (the lt level's quantum keeper hooks in).
  void run(MemoryPort& port, const std::function<void(uint64_t)>& sync,
           const std::function<void(uint64_t rays_done)>& progress);

  uint64_t end_ps() const { return end_ps_; }
  const std::vector<Ray>& rays() const { return rays_; }
  const std::array<CounterTotals, kRayTypeCount>& per_type() const { return per_type_; }
  CounterTotals total() const;
  const std::vector<UnitTime>& trv_time() const { return trv_time_; }
  const std::vector<UnitTime>& ist_time() const { return ist_time_; }
  const UnitTime& shading_time() const { return shading_time_; }
  const std::vector<uint64_t>& trv_nodes() const { return trv_nodes_; }  // per TRV unit
  const std::vector<uint64_t>& ist_tests() const { return ist_tests_; }  // per IST unit
  uint64_t stack_spill_bytes() const { return stack_spill_bytes_; }

 private:
  struct Slot {
    RayTraversal traversal;
    uint32_t ray = 0;
    bool active = false;
    uint64_t time_ps = 0, start_ps = 0;
    uint32_t seen_overflows = 0, seen_refills = 0;
    explicit Slot(const TraversalContext& c) : traversal(c) {}
  };
  uint64_t fetch(MemoryPort& port, Requester who, uint32_t unit, uint64_t address, uint32_t bytes,
                 DataKind kind, RayType type, uint64_t issue_ps);
  uint64_t stack_traffic(MemoryPort& port, Slot& slot, uint32_t slot_index, uint32_t unit);
  void finish(Slot& slot, uint32_t unit);

  HardwareConfig config_;
  const Workload* workload_;
  bool timed_;
  uint64_t cycle_ps_;
  std::vector<Ray> rays_;
  std::vector<uint64_t> ready_ps_;  // when each ray may start (spawned rays: after shading)
  std::vector<Slot> slots_;
  std::vector<uint64_t> trv_free_, ist_free_;
  uint64_t shading_free_ = 0, raygen_next_ = 0;
  uint64_t trv_interval_ps_, ist_interval_ps_, shading_interval_ps_, raygen_interval_ps_;
  uint64_t trv_window_ps_, ist_window_ps_;
  std::vector<UnitTime> trv_time_, ist_time_;
  std::vector<uint64_t> trv_nodes_, ist_tests_;
  UnitTime shading_time_;
  std::array<CounterTotals, kRayTypeCount> per_type_{};
  uint64_t end_ps_ = 0;
  uint64_t stack_base_ = 0, stack_spill_bytes_ = 0;
  std::vector<Ray> spawned_;
  std::array<uint64_t, 2> line_bytes_{64, 64};  // L1 line per requester, asked once per run
};

}  // namespace rtsim::sim
