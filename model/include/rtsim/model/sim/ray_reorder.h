#pragma once
// The ray-reordering unit: one per core, between ray generation (primary and
// secondary rays alike) and the TRV units. It takes up to reorder.batch_rays rays
// from ray generation, sorts them by a key and releases them in that order, the
// batch's first ray reorder_sort_cycles after the batch was formed. Rays with
// equal keys keep their arrival order, so key "none" changes only the timing.
//
// A batch forms when TRV asks for a ray and the previous batch is gone: it takes
// every ray ready at that moment, up to the batch size (work-conserving: a unit
// that waited for a full batch while TRV starved would only cost cycles). One
// buffer per core: the next batch forms when the last ray of this one has left.
//
// A stage (units/stage.h), written once for every level: the dispatcher
// (ray_dispatch.h) builds it and the functional, lt and cycle levels reach it
// through RayDispatcher::next; the reports, the energy model and the timeline reach
// it as a Stage. Untimed, the latency is zero. Timed, its cycles split
// (accounting.h) into busy (sorting a batch), blocked (holding sorted rays no TRV
// slot has taken yet) and idle.
#include <rtsim/model/core/ray.h>
#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/units/stage.h>

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

namespace rtsim {
class TraversalContext;
class RayTraversal;
}  // namespace rtsim

namespace rtsim::sim {

class StatsRegistry;

enum class ReorderKey : uint8_t {
  None,         // arrival order (the unit's latency and energy alone)
  Origin,       // Morton code of the origin in the scene's bounds
  OctantOrigin, // direction octant, then origin Morton code
  FirstNode,    // the node the ray enters after the root (a root box test)
};
ReorderKey parse_reorder_key(const std::string& text);  // a reorder.key value

// Cycles from a batch of `rays` forming to its first release: the depth of
// Batcher's bitonic sorting network over it, k (k + 1) / 2 stages for k = ceil(log2 rays).
uint32_t reorder_sort_cycles(const HardwareConfig& c, uint32_t rays);

// The unit's parameters (reorder.*); batch_rays 0: no unit.
struct ReorderSettings {
  uint32_t batch_rays = 0;
  ReorderKey key = ReorderKey::None;
  uint64_t latency_ps = 0;  // a batch's sort
  uint32_t entry_bytes = 48;
  static ReorderSettings from(const HardwareConfig& config);
};

// The sort key of one ray.
class RayReorderKeys {
 public:
  RayReorderKeys(ReorderKey key, const TraversalContext& context);
  ~RayReorderKeys();
  uint64_t operator()(const Ray& ray) const;
  // Root box tests the keys cost since the frame began (FirstNode; in the unit's energy).
  uint64_t box_tests() const { return box_tests_; }
  void restart() { box_tests_ = 0; }

 private:
  ReorderKey key_;
  Aabb bounds_;                          // the tree's: origins on a 1024^3 grid over it
  std::unique_ptr<RayTraversal> probe_;  // FirstNode: one step of the root
  mutable uint64_t box_tests_ = 0;
};

struct ReorderCounters {
  uint64_t batches = 0, full_batches = 0, rays = 0;
  uint64_t wait_ps = 0;  // summed over rays: batch formed to the ray's release
  std::array<uint64_t, kRayTypeCount> rays_by_type{};
};

// One core's buffer.
class RayReorderBuffer {
 public:
  RayReorderBuffer(uint32_t batch_rays, uint64_t latency_ps)
      : batch_rays_(batch_rays), latency_ps_(latency_ps) {}

  bool holding() const { return cursor_ < batch_.size(); }
  uint64_t ready_ps() const { return ready_ps_; }  // of the held batch
  // A new batch at now_ps (UINT64_MAX: untimed) of the rays take(now_ps, &ray)
  // gives, up to the batch size, sorted by key. Only when not holding.
  template <class Take>
  void form(uint64_t now_ps, const std::vector<Ray>& rays, const RayReorderKeys& keys, Take take) {
    batch_.clear();
    cursor_ = 0;
    uint32_t ray = 0;
    while (batch_.size() < batch_rays_ && take(now_ps, &ray)) batch_.push_back({keys(rays[ray]), ray});
    if (!batch_.empty()) sort_batch(now_ps, rays);
  }
  // The held batch's next ray, if it is released by now_ps.
  bool release(uint64_t now_ps, uint32_t* ray) {
    if (!holding() || ready_ps_ > now_ps) return false;
    *ray = batch_[cursor_++].ray;
    if (now_ps != UINT64_MAX) {
      counters_.wait_ps += now_ps - formed_ps_;
      if (!holding()) {  // the batch's last ray has left
        accounting.change(now_ps, UnitAccounting::Blocked, -1);
        accounting.change(now_ps, UnitAccounting::Resident, -1);
      }
    }
    return true;
  }
  const ReorderCounters& counters() const { return counters_; }
  // A new frame from t (0 untimed): the counts start again, nothing is held.
  void restart(uint64_t t) { batch_.clear(), cursor_ = 0, counters_ = {}, accounting.restart(t); }

  UnitAccounting accounting;  // timed levels only

 private:
  struct Entry {
    uint64_t key;
    uint32_t ray;
  };
  void sort_batch(uint64_t now_ps, const std::vector<Ray>& rays);
  uint32_t batch_rays_;
  uint64_t latency_ps_;
  std::vector<Entry> batch_;
  size_t cursor_ = 0;
  uint64_t formed_ps_ = 0, ready_ps_ = 0;
  ReorderCounters counters_;
};

// The unit's figures, summed over the cores' buffers: its stats (reorder.*) and
// the counts its energy comes from.
struct ReorderFigures {
  ReorderCounters total;
  uint64_t key_box_tests = 0;
};

// The stage: every core's buffer and the keys they share.
class RayReorderUnit final : public Stage {
 public:
  RayReorderUnit(const ReorderSettings& settings, uint32_t cores, const TraversalContext& context);
  static const StageDescription& description();

  // The core's next ray for TRV (an index into rays), ready at now_ps (UINT64_MAX:
  // untimed), forming a batch from take(t, &ray) (ray generation) when none is held.
  // A batch formed now but released later sets *wake_ps to its release.
  template <class Take>
  bool next(uint32_t core, uint64_t now_ps, const std::vector<Ray>& rays, uint32_t* ray, uint64_t* wake_ps,
            Take take) {
    RayReorderBuffer& unit = buffers_[core];
    if (!unit.holding()) {
      unit.form(now_ps, rays, keys_, take);
      if (unit.holding() && unit.ready_ps() > now_ps) *wake_ps = unit.ready_ps();
    }
    return unit.release(now_ps, ray);
  }
  bool holding(uint32_t core) const { return buffers_[core].holding(); }
  bool holding_any() const;
  uint64_t ready_ps(uint32_t core) const { return buffers_[core].ready_ps(); }
  void restart(uint64_t t);
  ReorderFigures figures() const;

  // Stage
  const UnitTraits& traits() const override;
  uint32_t instances() const override { return uint32_t(buffers_.size()); }
  UnitAccounting& accounting(uint32_t core) override { return buffers_[core].accounting; }
  StageWork work(uint32_t core) const override;
  void report(StatsRegistry& stats, const HardwareConfig& config, bool timed) const override;
  StageEnergy energy(const HardwareConfig& config, const EnergyPrices& prices) const override;

 private:
  ReorderSettings settings_;
  RayReorderKeys keys_;
  std::vector<RayReorderBuffer> buffers_;  // per core
};

}  // namespace rtsim::sim
