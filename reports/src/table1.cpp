#include <rtsim/builder/builder_registry.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/builder/metrics.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/stat_names.h>
#include <rtsim/reports/child_process.h>
#include <rtsim/reports/results_store.h>
#include <rtsim/reports/simulation_job.h>
#include <rtsim/reports/table1.h>
#include <rtsim/reports/text_table.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/progress.h>
#include <rtsim/workloads/scene_registry.h>

#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <mutex>
#include <thread>

namespace rtsim {

const std::array<PatentTable1Entry, 4>& patent_table1() {
  static const std::array<PatentTable1Entry, 4> table = {{{"BVH", 52.9, 44.9},
                                                          {"SBVH", 34.4, 36.4},
                                                          {"OSAH", 33.9, 36.1},
                                                          {"AO-BVH", 31.41, 30.80}}};
  return table;
}

const Table1Row* Table1::find(const std::string& camera, const std::string& builder) const {
  for (const Table1Row& row : rows)
    if (row.camera == camera && row.builder == builder) return &row;
  return nullptr;
}

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

Table1Counts counts_of(const CounterTotals& t) {
  Table1Counts c;
  c.rays = t.rays;
  c.ops_per_ray = t.per_ray(t.ops());
  c.trv_per_ray = t.per_ray(t.trv_ops);
  c.ist_per_ray = t.per_ray(t.ist_ops);
  c.node_fetches_per_ray = t.per_ray(t.node_fetches);
  c.box_tests_per_ray = t.per_ray(t.box_tests);
  c.tlas_trv_per_ray = t.per_ray(t.tlas_trv_ops);
  c.xfm_per_ray = t.per_ray(t.xfm_ops);
  return c;
}

// The mean of the seeds' counts per ray (the ray counts are the same in each).
Table1Counts mean_counts(const std::vector<Table1Counts>& seeds) {
  Table1Counts m = seeds.front();
  const double n = double(seeds.size());
  m.ops_per_ray = m.trv_per_ray = m.ist_per_ray = m.node_fetches_per_ray = m.box_tests_per_ray = 0;
  m.tlas_trv_per_ray = m.xfm_per_ray = 0;
  for (const Table1Counts& c : seeds) {
    m.ops_per_ray += c.ops_per_ray / n;
    m.trv_per_ray += c.trv_per_ray / n;
    m.ist_per_ray += c.ist_per_ray / n;
    m.node_fetches_per_ray += c.node_fetches_per_ray / n;
    m.box_tests_per_ray += c.box_tests_per_ray / n;
    m.tlas_trv_per_ray += c.tlas_trv_per_ray / n;
    m.xfm_per_ray += c.xfm_per_ray / n;
  }
  return m;
}

Interval ops_interval(const std::vector<Table1Counts>& seeds) {
  std::vector<double> ops;
  for (const Table1Counts& c : seeds) ops.push_back(c.ops_per_ray);
  return interval_of(ops);
}

// Trees that depend on the camera (OSAH's, RDH's from one camera) are built per
// camera; the others once per scene.
bool camera_dependent(const std::string& builder, BuildParams build) {
  build.builder = builder;
  return tree_depends_on_camera(build);
}
std::string tree_key(const std::string& builder, const std::string& camera, const BuildParams& build) {
  return camera_dependent(builder, build) ? builder + "-" + camera : builder;
}

// Every kind of data the ray type read from DRAM (nodes, prim refs, triangles, stack).
double dram_bytes_of_type(const nlohmann::json& stats, const char* type) {
  double sum = 0;
  const std::string prefix = std::string(sim::stat::kDramBytesByType) + "." + type + ".";
  for (const auto& [key, value] : flatten_stats(stats))
    if (key.compare(0, prefix.size(), prefix) == 0 && value > 0) sum += value;
  return sum;
}

void write_floats(const std::filesystem::path& path, const std::vector<float>& values) {
  write_file_atomic(path, [&](std::ostream& out) {
    out.write(reinterpret_cast<const char*>(values.data()), std::streamsize(values.size() * sizeof(float)));
  });
}

// Cycle-level runs: one `rtsim simulate` process each (SystemC elaborates once per process).
void run_cycle_level(Table1& table, const std::map<std::string, std::filesystem::path>& tree_files) {
  const Table1Options& o = table.options;
  std::vector<SimulationJob> jobs;
  std::vector<std::filesystem::path> logs;
  char res[32];
  std::snprintf(res, sizeof res, "%ux%u", o.width, o.height);
  for (Table1Row& row : table.rows) {
    SimulationJob job;
    job.scene = o.scene;
    job.builder = row.builder;
    job.bvh = tree_files.at(tree_key(row.builder, row.camera, o.build));
    job.camera = row.camera;
    job.fidelity = "cycle";
    job.config = o.hardware;
    job.node_format = o.node_format;
    job.resolution = res;
    job.ao_rays = o.ao_samples;
    if (o.diffuse_bounces > 0) job.diffuse_bounces = o.diffuse_bounces;
    job.opaque = o.opaque;
    job.instanced = o.instanced;
    job.seed = o.seed;
    job.frames = o.frames;
    job.out_dir = o.out_dir / "runs" / (row.camera + "-" + row.builder);
    jobs.push_back(job);
    logs.push_back(o.out_dir / "runs" / (row.camera + "-" + row.builder + ".log"));
  }
  const std::vector<SimulationOutcome> outcomes =
      JobRunner(o.rtsim_binary).simulate_all(jobs, logs, o.jobs, "table1: cycle level");
  for (size_t i = 0; i < jobs.size(); ++i) {
    const nlohmann::json& stats = outcomes[i].stats;
    Table1Row& row = table.rows[i];
    row.cycles = stat_value(stats, {"time", "cycles"});
    row.l1_node_hit_rate = stat_value(stats, {"l1_node", "all", "hit_rate"});
    row.l2_hit_rate = stat_value(stats, {"l2", "hit_rate"});
    row.primary.dram_bytes_per_ray = row.primary.rays ? dram_bytes_of_type(stats, "primary") / row.primary.rays : 0;
    row.ao.dram_bytes_per_ray = row.ao.rays ? dram_bytes_of_type(stats, "ao") / row.ao.rays : 0;
    row.combined.dram_bytes_per_ray = stat_value(stats, {"dram", "bytes_per_ray"});
    row.combined.pj_per_ray = stat_value(stats, {"energy", "pj_per_ray"});
    row.rays_per_joule = stat_value(stats, {"energy", "rays_per_joule"});
    if (row.primary.rays)
      row.primary.pj_per_ray = stat_value(stats, {"energy", "per_type", "primary", "pj_per_ray"});
    if (row.ao.rays) row.ao.pj_per_ray = stat_value(stats, {"energy", "per_type", "ao", "pj_per_ray"});
    if (row.diffuse.rays) {
      // All depths together: bytes summed, energy weighted by each depth's rays.
      double bytes = 0, pj = 0;
      for (uint32_t d = 1; d <= o.diffuse_bounces; ++d) {
        const char* type = ray_type_name(diffuse_ray_type(d));
        bytes += dram_bytes_of_type(stats, type);
        const double rays = stat_value(stats, {"per_type", type, "rays"});
        if (rays > 0) pj += rays * stat_value(stats, {"energy", "per_type", type, "pj_per_ray"});
      }
      row.diffuse.dram_bytes_per_ray = bytes / double(row.diffuse.rays);
      row.diffuse.pj_per_ray = pj / double(row.diffuse.rays);
    }
    row.cold_dram_bytes_per_ray = o.frames > 1 ? stat_value(stats, {"frames", "frame1", "dram_bytes_per_ray"})
                                               : row.combined.dram_bytes_per_ray;
    // The invariant of the model: the cycle level counts exactly what the functional level counts.
    const double trv = stat_value(stats, {"ops", "trv"}), ist = stat_value(stats, {"ops", "ist"});
    const double rays = stat_value(stats, {"rays", "total"});
    row.counts_match_cycle_level = uint64_t(rays) == row.combined.rays &&
                                   uint64_t(std::llround(trv)) == row.first_trv_ops &&
                                   uint64_t(std::llround(ist)) == row.first_ist_ops;
  }
}

// "12.3% fewer" / "4.5% more": the sign convention of the tables, in words.
std::string percent(double reduction) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.1f%% %s", 100.0 * std::fabs(reduction), reduction >= 0 ? "fewer" : "more");
  return buf;
}

