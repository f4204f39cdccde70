#include <rtsim/workloads/config_reader.h>
#include <rtsim/workloads/descriptor.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/host.h>
#include <rtsim/workloads/mesh_loader.h>
#include <rtsim/workloads/scene_registry.h>

#include <glm/gtc/matrix_transform.hpp>

#include <map>
#include <set>
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

// A mesh placed with a transform: one entry of what a [[mesh]] table brings (one
// mesh, or a track's meshes and instances).
struct Placement {
  uint32_t mesh;
  glm::mat4 transform;
};

// a * b, leaving the other exactly as it is when one is the identity: a track under
// an untransformed [[mesh]] keeps its own instance transforms bit for bit.
glm::mat4 compose(const glm::mat4& a, const glm::mat4& b) {
  if (a == glm::mat4(1.0f)) return b;
  if (b == glm::mat4(1.0f)) return a;
  return a * b;
}

}  // namespace

Scene read_scene_descriptor(const std::filesystem::path& path) {
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
  // With [[instance]] tables the [[mesh]] tables only define meshes (by name);
  // without, each [[mesh]] table places its file itself.
  std::vector<ConfigTable> instance_tables = root.array_of_tables("instance");
  const bool defines_only = !instance_tables.empty();
  // A file named by many [[mesh]] tables (instances with their own transforms) is
  // loaded once per set of load options: each load forks an assimp child (64 ms),
  // and 3,000 references took over a minute.
  using LoadKey = std::tuple<std::string, int, std::string, bool>;
  std::map<LoadKey, Mesh> loaded;
  // What a table's file brought, for a later table that may share it (below).
  std::map<std::pair<LoadKey, std::string>, std::vector<Placement>> shared;
  struct Definition {
    std::vector<Placement> placements;  // the table's transform applied
    std::vector<Camera> cameras;        // suggested by its file, the transform applied
  };
  std::map<std::string, Definition> definitions;
  std::vector<std::string> definition_names;  // in table order, for messages
  uint64_t scene_bytes = 0;  // vertices, triangles and material ids so far
  for (ConfigTable& t : meshes) {
    MeshOptions options;
    const std::string file_text = t.string("file");
    const std::filesystem::path file = path.parent_path() / file_text;
    const std::string name = t.string("name", file_text);
    options.bsp_patch_level = int(t.integer("patch_level", options.bsp_patch_level, 1, 64));
    options.pk3_map = t.string("map", "");
    options.bsp_drop_sky = t.boolean("drop_sky", options.bsp_drop_sky);
    const std::string override_material = t.string("material", "");
    const glm::mat4 transform = read_transform(t);
    t.finish();
    if (!override_material.empty() && !material_index.count(override_material))
      throw InputError(t.where("material"), "no [[material]] named '" + override_material + "'");
    if (defines_only && definitions.count(name))
      throw InputError(t.where(t.has("name") ? "name" : "file"),
                       "a [[mesh]] named '" + name + "' is defined twice (give each a distinct `name`)");

    std::error_code ec;
    const std::filesystem::path canonical = std::filesystem::weakly_canonical(file, ec);
    const LoadKey key((ec ? file : canonical).string(), options.bsp_patch_level, options.pk3_map,
                      options.bsp_drop_sky);
    auto found = loaded.find(key);
    if (found == loaded.end()) found = loaded.emplace(key, load_mesh(file, options)).first;
    const Mesh& mesh = found->second;
    dropped_sky_faces += mesh.dropped_sky_faces;
    dropped_tool_faces += mesh.dropped_tool_faces;

    // The meshes this table's file becomes. Each table adds the file's own materials
    // (and alpha textures) anew, so its triangles name their own copies: two tables
    // share meshes only where nothing of the sort differs, an overriding material or
    // a file with no materials.
    const bool shareable = !override_material.empty() || (mesh.materials.empty() && mesh.alpha_textures.empty());
    const auto share_key = std::make_pair(key, override_material);
    std::vector<Placement> placements;
    if (const auto it = shared.find(share_key); shareable && it != shared.end()) {
      placements = it->second;
    } else {
      scene_bytes = saturating_add(scene_bytes, saturating_add(saturating_mul(mesh.vertices.size(), sizeof(vec3)),
                                                               saturating_mul(mesh.triangles.size(), sizeof(uvec3) + 4)));
      check_memory_budget(scene_bytes, path.string(), "the vertices and triangles of every mesh file loaded");
      const uint32_t vertex_base = uint32_t(scene.vertices.size());
      const uint32_t triangle_base = uint32_t(scene.triangles.size());
      const uint32_t material_base = uint32_t(scene.materials.size());
      const uint32_t mesh_base = uint32_t(scene.meshes.size());
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
      // Untransformed: the instances carry the transforms (flatten applies them as
      // this loader once did, a mirroring one swapping vertices and coordinates).
      scene.vertices.insert(scene.vertices.end(), mesh.vertices.begin(), mesh.vertices.end());
      for (size_t i = 0; i < mesh.triangles.size(); ++i) {
        scene.triangles.push_back(mesh.triangles[i] + uvec3(vertex_base));
        uint32_t material = 0;
        if (!override_material.empty()) material = material_index[override_material];
        else if (!mesh.materials.empty() && i < mesh.material_ids.size())
          material = material_base + mesh.material_ids[i];
        else material = material_index.count("default") ? material_index["default"] : ~0u;
        scene.material_ids.push_back(material);
        if (keep_uvs)
          scene.triangle_uvs.push_back(alpha && i < mesh.triangle_uvs.size() ? mesh.triangle_uvs[i] : TriangleUv{});
      }
      if (override_material.empty())
        for (Material m : mesh.materials) {
          if (m.alpha_tested()) m.alpha_texture += texture_base;
          scene.materials.push_back(m);
        }
      if (mesh.instances.empty()) {
        scene.meshes.push_back({name, vertex_base, uint32_t(mesh.vertices.size()), triangle_base,
                                uint32_t(mesh.triangles.size())});
        placements.push_back({mesh_base, glm::mat4(1.0f)});
      } else {  // a track: its meshes, and its instances placing them
        for (const SceneMesh& m : mesh.meshes)
          scene.meshes.push_back({m.name, vertex_base + m.first_vertex, m.vertex_count, triangle_base + m.first_triangle,
                                  m.triangle_count});
        for (const Instance& i : mesh.instances) placements.push_back({mesh_base + i.mesh, i.object_to_world});
      }
      if (shareable) shared.emplace(share_key, placements);
    }
    for (Placement& p : placements) p.transform = compose(transform, p.transform);
    std::vector<Camera> cameras;
    for (Camera c : mesh.suggested_cameras) {
      c.position = vec3(transform * glm::vec4(c.position, 1.0f));
      c.target = vec3(transform * glm::vec4(c.target, 1.0f));
      cameras.push_back(c);
    }
    if (defines_only) {
      definition_names.push_back(name);
      definitions[name] = {std::move(placements), std::move(cameras)};
      continue;
    }
    for (const Placement& p : placements) scene.instances.push_back({p.mesh, p.transform});
    suggested.insert(suggested.end(), cameras.begin(), cameras.end());
  }

  // [[instance]]: a defined mesh placed once more, its transform after the mesh's own.
  std::set<std::string> placed;
  for (ConfigTable& t : instance_tables) {
    const std::string name = t.string("mesh");
    const glm::mat4 transform = read_transform(t);
    t.finish();
    const auto it = definitions.find(name);
    if (it == definitions.end()) {
      std::string known;
      for (const std::string& n : definition_names) known += (known.empty() ? "'" : ", '") + n + "'";
      throw InputError(t.where("mesh"), "no [[mesh]] named '" + name + "' (the [[mesh]] tables define " + known +
                                            "; a [[mesh]] without `name` is named by its `file`)");
    }
    for (const Placement& p : it->second.placements)
      scene.instances.push_back({p.mesh, compose(transform, p.transform)});
    // A mesh's suggested cameras (spawn points) follow its first instance.
    if (placed.insert(name).second)
      for (Camera c : it->second.cameras) {
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
  // One placement is no instancing: the scene is its flat form (the transform
  // applied as flatten applies it, which is how this loader always applied it).
  if (scene.instances.size() == 1) scene = flatten(scene);

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
  scene.validation.dropped_sky_faces = dropped_sky_faces;  // validation keeps them
  scene.validation.dropped_tool_faces = dropped_tool_faces;
  return scene;
}

Scene load_scene_descriptor(const std::filesystem::path& path, SceneForm form) {
  return scene_in_form(read_scene_descriptor(path), form);
}

}  // namespace rtsim
