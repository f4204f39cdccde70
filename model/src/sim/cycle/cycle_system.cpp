#include <rtsim/model/sim/cycle/cycle_system.h>

#include <cmath>

namespace rtsim::sim {

CycleSystem::CycleSystem(sc_core::sc_module_name name, const HardwareConfig& cfg,
                         const Workload& work, std::function<void(uint64_t)> progress)
    : sc_module(name), config(cfg), workload(work), shape(MachineShape::of(cfg)), scheduler("scheduler"),
      dispatcher(IssuePolicy::from(cfg), work.initial_rays, work.width, work.height,
                 work.spawn_secondary, work.context, frame_ray_bound(work)),
      noc_model(cfg, shape, true), progress_(std::move(progress)) {
  const uint64_t cycle_ps = cfg.cycle_ps();
  const auto module = [](const std::string& instance) { return MachineShape::module_name(instance); };
  // Built in the order of the one-core model before it (ray generation, L2, DRAM,
  // IST, TRV, shading). It is also the order in which the scheduler runs units
  // due at the same time, so it is part of the results.
  for (uint32_t c = 0; c < shape.cores; ++c)
    raygen.push_back(std::make_unique<CycleRayGen>(
        module(MachineShape::core_name(c) + ".raygen").c_str(), cfg, dispatcher, c, scheduler));
  for (uint32_t s = 0; s < shape.l2_slices; ++s)
    l2.push_back(std::make_unique<CycleCache>(module(MachineShape::slice_name(s)).c_str(),
                                              cfg.l2_slice(), cycle_ps, scheduler));
  dram = std::make_unique<CycleDram>("dram", cfg.dram, cfg.l2.line_bytes, scheduler);
  noc = std::make_unique<CycleCrossbar>("noc", noc_model, shape);
  for (auto& slice : l2) {
    noc->to_slice.bind(slice->target);
    slice->next.bind(dram->target);
  }
  for (uint32_t i = 0; i < shape.ist_units(); ++i) {
    ist.push_back(std::make_unique<CycleIst>(module(shape.ist_name(i)).c_str(), cfg, *this));
    l1_triangle.push_back(std::make_unique<CycleCache>(module(shape.l1_triangle_name(i)).c_str(),
                                                       cfg.l1_triangle_of(shape.core_of_ist(i)), cycle_ps, scheduler));
    l1_triangle.back()->set_level(1, &ist.back()->model.accounting);
    ist.back()->memory.bind(l1_triangle.back()->target);
    noc->bind_l1(l1_triangle.back()->next, shape.core_of_ist(i));
    if (ist.back()->texture_memory) {  // a scene with alpha-tested materials
      l1_texture.push_back(std::make_unique<CycleCache>(module(shape.l1_texture_name(i)).c_str(),
                                                        cfg.l1_texture, cycle_ps, scheduler));
      l1_texture.back()->set_level(1, &ist.back()->model.accounting);
      ist.back()->texture_memory->bind(l1_texture.back()->target);
      noc->bind_l1(l1_texture.back()->next, shape.core_of_ist(i));
    }
  }
  for (uint32_t u = 0; u < shape.trv_units(); ++u) {
    trv.push_back(
        std::make_unique<CycleTrv>(module(shape.trv_name(u)).c_str(), cfg, *work.context, u, *this));
    l1_node.push_back(std::make_unique<CycleCache>(module(shape.l1_node_name(u)).c_str(),
                                                   cfg.l1_node_of(shape.core_of_trv(u)), cycle_ps, scheduler));
    l1_node.back()->set_level(1, &trv.back()->model.accounting);
    trv.back()->memory.bind(l1_node.back()->target);
    noc->bind_l1(l1_node.back()->next, shape.core_of_trv(u));
    ist_for(u).serve(trv.back().get());
  }
  // Shading exists only when finished rays spawn more rays.
  if (work.spawn_secondary)
    for (uint32_t c = 0; c < shape.cores; ++c)
      shading.push_back(std::make_unique<CycleShading>(
          module(MachineShape::core_name(c) + ".shading").c_str(), cfg, work, *this, c));
  // Every slot starts free, in the dispatch policy's order (rays spread over units).
  for (uint32_t id : free_slot_order(shape.trv_units(), cfg.trv_ray_slots)) {
    const uint32_t unit = id / cfg.trv_ray_slots;
    raygen[shape.core_of_trv(unit)]->slot_free(trv[unit].get(), id % cfg.trv_ray_slots, 0);
  }
}

uint64_t CycleSystem::issued() const {
  uint64_t n = 0;
  for (auto& r : raygen) n += r->issued();
  return n;
}

void CycleSystem::ray_finished(CycleTrv& unit, uint32_t slot, uint32_t ray_index,
                               const RayTraversal& traversal, uint64_t t) {
  per_type[size_t(traversal.ray().type)].add(traversal.counters(), traversal.hit().hit());
  ++rays_done;
  end_ps = std::max(end_ps, t);
  const uint32_t core = shape.core_of_trv(unit.unit());
  if (!shading.empty()) shading[core]->shade(ray_index, traversal.ray(), traversal.hit(), t);
  raygen[core]->slot_free(&unit, slot, t);
  if ((++rays_done_total & 4095) == 0 && progress_) progress_(rays_done_total);
  check_frame_end(t);
}

void CycleSystem::spawned(uint32_t core, const std::vector<Ray>& rays, uint64_t t) {
  raygen[core]->add_rays(rays, t);
  check_frame_end(t);
}

void CycleSystem::check_frame_end(uint64_t t) {
  // Done when every issued ray has finished, nothing is queued and shading is idle.
  if (!dispatcher.empty() || issued() != rays_done) return;
  for (auto& s : shading)
    if (!s->idle()) return;
  end_ps = std::max(end_ps, t);
  const auto& d = dram->model.counters();
  frame_history.push_back({rays_done, d.bytes, d.bytes_written, end_ps - frame_start_ps});
  if (frame + 1 >= std::max<uint32_t>(1, workload.frames)) {
    finished = true;
    return;
  }
  ++frame;
  frame_start_ps = t;
  end_ps = t;
  reset_counters();
  dispatcher.restart(t);
  for (auto& r : raygen) r->restart(t);
}

void CycleSystem::reset_counters() {
  per_type = {};
  rays_done = 0;
  for (auto& r : raygen) r->reset_counters();
  for (auto& u : trv) u->reset_counters();
  for (auto& u : ist) u->reset_counters();
  for (auto& s : shading) s->reset_counters();
  for (auto& c : l1_node) c->reset_counters();
  for (auto& c : l1_triangle) c->reset_counters();
  for (auto& c : l1_texture) c->reset_counters();
  for (auto& c : l2) c->reset_counters();
  noc_model.reset_counters();
  dram->model.reset_counters();
}

}  // namespace rtsim::sim
