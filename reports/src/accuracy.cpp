// The measurements of `rtsim accuracy`: four sections, each timing one accuracy knob
// against the error it causes relative to the most exact setting of that knob.
#include <rtsim/builder/build.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/builder/metrics.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/reports/child_process.h>
#include <rtsim/reports/accuracy.h>
#include <rtsim/reports/simulation_job.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/progress.h>
#include <rtsim/workloads/scene_registry.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <time.h>

namespace rtsim {

AccuracyOptions quick_accuracy_options(AccuracyOptions base) {
  base.quick = true;
  base.fidelity_resolutions = {32};
  base.knob_resolution = 48;
  base.ao_rays_per_primitive = {1, 4, 16, 64};
  base.ao_rays_reference = 256;
  base.ao_shares = {1, 16};
  base.sbvh_alphas = {1e-3f, 1e-5f};
  base.ao_image_resolution = 48;
  base.ao_samples = {1, 4, 16, 64};
  base.ao_samples_reference = 256;
  base.resolutions = {16, 32, 64, 128};
  base.seeds = {1, 2};
  base.traffic_resolutions = {32, 64};
  base.traffic_frames = 2;
  base.traffic_cycle_resolution = 32;
  return base;
}

namespace {
bool within(double value, double reference, double tolerance, double floor) {
  return std::fabs(value - reference) <= std::max(tolerance * std::fabs(reference), floor);
}
}  // namespace

TrafficVerdict judge_traffic(const std::string& scene, const std::vector<TrafficPoint>& points,
                             const AccuracyOptions& o) {
  TrafficVerdict v;
  v.scene = scene;
  std::vector<const TrafficPoint*> functional, cycle;
  for (const TrafficPoint& p : points)
    if (p.scene == scene) (p.level == "cycle" ? cycle : functional).push_back(&p);
  const auto by_resolution = [](const TrafficPoint* a, const TrafficPoint* b) { return a->resolution < b->resolution; };
  std::sort(functional.begin(), functional.end(), by_resolution);
  std::sort(cycle.begin(), cycle.end(), by_resolution);
  // Frames: the first frame count whose last frame is within tolerance of the last
  // measured one, in DRAM bytes and cycles, at every resolution.
  uint32_t needed = 1;
  for (const TrafficPoint* p : functional) {
    const auto& d = p->dram_bytes_per_ray;
    uint32_t f = uint32_t(d.size());
    while (f > 1 && within(d[f - 2], d.back(), o.traffic_tolerance, o.traffic_floor_bytes)) --f;
    needed = std::max(needed, f);
  }
  for (const TrafficPoint* p : cycle) {
    const auto& c = p->cycles_per_ray;
    uint32_t f = uint32_t(c.size());
    while (f > 1 && within(c[f - 2], c.back(), o.traffic_tolerance, 0.0)) --f;
    needed = std::max(needed, f);
  }
  v.frames_needed = needed;
  v.frames_confirmed = needed < o.traffic_frames;
  // Resolution: the steady state against the highest resolution measured.
  if (!functional.empty()) {
    const TrafficPoint& top = *functional.back();
    v.cold_bytes_per_ray = top.dram_bytes_per_ray.front();
    v.steady_bytes_per_ray = top.dram_bytes_per_ray.back();
    for (size_t i = functional.size(); i-- > 0;) {
      if (!within(functional[i]->dram_bytes_per_ray.back(), v.steady_bytes_per_ray, o.traffic_tolerance,
                  o.traffic_floor_bytes))
        break;
      v.resolution_needed = functional[i]->resolution;
    }
    v.resolution_converged = functional.size() >= 2 && v.resolution_needed < top.resolution;
    if (!v.resolution_converged) v.resolution_needed = 0;
  }
  if (!cycle.empty()) v.cycles_per_ray = cycle.back()->cycles_per_ray.back();
  char buf[640];
  const uint32_t top_res = functional.empty() ? 0 : functional.back()->resolution;
  std::snprintf(buf, sizeof buf,
                "%s: at %ux%u the first (cold) frame reads %.3g DRAM B/ray, the steady state %.3g (%s); "
                "%s frame%s the steady state within %.0f%% (or %.2g B/ray)%s; %s",
                scene.c_str(), top_res, top_res, v.cold_bytes_per_ray, v.steady_bytes_per_ray,
                v.steady_bytes_per_ray < 0.5 * v.cold_bytes_per_ray
                    ? "the working set stays in the caches: cold traffic is the footprint the frame touches"
                    : "the working set exceeds the caches: warm frames miss as much as the first",
                std::to_string(needed).c_str(), needed == 1 ? " is already at" : "s reach", 100 * o.traffic_tolerance,
                o.traffic_floor_bytes, v.frames_confirmed ? "" : " (at least: the last frame measured was needed)",
                v.resolution_converged
                    ? ("steady-state DRAM B/ray is within tolerance of the " + std::to_string(top_res) + "x" +
                       std::to_string(top_res) + " value from " + std::to_string(v.resolution_needed) + "x" +
                       std::to_string(v.resolution_needed) + " on.")
                          .c_str()
                    : "DRAM B/ray still changes with resolution at the highest one measured: measure at "
                      "the resolution the study targets.");
  v.summary = buf;
  // Whether the traffic is the frame's footprint streamed once (bytes per frame
  // nearly flat as rays grow) or capacity misses (bytes growing with the rays).
  if (functional.size() >= 2) {
    const TrafficPoint &hi = *functional.back(), &lo = *functional[functional.size() - 2];
    const double bytes_hi = hi.dram_bytes_per_ray.back() * double(hi.rays);
    const double bytes_lo = lo.dram_bytes_per_ray.back() * double(lo.rays);
    if (bytes_lo > 0 && bytes_hi > 0 && hi.rays > lo.rays) {
      const double growth = std::log(bytes_hi / bytes_lo) / std::log(double(hi.rays) / double(lo.rays));
      std::snprintf(buf, sizeof buf,
                    " Steady-state DRAM bytes per frame grow as rays^%.2f between %ux%u and %ux%u (%.3g -> "
                    "%.3g MB)%s.",
                    growth, lo.resolution, lo.resolution, hi.resolution, hi.resolution, bytes_lo / 1e6,
                    bytes_hi / 1e6,
                    growth < 0.3 ? ": the frame streams its footprint about once, so per-ray traffic is "
                                   "footprint / rays and builders compare by bytes per frame"
                                 : ": capacity misses, which denser rays share less than proportionally");
      v.summary += buf;
    }
  }
  if (cycle.size() >= 2) {
    const TrafficPoint &hi = *cycle.back(), &lo = *cycle[cycle.size() - 2];
    std::snprintf(buf, sizeof buf, " Cycles per ray: %.3g at %ux%u, %.3g at %ux%u.", lo.cycles_per_ray.back(),
                  lo.resolution, lo.resolution, hi.cycles_per_ray.back(), hi.resolution, hi.resolution);
    v.summary += buf;
  }
  return v;
}

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Process CPU time (all threads): wall time on a machine shared by several jobs
// measures the load as much as the work.
double cpu_now() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

double relative(double value, double reference) {
  return reference != 0 ? (value - reference) / reference : (value == 0 ? 0.0 : HUGE_VAL);
}


EffectSettings frame_settings(uint32_t resolution, uint64_t seed, int ao_samples) {
  EffectSettings s;
  s.width = s.height = resolution;
  s.seed = seed;
  s.ao_samples = ao_samples;
  return s;
}

struct Frame {
  FrameRun run;
  double seconds = 0, cpu_seconds = 0;
};

Frame trace_frame(const Scene& scene, const Bvh& bvh, const Camera& camera,
                  const EffectSettings& settings) {
  const MemoryImage image(scene, bvh);
  const TraversalContext context(scene, bvh, image);
  Frame frame;
  const auto start = Clock::now();
  const double cpu_start = cpu_now();
  frame.run = run_frame(context, camera, settings);
  frame.cpu_seconds = cpu_now() - cpu_start;
  frame.seconds = seconds_since(start);
  return frame;
}

double ops_per_ray(const FrameRun& run) { return run.total.per_ray(run.total.ops()); }

// The builder hands back its weights, not the occlusion values; they are an affine
// function of the clamped values (occlusion_weights): w = (f + (1 - f) v) / m with
// m = f + (1 - f) * mean_occlusion, so v = (w m - f) / (1 - f), exact to float rounding.
std::vector<float> occlusion_values_of(const BuildReport& report, float floor) {
  if (!(floor < 1.0f)) throw std::logic_error("accuracy: AO weight floor 1 carries no occlusion values");
  const double mean_weight = floor + (1.0 - floor) * report.mean_occlusion;
  std::vector<float> values(report.weights.size());
  for (size_t i = 0; i < values.size(); ++i)
    values[i] = float(std::min(1.0, std::max(0.0, (report.weights[i] * mean_weight - floor) / (1.0 - floor))));
  return values;
}

double rmse(const std::vector<float>& a, const std::vector<float>& b, double* max_error = nullptr) {
  double sum = 0, worst = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const double d = double(a[i]) - double(b[i]);
    sum += d * d;
    worst = std::max(worst, std::fabs(d));
  }
  if (max_error) *max_error = worst;
  return a.empty() ? 0.0 : std::sqrt(sum / double(a.size()));
}

