// rtsim simulate: run the accelerator model at one fidelity level (functional,
// lt, cycle) on a scene + builder + camera (or a ray file) with a hardware
// configuration; writes DIR/config.json (resolved configuration and inputs),
// DIR/stats.json (deterministic, hierarchical) and DIR/host.json (host time,
// throughput, memory: kept apart so that stats.json is byte-identical across runs).
#include "rtsim_revision.h"
#include "cli_util.h"
#include "commands.h"

#include <rtsim/builder/bvh_file.h>

#include <rtsim/builder/build.h>
#include <rtsim/model/core/ray_file.h>
#include <rtsim/model/sim/memory_trace.h>
#include <rtsim/model/sim/simulator.h>
#include <rtsim/model/sim/stat_names.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/numbers.h>
#include <rtsim/workloads/progress.h>
#include <rtsim/workloads/scene_registry.h>

#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

namespace rtsim::cli {

namespace {

struct SimulateOptions {
  std::string scene, builder = "sah", camera, fidelity = "functional", config = "mobile", out_dir;
  std::string resolution = kDefaultResolution, rays_in, bvh_in, node_format;
  std::string timeline, timeline_window, trace_ray;
  uint64_t timeline_max_events = sim::Timeline::kDefaultMaxEvents;
  int ao = -1;
  double ao_cutoff = -1;  // AO ray length x scene diagonal; < 0: the scene's
  uint32_t spp = 1, bounces = 2, frames = 1, diffuse_bounces = 0;
  bool russian_roulette = false;
  uint64_t seed = 1, shuffle_faces = 0;
  bool opaque = false;
  bool instanced = false;
  std::vector<std::string> build_settings;  // --build-set KEY=VALUE
  std::string dram_trace_out, dram_trace_format = "dramsim3", cache_trace_out, cache_trace = "l2";
  bool json = false;
  // Flags whose presence matters (given or not), filled when the command is added.
  const CLI::Option* builder_flag = nullptr;
  std::vector<const CLI::Option*> ray_making_flags;  // meaningless with --rays-in
};

// "FROM..TO" (or "FROM.." to the end) in cycles, FROM < TO; InputError naming the flag.
std::pair<uint64_t, uint64_t> parse_cycle_window(const std::string& text) {
  const std::string flag = "--timeline-window";
  const size_t dots = text.find("..");
  if (dots == std::string::npos)
    throw InputError(flag, "expected FROM..TO cycles (or FROM.. to the end), got '" + text + "'");
  const uint64_t from = read_unsigned(text.substr(0, dots), 0, UINT64_MAX / 2, flag + " FROM");
  if (dots + 2 == text.size()) return {from, UINT64_MAX};
  const uint64_t to = read_unsigned(text.substr(dots + 2), 0, UINT64_MAX / 2, flag + " TO");
  if (to <= from)
    throw InputError(flag, "TO must be after FROM, got " + std::to_string(from) + ".." + std::to_string(to));
  return {from, to};
}

// The machine's cycles split per unit kind (stats machine.<kind>.<bucket>_cycles.mean,
// accounting.h), one row a kind, in percent of the run's cycles.
void print_accounting(const sim::StatsRegistry& s, bool accounted) {
  const double total = s.number("time.cycles");
  if (!(total > 0)) return;
  if (!accounted) {
    std::printf("  cycles: not split per unit (stats.accounting = \"off\")\n");
    return;
  }
  std::printf("  cycles (%% of %.0f, mean over units):", total);
  for (sim::CycleBucket b : sim::kAllCycleBuckets) {
    std::string name = sim::cycle_bucket_name(b);
    if (name.rfind("waiting_", 0) == 0) name = name.substr(8);
    std::printf(" %7s", name.c_str());
  }
  std::printf("\n");
  for (const sim::UnitTraits* kind : sim::all_unit_kinds()) {
    const std::string p = std::string("machine.") + kind->name + ".";
    if (!s.contains(p + "busy_cycles.mean")) continue;
    std::printf("  %-33s", kind->name);
    for (sim::CycleBucket b : sim::kAllCycleBuckets) {
      const std::string key = p + sim::cycle_bucket_name(b) + "_cycles.mean";
      if (s.contains(key)) std::printf(" %7.1f", 100.0 * s.number(key) / total);
      else std::printf(" %7s", "-");
    }
    std::printf("\n");
  }
}

void run_simulate(const SimulateOptions& o) {
  sim::SimulationRequest request;
  request.fidelity = sim::parse_fidelity(o.fidelity);
  request.config = sim::load_hardware_config(o.config);
  request.config.node_format = node_format_flag(o.node_format, request.config.node_format);
  parse_resolution(o.resolution, request.settings.width, request.settings.height);
  request.settings.ao_samples = o.ao;
  request.settings.spp = o.spp;
  request.settings.seed = o.seed;
  request.settings.max_depth = o.bounces;
  request.settings.diffuse_bounces = o.diffuse_bounces;
  request.settings.russian_roulette = o.russian_roulette;
  check_frame_flags(request.settings);
  if (!o.rays_in.empty()) refuse_with_rays_in(o.ray_making_flags);
  if (!o.trace_ray.empty()) {
    request.trace_ray = sim::parse_ray_target(o.trace_ray, request.settings.width, request.settings.height);
    if (o.json && o.out_dir.empty())
      throw InputError("--trace-ray", "with --json the ray's trace goes to ray_trace.json: give --out-dir");
  }
  std::pair<uint64_t, uint64_t> window{0, UINT64_MAX};
  if (!o.timeline_window.empty()) {
    if (o.timeline.empty()) throw InputError("--timeline-window", "needs --timeline FILE");
    window = parse_cycle_window(o.timeline_window);
  }
  if (!o.timeline.empty() && request.fidelity == sim::Fidelity::Functional)
    throw InputError("--timeline", "the functional level has no time to draw; use --fidelity lt or cycle");
  if (o.timeline_max_events < 1) throw InputError("--timeline-max-events", "must be at least 1");
  // The output folder and trace files first: a wrong one must not cost a whole simulation.
  OutputFolder out_dir;
  if (!o.out_dir.empty()) out_dir.prepare(o.out_dir, "--out-dir");
  std::unique_ptr<sim::Timeline> timeline;
  if (!o.timeline.empty()) {
    check_output_file(o.timeline, "--timeline");
    sim::TimelineOptions t;
    t.file = o.timeline;
    const double cycle_ps = request.config.clock_period_ps();
    t.from_ps = uint64_t(double(window.first) * cycle_ps);
    t.to_ps = window.second == UINT64_MAX ? UINT64_MAX : uint64_t(double(window.second) * cycle_ps);
    t.max_events = o.timeline_max_events;
    t.cycle_ps = cycle_ps;
    t.level = o.fidelity;
    timeline = std::make_unique<sim::Timeline>(t);
    request.timeline = timeline.get();
  }
  std::unique_ptr<sim::DramTraceWriter> dram_trace;
  std::unique_ptr<sim::CacheTraceWriter> cache_trace;
  const sim::DramTraceFormat dram_format = sim::parse_dram_trace_format(o.dram_trace_format);
  if (!o.dram_trace_out.empty()) {
    dram_trace = std::make_unique<sim::DramTraceWriter>(o.dram_trace_out, dram_format, request.config.dram,
                                                         request.config.l2.line_bytes);
    request.dram_trace = dram_trace.get();
  }
  if (!o.cache_trace_out.empty()) {
    cache_trace = std::make_unique<sim::CacheTraceWriter>(o.cache_trace_out, o.cache_trace, "--cache-trace-out");
    request.cache_trace = cache_trace.get();
  } else if (o.cache_trace != "l2") {
    throw InputError("--cache-trace", "needs --cache-trace-out FILE");
  }

  Workload workload;
  request.frames = o.frames;
  if (o.frames < 1 || o.frames > 1000) throw InputError("--frames", "must be 1..1000");
  if (o.ao_cutoff != -1 && !(o.ao_cutoff > 0 && o.ao_cutoff <= AoSettings::kMaxCutoffRelative))
    throw InputError("--ao-cutoff", "must be in (0, 10] (x scene diagonal)");
  load_workload(workload, o.scene, o.camera, o.builder, o.seed, o.bvh_in, o.shuffle_faces, 0,
                request.config.node_format, o.build_settings, float(o.ao_cutoff), o.builder_flag->count() > 0,
                [&](const Scene& loaded) {
                  if (o.rays_in.empty()) check_frame_memory(loaded, request.settings);
                }, o.opaque, o.instanced);
  const Scene& scene = workload.scene;
  const Camera& camera = *workload.camera;
  const BuildParams& params = workload.params;
  const Bvh& bvh = workload.bvh;
  request.scene = &scene;
  request.bvh = &bvh;
  request.camera = &camera;
  uint64_t rays_hash = 0;
  if (!o.rays_in.empty()) {
    RaySet set = read_ray_file(o.rays_in);
    if (set.scene_hash != 0 && set.scene_hash != scene.content_hash())
      throw InputError(o.rays_in, "scene hash: the rays were made for another scene");
    if (set.rays.empty()) throw InputError(o.rays_in, "holds no rays");
    request.rays = std::move(set.rays);
    rays_hash = file_content_hash(o.rays_in);
  }
  // Progress: the total grows with spawned rays; primary rays x (1 + AO + diffuse bounces) is the estimate.
  const EffectPlan plan = plan_effects(scene, request.settings);
  const uint64_t primary = request.rays.empty()
                               ? uint64_t(request.settings.width) * request.settings.height * o.spp
                               : request.rays.size();
  const uint64_t expected =
      o.frames * (request.rays.empty()
                      ? primary * (1 + (plan.on(RayType::Ao) ? plan.ao_samples : 0) + plan.diffuse_bounces)
                      : primary);
  auto progress = std::make_shared<Progress>("simulate " + o.fidelity, expected, "rays");
  uint64_t reported = 0;
  request.progress = [&, progress](uint64_t done) {
    if (done > reported) progress->advance(done - reported), reported = done;
  };

  const sim::SimulationResult result = sim::simulate(request);
  request.progress = nullptr;
  if (dram_trace) dram_trace->close();
  if (cache_trace) {
    // The stats are the last frame's; with one frame they cover the whole trace.
    if (o.frames == 1)
      cache_trace->footer(uint64_t(result.stats.number(o.cache_trace == "l2" ? "l2.writebacks"
                                                                              : o.cache_trace + ".all.writebacks")));
    cache_trace->close();
  }
  progress.reset();

  nlohmann::json config = nlohmann::json::parse(sim::to_json(request.config));
  nlohmann::json out;
  out["hardware"] = config;
  out["fidelity"] = o.fidelity;
  out["git_revision"] = RTSIM_GIT_REVISION;
  out["rtsim_version"] = RTSIM_VERSION;
  out["seed"] = o.seed;
  out["inputs"] = {
      {"scene", scene.name},
      {"scene_source", scene.source},
      {"scene_hash", hex64(scene.content_hash())},
      {"triangles", scene.triangle_count()},
      {"builder", params.builder},
      {"build", o.bvh_in.empty() ? nlohmann::json::parse(build_params_json(params)) : nlohmann::json()},
      {"bvh_file", o.bvh_in},
      {"bvh_hash", hex64(bvh_content_hash(bvh))},
      {"bvh_nodes", bvh.nodes.size()},
      {"bvh_width", bvh.width()},
      {"camera", camera.name},
      {"resolution", {request.settings.width, request.settings.height}},
      {"spp", o.spp},
      {"ao", o.ao},
      {"ao_cutoff_relative", scene.ao.cutoff_relative},
      {"bounces", o.bounces},
      {"diffuse_bounces", o.diffuse_bounces},
      {"russian_roulette", o.russian_roulette},
      {"frames", o.frames},
      {"shuffle_faces", o.shuffle_faces},
      {"opaque", o.opaque},
      {"config_source", o.config},
      {"config_hash", is_file(o.config) ? hex64(file_content_hash(o.config))
                                                                  : std::string("preset")},
      {"rays_file", o.rays_in},
      {"rays_hash", o.rays_in.empty() ? std::string() : hex64(rays_hash)}};
  for (RayType t : kAllRayTypes)
    out["effects"][ray_type_name(t)] = {{"on", result.plan.on(t)},
                                        {"why", result.plan.reason[ray_type_index(t)]}};
  out["effects"]["anyhit"] = {{"on", result.plan.anyhit}, {"why", result.plan.anyhit_reason}};
  if (o.instanced) {  // a flat run's config keeps its keys
    out["instanced"] = true;
    out["instances"] = scene.instances.size();
    out["instanced_triangles"] = scene.instanced_triangle_count();
  }

  if (timeline) {
    timeline->close();
    if (timeline->capped())
      std::fprintf(stderr,
                   "rtsim simulate: --timeline: the cap of %llu spans was reached at cycle %llu; the spans after "
                   "it are left out (narrow --timeline-window or raise --timeline-max-events)\n",
                   static_cast<unsigned long long>(o.timeline_max_events),
                   static_cast<unsigned long long>(double(timeline->capped_at_ps()) / request.config.clock_period_ps()));
  }
  const std::filesystem::path dir(o.out_dir);
  const std::string stats = result.stats.to_json();
  if (!o.out_dir.empty()) {
    write_file_atomic(dir / "config.json", out.dump(2) + "\n");
    write_file_atomic(dir / "stats.json", stats);
    write_file_atomic(dir / "host.json", sim::host_json(result));
    if (!result.ray_trace.is_null()) write_file_atomic(dir / "ray_trace.json", result.ray_trace.dump(1) + "\n");
    out_dir.keep();
  }

  if (o.json) {
    std::cout << stats;
    return;
  }
  const auto& s = result.stats;
  std::printf("%s: %llu rays, %llu cycles (%.3f ms simulated), %.1f ops/ray\n", o.fidelity.c_str(),
              static_cast<unsigned long long>(result.rays),
              static_cast<unsigned long long>(result.cycles), double(result.simulated_ps) * 1e-9,
              s.number("ops.per_ray"));
  std::printf("  L1 node hit %.3f  L1 tri hit %.3f  L2 hit %.3f  DRAM %.1f B/ray\n",
              s.number("l1_node.all.hit_rate"), s.number("l1_triangle.all.hit_rate"),
              s.number("l2.hit_rate"), s.number("dram.bytes_per_ray"));
  std::printf("  %llu cores, L2 slice balance %.3f, %.0f pJ/ray (dynamic)\n",
              static_cast<unsigned long long>(s.number("machine.cores")), s.number("l2.slice_balance"),
              s.number("energy.pj_per_ray"));
  if (s.contains("ops.xfm_ops"))  // a two-level tree (--instanced)
    std::printf("  instanced: TRV %.2f TLAS + %.2f BLAS ops/ray, %.3f XFM ops/ray; footprint %.1f MiB "
                "(%llu instances, %.1f MiB of instance records)\n",
                s.number("ops.tlas_trv_ops_per_ray"), s.number("ops.blas_trv_ops_per_ray"),
                s.number("ops.xfm_ops_per_ray"), s.number("memory.total_bytes") / 1048576.0,
                (unsigned long long)s.number("memory.instance_records"),
                s.number("memory.instance_bytes") / 1048576.0);
  if (s.contains("anyhit.tests"))  // the any-hit stage was built (alpha-tested materials)
    std::printf("  any-hit %.3f tests/ray, %.1f%% let the ray through, L1 texture hit %.3f, %.1f texel B/ray\n",
                s.number("anyhit.tests_per_ray"), 100.0 * s.number("anyhit.reject_ratio"),
                s.number("l1_texture.all.hit_rate"),
                result.rays ? s.number("fetches.texel_bytes") / double(result.rays) : 0.0);
  print_accounting(s, request.config.accounted());
  std::printf("  host %.3f s, %.0f simulated rays per CPU second%s%s\n", result.host_seconds,
              result.cpu_seconds > 0 ? double(result.rays) / result.cpu_seconds : 0.0,
              o.out_dir.empty() ? "" : "; results in ", dir.string().c_str());
  if (timeline)
    std::printf("  timeline: %s, %llu spans\n", o.timeline.c_str(),
                static_cast<unsigned long long>(timeline->events()));
  if (!result.ray_trace.is_null()) std::printf("\n%s", sim::ray_trace_text(result.ray_trace).c_str());
}

}  // namespace

void add_simulate_command(CLI::App& root) {
  auto opts = std::make_shared<SimulateOptions>();
  CLI::App* cmd = root.add_subcommand(
      "simulate", "Run the accelerator model (functional | lt | cycle) and write config/stats JSON");
  cmd->add_option("--scene", opts->scene, "scene name or file (default: interior)");
  opts->builder_flag =
      cmd->add_option("--builder", opts->builder, "BVH builder: " + builder_list())->capture_default_str();
  cmd->add_option("--camera", opts->camera, "camera name (default: view1, else the scene's first)");
  cmd->add_option("--fidelity", opts->fidelity, "functional | lt | cycle")->capture_default_str();
  cmd->add_option("--config", opts->config, "hardware preset (mobile | desktop | mobile-gpu | desktop-gpu) or TOML file")
      ->capture_default_str();
  auto* out_dir = cmd->add_option("--out-dir", opts->out_dir,
                                  "output folder for config.json, stats.json, host.json (and ray_trace.json);\n"
                                  "required unless --json prints the stats");
  auto* out_old = add_deprecated_option(cmd, "--out", "--out-dir", opts->out_dir);
  out_dir->excludes(out_old);
  cmd->add_option("--res", opts->resolution, "image size WxH")->capture_default_str();
  cmd->add_option("--ao-cutoff", opts->ao_cutoff,
                  "AO ray length x scene diagonal (default: the scene's); the builders' AO rays follow\n"
                  "it unless --build-set ao_cutoff_relative says otherwise");
  opts->ray_making_flags = {
      cmd->add_option("--ao", opts->ao, "AO rays per primary hit (-1: the scene decides, 0: off)")
          ->capture_default_str(),
      cmd->add_option("--spp", opts->spp, "samples per pixel")->capture_default_str()};
  for (const CLI::Option* flag : add_bounce_flags(cmd, opts->bounces, opts->diffuse_bounces, opts->russian_roulette))
    opts->ray_making_flags.push_back(flag);
  cmd->add_option("--seed", opts->seed, "seed of every random choice (rays and the build)")
      ->capture_default_str();
  cmd->add_option("--rays-in", opts->rays_in, "replay this ray file (rtsim trace --rays-out; no secondary rays)");
  add_deprecated_option(cmd, "--rays", "--rays-in", opts->rays_in);
  cmd->add_option("--frames", opts->frames,
                  "run the same rays this many times back to back, caches warm; stats of the last")
      ->capture_default_str();
  cmd->add_flag("--instanced", opts->instanced, kInstancedHelp);
  cmd->add_flag("--opaque", opts->opaque,
               "alpha-tested materials as opaque: the same geometry\nwithout the any-hit stage and "
               "its texture caches (to compare)");
  cmd->add_option("--shuffle-faces", opts->shuffle_faces,
                  "permute the scene's triangles with this seed first (0: no): results must not change");
  cmd->add_option("--node-format", opts->node_format,
                  "node record format: " + node_format_names("|") +
                      "\n(the tree is built for its width; default: memory.node_format)");
  cmd->add_option("--build-set", opts->build_settings,
                  "builder parameter KEY=VALUE by its table name (repeatable), e.g. max_leaf_size=8;\n"
                  "a campaign's build.KEY axes arrive this way")
      ->type_name("KEY=VALUE");
  cmd->add_option("--bvh", opts->bvh_in, "replay this saved tree (rtsim build --out) instead of building one");
  cmd->add_flag("--json", opts->json, "print stats.json to stdout (with no --out-dir: and write no files)");
  cmd->add_option("--timeline", opts->timeline,
                  "write the run's timeline (lt, cycle) to FILE in the Chrome/Perfetto trace-event format:\n"
                  "a track per unit, cache, crossbar port and DRAM channel (docs/timeline.md)")
      ->type_name("FILE");
  cmd->add_option("--timeline-window", opts->timeline_window,
                  "only the spans within cycles FROM..TO (or FROM.. to the end), counted from the run's start")
      ->type_name("FROM..TO");
  cmd->add_option("--timeline-max-events", opts->timeline_max_events,
                  "at most this many spans; past it the timeline stops, and says at which cycle")
      ->capture_default_str();
  cmd->add_option("--trace-ray", opts->trace_ray,
                  "print every request of one ray: X,Y[,TYPE[,INDEX]] (TYPE primary, ao, shadow, reflection,\n"
                  "refraction, diffuse1..diffuse8; INDEX: the sample of a primary ray,\nthe INDEX-th ray of TYPE the pixel spawns);\n"
                  "also written to ray_trace.json in --out-dir")
      ->type_name("X,Y[,TYPE[,INDEX]]");
  cmd->add_option("--dram-trace-out", opts->dram_trace_out,
                  "write every request reaching DRAM to FILE (docs/dram.md, \"Checked against\")");
  cmd->add_option("--dram-trace-format", opts->dram_trace_format,
                  "dramsim3 (address, READ|WRITE, DRAM cycle) | ramulator2 (R|W, address vector)")
      ->capture_default_str();
  cmd->add_option("--cache-trace-out", opts->cache_trace_out,
                  "write every access entering the --cache-trace cache, with its outcome, to FILE");
  cmd->add_option("--cache-trace", opts->cache_trace, "l1_node | l1_triangle | l2")->capture_default_str();
  cmd->callback([opts] {
    if (opts->out_dir.empty() && !opts->json)
      throw InputError("simulate", "--out-dir DIR is required (or --json to print the stats only)");
    run_simulate(*opts);
  });
}

}  // namespace rtsim::cli
