// rtsim build: build one BVH (or every builder with --all) for a scene, check it,
// print its quality report and optionally save it; --load reads a saved tree back.
#include "build_options.h"
#include "cli_util.h"
#include "commands.h"

#include <rtsim/builder/build.h>
#include <rtsim/builder/builder_registry.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/builder/metrics.h>
#include <rtsim/workloads/files.h>
#include <rtsim/builder/validate_bvh.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/progress.h>
#include <rtsim/workloads/scene_registry.h>
#include <rtsim/reports/interval.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>

namespace rtsim::cli {

namespace {

struct BuildOptions {
  std::string scene;
  std::string camera;
  std::string out;
  std::string out_dir;  // with --all
  std::string metrics_out;  // the one tree's report as JSON (not with --all)
  std::string load;
  bool json = false;
  bool all = false;
  bool list_builders = false;
  bool no_epo = false;
  bool opaque = false;  // alpha-tested materials as opaque (the tree of simulate --opaque)
  bool instanced = false;  // the two-level tree of the scene's instances
  uint32_t seed_spread = 1;  // trees per sampled builder for the spread of its costs
  std::string node_format = "bvh2-64";
  BuildParams params;
};

// Node-record bytes per triangle of the tree laid out in `format`.
double node_bytes_per_triangle(const Scene& scene, const Bvh& bvh, const std::string& format) {
  MemoryLayoutConfig layout;
  layout.node_format = format;
  const MemoryImage image(scene, bvh, layout);
  return double(image.footprint().node_bytes) / double(std::max<size_t>(1, scene.triangle_count()));
}

// A sampled builder's costs over `seeds` trees (seeds seed, seed + 1, ...): mean,
// 95% interval, min and max. Empty for a builder that draws no random rays, or seeds 1.
nlohmann::json seed_spread(const Scene& scene, const BuildParams& params, const BvhMetrics& first, uint32_t seeds) {
  if (seeds < 2 || !parameter_used_by(*find_builder_parameter("seed"), params.builder)) return nullptr;
  std::vector<double> sah = {first.sah_cost}, weighted = {first.weighted_cost};
  for (uint32_t k = 1; k < seeds; ++k) {
    BuildParams p = params;
    p.seed = params.seed + k;
    BuildReport r;
    const Bvh bvh = build_bvh(scene, p, &r);
    const BvhMetrics m = compute_metrics(bvh, scene, p, r, false);
    sah.push_back(m.sah_cost);
    weighted.push_back(m.weighted_cost);
  }
  auto spread = [](const std::vector<double>& v) {
    const Interval i = interval_of(v);
    return nlohmann::json{{"mean", i.mean}, {"lo95", i.lo}, {"hi95", i.hi},
                          {"min", *std::min_element(v.begin(), v.end())},
                          {"max", *std::max_element(v.begin(), v.end())}};
  };
  return {{"seeds", seeds}, {"first_seed", params.seed}, {"sah_cost", spread(sah)},
          {"weighted_cost", spread(weighted)}};
}

std::string human_bytes(double bytes) {
  char buf[32];
  if (bytes >= 1 << 20)
    std::snprintf(buf, sizeof buf, "%.1f MiB", bytes / (1 << 20));
  else
    std::snprintf(buf, sizeof buf, "%.1f KiB", bytes / 1024);
  return buf;
}

// Rows = metrics, columns = builders.
void print_table(const Scene& scene, const std::vector<BvhMetrics>& all,
                 const std::vector<bool>& valid, const std::vector<double>& node_bytes,
                 const std::string& format, const nlohmann::json& trees) {
  if (scene.instanced())
    std::printf("scene %s (instanced): %llu unique triangles, %llu placed by %zu instances of %zu meshes;\n"
                "two-level trees (a TLAS over the instances by SAH, AO-BVH's occlusion-weighted; a BLAS per mesh "
                "by the builder), costs in world space\n",
                scene.name.c_str(), (unsigned long long)scene.triangle_count(),
                (unsigned long long)scene.instanced_triangle_count(), scene.instances.size(), scene.meshes.size());
  else
    std::printf("scene %s: %llu triangles\n", scene.name.c_str(), (unsigned long long)scene.triangle_count());
  auto row = [&](const char* label, auto cell) {
    std::printf("%-18s", label);
    for (size_t i = 0; i < all.size(); ++i) std::printf(" %9s", cell(i).c_str());  // 10 builders in 120 columns
    std::printf("\n");
  };
  auto num = [](const char* fmt, double v) {
    char buf[48];
    std::snprintf(buf, sizeof buf, fmt, v);
    return std::string(buf);
  };
  row("builder", [&](size_t i) { return all[i].builder; });
  row("valid", [&](size_t i) { return std::string(valid[i] ? "yes" : "NO"); });
  row("SAH cost", [&](size_t i) { return num("%.3f", all[i].sah_cost); });
  bool any_spread = false;
  for (const auto& t : trees) any_spread |= t.contains("seed_spread") && !t["seed_spread"].is_null();
  if (any_spread)
    row("  +-95% over seeds", [&](size_t i) {
      const auto& t = trees[i];
      if (!t.contains("seed_spread") || t["seed_spread"].is_null()) return std::string("-");
      const auto& c = t["seed_spread"]["sah_cost"];
      return num("%.3f", (c["hi95"].get<double>() - c["lo95"].get<double>()) / 2);
    });
  row("weighted cost", [&](size_t i) { return num("%.3f", all[i].weighted_cost); });
  row("EPO", [&](size_t i) { return all[i].epo < 0 ? std::string("-") : num("%.3f", all[i].epo); });
  row("width", [&](size_t i) { return std::to_string(all[i].width); });
  row("nodes", [&](size_t i) { return std::to_string(all[i].nodes); });
  if (scene.instanced()) row("  of them TLAS", [&](size_t i) { return std::to_string(all[i].tlas_nodes); });
  row(("node B/tri " + format).c_str(), [&](size_t i) { return num("%.2f", node_bytes[i]); });
  row("leaves", [&](size_t i) { return std::to_string(all[i].leaves); });
  row("references", [&](size_t i) { return std::to_string(all[i].references); });
  row("max depth", [&](size_t i) { return std::to_string(all[i].max_depth); });
  row("avg leaf depth", [&](size_t i) { return num("%.2f", all[i].average_leaf_depth); });
  row("leaf sizes 1/2/3/4..", [&](size_t i) {
    std::string s;
    for (size_t k = 1; k < all[i].leaf_size_histogram.size(); ++k)
      s += (s.empty() ? "" : "/") + std::to_string(all[i].leaf_size_histogram[k]);
    return s.size() > 11 ? s.substr(0, 10) + "+" : s;
  });
  row("estimate s", [&](size_t i) { return num("%.3f", all[i].estimate_seconds); });
  row("build s", [&](size_t i) { return num("%.3f", all[i].build_seconds); });
  row("peak memory", [&](size_t i) { return human_bytes(double(all[i].peak_memory_bytes)); });
  row("memory B/triangle", [&](size_t i) {
    return num("%.1f", all[i].triangles ? double(all[i].peak_memory_bytes) / all[i].triangles : 0.0);
  });
}

void run_build(const BuildOptions& o) {
  check_build_flags(o.params);
  // Output paths before any work.
  OutputFolder trees_folder;
  const std::string out_dir = o.all && o.out_dir.empty() ? o.out : o.out_dir;
  if (!o.all && !o.out_dir.empty())
    throw InputError("--out-dir", "is the folder of --all; one tree goes to --out FILE");
  if (o.all && !o.out.empty() && o.out_dir.empty())
    warn_deprecated("--out (with --all)", "--out-dir");
  if (o.all && !out_dir.empty()) trees_folder.prepare(out_dir, o.out_dir.empty() ? "--out" : "--out-dir");
  if (!o.all && !o.out.empty()) check_output_file(o.out, "--out");
  if (!o.metrics_out.empty()) {
    if (o.all) throw InputError("--metrics-out", "names one tree's report; not with --all (use --json)");
    check_output_file(o.metrics_out, "--metrics-out");
  }
  Scene scene = load_scene(o.scene.empty() ? default_scene_name() : o.scene,
                           o.instanced ? SceneForm::Instanced : SceneForm::Flat);
  if (o.instanced && !scene.instanced())
    throw InputError("--instanced", "scene '" + scene.name + "' has no instances (it is flat)");
  if (o.opaque) scene.make_opaque();
  BuildParams base = o.params;
  // OSAH needs a camera; the named one (InputError naming the cameras if absent) or
  // the scene's default. A scene without cameras still builds every other tree.
  if (!o.camera.empty()) base.camera = scene.camera(o.camera).name;
  else if (!scene.cameras.empty()) base.camera = scene.default_camera().name;
  apply_node_format(base, node_format(o.node_format, typed_flag("--node-format")));
  std::vector<double> node_bytes;

  std::vector<BvhMetrics> metrics;
  std::vector<bool> valid;
  nlohmann::json report = nlohmann::json::array();

  if (!o.load.empty()) {
    BvhFileHeader header;
    const Bvh bvh = load_bvh(o.load, &scene, &header);
    BuildReport r;
    r.builder = header.builder + " (loaded)";
    BvhMetrics m = compute_metrics(bvh, scene, base, r, !o.no_epo);
    metrics.push_back(m);
    valid.push_back(true);
    node_bytes.push_back(node_bytes_per_triangle(scene, bvh, o.node_format));
    nlohmann::json j = nlohmann::json::parse(metrics_json(m));
    j["node_format"] = o.node_format;
    j["node_bytes_per_triangle"] = node_bytes.back();
    j["file"] = o.load;
    j["parameters"] = nlohmann::json::parse(header.params_json, nullptr, false);
    report.push_back(j);
  } else {
    std::vector<std::string> builders = o.all ? builder_names() : std::vector<std::string>{base.builder};
    if (o.all && o.instanced) {
      // Builders that build no BLAS are left out of --all, said so; named alone they refuse.
      std::vector<std::string> kept;
      for (const std::string& name : builders)
        if (builder_info(name).builds_blas) kept.push_back(name);
        else std::fprintf(stderr, "rtsim: %s builds no BLAS (its sample rays are world-space); left out\n", name.c_str());
      builders = kept;
    }
    for (const std::string& name : builders) {
      BuildParams params = base;
      params.builder = name;
      if (Progress::enabled()) std::fprintf(stderr, "building %s ...\n", name.c_str());
      BuildReport r;
      const Bvh bvh = build_bvh(scene, params, &r);
      const BvhValidation v = validate_bvh(bvh, scene, limits_for(params));
      if (!v.ok()) std::fprintf(stderr, "rtsim: %s tree is invalid:\n%s", name.c_str(), v.summary().c_str());
      const BvhMetrics m = compute_metrics(bvh, scene, params, r, !o.no_epo);
      nlohmann::json j = nlohmann::json::parse(metrics_json(m));
      node_bytes.push_back(node_bytes_per_triangle(scene, bvh, o.node_format));
      j["valid"] = v.ok();
      j["node_format"] = o.node_format;
      j["node_bytes_per_triangle"] = node_bytes.back();
      if (params.width > 2) j["collapse_seconds"] = r.collapse_seconds;
      j["parameters"] = nlohmann::json::parse(build_params_json(params));
      if (name == "aobvh" || name == "aosbvh") j["mean_occlusion"] = r.mean_occlusion, j["ao_rays"] = r.ao_rays;
      if (name == "osah") j["visible_triangles"] = r.visible_triangles;
      if (name == "rdh" || name == "rdh-sbvh") j["rdh_rays"] = r.rdh_rays;
      if (parameter_used_by(*find_builder_parameter("seed"), name)) {
        j["seeds"] = std::max<uint32_t>(1, o.seed_spread);
        j["seed_spread"] = seed_spread(scene, params, m, o.seed_spread);
      }
      // Before the tree: a cache that finds the tree finds its report too.
      if (!o.metrics_out.empty()) write_file_atomic(o.metrics_out, j.dump(2) + "\n");
      if (o.all ? !out_dir.empty() : !o.out.empty()) {
        const std::filesystem::path file =
            o.all ? std::filesystem::path(out_dir) / (scene.name + "-" + name + ".bvh")
                  : std::filesystem::path(o.out);
        save_bvh(file, bvh, scene, params);
        trees_folder.keep();
        j["file"] = file.string();
      }
      metrics.push_back(m);
      valid.push_back(v.ok());
      report.push_back(j);
    }
  }
  if (o.json) {
    nlohmann::json out;
    out["scene"] = scene.name;
    out["triangles"] = scene.triangle_count();
    if (scene.instanced()) {
      out["instanced"] = true;
      out["instances"] = scene.instances.size();
      out["meshes"] = scene.meshes.size();
      out["placed_triangles"] = scene.instanced_triangle_count();
    }
    out["trees"] = report;
    std::cout << out.dump(2) << "\n";
  } else {
    print_table(scene, metrics, valid, node_bytes, o.node_format, report);
  }
  for (bool ok : valid)
    if (!ok) throw ExitStatus(1, "a built tree failed the structural checks");
}

}  // namespace

void add_build_command(CLI::App& root) {
  auto o = std::make_shared<BuildOptions>();
  CLI::App* cmd = root.add_subcommand(
      "build",
      "Build a BVH for a scene, check it and print its quality report.\n"
      "Builders: sah (binned SAH; --bins 0 = full sweep), median (object median), sbvh\n"
      "(spatial splits, Stich et al. 2009), osah (visibility splits from --camera, Vinkler et\n"
      "al. 2012), aobvh / aosbvh (the patent's occlusion-weighted SAH read with object / with\n"
      "spatial splits), rdh, rdh-sbvh (ours), embree, embree-sbvh (Embree's rtcBuildBVH).\n"
      "The report: SAH cost (normalised by the root area, with T1/T2), weighted cost,\n"
      "end-point overlap, counts, depths, times, memory.");
  cmd->add_option("--scene", o->scene, "scene name or path (default: " + default_scene_name() + ")");
  cmd->add_option("--builder", o->params.builder, "builder: " + builder_list())->capture_default_str();
  cmd->add_option("--camera", o->camera, "camera for osah visibility (default: view1 or the first)");
  cmd->add_flag("--json", o->json, "print the report as JSON");
  cmd->add_option("--out", o->out, "save the tree to this file");
  cmd->add_option("--out-dir", o->out_dir, "with --all: save every tree in this folder as <scene>-<builder>.bvh");
  cmd->add_option("--metrics-out", o->metrics_out,
                  "also write the tree's report (the --json entry) to this file, atomically");
  cmd->add_flag("--all", o->all, "build every builder and print them side by side");
  cmd->add_flag("--list-builders", o->list_builders, "print the builder names, one a line, and stop");
  cmd->add_option("--load", o->load, "load a saved tree (checked against the scene) and report it");
  cmd->add_flag("--no-epo", o->no_epo, "skip the end-point overlap (the slowest metric)");
  cmd->add_option("--seed-spread", o->seed_spread,
                  "sampled builders (osah, aobvh, aosbvh, rdh, rdh-sbvh): build this many trees, seeds\n"
                  "--build-seed, +1, ..., and report the spread of their costs (the saved tree: the first)")
      ->check(CLI::Range(1u, 64u))
      ->capture_default_str();
  cmd->add_option("--node-format", o->node_format,
                  "build for this node record format: " + node_format_names("|") +
                      "\n(its width: wide formats collapse the binary tree; its leaf capacity)")
      ->capture_default_str();
  add_build_options(cmd, o->params);
  cmd->add_option("--seed", o->params.seed, "same as --build-seed");
  cmd->add_flag("--instanced", o->instanced, std::string(kInstancedHelp) +
                                                  "\n(saved with --out, replayed by simulate --instanced --bvh)");
  cmd->add_flag("--opaque", o->opaque,
                "alpha-tested materials as opaque (the tree that\n`simulate --opaque` traces)");
  cmd->callback([o] {
    if (o->list_builders) {
      for (const std::string& name : builder_names()) std::printf("%s\n", name.c_str());
      return;
    }
    finish_build_options(o->params);
    run_build(*o);
  });
}

}  // namespace rtsim::cli