std::string alpha_label(float alpha) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "alpha=%g", double(alpha));
  return buf;
}

const Camera& pick_camera(const Scene& scene, const std::string& name) {
  if (scene.cameras.empty()) throw InputError("scene '" + scene.name + "'", "has no cameras");
  return name.empty() ? scene.cameras.front() : scene.camera(name);  // InputError if absent
}

class AccuracyRun {
 public:
  explicit AccuracyRun(const AccuracyOptions& options)
      : o_(options), runner_(options.rtsim_binary),
        hardware_node_format_(sim::load_hardware_config(options.hardware).node_format),
        scene_(load_scene(options.scene)),
        camera_(pick_camera(scene_, options.camera)) {
    validate();
    report_.options = options;
    report_.scene_name = scene_.name;
    report_.camera = camera_.name;
    report_.triangles = scene_.triangle_count();
    const EffectPlan plan = plan_effects(scene_, frame_settings(8, o_.seed, -1));
    report_.scene_ao_samples = plan.on(RayType::Ao) ? plan.ao_samples : 0;
    report_.ao_length = plan.ao_length;
  }

  AccuracyReport run() {
    const auto start = Clock::now();
    std::filesystem::create_directories(o_.out_dir);
    builder_knobs();  // first: it builds the tree the other sections reuse
    fidelity_levels();
    ao_samples();
    resolution_stability();
    memory_traffic();
    report_.recommendations = recommend(report_);
    report_.total_seconds = seconds_since(start);
    return report_;
  }

