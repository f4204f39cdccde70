#pragma once
// The cycle-level (approximately timed, event driven) accelerator, built from
// machine.h's description: per core a ray generation, TRV units, IST units,
// shading (only if the workload spawns secondary rays) and per-unit L1s; a
// crossbar to the L2 slices; DRAM; all joined by TLM-2.0 sockets.
// Frames run back to back: when every ray of a frame (and every ray it spawned)
// is done, the counters start again and the same rays are issued once more.
// One process, the UnitScheduler, wakes the units (unit_scheduler.h).
#include <rtsim/model/sim/cycle/cycle_cache.h>
#include <rtsim/model/sim/cycle/cycle_ist.h>
#include <rtsim/model/sim/cycle/cycle_noc.h>
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
  CycleIst& ist_for(uint32_t trv_unit) { return *ist[shape.ist_of_trv(trv_unit)]; }
  void ray_finished(CycleTrv& trv, uint32_t slot, uint32_t ray_index, const RayTraversal& traversal,
                    uint64_t t);
  void spawned(uint32_t core, const std::vector<Ray>& rays, uint64_t t);  // from a core's shading
  uint64_t issued() const;  // rays the cores' ray generation issued this frame
  void observe(const Ray& ray, const MemoryAccess& access) const {
    if (workload.observer) workload.observer(ray, access);
  }

  const HardwareConfig& config;
  const Workload& workload;
  MachineShape shape;
  UnitScheduler scheduler;  // wakes every unit below
  RayDispatcher dispatcher;
  std::vector<std::unique_ptr<CycleRayGen>> raygen;    // per core
  std::vector<std::unique_ptr<CycleTrv>> trv;           // global TRV unit numbers
  std::vector<std::unique_ptr<CycleIst>> ist;
  std::vector<std::unique_ptr<CycleShading>> shading;  // per core; empty when nothing needs shading
  std::vector<std::unique_ptr<CycleCache>> l1_node, l1_triangle, l2;  // l2: its slices
  std::vector<std::unique_ptr<CycleCache>> l1_texture;  // per IST unit, alpha-tested scenes only
  Crossbar noc_model;
  std::unique_ptr<CycleCrossbar> noc;
  std::unique_ptr<CycleDram> dram;
  std::array<CounterTotals, kRayTypeCount> per_type{};
  uint64_t rays_done = 0;          // in the last frame
  uint64_t rays_done_total = 0;    // over every frame (progress)
  uint64_t frame_start_ps = 0, end_ps = 0;
  uint32_t frame = 0;
  bool finished = false;
  std::vector<FrameFigures> frame_history;

 private:
  void check_frame_end(uint64_t t);
  void reset_counters();
  std::function<void(uint64_t)> progress_;
};

}  // namespace rtsim::sim