std::string display(const std::string& builder) { return builder_info(builder).display_name; }

double reduction(double value, double baseline) { return baseline > 0 ? 1.0 - value / baseline : 0.0; }

// A row's ops/ray as an interval: its seed spread, or the point itself.
struct OpsRange {
  double mean, lo, hi;
};
OpsRange ops_range(const Table1Row& r) {
  const double m = r.combined.ops_per_ray;
  if (r.ops_combined.n < 2 || !std::isfinite(r.ops_combined.lo)) return {m, m, m};
  return {m, r.ops_combined.lo, r.ops_combined.hi};
}

void add_verdicts(Table1& table) {
  for (const std::string& camera : table.options.cameras)
    for (const char* reading : {"aobvh", "aosbvh"})
      for (const char* baseline_name : {"median", "sah"}) {
        const std::vector<Table1Relation> relations = patent_relations(table, camera, reading, baseline_name);
        if (relations.empty()) continue;
        std::vector<std::string> broken, unresolved;
        for (const Table1Relation& r : relations) {
          const std::string text = display(r.a) + " (" + format_number(table.find(camera, r.a)->combined.ops_per_ray) +
                                   ") < " + display(r.b) + " (" +
                                   format_number(table.find(camera, r.b)->combined.ops_per_ray) + ")";
          if (r.state == Table1Relation::State::Broken) broken.push_back(text);
          if (r.state == Table1Relation::State::Unresolved) unresolved.push_back(text);
        }
        const double b = table.find(camera, baseline_name)->combined.ops_per_ray;
        auto red = [&](const char* builder) { return percent(reduction(table.find(camera, builder)->combined.ops_per_ray, b)); };
        std::string sentence = camera + ", " + display(reading) + " against the " + display(baseline_name) + " (" +
                               format_number(b) + " ops/ray): SBVH " + red("sbvh") + ", OSAH " + red("osah") +
                               ", AO-BVH " + red(reading) + " ops/ray; ";
        if (broken.empty() && unresolved.empty()) {
          sentence += "the patent's ordering HOLDS (AO-BVH < OSAH, AO-BVH < SBVH, all three < BVH).";
        } else {
          if (!broken.empty()) {
            sentence += "the patent's ordering does NOT hold: not ";
            for (size_t i = 0; i < broken.size(); ++i) sentence += (i ? "; not " : "") + broken[i];
          } else {
            sentence += "the patent's ordering is not broken, but not resolved either";
          }
          if (!unresolved.empty()) {
            sentence += broken.empty() ? ": " : "; within the seed spread: ";
            for (size_t i = 0; i < unresolved.size(); ++i) sentence += (i ? "; " : "") + unresolved[i];
          }
          sentence += ".";
        }
        table.verdicts.push_back(sentence);
      }
}

}  // namespace

