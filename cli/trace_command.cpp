// rtsim trace: run primary rays (and the secondary rays the scene calls for)
// through the functional ray core; print ops/ray, fetches, bytes, cache hit
// rates and throughput; write pictures; optionally validate against Embree.
#include "cli_util.h"
#include "commands.h"

#include <rtsim/builder/build.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/core/ray_file.h>
#include <rtsim/model/core/validate.h>
#include <rtsim/model/sim/memory_system.h>
#include <rtsim/model/sim/ray_probe.h>
#include <rtsim/model/sim/simulator.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/image.h>
#include <rtsim/workloads/scene_registry.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>

namespace rtsim::cli {

namespace {

struct TraceOptions {
  std::string scene, builder = "sah", camera, resolution = kDefaultResolution, out_dir, rays_in, rays_out,
      bvh_in;
  // "" = the hardware configuration's memory.node_format; else a format's name.
  std::string node_format, node_layout, config = "mobile", trace_ray;
  int ao = -1;
  uint32_t spp = 1, threads = 0, bounces = 2, stack_limit = 128, diffuse_bounces = 0;
  bool russian_roulette = false;
  uint64_t shuffle_faces = 0;
  bool opaque = false;
  bool instanced = false;
  uint64_t seed = 1;
  float heat_max = 150.0f;
  float xfm_heat_max = 64.0f;  // instances entered per pixel at the top of xfm_heatmap.png
  bool json = false, validate = false;
  // Flags whose presence matters (given or not), filled when the command is added.
  const CLI::Option* builder_flag = nullptr;
  std::vector<const CLI::Option*> ray_making_flags;  // meaningless with --rays-in
};

nlohmann::json totals_json(const CounterTotals& t, uint64_t all_ops) {
  return {{"rays", t.rays},
          {"hits", t.hits},
          {"ops_per_ray", t.per_ray(t.ops())},
          {"trv_ops_per_ray", t.per_ray(t.trv_ops)},
          {"ist_ops_per_ray", t.per_ray(t.ist_ops)},
          {"ist_exact_steps_per_million_ist_ops",
           t.ist_ops ? 1e6 * double(t.ist_exact_steps) / double(t.ist_ops) : 0.0},
          {"box_tests_per_ray", t.per_ray(t.box_tests)},
          {"node_fetches_per_ray", t.per_ray(t.node_fetches)},
          {"prim_ref_fetches_per_ray", t.per_ray(t.prim_ref_fetches)},
          {"triangle_fetches_per_ray", t.per_ray(t.triangle_fetches)},
          {"bytes_per_ray", t.per_ray(t.bytes())},
          {"ops", t.ops()},
          {"share_of_ops", all_ops ? double(t.ops()) / double(all_ops) : 0.0},
          {"max_stack_depth", t.max_stack_depth},
          {"stack_overflows", t.stack_overflows},
          {"anyhit_tests_per_ray", t.per_ray(t.anyhit_tests)},
          {"anyhit_rejects", t.anyhit_rejects},
          {"texel_bytes_per_ray", t.per_ray(t.texel_bytes)},
          // Two-level trees (--instanced): zero for a flat scene.
          {"tlas_trv_ops_per_ray", t.per_ray(t.tlas_trv_ops)},
          {"xfm_ops_per_ray", t.per_ray(t.xfm_ops)},
          {"instance_bytes_per_ray", t.per_ray(t.instance_bytes)}};
}

// One cache level as a whole (an L2's slices summed).
nlohmann::json cache_json(const std::vector<std::unique_ptr<sim::CacheModel>>& level) {
  sim::CacheModel::Counters k;
  uint64_t size = 0, requested = 0, filled = 0;
  for (auto& c : level) {
    k.add(c->counters());
    size += c->config().size_bytes;
    requested += c->requested().total();
    filled += c->filled().total();
  }
  const sim::CacheConfig& c = level.front()->config();
  return {{"size_bytes", size},        {"line_bytes", c.line_bytes},
          {"ways", c.associativity},   {"accesses", k.accesses},
          {"hits", k.hits},            {"misses", k.misses},
          {"hit_rate", k.accesses ? double(k.hits) / double(k.accesses) : 0.0},
          {"writebacks", k.writebacks},
          {"bytes_requested", requested},
          {"bytes_filled", filled},
          {"instances", level.size()}};
}

double hit_rate(const std::vector<std::unique_ptr<sim::CacheModel>>& level) {
  return cache_json(level)["hit_rate"].get<double>();
}

// One ray's requests through the same one-unit hierarchy, with the caches as the
// trace left them when that ray came: the rays before it are replayed first.
nlohmann::json trace_one_ray(const sim::RayTarget& target, const TraversalContext& context, const Camera& camera,
                             const EffectSettings& settings, const FrameRun& run, const std::vector<Ray>& replayed,
                             const sim::HardwareConfig& one_unit, const MemoryImage& image, uint32_t threads) {
  const Ray ray = sim::find_target_ray(target, context, &camera, settings, run.plan, replayed);
  sim::RayProbe probe(ray);
  size_t index = 0;
  while (index < run.rays.size() && !probe.is(run.rays[index])) ++index;
  if (index == run.rays.size()) throw std::logic_error("--trace-ray: the frame did not trace the ray it spawns");
  sim::FunctionalMemory memory(one_unit, image.has_alpha_data());
  sim::FunctionalMemorySink before(memory);
  std::vector<TraceResult> results;
  trace_rays(context, std::vector<Ray>(run.rays.begin(), run.rays.begin() + ptrdiff_t(index)), results, &before,
             threads);
  sim::FunctionalMemorySink probing(memory, &probe);
  RayTraversal traversal(context);
  probe.begin(0);
  trace_ray(traversal, ray, &probing);
  probe.end(0, traversal.counters());
  return sim::ray_trace_json(probe, target, image, context, one_unit.clock_period_ps(), 0, false);
}

// --node-format, or the old --node-layout and its names (bvh2-64 | single-32, and
// before them wide | single) with a deprecation warning.
std::string node_format_from_flags(const TraceOptions& o, const std::string& hardware_format) {
  std::string format = o.node_format;
  if (!o.node_layout.empty()) {
    const std::string& old = o.node_layout;
    const std::string now = old == "wide" || old == "bvh2-64" ? "bvh2-64"
                            : old == "single" || old == "single-32" ? "bvh2-32" : "";
    if (now.empty())
      throw InputError("--node-layout", "must be bvh2-64 or single-32; the flag is now --node-format (" +
                                            node_format_names() + ")");
    warn_deprecated("--node-layout " + old, "--node-format " + now);
    if (format.empty()) format = now;
  }
  return node_format_flag(format, hardware_format);
}

// The frame the flags ask for (run_trace checks their combination).
EffectSettings frame_settings(const TraceOptions& o) {
  EffectSettings settings;
  parse_resolution(o.resolution, settings.width, settings.height);
  if (!(o.heat_max > 0.0f)) throw InputError("--heat-max", "must be > 0");
  if (!(o.xfm_heat_max > 0.0f)) throw InputError("--xfm-heat-max", "must be > 0");
  if (o.stack_limit < 1) throw InputError("--stack-limit", "must be at least 1");
  settings.spp = o.spp;
  settings.seed = o.seed;
  settings.ao_samples = o.ao;
  settings.max_depth = o.bounces;
  settings.diffuse_bounces = o.diffuse_bounces;
  settings.russian_roulette = o.russian_roulette;
  return settings;
}

// The run's figures as trace --json prints them (without validate and ray_trace).
nlohmann::json trace_json(const TraceOptions& o, const Workload& workload, const sim::HardwareConfig& hardware,
                          const EffectSettings& settings, const MemoryImage& image, const FrameRun& run,
                          const sim::FunctionalMemory& memory) {
  const Scene& scene = workload.scene;
  const BuildReport& build_report = workload.report;
  nlohmann::json j;
  j["scene"] = scene.name;
  j["triangles"] = scene.triangle_count();
  j["builder"] = workload.params.builder;
  j["camera"] = workload.camera->name;
  j["resolution"] = {settings.width, settings.height};
  j["spp"] = settings.spp;
  j["seed"] = settings.seed;
  j["node_format"] = hardware.node_format;
  j["bvh_width"] = workload.bvh.width();
  j["config"] = o.config;
  j["node_bytes"] = image.node_bytes();
  j["triangle_bytes"] = image.triangle_bytes();
  j["bvh_nodes"] = workload.bvh.nodes.size();
  j["build_seconds"] = build_report.build_seconds + build_report.estimate_seconds;
  j["waves"] = run.waves;
  j["trace_seconds"] = run.trace_seconds;
  j["rays_per_second"] = run.trace_seconds > 0 ? double(run.total.rays) / run.trace_seconds : 0.0;
  j["total"] = totals_json(run.total, run.total.ops());
  for (RayType t : kAllRayTypes) {
    const int k = ray_type_index(t);
    j["effects"][ray_type_name(t)] = {{"on", run.plan.enabled[k]}, {"why", run.plan.reason[k]}};
    if (run.per_type[k].rays) j["per_type"][ray_type_name(t)] = totals_json(run.per_type[k], run.total.ops());
  }
  j["effects"]["anyhit"] = {{"on", run.plan.anyhit}, {"why", run.plan.anyhit_reason}};
  const uint64_t dram_bytes = memory.dram.counters().bytes;
  j["caches"] = {{"l1_node", cache_json(memory.l1_node)},
                 {"l1_triangle", cache_json(memory.l1_triangle)},
                 {"l2", cache_json(memory.l2)},
                 {"dram_bytes", dram_bytes},
                 {"dram_bytes_per_ray", run.total.per_ray(dram_bytes)}};
  j["memory_bytes"] = image.footprint().total_bytes();
  if (workload.bvh.two_level()) {
    // What the two-level tree is built from, and (aobvh) how far a placement's own
    // occlusion lies from the mean its shared BLAS is built with.
    j["instancing"] = {{"instances", scene.instances.size()},
                       {"meshes", scene.meshes.size()},
                       {"unique_triangles", scene.triangle_count()},
                       {"instanced_triangles", scene.instanced_triangle_count()},
                       {"tlas_nodes", workload.bvh.tlas_nodes},
                       {"tlas_seconds", build_report.tlas_seconds},
                       {"placement_spread", build_report.placement_spread},
                       {"mean_occlusion", build_report.mean_occlusion}};
  }
  return j;
}

// ops_heatmap.png, ao.png (when AO ran), xfm_heatmap.png (two-level trees) and
// shaded.png in --out-dir.
void write_trace_pictures(const TraceOptions& o, const Scene& scene, const FrameRun& run, OutputFolder& pictures,
                          nlohmann::json& j) {
  const std::filesystem::path dir(o.out_dir);
  std::filesystem::create_directories(dir);
  write_png(dir / "ops_heatmap.png", heatmap(ops_per_pixel(run), run.width, run.height, o.heat_max));
  if (run.per_type[ray_type_index(RayType::Ao)].rays) write_png(dir / "ao.png", ao_image(run));
  write_png(dir / "shaded.png", shaded_image(scene, run));
  j["pictures"] = {{"dir", dir.string()}, {"heat_max_ops", o.heat_max}};
  if (run.total.xfm_ops) {
    // Instances entered per pixel, all rays, on a scale that compares builders too.
    write_png(dir / "xfm_heatmap.png", heatmap(xfm_per_pixel(run), run.width, run.height, o.xfm_heat_max));
    j["pictures"]["heat_max_xfm"] = o.xfm_heat_max;
  }
  pictures.keep();
}

// Every ray against Embree, disagreements decided by the exact referee; returns
// the rays the core got wrong.
uint64_t validate_trace(const Scene& scene, const FrameRun& run, uint32_t threads, nlohmann::json& j) {
  EmbreeScene embree(scene);
  ValidationRule rule;
  rule.absolute_bound = 1e-6f * scene.diagonal();
  const ValidationResult v = validate_against_embree(embree, run.rays, run.results, rule, threads, &scene);
  j["validate"] = {{"rays", v.rays},
                   {"disagreements", v.disagreements},
                   {"embree_wrong", v.embree_wrong},
                   {"core_wrong", v.core_wrong},
                   {"both_admissible", v.both_admissible},
                   {"hit_miss", v.hit_miss},
                   {"distance", v.distance},
                   {"prim_tied_allowed", v.prim_tied},
                   {"endpoint_ties_allowed", v.endpoint_ties},
                   {"relative_bound", rule.relative_bound},
                   {"absolute_bound", rule.absolute_bound},
                   {"examples", v.examples}};
  return v.failures();
}

// The terminal summary: per ray type, effects, caches, throughput, validation.
void print_trace_summary(const TraceOptions& o, const nlohmann::json& j, const Workload& workload,
                         const sim::HardwareConfig& hardware, const EffectSettings& settings,
                         const MemoryImage& image, const FrameRun& run, const sim::FunctionalMemory& memory) {
  const Scene& scene = workload.scene;
  std::printf("scene %s (%zu triangles), builder %s (%zu nodes), camera %s, %ux%u x %u spp, %s nodes (%u B)\n",
              scene.name.c_str(), scene.triangle_count(), workload.params.builder.c_str(), workload.bvh.nodes.size(),
              workload.camera->name.c_str(), settings.width, settings.height, settings.spp,
              hardware.node_format.c_str(), image.node_bytes());
  std::printf("\n%-11s %9s %9s %8s %8s %8s %9s %9s %9s %7s\n", "ray type", "rays", "ops/ray",
              "TRV/ray", "IST/ray", "box/ray", "node f/r", "tri f/r", "bytes/r", "share");
  auto row = [&](const char* name, const CounterTotals& t) {
    std::printf("%-11s %9llu %9.2f %8.2f %8.2f %8.2f %9.2f %9.2f %9.1f %6.1f%%\n", name,
                (unsigned long long)t.rays, t.per_ray(t.ops()), t.per_ray(t.trv_ops),
                t.per_ray(t.ist_ops), t.per_ray(t.box_tests), t.per_ray(t.node_fetches),
                t.per_ray(t.triangle_fetches), t.per_ray(t.bytes()),
                run.total.ops() ? 100.0 * double(t.ops()) / double(run.total.ops()) : 0.0);
  };
  for (RayType t : kAllRayTypes)
    if (run.per_type[ray_type_index(t)].rays) row(ray_type_name(t), run.per_type[ray_type_index(t)]);
  row("total", run.total);
  if (j.contains("instancing")) {
    const auto& i = j["instancing"];
    std::printf("two-level tree: %llu instances of %llu meshes, %llu unique of %llu instanced triangles, "
                "TLAS %llu nodes (built in %.3f s)%s\n",
                (unsigned long long)i["instances"].get<uint64_t>(), (unsigned long long)i["meshes"].get<uint64_t>(),
                (unsigned long long)i["unique_triangles"].get<uint64_t>(),
                (unsigned long long)i["instanced_triangles"].get<uint64_t>(),
                (unsigned long long)i["tlas_nodes"].get<uint64_t>(), i["tlas_seconds"].get<double>(),
                workload.params.builder == "aobvh" || workload.params.builder == "aosbvh"
                    ? (", AO over placements: mean " + std::to_string(i["mean_occlusion"].get<double>()) +
                       ", a placement " + std::to_string(i["placement_spread"].get<double>()) + " from its mean")
                          .c_str()
                    : "");
  }
  std::printf("\neffects:\n");
  for (RayType t : kAllRayTypes) {
    const bool on = run.plan.enabled[ray_type_index(t)];
    // Diffuse depths past the asked ones are off for one reason: diffuse1's line (or
    // the first depth not asked) says it once.
    if (!on && diffuse_depth(t) > std::max(1u, run.plan.diffuse_bounces + 1)) continue;
    std::printf("  %-11s %-4s %s\n", ray_type_name(t), on ? "on" : "off", run.plan.reason[ray_type_index(t)].c_str());
  }
  std::printf("  %-11s %-4s %s\n", "any-hit", run.plan.anyhit ? "on" : "off", run.plan.anyhit_reason.c_str());
  std::printf("\ncaches (%s, one ray in flight):  L1 node %.1f%%  L1 triangle %.1f%%  L2 %.1f%%  DRAM %.1f B/ray\n",
              o.config.c_str(), 100 * hit_rate(memory.l1_node),
              100 * hit_rate(memory.l1_triangle), 100 * hit_rate(memory.l2),
              run.total.per_ray(memory.dram.counters().bytes));
  std::printf("max stack depth %u, stack overflows %llu\n", run.total.max_stack_depth,
              (unsigned long long)run.total.stack_overflows);
  std::printf("throughput: %.3f M rays/s (%.3f s for %llu rays in %u waves, with cache simulation)\n",
              j["rays_per_second"].get<double>() * 1e-6, run.trace_seconds,
              (unsigned long long)run.total.rays, run.waves);
  if (!o.out_dir.empty()) {
    char xfm[96] = "";
    if (run.total.xfm_ops) std::snprintf(xfm, sizeof xfm, "; xfm_heatmap 0..%g XFM ops/pixel", o.xfm_heat_max);
    std::printf("pictures in %s (heatmap scale 0..%g ops/pixel%s)\n", o.out_dir.c_str(), o.heat_max, xfm);
  }
  if (o.validate) {
    const auto& v = j["validate"];
    std::printf("validate vs Embree: %llu disagreements in %llu rays, decided by the exact referee: "
                "%llu Embree wrong, %llu core wrong, %llu both admissible\n"
                "  (|dt| <= %g x t + %g; allowed: %llu different prims at tied distance, %llu one-sided "
                "hits at tmin/tmax)\n",
                (unsigned long long)v["disagreements"].get<uint64_t>(), (unsigned long long)run.rays.size(),
                (unsigned long long)v["embree_wrong"].get<uint64_t>(),
                (unsigned long long)v["core_wrong"].get<uint64_t>(),
                (unsigned long long)v["both_admissible"].get<uint64_t>(),
                v["relative_bound"].get<double>(), v["absolute_bound"].get<double>(),
                (unsigned long long)v["prim_tied_allowed"].get<uint64_t>(),
                (unsigned long long)v["endpoint_ties_allowed"].get<uint64_t>());
    for (const auto& e : v["examples"]) std::printf("  %s\n", e.get<std::string>().c_str());
  }
  if (j.contains("ray_trace")) std::printf("\n%s", sim::ray_trace_text(j["ray_trace"]).c_str());
}

void run_trace(const TraceOptions& o) {
  const EffectSettings settings = frame_settings(o);
  sim::HardwareConfig hardware = sim::load_hardware_config(o.config);
  hardware.node_format = node_format_from_flags(o, hardware.node_format);
  check_frame_flags(settings);
  if (!o.rays_in.empty()) refuse_with_rays_in(o.ray_making_flags);
  std::optional<sim::RayTarget> target;
  if (!o.trace_ray.empty()) target = sim::parse_ray_target(o.trace_ray, settings.width, settings.height);
  // Output paths first: a wrong one must not cost a build and a trace.
  OutputFolder pictures;
  if (!o.out_dir.empty()) pictures.prepare(o.out_dir, "--out-dir");
  if (!o.rays_out.empty()) check_output_file(o.rays_out, "--rays-out");

  Workload workload;
  load_workload(workload, o.scene, o.camera, o.builder, o.seed, o.bvh_in, o.shuffle_faces, o.threads,
                hardware.node_format, {}, -1, o.builder_flag->count() > 0, [&](const Scene& loaded) {
                  if (o.rays_in.empty()) check_frame_memory(loaded, settings);
                }, o.opaque, o.instanced);
  const Scene& scene = workload.scene;
  const MemoryImage image(scene, workload.bvh, sim::memory_layout_for(hardware));
  TraversalConfig traversal = sim::traversal_config_for(hardware);
  traversal.stack_limit = o.stack_limit;
  const TraversalContext context(scene, workload.bvh, image, traversal);

  // The hardware's memory hierarchy as one core of one TRV and one IST unit with one
  // ray in flight (the L2 keeps its slices).
  sim::HardwareConfig one_unit = hardware;
  one_unit.cores = one_unit.trv_units = one_unit.ist_units = 1;
  sim::FunctionalMemory memory(one_unit, image.has_alpha_data());
  sim::FunctionalMemorySink caches(memory);
  FrameRun run;
  std::vector<Ray> replayed;  // the ray file's rays (--trace-ray looks among them)
  if (!o.rays_in.empty()) {
    RaySet set = read_ray_file(o.rays_in);
    if (set.scene_hash != 0 && set.scene_hash != scene.content_hash())
      throw InputError(o.rays_in, "scene hash: the rays were made for another scene");
    if (target) replayed = set.rays;
    run = run_rays(context, std::move(set.rays), settings.width, settings.height, &caches, o.threads);
  } else {
    run = run_frame(context, *workload.camera, settings, &caches, o.threads);
  }
  if (!o.rays_out.empty()) write_ray_file(o.rays_out, RaySet{run.rays, scene.content_hash()});

  nlohmann::json j = trace_json(o, workload, hardware, settings, image, run, memory);
  if (target)
    j["ray_trace"] =
        trace_one_ray(*target, context, *workload.camera, settings, run, replayed, one_unit, image, o.threads);
  if (!o.out_dir.empty()) write_trace_pictures(o, scene, run, pictures, j);
  const uint64_t disagreements = o.validate ? validate_trace(scene, run, o.threads, j) : 0;

  if (o.json) std::cout << j.dump(2) << "\n";
  else print_trace_summary(o, j, workload, hardware, settings, image, run, memory);
  if (disagreements > 0)
    throw ExitStatus(1, "validation: the exact referee found the core wrong on " +
                            std::to_string(disagreements) + " rays");
}

}  // namespace

void add_trace_command(CLI::App& root) {
  auto options = std::make_shared<TraceOptions>();
  CLI::App* cmd = root.add_subcommand(
      "trace", "Trace primary rays and the secondary rays the scene calls for through the functional core");
  cmd->add_option("--scene", options->scene, "scene name or file (default: the default scene)");
  options->builder_flag =
      cmd->add_option("--builder", options->builder, "BVH builder: " + builder_list())->capture_default_str();
  cmd->add_option("--camera", options->camera, "camera name (default: view1, else the scene's first)");
  options->ray_making_flags.push_back(
      cmd->add_option("--ao", options->ao, "AO rays per primary hit (0: off; default: the scene's)"));
  cmd->add_option("--res", options->resolution, "image resolution WxH")->capture_default_str();
  options->ray_making_flags.push_back(
      cmd->add_option("--spp", options->spp, "samples per pixel")->capture_default_str());
  cmd->add_option("--seed", options->seed, "seed of every random choice (rays and the build)")
      ->capture_default_str();
  for (const CLI::Option* flag :
       add_bounce_flags(cmd, options->bounces, options->diffuse_bounces, options->russian_roulette))
    options->ray_making_flags.push_back(flag);
  cmd->add_option("--threads", options->threads,
                  "threads for the build, the trace and validation (0: all); results do not depend on it");
  cmd->add_option("--config", options->config,
                  "hardware preset (model/presets: mobile, desktop, mobile-gpu, desktop-gpu) or TOML file")
      ->capture_default_str();
  cmd->add_option("--node-format", options->node_format,
                  "node record format: " + node_format_names("|") +
                      "\n(the tree is built for its width; default: memory.node_format)");
  cmd->add_option("--node-layout", options->node_layout, "deprecated: --node-format")->group("");
  cmd->add_flag("--instanced", options->instanced, kInstancedHelp);
  cmd->add_flag("--opaque", options->opaque,
               "alpha-tested materials as opaque: the same geometry\nwithout the any-hit stage and "
               "its texture caches (to compare)");
  cmd->add_option("--shuffle-faces", options->shuffle_faces,
                  "permute the scene's triangles with this seed first (0: no): results must not change");
  cmd->add_option("--stack-limit", options->stack_limit, "traversal stack entries before overflow")
      ->capture_default_str();
  cmd->add_option("--heat-max", options->heat_max, "ops/pixel at the top of the heatmap scale (fixed so builders compare)")
      ->capture_default_str();
  cmd->add_option("--xfm-heat-max", options->xfm_heat_max,
                  "instance transforms per pixel at the top of xfm_heatmap.png (two-level trees)")
      ->capture_default_str();
  cmd->add_option("--out-dir", options->out_dir,
                  "write ops_heatmap.png, ao.png, shaded.png (and xfm_heatmap.png, --instanced) here");
  cmd->add_option("--rays-out", options->rays_out, "write every traced ray to this ray file");
  cmd->add_option("--rays-in", options->rays_in, "replay the rays of this ray file instead of a camera");
  cmd->add_option("--bvh", options->bvh_in, "trace this saved tree (rtsim build --out) instead of building one");
  cmd->add_flag("--json", options->json, "print JSON");
  cmd->add_option("--trace-ray", options->trace_ray,
                  "print every request of one ray through the one-unit hierarchy: X,Y[,TYPE[,INDEX]]\n"
                  "(as simulate --trace-ray; with --json under \"ray_trace\")")
      ->type_name("X,Y[,TYPE[,INDEX]]");
  cmd->add_flag("--validate", options->validate,
                "check every ray against Embree, an exact referee deciding\n"
                "disagreements; exit 1 if the core is wrong on any ray");
  cmd->callback([options] { run_trace(*options); });
}

}  // namespace rtsim::cli
