// accuracy.md / .json / .csv, the terminal text, and the trade-off picture.
#include <rtsim/reports/accuracy.h>
#include <rtsim/reports/plot_script.h>
#include <rtsim/reports/text_table.h>
#include <rtsim/workloads/files.h>

#include <nlohmann/json.hpp>

#include <cctype>
#include <cmath>
#include <cstdio>

namespace rtsim {

namespace {

std::string res(uint32_t r) { return std::to_string(r) + "x" + std::to_string(r); }

TextTable fidelity_table(const AccuracyReport& r) {
  TextTable t({"scene", "level", "res", "rays", "sim wall s", "sim CPU s", "process s", "rays/host s", "rays/CPU s",
               "cycles",
               "cycle error", "DRAM bytes", "DRAM error", "ops/ray", "counts = cycle"});
  for (const FidelityPoint& p : r.fidelity)
    t.add_row({p.scene, p.level, res(p.resolution), std::to_string(p.rays), format_significant(p.host_seconds, 3), format_significant(p.cpu_seconds, 3),
               format_significant(p.process_seconds, 3), format_significant(p.rays_per_host_second, 3), format_significant(p.rays_per_cpu_second, 3), format_significant(p.cycles, 7), format_percent(p.cycle_error),
               format_significant(p.dram_bytes, 7), format_percent(p.dram_error), format_significant(p.ops_per_ray), p.counts_match_cycle ? "yes" : "NO"});
  return t;
}

TextTable knob_table(const AccuracyReport& r) {
  TextTable t({"knob", "setting", "estimate s", "build s", "CPU s", "SAH cost", "references", "ops/ray",
               "ops/ray vs reference", "occlusion RMSE", "occlusion max error", "weight RMSE"});
  for (const KnobPoint& k : r.knobs)
    t.add_row({k.family, k.label + (k.reference ? " (reference)" : ""), format_significant(k.estimate_seconds, 3),
               format_significant(k.build_seconds, 3), format_significant(k.cpu_seconds, 3), format_significant(k.sah_cost), std::to_string(k.references), format_significant(k.ops_per_ray),
               format_percent(k.ops_error), k.occlusion_rmse < 0 ? "-" : format_significant(k.occlusion_rmse, 3),
               k.occlusion_max_error < 0 ? "-" : format_significant(k.occlusion_max_error, 3),
               k.weight_rmse < 0 ? "-" : format_significant(k.weight_rmse, 3)});
  return t;
}

TextTable ao_table(const AccuracyReport& r) {
  TextTable t({"AO rays/pixel", "rays", "frame s", "CPU s", "image RMSE", "ops/ray", "AO ops/ray"});
  for (const AoSamplesPoint& p : r.ao)
    t.add_row({std::to_string(p.samples) + (p.reference ? " (reference)" : ""), std::to_string(p.rays),
               format_significant(p.seconds, 3), format_significant(p.cpu_seconds, 3), p.reference ? "0 (reference)" : format_significant(p.image_rmse, 3), format_significant(p.ops_per_ray),
               format_significant(p.ao_ops_per_ray)});
  return t;
}

TextTable resolution_table(const AccuracyReport& r) {
  TextTable t({"res", "seed", "rays", "frame s", "CPU s", "ops/ray", "vs highest-res mean"});
  for (const ResolutionPoint& p : r.resolution)
    t.add_row({res(p.resolution), std::to_string(p.seed), std::to_string(p.rays), format_significant(p.seconds, 3),
               format_significant(p.cpu_seconds, 3), format_significant(p.ops_per_ray, 6), format_percent(p.error)});
  return t;
}

TextTable traffic_table(const AccuracyReport& r) {
  TextTable t({"scene", "level", "res", "rays/frame", "DRAM B/ray by frame (1 = cold)",
               "cycles/ray by frame", "CPU s"});
  const auto series = [](const std::vector<double>& v) {
    std::string out;
    for (double x : v) out += (out.empty() ? "" : " / ") + format_significant(x, 4);
    return out.empty() ? std::string("-") : out;
  };
  for (const TrafficPoint& p : r.traffic)
    t.add_row({p.scene, p.level, res(p.resolution), std::to_string(p.rays), series(p.dram_bytes_per_ray),
               series(p.cycles_per_ray), format_significant(p.cpu_seconds, 3)});
  return t;
}

std::string setup_text(const AccuracyReport& r) {
  const AccuracyOptions& o = r.options;
  char buf[1024];
  std::snprintf(buf, sizeof buf,
                "Scene '%s' (%llu triangles), camera %s, seed %llu, hardware '%s'%s. The tree of the fidelity, "
                "AO and resolution sections: %s with default parameters. AO rays per primary hit where not "
                "varied: %u (the scene's setting), length %.4g. Builder knobs traced at %s; AO images at %s. "
                "Tolerances: ops/ray %s, cycles/DRAM bytes %s of the cycle level, AO image RMSE %.3g. Host: "
                "wall times and process CPU seconds (all threads); the comparisons and the picture use CPU "
                "seconds, which a machine shared with other jobs does not inflate. "
                "%.1f s in all.",
                r.scene_name.c_str(), static_cast<unsigned long long>(r.triangles), r.camera.c_str(),
                static_cast<unsigned long long>(o.seed), o.hardware.c_str(), o.quick ? ", quick sizes" : "",
                o.builder.c_str(), r.scene_ao_samples, double(r.ao_length), res(o.knob_resolution).c_str(),
                res(o.ao_image_resolution).c_str(), format_percent(o.tolerance).c_str(), format_percent(o.fidelity_tolerance).c_str(),
                o.image_rmse_target, r.total_seconds);
  return buf;
}

const char* kFidelityNote =
    "Each level ran as its own `rtsim simulate` process on the same saved tree and rays; errors are "
    "relative to the cycle level at the same resolution.";
const char* kKnobNote =
    "ops/ray of each tree on the same frame; the reference of each knob is its most exact setting "
    "(largest K, full sweep, smallest alpha). Occlusion values are per triangle, in [0, 1]. Estimate = AO "
    "rays (AO-BVH only), build = tree construction.";
const char* kAoNote =
    "AO image = fraction of a pixel's AO rays that escaped; RMSE over the pixels whose primary ray hit. "
    "AO rays are keyed by their index, so each image's rays are the first n of the reference's: the error "
    "is the distance to what the reference shows (slightly below the distance to the converged image).";
const char* kTrafficNote =
    "Each run simulates the same rays several frames back to back (`--frames`), caches warm after the "
    "first; every frame's DRAM bytes and cycles per ray are shown, frame 1 with cold caches. DRAM bytes "
    "come from the functional level, cycles from the cycle level (which reads the same DRAM bytes to a few "
    "tenths of a percent). A figure is converged when it is within the tolerance of the steady state "
    "(the last frame) or of the highest resolution measured.";
const char* kResolutionNote =
    "Primary rays go through pixel centres, so the seed changes only the AO rays; the reference is the "
    "mean over seeds at the highest resolution.";

nlohmann::json to_json(const AccuracyReport& r) {
  const AccuracyOptions& o = r.options;
  nlohmann::json j;
  j["scene"] = r.scene_name;
  j["triangles"] = r.triangles;
  j["camera"] = r.camera;
  j["seed"] = o.seed;
  j["hardware"] = o.hardware;
  j["quick"] = o.quick;
  j["tree_builder"] = o.builder;
  j["ao_samples"] = r.scene_ao_samples;
  j["ao_length"] = r.ao_length;
  j["tolerances"] = {{"ops_per_ray", o.tolerance},
                     {"cycles_and_dram", o.fidelity_tolerance},
                     {"ao_image_rmse", o.image_rmse_target}};
  j["knob_resolution"] = o.knob_resolution;
  j["ao_image_resolution"] = o.ao_image_resolution;
  j["total_seconds"] = r.total_seconds;
  for (const FidelityPoint& p : r.fidelity)
    j["fidelity"].push_back({{"scene", p.scene},
                             {"level", p.level},
                             {"resolution", p.resolution},
                             {"rays", p.rays},
                             {"host_seconds", p.host_seconds},
                             {"cpu_seconds", p.cpu_seconds},
                             {"process_seconds", p.process_seconds},
                             {"rays_per_host_second", p.rays_per_host_second},
                             {"rays_per_cpu_second", p.rays_per_cpu_second},
                             {"cycles", p.cycles},
                             {"dram_bytes", p.dram_bytes},
                             {"ops_per_ray", p.ops_per_ray},
                             {"cycle_error", p.cycle_error},
                             {"dram_error", p.dram_error},
                             {"counts_match_cycle", p.counts_match_cycle}});
  for (const KnobPoint& k : r.knobs) {
    nlohmann::json row = {{"family", k.family},
                          {"setting", k.label},
                          {"value", k.value},
                          {"reference", k.reference},
                          {"estimate_seconds", k.estimate_seconds},
                          {"build_seconds", k.build_seconds},
                          {"total_seconds", k.total_seconds()},
                          {"cpu_seconds", k.cpu_seconds},
                          {"sah_cost", k.sah_cost},
                          {"references", k.references},
                          {"ops_per_ray", k.ops_per_ray},
                          {"ops_error", k.ops_error}};
    if (k.occlusion_rmse >= 0) {
      row["occlusion_rmse"] = k.occlusion_rmse;
      row["occlusion_max_error"] = k.occlusion_max_error;
      row["weight_rmse"] = k.weight_rmse;
    }
    j["knobs"].push_back(row);
  }
  for (const AoSamplesPoint& p : r.ao)
    j["ao_rays_per_pixel"].push_back({{"samples", p.samples},
                                      {"reference", p.reference},
                                      {"rays", p.rays},
                                      {"seconds", p.seconds},
                                      {"cpu_seconds", p.cpu_seconds},
                                      {"image_rmse", p.image_rmse},
                                      {"ops_per_ray", p.ops_per_ray},
                                      {"ao_ops_per_ray", p.ao_ops_per_ray}});
  nlohmann::json resolution;
  for (const ResolutionPoint& p : r.resolution)
    resolution["points"].push_back({{"resolution", p.resolution},
                                    {"seed", p.seed},
                                    {"rays", p.rays},
                                    {"seconds", p.seconds},
                                    {"cpu_seconds", p.cpu_seconds},
                                    {"ops_per_ray", p.ops_per_ray},
                                    {"error", p.error}});
  resolution["reference_ops_per_ray"] = r.resolution_reference_ops;
  resolution["tolerance"] = o.tolerance;
  resolution["resolution_needed"] = r.resolution_needed;
  resolution["rays_needed"] = r.rays_needed;
  j["resolution"] = resolution;
  for (const TrafficPoint& p : r.traffic)
    j["traffic"]["points"].push_back({{"scene", p.scene},
                                      {"level", p.level},
                                      {"resolution", p.resolution},
                                      {"rays_per_frame", p.rays},
                                      {"dram_bytes_per_ray", p.dram_bytes_per_ray},
                                      {"cycles_per_ray", p.cycles_per_ray},
                                      {"cpu_seconds", p.cpu_seconds}});
  for (const TrafficVerdict& v : r.traffic_verdicts)
    j["traffic"]["verdicts"].push_back({{"scene", v.scene},
                                        {"frames_needed", v.frames_needed},
                                        {"frames_confirmed", v.frames_confirmed},
                                        {"resolution_needed", v.resolution_needed},
                                        {"resolution_converged", v.resolution_converged},
                                        {"cold_bytes_per_ray", v.cold_bytes_per_ray},
                                        {"steady_bytes_per_ray", v.steady_bytes_per_ray},
                                        {"cycles_per_ray", v.cycles_per_ray},
                                        {"summary", v.summary}});
  j["traffic"]["tolerance"] = o.traffic_tolerance;
  j["traffic"]["floor_bytes_per_ray"] = o.traffic_floor_bytes;
  for (const Recommendation& rec : r.recommendations)
    j["recommendations"].push_back({{"topic", rec.topic}, {"setting", rec.setting}, {"why", rec.why}});
  return j;
}

// One long table: every measured point with its time and its error against its reference.
std::string to_csv(const AccuracyReport& r) {
  TextTable t({"scene", "section", "setting", "resolution", "seed", "rays", "seconds", "cpu_seconds",
               "error_metric", "error", "ops_per_ray"});
  auto row = [&](const std::string& section, const std::string& setting, uint32_t resolution, uint64_t seed,
                 uint64_t rays, double seconds, double cpu, const std::string& metric, double error, double ops,
                 const std::string& scene = "") {
    t.add_row({scene.empty() ? r.scene_name : scene, section, setting, std::to_string(resolution), std::to_string(seed), std::to_string(rays),
               format_significant(seconds, 6), format_significant(cpu, 6), metric, format_significant(error, 6), format_significant(ops, 6)});
  };
  for (const FidelityPoint& p : r.fidelity) {
    row("fidelity", p.level, p.resolution, r.options.seed, p.rays, p.host_seconds, p.cpu_seconds, "cycle_error", p.cycle_error,
        p.ops_per_ray, p.scene);
    row("fidelity", p.level, p.resolution, r.options.seed, p.rays, p.host_seconds, p.cpu_seconds, "dram_error", p.dram_error,
        p.ops_per_ray, p.scene);
  }
  for (const KnobPoint& k : r.knobs) {
    row(k.family, k.label, r.options.knob_resolution, r.options.seed, 0, k.total_seconds(), k.cpu_seconds, "ops_error",
        k.ops_error, k.ops_per_ray);
    if (k.occlusion_rmse >= 0)
      row(k.family, k.label, r.options.knob_resolution, r.options.seed, 0, k.total_seconds(), k.cpu_seconds, "occlusion_rmse",
          k.occlusion_rmse, k.ops_per_ray);
  }
  for (const AoSamplesPoint& p : r.ao)
    row("ao_rays_per_pixel", std::to_string(p.samples), r.options.ao_image_resolution, r.options.seed, p.rays,
        p.seconds, p.cpu_seconds, "image_rmse", p.image_rmse, p.ops_per_ray);
  for (const ResolutionPoint& p : r.resolution)
    row("resolution", res(p.resolution), p.resolution, p.seed, p.rays, p.seconds, p.cpu_seconds, "ops_error", p.error,
        p.ops_per_ray);
  for (const TrafficPoint& p : r.traffic)
    for (size_t f = 0; f < p.dram_bytes_per_ray.size(); ++f) {
      const std::string setting = p.scene + " " + p.level + " frame " + std::to_string(f + 1);
      row("traffic", setting, p.resolution, r.options.seed, p.rays, 0, p.cpu_seconds, "dram_bytes_per_ray",
          p.dram_bytes_per_ray[f], 0);
      if (f < p.cycles_per_ray.size())
        row("traffic", setting, p.resolution, r.options.seed, p.rays, 0, p.cpu_seconds, "cycles_per_ray",
            p.cycles_per_ray[f], 0);
    }
  return t.csv();
}

}  // namespace

std::string accuracy_text(const AccuracyReport& r) {
  std::string out = "What accuracy costs in time, scene '" + r.scene_name + "'\n\n" + setup_text(r) + "\n\n";
  out += "1. Fidelity levels\n" + fidelity_table(r).plain() + "\n";
  out += "2. Builder knobs\n" + knob_table(r).plain() + "\n";
  out += "3. AO rays per pixel (" + res(r.options.ao_image_resolution) + ")\n" + ao_table(r).plain() + "\n";
  out += "4. Resolution against ops/ray stability\n" + resolution_table(r).plain() + "\n";
  out += "5. Memory traffic against resolution and frames\n" + traffic_table(r).plain();
  for (const TrafficVerdict& v : r.traffic_verdicts) out += "  " + v.summary + "\n";
  out += "\n";
  out += "Recommended settings:\n";
  for (const Recommendation& rec : r.recommendations)
    out += "  - " + rec.topic + ": " + rec.setting + "\n      " + rec.why + "\n";
  return out;
}

void write_accuracy(const AccuracyReport& r) {
  const auto& dir = r.options.out_dir;
  std::string md = "# What accuracy costs in time: `" + r.scene_name + "`\n\n" + setup_text(r) + "\n\n";
  md += "## Recommended settings\n\n";
  for (const Recommendation& rec : r.recommendations)
    md += "- **" + rec.topic + "**: `" + rec.setting + "`. " +
          (rec.why.empty() ? "" : std::string(1, char(std::toupper(static_cast<unsigned char>(rec.why[0]))))) +
          (rec.why.empty() ? "" : rec.why.substr(1)) + "\n";
  md += "\n![Trade-offs](accuracy_tradeoffs.png)\n\n";
  md += "## 1. Fidelity levels\n\n" + std::string(kFidelityNote) + "\n\n" + fidelity_table(r).markdown() + "\n";
  md += "## 2. Builder knobs\n\n" + std::string(kKnobNote) + "\n\n" + knob_table(r).markdown() + "\n";
  md += "## 3. AO rays per pixel\n\n" + std::string(kAoNote) + "\n\n" + ao_table(r).markdown() +
        "\n![AO images](accuracy_ao_images.png)\n\n";
  md += "## 4. Resolution against the stability of ops/ray\n\n" + std::string(kResolutionNote) + "\n\n" +
        resolution_table(r).markdown() + "\nReference " + format_significant(r.resolution_reference_ops, 6) +
        " ops/ray; within " + format_percent(r.options.tolerance) + " from " + res(r.resolution_needed) + " (" +
        std::to_string(r.rays_needed) + " rays per frame) on.\n";
  md += "\n## 5. Memory traffic against resolution and frames\n\n" + std::string(kTrafficNote) + "\n\n" +
        traffic_table(r).markdown() + "\n";
  for (const TrafficVerdict& v : r.traffic_verdicts) md += "- " + v.summary + "\n";
  md += "\n![Memory traffic](accuracy_traffic.png)\n";
  write_file_atomic(dir / "accuracy.md", md);
  write_file_atomic(dir / "accuracy.json", to_json(r).dump(2) + "\n");
  write_file_atomic(dir / "accuracy.csv", to_csv(r));
  run_plot_script("accuracy_plots.py", {dir.string()});
}

}  // namespace rtsim
