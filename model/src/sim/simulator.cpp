#include <rtsim/model/sim/cycle/cycle_system.h>
#include <rtsim/model/sim/memory_system.h>
#include <rtsim/model/sim/ray_engine.h>
#include <rtsim/model/sim/simulator.h>
#include <rtsim/workloads/error.h>

#include <nlohmann/json.hpp>

#include <sys/resource.h>

#include <chrono>
#include <ctime>
#include <cmath>
#include <stdexcept>

namespace rtsim::sim {

namespace {

double cpu_now() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + double(t.tv_nsec) * 1e-9;
}

uint64_t peak_rss_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return uint64_t(usage.ru_maxrss) * 1024;  // Linux reports KiB
}

struct UnitFigures {
  uint64_t busy_ps = 0, occupied_ps = 0, stalled_ps = 0;
};

void report_unit(StatsRegistry& s, const std::string& prefix, const UnitFigures& f,
                 uint64_t total_ps, double cycle_ps, uint64_t work, const std::string& work_unit,
                 const std::string& work_description) {
  const auto cycles = [&](uint64_t ps) { return uint64_t(std::llround(double(ps) / cycle_ps)); };
  const uint64_t total = cycles(total_ps);
  const uint64_t busy = std::min(cycles(f.busy_ps), total);
  const uint64_t occupied = std::min(cycles(f.occupied_ps), total);
  const uint64_t stalled = std::min(cycles(f.stalled_ps), occupied);
  s.set(prefix + ".busy_cycles", busy, "cycles", "cycles the unit's pipeline accepted work");
  s.set(prefix + ".idle_cycles", total - occupied, "cycles", "cycles with no work resident");
  s.set(prefix + ".stalled_cycles", stalled, "cycles",
        "cycles resident work waited for a full downstream queue");
  s.set(prefix + ".waiting_cycles", occupied - std::min(occupied, busy), "cycles",
        "cycles with work resident but the pipeline not fed (memory latency, stalls)");
  s.set_real(prefix + ".utilisation", total ? double(busy) / double(total) : 0, "ratio",
             "busy cycles / simulated cycles");
  s.set(prefix + "." + work_unit, work, work_unit, work_description);
}

void report_counts(StatsRegistry& s, const std::array<CounterTotals, kRayTypeCount>& per_type) {
  CounterTotals total;
  for (auto& c : per_type) total.add(c);
  s.set("rays.total", total.rays, "rays", "rays simulated, all types");
  s.set("ops.trv", total.trv_ops, "ops", "TRV ops: BVH nodes processed");
  s.set("ops.ist", total.ist_ops, "ops", "IST ops: ray-triangle tests");
  s.set("ops.ist_exact_steps", total.ist_exact_steps, "steps",
        "IST edge functions and plane distances redone in double because float rounding "
        "could have decided them (a hardware unit's slow path)");
  s.set("ops.box_tests", total.box_tests, "tests", "ray-box slab tests");
  s.set_real("ops.per_ray", total.per_ray(total.ops()), "ops/ray", "(TRV + IST ops) / rays");
  s.set("fetches.node", total.node_fetches, "fetches", "node records read by TRV (before caches)");
  s.set("fetches.prim_ref", total.prim_ref_fetches, "fetches", "leaf prim-ref lists read by IST");
  s.set("fetches.triangle", total.triangle_fetches, "fetches",
        "triangle records read by IST (an any-hit ray may read some of its last step it does not test)");
  s.set("fetches.bytes", total.bytes(), "bytes", "bytes of all fetches before caches");
  s.set("stack.overflows", total.stack_overflows, "entries",
        "pushes that found the short stack full and spilled to memory");
  s.set("stack.refills", total.stack_refills, "entries", "spilled entries read back");
  for (RayType t : kAllRayTypes) {
    const CounterTotals& c = per_type[size_t(t)];
    if (c.rays == 0) continue;
    const std::string p = std::string("per_type.") + ray_type_name(t);
    s.set(p + ".rays", c.rays, "rays", std::string(ray_type_name(t)) + " rays");
    s.set(p + ".hits", c.hits, "rays", "rays that hit something");
    s.set(p + ".trv_ops", c.trv_ops, "ops", "TRV ops of these rays");
    s.set(p + ".ist_ops", c.ist_ops, "ops", "IST ops of these rays");
    s.set(p + ".node_fetches", c.node_fetches, "fetches", "node fetches of these rays");
    s.set(p + ".triangle_fetches", c.triangle_fetches, "fetches", "triangle fetches of these rays");
    s.set_real(p + ".ops_per_ray", c.per_ray(c.ops()), "ops/ray", "(TRV + IST ops) / rays");
  }
}