 private:
  void validate() const {
    auto check_resolutions = [](const std::vector<uint32_t>& list, const char* field) {
      if (list.empty()) throw InputError(field, "needs at least one value");
      for (uint32_t r : list)
        if (r == 0 || r > 4096) throw InputError(field, "resolutions must be 1..4096");
    };
    check_resolutions(o_.fidelity_resolutions, "fidelity_resolutions");
    check_resolutions(o_.traffic_resolutions, "--traffic-res");
    if (o_.traffic_frames < 2 || o_.traffic_frames > 16)
      throw InputError("--traffic-frames", "must be 2..16 (the first frame is the cold one)");
    for (const std::string& s : o_.traffic_scenes) load_scene(s);  // an unknown scene fails now
    for (const std::string& s : o_.fidelity_scenes) load_scene(s);
    check_resolutions(o_.resolutions, "resolutions");
    check_resolutions({o_.knob_resolution, o_.ao_image_resolution}, "resolution");
    for (uint32_t k : o_.ao_rays_per_primitive)
      if (k == 0 || k >= o_.ao_rays_reference)
        throw InputError("ao_rays_per_primitive", "each K must be 1..reference-1");
    for (uint32_t g : o_.ao_shares)
      if (g == 0) throw InputError("ao_shares", "each share must be at least 1 triangle");
    for (uint32_t n : o_.ao_samples)
      if (n == 0 || n >= o_.ao_samples_reference)
        throw InputError("ao_samples", "each count must be 1..reference-1");
    if (o_.seeds.empty()) throw InputError("seeds", "needs at least one seed");
    if (!(o_.tolerance > 0) || !(o_.fidelity_tolerance > 0) || !(o_.image_rmse_target > 0))
      throw InputError("tolerance", "must be > 0");
    // Bad hardware input must fail here, naming the cause, not as a failed child run later.
    sim::load_hardware_config(o_.hardware);
    bool known = false;
    for (const std::string& b : builder_names()) known |= b == o_.builder;
    if (!known) throw InputError("--builder", "unknown builder '" + o_.builder + "'");
  }

