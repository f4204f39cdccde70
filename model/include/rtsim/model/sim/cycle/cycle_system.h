#pragma once
// The cycle-level (approximately timed, event driven) accelerator: ray
// generation, TRV units, IST units, shading (only if the workload spawns
// secondary rays), per-unit L1s, shared L2 and DRAM behind TLM-2.0 sockets.
// Frames run back to back: when every ray of a frame (and every ray it spawned)
// is done, the counters start again and the same rays are issued once more.
#include <rtsim/model/sim/cycle/cycle_cache.h>
#include <rtsim/model/sim/cycle/cycle_ist.h>
#include <rtsim/model/sim/cycle/cycle_raygen.h>
#include <rtsim/model/sim/cycle/cycle_shading.h>
#include <rtsim/model/sim/cycle/cycle_trv.h>
#include <rtsim/model/sim/ray_engine.h>

#include <functional>
#include <memory>

namespace rtsim::sim {

class CycleSystem : public sc_core::sc_module {
 public:
  CycleSystem(sc_core::sc_module_name name, const HardwareConfig& config, const Workload& workload,
              std::function<void(uint64_t)> progress);

  // Called by the units.
  CycleIst& ist_for(uint32_t trv_unit) { return *ist[trv_unit % ist.size()]; }
  void ray_finished(CycleTrv& trv, uint32_t slot, uint32_t ray_index, const RayTraversal& traversal,
                    uint64_t t);
  void spawned(const std::vector<Ray>& rays, uint64_t t);  // from shading
  void observe(const Ray& ray, const MemoryAccess& access) const {
    if (workload.observer) workload.observer(ray, access);
  }

  const HardwareConfig& config;
  const Workload& workload;
  std::unique_ptr<CycleRayGen> raygen;
  std::vector<std::unique_ptr<CycleTrv>> trv;
  std::vector<std::unique_ptr<CycleIst>> ist;
  std::unique_ptr<CycleShading> shading;  // null when nothing needs shading
  std::vector<std::unique_ptr<CycleCache>> l1_node, l1_triangle;
  std::unique_ptr<CycleCache> l2;
  std::unique_ptr<CycleDram> dram;
  std::array<CounterTotals, kRayTypeCount> per_type{};
  uint64_t rays_done = 0;          // in the last frame
  uint64_t rays_done_total = 0;    // over every frame (progress)
  uint64_t frame_start_ps = 0, end_ps = 0;
  uint32_t frame = 0;
  bool finished = false;

 private:
  void check_frame_end(uint64_t t);
  void reset_counters();
  std::function<void(uint64_t)> progress_;
};

}  // namespace rtsim::sim
