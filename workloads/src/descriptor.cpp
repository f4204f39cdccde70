#include <rtsim/workloads/config_reader.h>
#include <rtsim/workloads/descriptor.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/host.h>
#include <rtsim/workloads/mesh_loader.h>
#include <rtsim/workloads/validate.h>

#include <glm/gtc/matrix_transform.hpp>

#include <map>
#include <tuple>

namespace rtsim {

namespace {

Material read_material(ConfigTable& t) {
  Material m;
  m.name = t.string("name");
  m.albedo = t.vector3("albedo", m.albedo);
  m.reflectance = float(t.number("reflectance", 0.0, 0.0, 1.0));
  m.transmittance = float(t.number("transmittance", 0.0, 0.0, 1.0));
  m.ior = float(t.number("ior", 1.5, 1.0, 4.0));
  m.emission = t.vector3("emission", vec3(0.0f));
  t.finish();
  return m;
}

Light read_light(ConfigTable& t) {
  Light l;
  const std::string kind = t.string("kind", "point");
  if (kind == "point") {
    l.kind = Light::Kind::Point;
    l.position = t.vector3("position");
  } else if (kind == "directional") {
    l.kind = Light::Kind::Directional;
    l.direction = t.vector3("direction");
    if (glm::dot(l.direction, l.direction) == 0.0f)
      throw InputError(t.where("direction"), "must not be zero");
    l.direction = glm::normalize(l.direction);
  } else {
    throw InputError(t.where("kind"), "must be \"point\" or \"directional\", not \"" + kind + "\"");
  }
  l.intensity = t.vector3("intensity", vec3(1.0f));
  t.finish();
  return l;
}

Camera read_camera(ConfigTable& t) {
  Camera c;
  c.name = t.string("name");
  c.position = t.vector3("position");
  c.target = t.vector3("target");
  c.up = t.vector3("up", vec3(0, 1, 0));
  c.vertical_fov_deg = float(t.number("fov", 60.0, 1.0, 179.0));
  t.finish();
  // An up vector along the view direction leaves the camera's roll undefined; a
  // silent substitute would give a picture the author did not ask for.
  const vec3 forward = c.target - c.position;
  if (glm::dot(forward, forward) > 0.0f) {
    const float up_length = glm::length(c.up);
    if (!(up_length > 0.0f)) throw InputError(t.where("up"), "must not be zero");
    const float sine = glm::length(glm::cross(glm::normalize(forward), c.up / up_length));
    if (!(sine > 1e-4f))
      throw InputError(t.where("up"), "is parallel to the view direction (target - position), so "
                                      "the camera's roll is undefined; give an up vector across it");
  }
  return c;
}

glm::mat4 read_transform(ConfigTable& t) {
  const vec3 translate = t.vector3("translate", vec3(0.0f));
  const vec3 rotate = t.vector3("rotate_deg", vec3(0.0f));
  vec3 scale(1.0f);
  const nlohmann::json& s = t.raw("scale");
  if (s.is_number()) scale = vec3(s.get<float>());
  else if (s.is_array() && s.size() == 3 && s[0].is_number() && s[1].is_number() && s[2].is_number())
    scale = vec3(s[0].get<float>(), s[1].get<float>(), s[2].get<float>());
  else if (!s.is_null())
    throw InputError(t.where("scale"), "must be a number or an array of 3 numbers");
  if (!is_finite(scale) || scale.x == 0.0f || scale.y == 0.0f || scale.z == 0.0f)
    throw InputError(t.where("scale"), "must be finite and non-zero");
  glm::mat4 m = glm::translate(glm::mat4(1.0f), translate);
  m = glm::rotate(m, glm::radians(rotate.z), vec3(0, 0, 1));
  m = glm::rotate(m, glm::radians(rotate.y), vec3(0, 1, 0));
  m = glm::rotate(m, glm::radians(rotate.x), vec3(1, 0, 0));
  return glm::scale(m, scale);
}

}  // namespace

Scene load_scene_descriptor(const std::filesystem::path& path) {
  const nlohmann::json doc = parse_config_file(path);
  ConfigTable root(doc, path.string());
  Scene scene;
  scene.name = root.string("name", path.parent_path().filename().string());
  scene.source = path.string();
  scene.licence = root.string("licence", "");
  root.string("description", "");

  // Materials named in the descriptor come first; meshes' own materials follow.
  std::map<std::string, uint32_t> material_index;
  for (ConfigTable& t : root.array_of_tables("material")) {
    Material m = read_material(t);
    if (material_index.count(m.name))
      throw InputError(t.where("name"), "material '" + m.name + "' is defined twice");
    material_index[m.name] = uint32_t(scene.materials.size());
    scene.materials.push_back(m);
  }

  std::vector<Camera> suggested;
  uint64_t dropped_sky_faces = 0, dropped_tool_faces = 0;
  std::vector<ConfigTable> meshes = root.array_of_tables("mesh");
  if (meshes.empty()) throw InputError(root.where("mesh"), "at least one [[mesh]] is required");
  // A file named by many [[mesh]] tables (instances with their own transforms) is
  // loaded once per set of load options: each load forks an assimp child (64 ms),
  // and 3,000 references took over a minute.
  std::map<std::tuple<std::string, int, std::string, bool>, Mesh> loaded;
  uint64_t scene_bytes = 0;  // vertices, triangles and material ids so far
  for (ConfigTable& t : meshes) {
    MeshOptions options;
    const std::filesystem::path file = path.parent_path() / t.string("file");
    options.bsp_patch_level = int(t.integer("patch_level", options.bsp_patch_level, 1, 64));
    options.pk3_map = t.string("map", "");
    options.bsp_drop_sky = t.boolean("drop_sky", options.bsp_drop_sky);
    const std::string override_material = t.string("material", "");
    const glm::mat4 transform = read_transform(t);
    t.finish();
    if (!override_material.empty() && !material_index.count(override_material))
      throw InputError(t.where("material"), "no [[material]] named '" + override_material + "'");

    std::error_code ec;
    const std::filesystem::path canonical = std::filesystem::weakly_canonical(file, ec);
    const auto key = std::make_tuple((ec ? file : canonical).string(), options.bsp_patch_level, options.pk3_map,
                                     options.bsp_drop_sky);
    auto found = loaded.find(key);
    if (found == loaded.end()) found = loaded.emplace(key, load_mesh(file, options)).first;
    const Mesh& mesh = found->second;
    scene_bytes = saturating_add(scene_bytes, saturating_add(saturating_mul(mesh.vertices.size(), sizeof(vec3)),
                                                             saturating_mul(mesh.triangles.size(), sizeof(uvec3) + 4)));
    check_memory_budget(scene_bytes, path.string(),
                        "the [[mesh]] tables' vertices and triangles, each reference a copy");
    dropped_sky_faces += mesh.dropped_sky_faces;
    dropped_tool_faces += mesh.dropped_tool_faces;
    const uint32_t vertex_base = uint32_t(scene.vertices.size());
    const uint32_t material_base = uint32_t(scene.materials.size());
    // Texture coordinates: per triangle, zero where a mesh has none (only alpha-tested
    // materials sample them, and those come with their mesh's coordinates).
    const bool alpha = override_material.empty() && !mesh.alpha_textures.empty();
    // Decided before the loop: with no triangles yet (the first mesh) the resize
    // leaves triangle_uvs empty, and an emptiness test would then keep none.
    const bool keep_uvs = alpha || !scene.triangle_uvs.empty();
    if (keep_uvs && scene.triangle_uvs.size() < scene.triangles.size())
      scene.triangle_uvs.resize(scene.triangles.size(), TriangleUv{});
    const int32_t texture_base = int32_t(scene.alpha_textures.size());
    if (alpha) scene.alpha_textures.insert(scene.alpha_textures.end(), mesh.alpha_textures.begin(), mesh.alpha_textures.end());
    for (const vec3& v : mesh.vertices) scene.vertices.push_back(vec3(transform * glm::vec4(v, 1.0f)));
    // A mirroring transform flips winding; keep triangles front-facing.
    const bool flips = glm::determinant(glm::mat3(transform)) < 0.0f;
    for (size_t i = 0; i < mesh.triangles.size(); ++i) {
      uvec3 tri = mesh.triangles[i] + uvec3(vertex_base);
      if (flips) std::swap(tri.y, tri.z);
      scene.triangles.push_back(tri);
      uint32_t material = 0;
      if (!override_material.empty()) material = material_index[override_material];
      else if (!mesh.materials.empty() && i < mesh.material_ids.size())
        material = material_base + mesh.material_ids[i];
      else material = material_index.count("default") ? material_index["default"] : ~0u;
      scene.material_ids.push_back(material);
      if (keep_uvs) {
        TriangleUv uv = alpha && i < mesh.triangle_uvs.size() ? mesh.triangle_uvs[i] : TriangleUv{};
        if (flips) std::swap(uv[1], uv[2]);
        scene.triangle_uvs.push_back(uv);
      }
    }
    if (override_material.empty())
      for (Material m : mesh.materials) {
        if (m.alpha_tested()) m.alpha_texture += texture_base;
        scene.materials.push_back(m);
      }
    for (Camera c : mesh.suggested_cameras) {
      c.position = vec3(transform * glm::vec4(c.position, 1.0f));
      c.target = vec3(transform * glm::vec4(c.target, 1.0f));
      suggested.push_back(c);
    }
  }
  if (!scene.triangle_uvs.empty()) scene.triangle_uvs.resize(scene.triangles.size(), TriangleUv{});
  // Triangles with no material of their own get a plain diffuse default.
  uint32_t fallback = ~0u;
  for (uint32_t& m : scene.material_ids)
    if (m == ~0u) {
      if (fallback == ~0u) {
        fallback = uint32_t(scene.materials.size());
        scene.materials.push_back(Material{});
      }
      m = fallback;
    }

  for (ConfigTable& t : root.array_of_tables("light")) scene.lights.push_back(read_light(t));
  ConfigTable ao = root.table("ao");
  scene.ao.enabled = ao.boolean("enabled", scene.ao.enabled);
  scene.ao.cutoff_relative = float(ao.number("cutoff", scene.ao.cutoff_relative, 1e-6, 10.0));
  scene.ao.samples = uint32_t(ao.integer("samples", scene.ao.samples, 1, 4096));
  ao.finish();
  for (ConfigTable& t : root.array_of_tables("camera")) {
    Camera c = read_camera(t);
    for (const Camera& existing : scene.cameras)
      if (existing.name == c.name) throw InputError(t.where("name"), "camera '" + c.name + "' is defined twice");
    scene.cameras.push_back(c);
  }
  // Cameras the mesh suggests (spawn points, track quads) are kept as spawnN.
  for (size_t i = 0; i < suggested.size(); ++i) {
    suggested[i].name = suggested[i].name.empty() ? "spawn" + std::to_string(i) : suggested[i].name;
    if (!scene.find_camera(suggested[i].name)) scene.cameras.push_back(suggested[i]);
  }
  root.finish();
  // Every command that traces needs a camera; say so here, not half-way through one.
  if (scene.cameras.empty())
    throw InputError(root.where("camera"), "at least one [[camera]] is required (rtsim table1 "
                                           "uses view1 and view2; see docs/scene-descriptor.md)");
  validate_scene(scene);
  scene.validation.dropped_sky_faces = dropped_sky_faces;
  scene.validation.dropped_tool_faces = dropped_tool_faces;
  return scene;
}

}  // namespace rtsim