  BuildParams base_params() const {
    BuildParams p;
    p.seed = o_.seed;
    p.camera = camera_.name;
    return p;
  }

  // ops/ray of a tree on the knob frame (the scene's AO setting).
  double knob_ops(const Bvh& bvh) const {
    return ops_per_ray(trace_frame(scene_, bvh, camera_, frame_settings(o_.knob_resolution, o_.seed, -1)).run);
  }

  KnobPoint build_point(const std::string& family, const std::string& label, double value,
                        const BuildParams& params, Bvh* keep = nullptr, BuildReport* keep_report = nullptr) {
    BuildReport report;
    const double cpu_start = cpu_now();
    Bvh bvh = build_bvh(scene_, params, &report);
    const double cpu_seconds = cpu_now() - cpu_start;
    KnobPoint p;
    p.cpu_seconds = cpu_seconds;
    p.family = family;
    p.label = label;
    p.value = value;
    p.estimate_seconds = report.estimate_seconds;
    p.build_seconds = report.build_seconds;
    p.sah_cost = sah_cost(bvh, params.t1, params.t2);
    p.references = bvh.prim_refs.size();
    p.ops_per_ray = knob_ops(bvh);
    if (keep) *keep = std::move(bvh);
    if (keep_report) *keep_report = std::move(report);
    return p;
  }

  static void relative_to_reference(std::vector<KnobPoint>& points) {
    const KnobPoint* ref = nullptr;
    for (const KnobPoint& p : points)
      if (p.reference) ref = &p;
    if (!ref) return;
    const double base = ref->ops_per_ray;
    for (KnobPoint& p : points) p.ops_error = relative(p.ops_per_ray, base);
  }