void report_memory(StatsRegistry& s, const std::vector<const CacheModel*>& l1_node,
                   const std::vector<const CacheModel*>& l1_triangle, const CacheModel& l2,
                   const DramModel& dram, bool row_timing, bool timed, uint64_t sim_ps,
                   uint64_t rays) {
  report_cache_group(s, "l1_node.all", l1_node);
  for (size_t i = 0; i < l1_node.size(); ++i) l1_node[i]->report(s, "l1_node.unit" + std::to_string(i));
  report_cache_group(s, "l1_triangle.all", l1_triangle);
  for (size_t i = 0; i < l1_triangle.size(); ++i)
    l1_triangle[i]->report(s, "l1_triangle.unit" + std::to_string(i));
  l2.report(s, "l2");
  dram.report(s, "dram", row_timing, timed, sim_ps);
  // Every DRAM byte read is an L2 fill: attribute them the same way.
  l2.filled().report(s, "dram.bytes_by_type", "bytes read from DRAM");
  s.set_real("dram.bytes_per_ray", rays ? double(dram.counters().bytes) / double(rays) : 0,
             "bytes/ray", "DRAM bytes read / rays");
}

void report_layout(StatsRegistry& s, const MemoryImage& image, uint64_t triangles) {
  const MemoryFootprint& f = image.footprint();
  s.set("memory.node_records", f.node_records, "records", "node records in memory");
  s.set("memory.node_bytes", f.node_bytes, "bytes", "bytes of node records");
  s.set("memory.prim_ref_bytes", f.prim_ref_bytes, "bytes", "bytes of leaf prim-ref lists");
  s.set("memory.triangle_records", f.triangle_records, "records",
        "triangle records (inline storage: one per leaf reference)");
  s.set("memory.triangle_bytes", f.triangle_bytes, "bytes", "bytes of triangle records, padding included");
  s.set("memory.total_bytes", f.total_bytes(), "bytes", "footprint of the BVH and its triangles");
  s.set_real("memory.bytes_per_triangle", triangles ? double(f.total_bytes()) / double(triangles) : 0,
             "bytes/triangle", "footprint / scene triangles");
}

void report_time(StatsRegistry& s, const HardwareConfig& c, uint64_t sim_ps, uint64_t rays,
                 bool estimate, uint32_t frames) {
  const double cycle_ps = c.clock_period_ps();
  const uint64_t cycles = uint64_t(std::llround(double(sim_ps) / cycle_ps));
  const std::string how = estimate ? " (analytic estimate)" : "";
  s.set("time.cycles", cycles, "cycles", "simulated accelerator cycles of the last frame" + how);
  s.set_real("time.seconds", double(sim_ps) * 1e-12, "s", "simulated time of the last frame" + how);
  s.set_real("time.rays_per_second", sim_ps ? double(rays) / (double(sim_ps) * 1e-12) : 0, "rays/s",
             "rays per second at the simulated clock" + how);
  s.set("time.clock_mhz", c.clock_mhz, "MHz", "accelerator clock");
  s.set("time.frames", frames, "frames",
        "frames simulated back to back (the same rays, caches warm); every figure is the last's");
}

void report_frames(StatsRegistry& s, const std::vector<FrameFigures>& history,
                   const HardwareConfig& c, bool untimed) {
  if (history.size() < 2) return;
  for (size_t f = 0; f < history.size(); ++f) {
    const FrameFigures& h = history[f];
    const std::string p = "frames.frame" + std::to_string(f + 1);
    const std::string which = f == 0 ? " (cold caches)" : "";
    s.set(p + ".dram_bytes", h.dram_bytes_read, "bytes", "bytes read from DRAM in this frame" + which);
    s.set(p + ".dram_bytes_written", h.dram_bytes_written, "bytes", "bytes written to DRAM in this frame");
    s.set_real(p + ".dram_bytes_per_ray", h.rays ? double(h.dram_bytes_read) / double(h.rays) : 0,
               "bytes/ray", "DRAM bytes read / rays in this frame" + which);
    if (!untimed)
      s.set(p + ".cycles", uint64_t(std::llround(double(h.simulated_ps) / c.clock_period_ps())),
            "cycles", "simulated cycles of this frame" + which);
  }
}

