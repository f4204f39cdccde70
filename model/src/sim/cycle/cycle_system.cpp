#include <rtsim/model/sim/cycle/cycle_system.h>

#include <cmath>

namespace rtsim::sim {

CycleSystem::CycleSystem(sc_core::sc_module_name name, const HardwareConfig& cfg,
                         const Workload& work, std::function<void(uint64_t)> progress)
    : sc_module(name), config(cfg), workload(work), progress_(std::move(progress)) {
  const uint64_t cycle_ps = uint64_t(std::llround(cfg.clock_period_ps()));
  raygen = std::make_unique<CycleRayGen>("raygen", cfg, work);
  l2 = std::make_unique<CycleCache>("l2", cfg.l2, cycle_ps);
  dram = std::make_unique<CycleDram>("dram", cfg.dram, cfg.l2.line_bytes);
  l2->next.bind(dram->target);
  for (uint32_t i = 0; i < cfg.ist_units; ++i) {
    const std::string id = std::to_string(i);
    ist.push_back(std::make_unique<CycleIst>(("ist" + id).c_str(), cfg, *this));
    l1_triangle.push_back(
        std::make_unique<CycleCache>(("l1_triangle" + id).c_str(), cfg.l1_triangle, cycle_ps));
    ist.back()->memory.bind(l1_triangle.back()->target);
    l1_triangle.back()->next.bind(l2->target);
  }
  for (uint32_t u = 0; u < cfg.trv_units; ++u) {
    const std::string id = std::to_string(u);
    trv.push_back(std::make_unique<CycleTrv>(("trv" + id).c_str(), cfg, *work.context, u, *this));
    l1_node.push_back(std::make_unique<CycleCache>(("l1_node" + id).c_str(), cfg.l1_node, cycle_ps));
    trv.back()->memory.bind(l1_node.back()->target);
    l1_node.back()->next.bind(l2->target);
    ist_for(u).serve(trv.back().get());
  }
  // Shading exists only when finished rays spawn more rays.
  if (work.spawn_secondary)
    shading = std::make_unique<CycleShading>("shading", cfg, work, *this);
  // Every slot starts free, in the dispatch policy's order (rays spread over units).
  for (uint32_t id : free_slot_order(cfg.trv_units, cfg.trv_ray_slots))
    raygen->slot_free(trv[id / cfg.trv_ray_slots].get(), id % cfg.trv_ray_slots, 0);
}

void CycleSystem::ray_finished(CycleTrv& unit, uint32_t slot, uint32_t ray_index,
                               const RayTraversal& traversal, uint64_t t) {
  per_type[size_t(traversal.ray().type)].add(traversal.counters(), traversal.hit().hit());
  ++rays_done;
  end_ps = std::max(end_ps, t);
  if (shading) shading->shade(ray_index, traversal.ray(), traversal.hit(), t);
  raygen->slot_free(&unit, slot, t);
  if ((++rays_done_total & 4095) == 0 && progress_) progress_(rays_done_total);
  check_frame_end(t);
}

void CycleSystem::spawned(const std::vector<Ray>& rays, uint64_t t) {
  raygen->add_rays(rays, t);
  check_frame_end(t);
}

void CycleSystem::check_frame_end(uint64_t t) {
  // Done when every issued ray has finished, nothing is queued and shading is idle.
  if (!raygen->queue_empty() || raygen->issued() != rays_done || (shading && !shading->idle()))
    return;
  end_ps = std::max(end_ps, t);
  if (frame + 1 >= std::max<uint32_t>(1, workload.frames)) {
    finished = true;
    return;
  }
  ++frame;
  frame_start_ps = t;
  end_ps = t;
  reset_counters();
  raygen->restart(t);
}

void CycleSystem::reset_counters() {
  per_type = {};
  rays_done = 0;
  raygen->reset_counters();
  for (auto& u : trv) u->reset_counters();
  for (auto& u : ist) u->reset_counters();
  if (shading) shading->reset_counters();
  for (auto& c : l1_node) c->reset_counters();
  for (auto& c : l1_triangle) c->reset_counters();
  l2->reset_counters();
  dram->model.reset_counters();
}

}  // namespace rtsim::sim