  void builder_knobs() {
    const size_t steps = o_.ao_rays_per_primitive.size() + 1 + o_.ao_shares.size() + o_.sah_bins.size() +
                         o_.sbvh_alphas.size() + 1;
    Progress progress("accuracy: builder knobs", steps, "trees");
    const BuildParams defaults = base_params();

    // AO rays per primitive (no sharing): the reference K first, its values are what
    // the others approach.
    std::vector<KnobPoint> k_points;
    std::vector<uint32_t> ks = o_.ao_rays_per_primitive;
    ks.push_back(o_.ao_rays_reference);
    std::vector<std::pair<std::vector<float>, std::vector<float>>> per_k(ks.size());
    auto keep_if_default = [&](const BuildParams& p, Bvh* bvh) {
      if (o_.builder == "aobvh" && p.ao_rays == defaults.ao_rays && p.ao_share == defaults.ao_share)
        main_tree_ = std::make_unique<Bvh>(std::move(*bvh));
    };
    for (size_t i = ks.size(); i-- > 0;) {
      BuildParams p = defaults;
      p.builder = "aobvh";
      p.ao_rays = ks[i];
      p.ao_share = 1;
      Bvh bvh;
      BuildReport br;
      KnobPoint point = build_point("ao_rays", "K=" + std::to_string(ks[i]), ks[i], p, &bvh, &br);
      point.reference = i + 1 == ks.size();
      per_k[i] = {occlusion_values_of(br, p.ao_weight_floor), br.weights};
      keep_if_default(p, &bvh);
      k_points.insert(k_points.begin(), point);
      progress.advance();
    }
    const std::vector<float>& ref_values = per_k.back().first;
    const std::vector<float>& ref_weights = per_k.back().second;
    for (size_t i = 0; i < ks.size(); ++i) {
      k_points[i].occlusion_rmse = rmse(per_k[i].first, ref_values, &k_points[i].occlusion_max_error);
      k_points[i].weight_rmse = rmse(per_k[i].second, ref_weights);
    }
    relative_to_reference(k_points);

    // Shared estimates at the default K, against the same reference (K rays per triangle).
    std::vector<KnobPoint> share_points;
    for (uint32_t g : o_.ao_shares) {
      BuildParams p = defaults;
      p.builder = "aobvh";
      p.ao_share = g;
      Bvh bvh;
      BuildReport br;
      KnobPoint point = build_point("ao_share", "G=" + std::to_string(g) + " (K=" + std::to_string(p.ao_rays) + ")",
                                    g, p, &bvh, &br);
      point.occlusion_rmse = rmse(occlusion_values_of(br, p.ao_weight_floor), ref_values, &point.occlusion_max_error);
      point.weight_rmse = rmse(br.weights, ref_weights);
      point.ops_error = relative(point.ops_per_ray, k_points.back().ops_per_ray);
      keep_if_default(p, &bvh);
      share_points.push_back(point);
      progress.advance();
    }

    // Binned vs full-sweep SAH: the full sweep is the exact (reference) one.
    std::vector<KnobPoint> bin_points;
    for (uint32_t bins : o_.sah_bins) {
      BuildParams p = defaults;
      p.builder = "sah";
      p.bins = bins;
      KnobPoint point = build_point("sah_bins", bins ? "bins=" + std::to_string(bins) : "full sweep", bins, p);
      point.reference = bins == 0;
      bin_points.push_back(point);
      progress.advance();
    }
    relative_to_reference(bin_points);

    // SBVH alpha: the smallest alpha allows the most spatial splits (reference).
    std::vector<KnobPoint> alpha_points;
    float smallest = o_.sbvh_alphas.empty() ? 0.0f : *std::min_element(o_.sbvh_alphas.begin(), o_.sbvh_alphas.end());
    for (float alpha : o_.sbvh_alphas) {
      BuildParams p = defaults;
      p.builder = "sbvh";
      p.sbvh_alpha = alpha;
      KnobPoint point = build_point("sbvh_alpha", alpha_label(alpha), alpha, p);
      point.reference = alpha == smallest;
      alpha_points.push_back(point);
      progress.advance();
    }
    relative_to_reference(alpha_points);

    // The tree of the other sections: the builder's defaults (reused from above if built).
    if (!main_tree_) {
      BuildParams p = defaults;
      p.builder = o_.builder;
      main_tree_ = std::make_unique<Bvh>(build_bvh(scene_, p));
      main_params_ = p;
    } else {
      main_params_ = defaults;
      main_params_.builder = "aobvh";
    }
    progress.advance();
    for (auto* list : {&k_points, &share_points, &bin_points, &alpha_points})
      report_.knobs.insert(report_.knobs.end(), list->begin(), list->end());
  }

  // The report's scene, then (unless quick or named) the fetched memory-bound scenes.
  std::vector<std::string> fidelity_scenes() const {
    if (!o_.fidelity_scenes.empty()) return o_.fidelity_scenes;
    std::vector<std::string> scenes = {o_.scene};
    if (o_.quick) return scenes;
    for (const char* s : {"dragon", "black_forest"})
      if (s != scene_.name && std::filesystem::exists(scene_cache_dir() / s / "scene.toml")) scenes.push_back(s);
    return scenes;
  }