bool& systemc_used() {
  static bool used = false;
  return used;
}

}  // namespace

MemoryLayoutConfig memory_layout_for(const HardwareConfig& c) {
  MemoryLayoutConfig layout;
  layout.node_format = c.node_format;
  layout.node_order = c.node_order == "breadth-first" ? NodeOrder::BreadthFirst : NodeOrder::DepthFirst;
  layout.triangle_storage =
      c.triangle_storage == "inline" ? TriangleStorage::Inline : TriangleStorage::Indexed;
  layout.triangle_packing = c.triangle_packing == "line" ? TrianglePacking::Line : TrianglePacking::Packed;
  layout.triangle_bytes = c.triangle_bytes;
  layout.line_bytes = c.l1_triangle.line_bytes;
  return layout;
}

TraversalConfig traversal_config_for(const HardwareConfig& c) {
  TraversalConfig t;
  t.stack_limit = c.trv_stack_entries;
  t.stack_entry_bytes = c.trv_stack_entry_bytes;
  t.overflow_policy = StackOverflowPolicy::SpillToMemory;
  t.triangles_per_step = c.ist_triangles_in_flight;
  return t;
}

SimulationResult simulate(const SimulationRequest& request) {
  if (!request.scene || !request.bvh) throw InputError("simulate", "scene and BVH are required");
  if (request.rays.empty() && !request.camera)
    throw InputError("simulate", "a camera or a ray set is required");
  if (request.frames < 1 || request.frames > 1000) throw InputError("--frames", "must be 1..1000");
  const HardwareConfig& config = request.config;
  validate(config);
  if (request.fidelity != Fidelity::Functional) {
    if (systemc_used())
      throw std::runtime_error("a SystemC fidelity level runs once per process (one elaboration)");
    systemc_used() = true;
  }

  const MemoryImage image(*request.scene, *request.bvh, memory_layout_for(config));
  const TraversalContext context(*request.scene, *request.bvh, image, traversal_config_for(config));

  Workload work;
  work.scene = request.scene;
  work.context = &context;
  work.settings = request.settings;
  work.width = request.settings.width;
  work.height = request.settings.height;
  work.frames = request.frames;
  work.observer = request.observer;
  SimulationResult result;
  if (request.rays.empty()) {
    work.plan = plan_effects(*request.scene, request.settings);
    work.initial_rays = generate_primary_rays(*request.camera, request.settings);
    for (RayType t : kAllRayTypes)
      if (t != RayType::Primary && work.plan.on(t)) work.spawn_secondary = true;
  } else {
    work.initial_rays = request.rays;
  }
  result.plan = work.plan;
  auto progress = request.progress ? request.progress : [](uint64_t) {};

  StatsRegistry& s = result.stats;
  const double cycle_ps = config.clock_period_ps();
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = cpu_now();

  if (request.fidelity == Fidelity::Functional || request.fidelity == Fidelity::Lt) {
    std::unique_ptr<FunctionalMemory> functional;
    std::unique_ptr<LtSystem> lt;
    RayEngine* engine = nullptr;
    std::unique_ptr<RayEngine> own_engine;
    if (request.fidelity == Fidelity::Functional) {
      functional = std::make_unique<FunctionalMemory>(config);
      own_engine = std::make_unique<RayEngine>(config, work, false);
      engine = own_engine.get();
      engine->run(
          *functional, [](uint64_t) {},
          [&](bool last) {
            const auto& d = functional->dram.counters();
            result.frame_history.push_back({engine->total().rays, d.bytes, d.bytes_written, 0});
            if (!last) functional->reset_counters();
          },
          progress);
    } else {
      lt = std::make_unique<LtSystem>("lt", config, work, progress);
      engine = &lt->engine;
      sc_core::sc_start();
      result.frame_history = lt->frame_history;
    }
    result.host_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    result.cpu_seconds = cpu_now() - cpu_start;
    result.per_type = engine->per_type();
    const CounterTotals total = engine->total();
    result.rays = total.rays;

    std::vector<const CacheModel*> l1n, l1t;
    const CacheModel* l2;
    const DramModel* dram;
    if (functional) {
      for (auto& c : functional->l1_node) l1n.push_back(c.get());
      for (auto& c : functional->l1_triangle) l1t.push_back(c.get());
      l2 = &functional->l2;
      dram = &functional->dram;
      // Analytic estimate: the busiest resource bounds the run.
      const double bytes_per_cycle = dram->peak_bytes_per_second() * cycle_ps * 1e-12;
      const uint64_t dram_bytes = dram->counters().bytes;
      uint64_t trv_passes = 0;
      for (uint64_t p : engine->trv_passes()) trv_passes += p;
      const double cycles = std::max(
          {double(trv_passes) / (config.trv_units * config.trv_nodes_per_cycle),
           double(total.ist_ops) / (config.ist_units * config.ist_tests_per_cycle),
           double(total.rays) / config.raygen_rays_per_cycle,
           double(dram_bytes) / bytes_per_cycle});
      result.simulated_ps = uint64_t(std::llround(std::ceil(cycles) * cycle_ps));
      s.set_real("time.bound_trv_cycles",
                 double(trv_passes) / (config.trv_units * config.trv_nodes_per_cycle), "cycles",
                 "box-test pipeline passes / TRV throughput");
      s.set_real("time.bound_ist_cycles",
                 double(total.ist_ops) / (config.ist_units * config.ist_tests_per_cycle), "cycles",
                 "IST ops / IST throughput");
      s.set_real("time.bound_dram_cycles", double(dram_bytes) / bytes_per_cycle,
                 "cycles", "DRAM bytes read / peak DRAM bytes per cycle");
      // Untimed: a unit is busy for its work / throughput, idle for the rest of the
      // estimate; stalls are not modelled at this level.
      const auto unit_busy_ps = [&](uint64_t work_done, double per_cycle) {
        return uint64_t(std::llround(double(work_done) / per_cycle * cycle_ps));
      };
      for (size_t u = 0; u < engine->trv_passes().size(); ++u) {
        const uint64_t busy = unit_busy_ps(engine->trv_passes()[u], config.trv_nodes_per_cycle);
        report_unit(s, "trv.unit" + std::to_string(u), {busy, busy, 0}, result.simulated_ps,
                    cycle_ps, engine->trv_passes()[u], "passes", "box-test pipeline passes (a node takes ceil(children / trv.boxes_per_pass))");
      }
      for (size_t u = 0; u < engine->ist_tests().size(); ++u) {
        const uint64_t busy = unit_busy_ps(engine->ist_tests()[u], config.ist_tests_per_cycle);
        report_unit(s, "ist.unit" + std::to_string(u), {busy, busy, 0}, result.simulated_ps,
                    cycle_ps, engine->ist_tests()[u], "tests", "triangle tests through the pipeline");
      }
    } else {
      for (auto& c : lt->l1_node) l1n.push_back(&c->model);
      for (auto& c : lt->l1_triangle) l1t.push_back(&c->model);
      l2 = &lt->l2->model;
      result.simulated_ps = engine->end_ps() - engine->start_ps();
      lt->dram->model.settle(engine->end_ps());  // idle-time refreshes into the counts
      dram = &lt->dram->model;
      // Per-unit figures of the engine's unit timing.
      for (size_t u = 0; u < engine->trv_time().size(); ++u) {
        const UnitTime& t = engine->trv_time()[u];
        report_unit(s, "trv.unit" + std::to_string(u), {t.busy_ps, t.occupied_ps(), 0},
                    result.simulated_ps, cycle_ps,
                    engine->trv_passes()[u], "passes", "box-test pipeline passes (a node takes ceil(children / trv.boxes_per_pass))");
      }
      for (size_t u = 0; u < engine->ist_time().size(); ++u) {
        const UnitTime& t = engine->ist_time()[u];
        report_unit(s, "ist.unit" + std::to_string(u), {t.busy_ps, t.occupied_ps(), 0},
                    result.simulated_ps, cycle_ps,
                    engine->ist_tests()[u], "tests", "triangle tests through the pipeline");
      }
      if (work.spawn_secondary) {
        const UnitTime& t = engine->shading_time();
        report_unit(s, "shading", {t.busy_ps, t.occupied_ps(), 0}, result.simulated_ps, cycle_ps,
                    engine->shaded(), "rays", "rays shaded");
      }
    }
    report_memory(s, l1n, l1t, *l2, *dram, lt != nullptr, lt != nullptr, result.simulated_ps,
                  total.rays);
    report_time(s, config, result.simulated_ps, total.rays, functional != nullptr, request.frames);
  } else {
    CycleSystem system("accelerator", config, work, progress);
    sc_core::sc_start();
    result.host_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    result.cpu_seconds = cpu_now() - cpu_start;
    if (!system.finished)
      throw std::runtime_error("cycle model stopped with " +
                               std::to_string(system.raygen->issued() - system.rays_done) +
                               " rays unfinished");
    result.per_type = system.per_type;
    result.rays = system.rays_done;
    result.frame_history = system.frame_history;
    result.simulated_ps = system.end_ps - system.frame_start_ps;
    system.dram->model.settle(system.end_ps);  // idle-time refreshes into the counts
    const uint64_t T = result.simulated_ps;
    for (size_t u = 0; u < system.trv.size(); ++u) {
      const Occupancy& o = system.trv[u]->occupancy;
      report_unit(s, "trv.unit" + std::to_string(u), {o.busy_ps, o.occupied_ps, o.stalled_ps}, T,
                  cycle_ps, system.trv[u]->passes, "passes", "box-test pipeline passes (a node takes ceil(children / trv.boxes_per_pass))");
    }
    for (size_t u = 0; u < system.ist.size(); ++u) {
      const Occupancy& o = system.ist[u]->occupancy;
      report_unit(s, "ist.unit" + std::to_string(u), {o.busy_ps, o.occupied_ps, o.stalled_ps}, T,
                  cycle_ps, system.ist[u]->tests, "tests", "triangle tests through the pipeline");
    }
    if (system.shading) {
      const Occupancy& o = system.shading->occupancy;
      report_unit(s, "shading", {system.shading->busy_ps, o.occupied_ps, 0}, T, cycle_ps,
                  system.shading->shaded, "rays", "rays shaded");
      s.set("shading.spawned", system.shading->spawned, "rays", "secondary rays spawned");
    }
    s.set("raygen.stalled_cycles",
          uint64_t(std::llround(double(system.raygen->stalled_ps) / cycle_ps)), "cycles",
          "cycles a ready ray found no free TRV slot");
    std::vector<const CacheModel*> l1n, l1t;
    for (auto& c : system.l1_node) l1n.push_back(&c->model);
    for (auto& c : system.l1_triangle) l1t.push_back(&c->model);
    report_memory(s, l1n, l1t, system.l2->model, system.dram->model, true, true, T, result.rays);
    s.set("l2.downstream_stall_cycles",
          uint64_t(std::llround(double(system.l2->downstream_stall_ps) / cycle_ps)), "cycles",
          "cycles the L2's outbound queue waited because the DRAM queue was full");
    s.set("l2.downstream_refusals", system.l2->downstream_refusals, "requests",
          "requests the DRAM did not take at once (its channel queue was full)");
    report_time(s, config, T, result.rays, false, request.frames);
  }
  report_counts(s, result.per_type);
  report_layout(s, image, request.scene->triangle_count());
  report_frames(s, result.frame_history, config, request.fidelity == Fidelity::Functional);
  result.cycles = uint64_t(std::llround(double(result.simulated_ps) / cycle_ps));
  result.peak_memory_bytes = peak_rss_bytes();
  return result;
}

std::string host_json(const SimulationResult& r) {
  nlohmann::json j;
  j["host_seconds"] = {{"value", r.host_seconds}, {"unit", "s"},
                       {"description", "wall time of the simulation (excluding loading and BVH build)"}};
  j["rays_per_host_second"] = {
      {"value", r.host_seconds > 0 ? double(r.rays) / r.host_seconds : 0.0},
      {"unit", "rays/s"},
      {"description", "simulated rays per host second"}};
  j["cpu_seconds"] = {{"value", r.cpu_seconds}, {"unit", "s"},
                      {"description", "CPU time of the simulation (one thread)"}};
  j["rays_per_cpu_second"] = {
      {"value", r.cpu_seconds > 0 ? double(r.rays) / r.cpu_seconds : 0.0},
      {"unit", "rays/s"},
      {"description", "simulated rays per CPU second (unaffected by other load)"}};
  j["peak_memory"] = {{"value", r.peak_memory_bytes}, {"unit", "bytes"},
                      {"description", "peak resident set size of the process"}};
  return j.dump(2) + "\n";
}

}  // namespace rtsim::sim