std::vector<Table1Relation> patent_relations(const Table1& table, const std::string& camera,
                                             const std::string& reading, const std::string& baseline) {
  const Table1Row* ao = table.find(camera, reading);
  const Table1Row* osah = table.find(camera, "osah");
  const Table1Row* sbvh = table.find(camera, "sbvh");
  const Table1Row* base = table.find(camera, baseline);
  if (!ao || !osah || !sbvh || !base) return {};
  std::vector<Table1Relation> out;
  auto relation = [&](const Table1Row& a, const Table1Row& b) {
    const OpsRange x = ops_range(a), y = ops_range(b);
    Table1Relation r;
    r.a = a.builder;
    r.b = b.builder;
    const bool points = x.lo == x.hi && y.lo == y.hi;
    r.state = x.hi < y.lo                ? Table1Relation::State::Holds
              : x.lo > y.hi || points     ? Table1Relation::State::Broken
                                          : Table1Relation::State::Unresolved;
    out.push_back(r);
  };
  relation(*ao, *osah);
  relation(*ao, *sbvh);
  for (const Table1Row* r : {sbvh, osah, ao}) relation(*r, *base);
  return out;
}

namespace {
Table1 run_table1_checked(const Table1Options& options);
}  // namespace

Table1 run_table1(const Table1Options& options) {
  // Everything that can be checked is checked before the first tree is built.
  if (options.cycle_level) {
    try {
      sim::load_hardware_config(options.hardware);
    } catch (const InputError& e) {
      throw InputError(std::string("--config: ") + e.what());
    }
  }
  // The folders this run creates go again if it fails, so a failed run leaves no
  // half-filled output behind (the result files are only written at the end).
  std::vector<std::filesystem::path> created;
  for (const char* sub : {"trees", "data", "runs"})
    if (!path_exists(options.out_dir / sub)) created.push_back(options.out_dir / sub);
  try {
    return run_table1_checked(options);
  } catch (...) {
    std::error_code ec;
    for (const auto& folder : created) std::filesystem::remove_all(folder, ec);
    throw;
  }
}