  void fidelity_levels() {
    const std::filesystem::path tree_file = o_.out_dir / "runs" / "tree.bvh";
    std::filesystem::create_directories(o_.out_dir / "runs");
    save_bvh(tree_file, *main_tree_, scene_, main_params_);
    const char* levels[] = {"functional", "lt", "cycle"};
    const std::vector<std::string> scenes = fidelity_scenes();
    Progress progress("accuracy: fidelity levels", scenes.size() * o_.fidelity_resolutions.size() * 3, "runs");
    for (const std::string& scene : scenes) {
      // The report's scene replays its tree on its camera; another is built by the
      // simulate run itself (same builder) and seen from its default camera.
      const bool main_scene = scene == o_.scene;
      const std::string scene_name = main_scene ? scene_.name : std::filesystem::path(scene).filename().string();
      for (uint32_t res : o_.fidelity_resolutions) {
        std::vector<FidelityPoint> points;
        std::vector<nlohmann::json> stats;
        for (const char* level : levels) {
          const std::string name = (main_scene ? "" : scene_name + "-") + std::string(level) + "-" + std::to_string(res);
          const std::filesystem::path dir = o_.out_dir / "runs" / name;
          SimulationJob job;
          job.scene = scene;
          if (main_scene) {
            job.bvh = tree_file;
            job.camera = camera_.name;
            job.ao_rays = int(report_.scene_ao_samples);
          } else {
            job.builder = o_.builder;
          }
          job.fidelity = level;
          job.config = o_.hardware;
          job.resolution = std::to_string(res) + "x" + std::to_string(res);
          job.seed = o_.seed;
          job.out_dir = dir;
          const SimulationOutcome run = runner_.simulate(job, o_.out_dir / "runs" / (name + ".log"));
          FidelityPoint p;
          p.scene = scene_name;
          p.process_seconds = run.process_seconds;
          p.level = level;
          p.resolution = res;
          const nlohmann::json &s = run.stats, &host = run.host;
          p.rays = uint64_t(stat_value(s, {"rays", "total"}));
          p.cycles = stat_value(s, {"time", "cycles"});
          p.dram_bytes = stat_value(s, {"dram", "bytes"});
          p.ops_per_ray = stat_value(s, {"ops", "per_ray"});
          p.host_seconds = stat_value(host, {"host_seconds"});
          p.cpu_seconds = stat_value(host, {"cpu_seconds"});
          p.rays_per_host_second = stat_value(host, {"rays_per_host_second"});
          p.rays_per_cpu_second = stat_value(host, {"rays_per_cpu_second"});
          points.push_back(p);
          stats.push_back(s);
          progress.advance();
        }
        const FidelityPoint& cycle = points.back();
        const nlohmann::json& cs = stats.back();
        for (size_t i = 0; i < points.size(); ++i) {
          points[i].cycle_error = relative(points[i].cycles, cycle.cycles);
          points[i].dram_error = relative(points[i].dram_bytes, cycle.dram_bytes);
          // The model's invariant: one functional core, so the counts agree at every level.
          points[i].counts_match_cycle = stat_value(stats[i], {"ops", "trv"}) == stat_value(cs, {"ops", "trv"}) &&
                                         stat_value(stats[i], {"ops", "ist"}) == stat_value(cs, {"ops", "ist"}) &&
                                         points[i].rays == cycle.rays;
        }
        report_.fidelity.insert(report_.fidelity.end(), points.begin(), points.end());
      }
    }
  }

  // AO image error over the pixels whose primary ray hit (the others are black in every image).
  static std::vector<uint8_t> hit_mask(const FrameRun& run) {
    std::vector<uint8_t> mask(size_t(run.width) * run.height, 0);
    for (size_t i = 0; i < run.rays.size(); ++i)
      if (run.rays[i].type == RayType::Primary && run.rays[i].pixel < mask.size() && run.results[i].hit.hit())
        mask[run.rays[i].pixel] = 1;
    return mask;
  }

  void ao_samples() {
    Progress progress("accuracy: AO rays per pixel", o_.ao_samples.size() + 1, "frames");
    std::vector<uint32_t> counts = o_.ao_samples;
    counts.push_back(o_.ao_samples_reference);
    std::vector<float> reference;
    std::vector<uint8_t> mask;
    std::vector<AoSamplesPoint> points(counts.size());
    // Reference first. AO rays are keyed by (seed, pixel, sample, bounce, k), so the
    // first n rays of every pixel are the same at every count: the error measured is
    // how far n rays are from what the reference image shows (nested estimates).
    for (size_t i = counts.size(); i-- > 0;) {
      Frame f = trace_frame(scene_, *main_tree_, camera_,
                            frame_settings(o_.ao_image_resolution, o_.seed, int(counts[i])));
      const Image image = ao_image(f.run);
      std::vector<float> grey(image.pixels.size());
      for (size_t p = 0; p < grey.size(); ++p) grey[p] = image.pixels[p].x;
      AoSamplesPoint& point = points[i];
      point.samples = counts[i];
      point.reference = i + 1 == counts.size();
      point.rays = f.run.total.rays;
      point.seconds = f.seconds;
      point.cpu_seconds = f.cpu_seconds;
      point.ops_per_ray = ops_per_ray(f.run);
      const CounterTotals& ao = f.run.per_type[ray_type_index(RayType::Ao)];
      point.ao_ops_per_ray = ao.per_ray(ao.ops());
      if (point.reference) {
        reference = grey;
        mask = hit_mask(f.run);
        write_image_data("ao_reference.f32", grey);
      } else {
        double sum = 0;
        size_t n = 0;
        for (size_t p = 0; p < grey.size(); ++p)
          if (mask[p]) sum += double(grey[p] - reference[p]) * double(grey[p] - reference[p]), ++n;
        point.image_rmse = n ? std::sqrt(sum / double(n)) : 0.0;
        write_image_data("ao_" + std::to_string(counts[i]) + ".f32", grey);
      }
      progress.advance();
    }
    report_.ao = points;
  }

  void write_image_data(const std::string& name, const std::vector<float>& values) const {
    std::filesystem::create_directories(o_.out_dir / "data");
    write_file_atomic(o_.out_dir / "data" / name, [&](std::ostream& out) {
      out.write(reinterpret_cast<const char*>(values.data()), std::streamsize(values.size() * sizeof(float)));
    });
  }

  void resolution_stability() {
    std::vector<uint32_t> resolutions = o_.resolutions;
    std::sort(resolutions.begin(), resolutions.end());
    resolutions.erase(std::unique(resolutions.begin(), resolutions.end()), resolutions.end());
    Progress progress("accuracy: resolution", resolutions.size() * o_.seeds.size(), "frames");
    std::vector<ResolutionPoint> points;
    for (uint32_t res : resolutions)
      for (uint64_t seed : o_.seeds) {
        Frame f = trace_frame(scene_, *main_tree_, camera_, frame_settings(res, seed, -1));
        ResolutionPoint p;
        p.resolution = res;
        p.seed = seed;
        p.rays = f.run.total.rays;
        p.seconds = f.seconds;
        p.cpu_seconds = f.cpu_seconds;
        p.ops_per_ray = ops_per_ray(f.run);
        points.push_back(p);
        progress.advance();
      }
    // Reference: the mean over seeds at the highest resolution.
    double sum = 0;
    size_t n = 0;
    for (const ResolutionPoint& p : points)
      if (p.resolution == resolutions.back()) sum += p.ops_per_ray, ++n;
    const double reference = n ? sum / double(n) : 0.0;
    for (ResolutionPoint& p : points) p.error = relative(p.ops_per_ray, reference);
    // Needed: the smallest resolution from which on every seed stays within the tolerance.
    uint32_t needed = resolutions.back();
    for (size_t i = resolutions.size(); i-- > 0;) {
      bool all_within = true;
      for (const ResolutionPoint& p : points)
        if (p.resolution == resolutions[i] && !(std::fabs(p.error) <= o_.tolerance)) all_within = false;
      if (!all_within) break;
      needed = resolutions[i];
    }
    uint64_t rays = 0;
    size_t count = 0;
    for (const ResolutionPoint& p : points)
      if (p.resolution == needed) rays += p.rays, ++count;
    report_.resolution = points;
    report_.resolution_reference_ops = reference;
    report_.resolution_needed = needed;
    report_.rays_needed = count ? rays / count : 0;
  }