namespace {
Table1 run_table1_checked(const Table1Options& options) {
  Table1 table;
  table.options = options;
  const auto total_start = std::chrono::steady_clock::now();
  Scene scene = load_scene(options.scene, options.instanced ? SceneForm::Instanced : SceneForm::Flat);
  if (options.instanced && !scene.instanced())
    throw InputError("--instanced", "scene '" + scene.name + "' has no instances (it is flat)");
  const size_t alpha_tested = scene.alpha_tested_triangles();
  if (options.opaque) scene.make_opaque();
  for (const std::string& camera : options.cameras) scene.camera(camera);  // InputError if absent
  for (const std::string& b : options.builders) builder_info(b, "--builders");
  // Two-level trees: builders that build no BLAS are left out, and the table says so.
  std::vector<std::string> builders, left_out;
  for (const std::string& b : options.builders)
    (!options.instanced || builder_info(b).builds_blas ? builders : left_out).push_back(b);
  if (builders.empty())
    throw InputError("--builders", "none of them builds the BLASes of an instanced scene's two-level tree");
  table.options.builders = builders;
  table.scene_name = scene.name;
  table.triangles = scene.triangle_count();
  if (scene.instanced()) table.instances = scene.instances.size(), table.placed_triangles = scene.instanced_triangle_count();

  EffectSettings settings;
  settings.width = options.width;
  settings.height = options.height;
  settings.seed = options.seed;
  settings.ao_samples = options.ao_samples;
  settings.diffuse_bounces = options.diffuse_bounces;
  const EffectPlan plan = plan_effects(scene, settings);
  table.ao_samples = plan.on(RayType::Ao) ? plan.ao_samples : 0;
  table.ao_length = plan.ao_length;
  table.options.ao_samples = int(table.ao_samples);  // the cycle-level runs get the resolved value

  // Trees: every builder once, the camera-dependent ones (OSAH, RDH) once per camera,
  // the sampled ones once per seed. The first seed's tree is saved, so that the
  // cycle-level runs replay exactly that tree; the others are traced and dropped.
  std::map<std::string, std::filesystem::path> tree_files;
  std::filesystem::create_directories(options.out_dir / "trees");
  std::filesystem::create_directories(options.out_dir / "data");
  const BuilderParameter& seed_parameter = *find_builder_parameter("seed");
  auto seeds_of = [&](const std::string& builder) {
    return parameter_used_by(seed_parameter, builder) ? std::max<uint32_t>(1, options.build_seeds) : 1u;
  };
  // (builder, camera the tree is built for, cameras it is traced from)
  struct TreeJob {
    std::string builder, camera;
    std::vector<std::string> traced;
  };
  std::vector<TreeJob> tree_jobs;
  size_t builds = 0;
  for (const std::string& b : builders) {
    if (camera_dependent(b, options.build))
      for (const std::string& c : options.cameras) tree_jobs.push_back({b, c, {c}});
    else
      tree_jobs.push_back({b, options.cameras.front(), options.cameras});
    builds += seeds_of(b) * (camera_dependent(b, options.build) ? options.cameras.size() : 1);
  }
  struct Traced {
    Table1Row row;
    std::vector<Table1Counts> combined, primary, ao, diffuse;  // one per seed
  };
  std::map<std::pair<std::string, std::string>, Traced> traced;  // (camera, builder)
  {
    Progress progress("table1: building and tracing trees", builds, "trees");
    for (const TreeJob& job : tree_jobs) {
      for (uint32_t k = 0; k < seeds_of(job.builder); ++k) {
        BuildParams params = options.build;
        params.builder = job.builder;
        params.camera = job.camera;
        params.seed = options.build.seed + k;
        apply_node_format(params, node_format(options.node_format));
        BuildReport report;
        const Bvh bvh = build_bvh(scene, params, &report);
        MemoryLayoutConfig layout;
        layout.node_format = options.node_format;
        const MemoryImage image(scene, bvh, layout);
        const TraversalContext context(scene, bvh, image);
        if (k == 0) {
          const std::string key = tree_key(job.builder, job.camera, options.build);
          tree_files[key] = options.out_dir / "trees" / (key + ".bvh");
          save_bvh(tree_files[key], bvh, scene, params);
        }
        for (const std::string& camera_name : job.traced) {
          const FrameRun run = run_frame(context, scene.camera(camera_name), settings);
          Traced& t = traced[{camera_name, job.builder}];
          t.combined.push_back(counts_of(run.total));
          t.primary.push_back(counts_of(run.per_type[ray_type_index(RayType::Primary)]));
          t.ao.push_back(counts_of(run.per_type[ray_type_index(RayType::Ao)]));
          CounterTotals diffuse;
          for (uint32_t d = 1; d <= options.diffuse_bounces; ++d)
            diffuse.add(run.per_type[ray_type_index(diffuse_ray_type(d))]);
          t.diffuse.push_back(counts_of(diffuse));
          if (k != 0) continue;
          Table1Row& row = t.row;
          row.camera = camera_name;
          row.builder = job.builder;
          row.first_trv_ops = run.total.trv_ops;
          row.first_ist_ops = run.total.ist_ops;
          row.build_seconds = report.build_seconds;
          row.estimate_seconds = report.estimate_seconds;
          row.sah_cost = bvh.two_level() ? two_level_sah_cost(bvh, scene, params.t1, params.t2)
                                         : sah_cost(bvh, params.t1, params.t2);
          row.nodes = bvh.nodes.size();
          row.node_bytes_per_triangle =
              double(image.footprint().node_bytes) / double(std::max<size_t>(1, scene.triangle_count()));
          write_floats(options.out_dir / "data" / ("ops_" + camera_name + "_" + job.builder + ".f32"),
                       ops_per_pixel(run));
        }
        progress.advance();
      }
    }
  }
  for (const std::string& camera_name : options.cameras)
    for (const std::string& builder : builders) {
      Traced& t = traced.at({camera_name, builder});
      Table1Row row = t.row;
      row.seeds = uint32_t(t.combined.size());
      row.combined = mean_counts(t.combined);
      row.primary = mean_counts(t.primary);
      row.ao = mean_counts(t.ao);
      row.diffuse = mean_counts(t.diffuse);
      row.ops_combined = ops_interval(t.combined);
      row.ops_primary = ops_interval(t.primary);
      row.ops_ao = ops_interval(t.ao);
      row.ops_diffuse = ops_interval(t.diffuse);
      table.rows.push_back(row);
    }
  if (options.cycle_level) run_cycle_level(table, tree_files);
  add_verdicts(table);

  const NodeFormat& format = node_format(options.node_format);
  char node_rule[512];
  if (format.encoding == BoxEncoding::OwnBoxFp32)
    std::snprintf(node_rule, sizeof node_rule,
                  "TRV op = one ray processing one node of a binary tree in format %s (fetch its "
                  "%u-byte record holding its own box, 1 box test, stack update)",
                  format.name.c_str(), format.record_bytes);
  else
    std::snprintf(node_rule, sizeof node_rule,
                  "TRV op = one ray processing one node of format %s (fetch its %u-byte record "
                  "holding up to %u child boxes, test all of them, stack update), whatever its "
                  "width: box tests per ray are shown beside it to compare widths%s",
                  format.name.c_str(), format.record_bytes, format.width,
                  format.width > 2 ? " (the builders' binary trees collapsed to this width with "
                                     "their own cost model; embree built wide by Embree)"
                                   : "");
  char rule[2560];
  std::snprintf(rule, sizeof rule,
                "%s; IST op = one ray-triangle test "
                "(watertight); ops/ray = (TRV + IST ops) / rays. Rays: %ux%u primary rays (1 per "
                "pixel, closest hit) per camera, plus %u AO rays per primary hit (cosine-weighted, "
                "any hit, length %.4g = %.3g x scene diagonal). Node fetch = one node record read by "
                "TRV before any cache. Max leaf size %u, T1 = %g, T2 = %g, %u SAH bins, AO-BVH K = %u "
                "rays per estimate shared by up to %u triangles, weight floor %g; OSAH (the authors' rules) "
                "w = %g, visibility from %ux%u primary rays and %u AO rays per hit. Sampled builders "
                "(their rays drawn from the builder seed) are built with %u seeds from %llu on: their "
                "ops/ray are the means with a 95%% Student-t interval (n = %u); their DRAM bytes, cycles "
                "and heatmaps are the first seed's tree's. %s%s %.1f s in all.",
                node_rule, options.width, options.height, table.ao_samples, table.ao_length,
                scene.ao.cutoff_relative, std::min(options.build.max_leaf_size, format.max_leaf_triangles), options.build.t1,
                options.build.t2, options.build.bins, options.build.ao_rays, options.build.ao_share,
                options.build.ao_weight_floor, options.build.osah_w, options.build.osah_width,
                options.build.osah_height, options.build.osah_ao_rays, options.build_seeds,
                static_cast<unsigned long long>(options.build.seed), options.build_seeds,
                table1_cycle_runs_text(options).c_str(),
                options.cycle_level && options.frames > 1
                    ? " DRAM B/ray shown as the first frame's (cold caches) / the last's (steady state)."
                    : "",
                seconds_since(total_start));
  table.counting_rule = rule;
  if (options.diffuse_bounces > 0)
    table.counting_rule += " Diffuse paths: " + std::to_string(options.diffuse_bounces) +
                           " cosine-weighted closest-hit bounces per primary hit (seeded by pixel and depth), "
                           "counted in ops/ray and the DRAM figures, and as one 'diffuse ops/ray' column "
                           "over all depths; the patent's Table 1 has none.";
  if (options.instanced) {
    table.counting_rule += " Instanced (--instanced): " + std::to_string(scene.instances.size()) +
                           " instances of " + std::to_string(scene.meshes.size()) +
                           " meshes, two-level trees (a BLAS per mesh by the builder, a TLAS over the instances by "
                           "SAH, AO-BVH's weighted by the instances' mean occlusion); TRV counts TLAS and BLAS "
                           "node visits (JSON: tlas_trv_ops_per_ray), and the instance transforms "
                           "(xfm_ops_per_ray, one per instance entered) are neither TRV nor IST ops.";
    if (!left_out.empty()) {
      std::string names;
      for (const std::string& b : left_out) names += (names.empty() ? "" : ", ") + b;
      table.counting_rule += " Left out: " + names + " (builds no BLAS: its sample rays are world-space).";
    }
  }
  if (alpha_tested > 0)
    table.counting_rule +=
        options.opaque ? " Alpha testing off (--opaque): the scene's " + std::to_string(alpha_tested) +
                             " alpha-tested triangles are opaque, trees built for that."
                       : " Alpha testing on: hits on the scene's " + std::to_string(alpha_tested) +
                             " alpha-tested triangles run an any-hit test (a UV and a texel read); "
                             "those tests are neither TRV nor IST ops (stats anyhit.*).";
  return table;
}

}  // namespace

}  // namespace rtsim