  // 5. DRAM bytes and cycles per ray against resolution and frames, per scene.
  void memory_traffic() {
    std::vector<std::string> scenes = o_.traffic_scenes;
    if (scenes.empty()) scenes.push_back(o_.scene);
    std::vector<uint32_t> resolutions = o_.traffic_resolutions;
    std::sort(resolutions.begin(), resolutions.end());
    resolutions.erase(std::unique(resolutions.begin(), resolutions.end()), resolutions.end());
    size_t runs = 0;
    for (uint32_t r : resolutions) runs += r <= o_.traffic_cycle_resolution ? 2 : 1;
    Progress progress("accuracy: memory traffic", runs * scenes.size(), "runs");
    const std::filesystem::path runs_dir = o_.out_dir / "runs" / "traffic";
    std::filesystem::create_directories(runs_dir);
    for (const std::string& scene : scenes) {
      // One tree per scene, built once by a child and replayed by every run.
      const std::string key = std::to_string(std::hash<std::string>{}(scene) % 1000000);
      const std::filesystem::path tree = runs_dir / ("tree-" + key + ".bvh");
      BuildJob build;
      build.scene = scene;
      build.builder = o_.builder;
      build.seed = o_.seed;
      build.out = tree;
      build.node_format = hardware_node_format_;  // the tree for the format its runs fetch
      runner_.build(build, runs_dir / ("build-" + key + ".log"));
      for (uint32_t res : resolutions)
        for (const char* level : {"functional", "cycle"}) {
          if (std::string(level) == "cycle" && res > o_.traffic_cycle_resolution) continue;
          const std::string name = key + "-" + level + "-" + std::to_string(res);
          SimulationJob job;
          job.scene = scene;
          job.bvh = tree;
          job.fidelity = level;
          job.config = o_.hardware;
          job.resolution = std::to_string(res) + "x" + std::to_string(res);
          job.seed = o_.seed;
          job.frames = o_.traffic_frames;
          job.out_dir = runs_dir / name;
          const SimulationOutcome run = runner_.simulate(job, runs_dir / (name + ".log"));
          const nlohmann::json &st = run.stats, &host = run.host;
          TrafficPoint p;
          p.scene = scene;
          p.level = level;
          p.resolution = res;
          p.rays = uint64_t(stat_value(st, {"rays", "total"}));
          p.cpu_seconds = stat_value(host, {"cpu_seconds"});
          for (uint32_t f = 1; f <= o_.traffic_frames; ++f) {
            const std::string frame = "frame" + std::to_string(f);
            p.dram_bytes_per_ray.push_back(stat_value(st, {"frames", frame.c_str(), "dram_bytes_per_ray"}));
            if (p.level == "cycle")
              p.cycles_per_ray.push_back(stat_value(st, {"frames", frame.c_str(), "cycles"}) /
                                         double(std::max<uint64_t>(1, p.rays)));
          }
          report_.traffic.push_back(p);
          progress.advance();
        }
      report_.traffic_verdicts.push_back(judge_traffic(scene, report_.traffic, o_));
    }
  }

  const AccuracyOptions& o_;
  JobRunner runner_;
  std::string hardware_node_format_;
  Scene scene_;
  const Camera& camera_;
  AccuracyReport report_;
  std::unique_ptr<Bvh> main_tree_;
  BuildParams main_params_;
};

}  // namespace

AccuracyReport run_accuracy(const AccuracyOptions& options) {
  if (options.rtsim_binary.empty()) throw std::logic_error("accuracy: rtsim_binary is required for the fidelity runs");
  AccuracyRun run(options);
  return run.run();
}

}  // namespace rtsim
