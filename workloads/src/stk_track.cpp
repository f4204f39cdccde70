// SuperTuxKart: .spm meshes and scene.xml tracks (each model file a mesh, each
// placement an instance).
//
// Coordinates: STK (Irrlicht) is Y-up and left-handed. We mirror Z,
// (x, y, z) -> (x, y, -z), so the space is right-handed and the track is not
// seen mirror-imaged. After the mirror the file's triangles wind clockwise
// seen from the front (checked on the real tracks with the preview render:
// unreversed, every surface showed its back), so each triangle is reversed.
// Track transforms are composed in Irrlicht space and conjugated by the mirror.
#include "byte_reader.h"

#include <rtsim/workloads/alpha_texture.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/mesh_loader.h>
#include <rtsim/workloads/numbers.h>

#include <glm/gtc/matrix_transform.hpp>
#include <pugixml.hpp>

#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>

namespace rtsim {

namespace {

using detail::ByteCursor;
using detail::ByteReader;

constexpr uint8_t kSpmVersion = 1;
constexpr uint8_t kKindSkinned = 1, kKindStatic = 2;
constexpr float kQuadCameraHeight = 2.0f;
constexpr size_t kMaxQuadCameras = 16;
constexpr int kMaxLibraryDepth = 16;

vec3 mirror_z(const vec3& v) { return vec3(v.x, v.y, -v.z); }

// IEEE 754 binary16 to float: SPM stores texture coordinates as pairs of these.
float half_to_float(uint16_t h) {
  const int exponent = (h >> 10) & 0x1f;
  const uint32_t mantissa = h & 0x3ffu;
  float magnitude;
  if (exponent == 0) magnitude = std::ldexp(float(mantissa), -24);  // zero and subnormals
  else if (exponent == 31) magnitude = mantissa ? std::numeric_limits<float>::quiet_NaN()
                                                : std::numeric_limits<float>::infinity();
  else magnitude = std::ldexp(float(mantissa | 0x400u), exponent - 25);  // 1.m x 2^(e - 15)
  return (h & 0x8000u) ? -magnitude : magnitude;
}

}  // namespace

Mesh parse_spm(const std::vector<uint8_t>& bytes, const std::string& file_name) {
  const ByteReader reader(bytes, file_name);
  ByteCursor in(reader);
  if (in.read_string(2, "magic") != "SP") reader.fail(0, "not a SuperTuxKart mesh (magic is not \"SP\")");
  const uint8_t version_kind = in.read<uint8_t>("version/kind byte");
  const uint8_t version = version_kind >> 3, kind = version_kind & 0x07;
  if (version != kSpmVersion)
    reader.fail(2, "unsupported SPM version " + std::to_string(version) + " (expected 1)");
  if (kind != kKindSkinned && kind != kKindStatic)
    reader.fail(2, "unsupported SPM kind " + std::to_string(kind) +
                       " (1 skinned and 2 static are supported; 0 space-partitioned is not)");
  const uint8_t flags = in.read<uint8_t>("flags byte");
  const bool has_normal = flags & 0x1, has_colour = flags & 0x2, has_tangent = flags & 0x4;
  in.skip(24, "bounding box");

  Mesh mesh;
  struct MaterialInfo {
    bool uv1 = false, uv2 = false;
  };
  std::vector<MaterialInfo> material_info;
  const uint16_t material_count = in.read<uint16_t>("material count");
  for (uint16_t m = 0; m < material_count; ++m) {
    const std::string what = "material " + std::to_string(m);
    const uint8_t len1 = in.read<uint8_t>(what + " texture 1 name length");
    const std::string tex1 = in.read_string(len1, what + " texture 1 name");
    const uint8_t len2 = in.read<uint8_t>(what + " texture 2 name length");
    const std::string tex2 = in.read_string(len2, what + " texture 2 name");
    Material material;
    material.name = tex1.empty() ? "spm_untextured" : tex1;
    mesh.materials.push_back(material);
    material_info.push_back({!tex1.empty(), !tex2.empty()});
  }

  const uint16_t section_count = in.read<uint16_t>("section count");
  for (uint16_t s = 0; s < section_count; ++s) {
    const uint16_t buffer_count = in.read<uint16_t>("section " + std::to_string(s) + " buffer count");
    for (uint16_t b = 0; b < buffer_count; ++b) {
      const std::string where = "section " + std::to_string(s) + " buffer " + std::to_string(b);
      const uint64_t header_at = in.offset();
      const uint32_t vertex_count = in.read<uint32_t>(where + " vertex count");
      const uint32_t index_count = in.read<uint32_t>(where + " index count");
      const uint16_t material = in.read<uint16_t>(where + " material id");
      if (vertex_count > 65535)
        reader.fail(header_at, where + ": vertex count " + std::to_string(vertex_count) +
                                   " exceeds 65535 (16-bit indices)");
      if (index_count % 3 != 0)
        reader.fail(header_at + 4, where + ": index count " + std::to_string(index_count) +
                                       " is not a multiple of 3");
      if (material >= material_info.size())
        reader.fail(header_at + 8, where + ": material id " + std::to_string(material) +
                                       " out of range (" + std::to_string(material_info.size()) +
                                       " materials)");
      const MaterialInfo info = material_info[material];
      const uint32_t base = uint32_t(mesh.vertices.size());
      std::vector<glm::vec2> buffer_uvs(vertex_count, glm::vec2(0.0f));  // (0, 0) without a texture
      for (uint32_t v = 0; v < vertex_count; ++v) {
        const uint64_t vertex_at = in.offset();
        vec3 p;
        p.x = in.read<float>(where + " vertex position");
        p.y = in.read<float>(where + " vertex position");
        p.z = in.read<float>(where + " vertex position");
        if (!is_finite(p))
          reader.fail(vertex_at, where + ": vertex " + std::to_string(v) + " has a non-finite coordinate");
        mesh.vertices.push_back(mirror_z(p));
        if (has_normal) in.skip(4, where + " vertex normal");
        if (has_colour && in.read<uint8_t>(where + " vertex colour id") != 128)
          in.skip(3, where + " vertex colour");
        if (info.uv1) {
          // Two IEEE half floats, u then v (what STK's loader reads); one 4-byte read
          // so that a truncated file names the same field as before.
          const uint32_t packed = in.read<uint32_t>(where + " vertex uv");
          buffer_uvs[v] = glm::vec2(half_to_float(uint16_t(packed & 0xffffu)), half_to_float(uint16_t(packed >> 16)));
          if (info.uv2) in.skip(4, where + " vertex uv2");
          if (has_tangent) in.skip(4, where + " vertex tangent");
        }
        if (kind == kKindSkinned) in.skip(16, where + " vertex joints");
      }
      const bool wide = vertex_count > 255;
      for (uint32_t i = 0; i < index_count; i += 3) {
        uvec3 tri;
        for (int k = 0; k < 3; ++k) {
          const uint64_t index_at = in.offset();
          const uint32_t index = wide ? in.read<uint16_t>(where + " index") : in.read<uint8_t>(where + " index");
          if (index >= vertex_count)
            reader.fail(index_at, where + ": index " + std::to_string(i + k) + " = " + std::to_string(index) +
                                      " out of range (" + std::to_string(vertex_count) + " vertices)");
          tri[k] = base + index;
        }
        std::swap(tri.y, tri.z);  // clockwise after the mirror: make it counter-clockwise
        mesh.triangles.push_back(tri);
        mesh.triangle_uvs.push_back({buffer_uvs[tri.x - base], buffer_uvs[tri.y - base], buffer_uvs[tri.z - base]});
        mesh.material_ids.push_back(material);
      }
    }
  }
  // Skinned meshes continue with armature/animation data: not needed for the rest pose.
  return mesh;
}

namespace {

// Irrlicht's setRotationDegrees(x, y, z) is Rz * Ry * Rx acting on column vectors.
glm::mat4 irrlicht_rotation(const vec3& degrees) {
  glm::mat4 r(1.0f);
  r = glm::rotate(r, glm::radians(degrees.z), vec3(0, 0, 1));
  r = glm::rotate(r, glm::radians(degrees.y), vec3(0, 1, 0));
  r = glm::rotate(r, glm::radians(degrees.x), vec3(1, 0, 0));
  return r;
}

bool parse_vec3(const char* text, vec3& out) {
  std::istringstream in(text);
  in >> out.x >> out.y >> out.z;
  return bool(in) && is_finite(out);
}

std::string lower_ascii(std::string s) {
  for (char& c : s)
    if (c >= 'A' && c <= 'Z') c = char(c - 'A' + 'a');
  return s;
}

// STK's shader names whose foliage we alpha-test: "alphatest", and "grass" (its
// fragment shader discards below alpha 0.5 as alphatest's does; it only adds wind,
// which a still frame has not). "alphablend" (and "additive", "ghost") blend rather
// than cut, so a ray tracer's any-hit test would not reproduce them, and they stay
// opaque like every other shader here.
bool alpha_tested_shader(const std::string& shader) { return shader == "alphatest" || shader == "grass"; }

// Reads a track's scene.xml (and its libraries) into one Mesh of meshes and instances.
class TrackReader {
 public:
  // decode_textures false: find the alpha-tested textures' files but read none
  // (what `scenes fetch` needs to know which to copy); materials stay opaque.
  TrackReader(std::filesystem::path track_dir, bool decode_textures)
      : track_dir_(std::move(track_dir)), decode_textures_(decode_textures) {
    const std::filesystem::path data = track_dir_.parent_path().parent_path();
    library_dir_ = data / "library";
    textures_dir_ = data / "textures";
  }

  void read_scene(const std::filesystem::path& xml_path, const std::filesystem::path& model_dir,
                     const glm::mat4& parent, int depth) {
    pugi::xml_document doc;
    const std::string xml = read_input_file(xml_path, kMaxConfigFileBytes);  // bounded, regular files only
    const pugi::xml_parse_result parsed = doc.load_buffer(xml.data(), xml.size());
    if (!parsed)
      throw InputError(xml_path.string(), "XML error at byte " + std::to_string(parsed.offset) + ": " +
                                              parsed.description());
    const pugi::xml_node root = doc.child("scene");
    if (!root) throw InputError(xml_path.string(), "no <scene> element");
    const std::string file = xml_path.string();

    // LOD groups: a definition list, instanced by lod_instance objects. The most
    // detailed member is the one with the smallest switching distance.
    std::map<std::string, std::pair<double, std::string>> lod_models;
    for (pugi::xml_node group : root.child("lod").children("group"))
      for (pugi::xml_node member : group.children("static-object")) {
        const std::string model = member.attribute("model").as_string();
        if (model.empty()) continue;
        const double distance = member.attribute("lod_distance").as_double(1e30);
        auto& best = lod_models[group.attribute("name").as_string()];
        if (best.second.empty() || distance < best.first) best = {distance, model};
      }

    for (pugi::xml_node node : root.children()) {
      const std::string name = node.name();
      if (name == "track") {
        const vec3 at(node.attribute("x").as_float(0), node.attribute("y").as_float(0),
                      node.attribute("z").as_float(0));
        const std::string model = node.attribute("model").as_string();
        if (!model.empty())
          add_model(model_dir, model, parent * glm::translate(glm::mat4(1.0f), at), file);
        for (pugi::xml_node child : node.children("static-object"))
          add_object(child, model_dir, parent, lod_models, file);
      } else if (name == "object" || name == "static-object") {
        add_object(node, model_dir, parent, lod_models, file);
      } else if (name == "library") {
        const std::string library = node.attribute("name").as_string();
        if (library.empty()) throw InputError(file, "<library> without a name");
        if (library.rfind("gfx_", 0) == 0 || !shown(node)) continue;  // effects only / not shown
        if (depth >= kMaxLibraryDepth)
          throw InputError(file, "libraries nested deeper than " + std::to_string(kMaxLibraryDepth) +
                                     " (a cycle?) at library '" + library + "'");
        const std::filesystem::path dir = library_dir_ / library;
        if (!path_exists(dir / "node.xml"))
          throw InputError(file, "library '" + library + "' not found (" + (dir / "node.xml").string() + ")");
        read_scene(dir / "node.xml", dir, parent * object_transform(node, file), depth + 1);
      }
    }
  }

  Mesh take() {
    mesh_.alpha_textures_missing = missing_textures_.size();
    // Coordinates only matter to alpha tests: an opaque track carries none.
    if (mesh_.alpha_textures.empty()) mesh_.triangle_uvs = {};
    return std::move(mesh_);
  }

  const std::set<std::filesystem::path>& texture_files() const { return texture_files_; }

 private:
  // Reverse-only and disabled objects are not part of the normal race.
  static bool shown(const pugi::xml_node& node) {
    const std::string condition = node.attribute("if").as_string();
    return condition != "isTrackReverse" && condition != "false";
  }

  glm::mat4 object_transform(const pugi::xml_node& node, const std::string& file) const {
    vec3 xyz(0.0f), hpr(0.0f), scale(1.0f);
    const char* keys[3] = {"xyz", "hpr", "scale"};
    vec3* values[3] = {&xyz, &hpr, &scale};
    for (int k = 0; k < 3; ++k)
      if (pugi::xml_attribute a = node.attribute(keys[k]); a && !parse_vec3(a.value(), *values[k]))
        throw InputError(file, std::string("<") + node.name() + " id=\"" + node.attribute("id").as_string() +
                                   "\"> attribute " + keys[k] + "=\"" + a.value() +
                                   "\" is not three finite numbers");
    return glm::translate(glm::mat4(1.0f), xyz) * irrlicht_rotation(hpr) * glm::scale(glm::mat4(1.0f), scale);
  }

  void add_object(const pugi::xml_node& node, const std::filesystem::path& model_dir,
                  const glm::mat4& parent,
                  const std::map<std::string, std::pair<double, std::string>>& lod_models,
                  const std::string& file) {
    const std::string interaction = node.attribute("interaction").as_string();
    if (interaction == "physics-only" || interaction == "physicsonly" || !shown(node)) return;
    std::string model = node.attribute("model").as_string();
    if (node.attribute("lod_instance").as_bool(false)) {
      const auto it = lod_models.find(node.attribute("lod_group").as_string());
      if (it == lod_models.end())
        throw InputError(file, std::string("lod_instance of unknown lod_group '") +
                                   node.attribute("lod_group").as_string() + "'");
      model = it->second.second;
    }
    if (model.empty()) return;  // billboards, sound and particle emitters: no geometry
    add_model(model_dir, model, parent * object_transform(node, file), file);
  }

  // A model file of the folder model_dir (a track's or a library object's): its mesh
  // (added at its first placement) and one instance placing it.
  void add_model(const std::filesystem::path& model_dir, const std::string& model_name,
                 const glm::mat4& irrlicht_transform, const std::string& referenced_by) {
    const std::filesystem::path path = model_dir / model_name;
    auto it = models_.find(path.string());
    if (it == models_.end()) {
      if (!path_exists(path))
        throw InputError(referenced_by, "model '" + path.filename().string() + "' not found (" +
                                            path.string() + ")");
      // A model is one mesh: one that brings instances of its own is placed flat.
      auto loaded = std::make_unique<Mesh>(flatten(load_mesh(path)));
      adopt_alpha_textures(*loaded, model_dir);
      it = models_.emplace(path.string(), Model{std::move(loaded), ~0u}).first;
    }
    Model& model = it->second;
    // Models are already mirrored; M in Irrlicht space acts as F*M*F on mirrored points.
    const glm::mat4 mirror = glm::scale(glm::mat4(1.0f), vec3(1, 1, -1));
    const glm::mat4 transform = mirror * irrlicht_transform * mirror;
    if (!instance_transform_problem(transform).empty()) {
      // STK collapses objects with a zero scale; no instance can hold that, so the
      // placed copy becomes a mesh of its own, in world space.
      mesh_.instances.push_back({add_mesh(*model.mesh, path.string() + " (placed flat)", &transform), glm::mat4(1.0f)});
      return;
    }
    if (model.index == ~0u) model.index = add_mesh(*model.mesh, path.string(), nullptr);
    mesh_.instances.push_back({model.index, transform});
  }

  // Appends a model's vertices and triangles as a mesh, its materials mapped into
  // the track's (materials first met here are added, as the flat track added them).
  // bake: the transform to apply to the vertices (a placed-flat copy), else none.
  uint32_t add_mesh(const Mesh& model, const std::string& name, const glm::mat4* bake) {
    std::vector<uint32_t> material_map(model.materials.size());
    for (size_t m = 0; m < model.materials.size(); ++m) {
      // By name and texture: one name can be alpha-tested with different files in
      // two objects' folders (or alpha-tested in one and opaque in another).
      const Material& material = model.materials[m];
      const std::pair<std::string, int32_t> key(material.name, material.alpha_texture);
      auto found = material_index_.find(key);
      if (found == material_index_.end()) {
        found = material_index_.emplace(key, uint32_t(mesh_.materials.size())).first;
        mesh_.materials.push_back(material);
      }
      material_map[m] = found->second;
    }
    SceneMesh mesh;
    mesh.name = name;
    mesh.first_vertex = uint32_t(mesh_.vertices.size());
    mesh.vertex_count = uint32_t(model.vertices.size());
    mesh.first_triangle = uint32_t(mesh_.triangles.size());
    mesh.triangle_count = uint32_t(model.triangles.size());
    // The flat track's expressions: a baked copy is the very vertices it had there.
    const bool flips = bake && glm::determinant(glm::mat3(*bake)) < 0.0f;
    for (const vec3& v : model.vertices) mesh_.vertices.push_back(bake ? vec3(*bake * glm::vec4(v, 1.0f)) : v);
    for (size_t t = 0; t < model.triangles.size(); ++t) {
      uvec3 tri = model.triangles[t] + uvec3(mesh.first_vertex);
      TriangleUv uv = t < model.triangle_uvs.size() ? model.triangle_uvs[t] : TriangleUv{};
      if (flips) std::swap(tri.y, tri.z), std::swap(uv[1], uv[2]);  // the coordinates follow their vertices
      mesh_.triangles.push_back(tri);
      mesh_.triangle_uvs.push_back(uv);
      mesh_.material_ids.push_back(t < model.material_ids.size() && model.material_ids[t] < material_map.size()
                                       ? material_map[model.material_ids[t]]
                                       : 0);
    }
    if (mesh_.materials.empty()) mesh_.materials.push_back(Material{});
    mesh_.meshes.push_back(std::move(mesh));
    return uint32_t(mesh_.meshes.size() - 1);
  }

  // Gives a freshly loaded model's materials their alpha textures, as indices into
  // mesh_.alpha_textures (so models_ hold flattened indices): textures the loader
  // brought are merged by file; an SPM's materials are looked up in materials.xml.
  void adopt_alpha_textures(Mesh& model, const std::filesystem::path& model_dir) {
    std::vector<int32_t> remap(model.alpha_textures.size());
    for (size_t i = 0; i < model.alpha_textures.size(); ++i) {
      const std::string file = model.alpha_textures[i].file;
      int32_t& index = texture_index_.try_emplace(file, -1).first->second;
      if (index < 0) {  // new, or a file that an earlier lookup could not decode
        index = int32_t(mesh_.alpha_textures.size());
        mesh_.alpha_textures.push_back(std::move(model.alpha_textures[i]));
      }
      remap[i] = index;
    }
    model.alpha_textures.clear();
    for (Material& m : model.materials) {
      if (m.alpha_tested()) {
        m.alpha_texture = size_t(m.alpha_texture) < remap.size() ? remap[size_t(m.alpha_texture)] : -1;
        continue;
      }
      if (!alpha_tested_shader(stk_shader(m.name, model_dir))) continue;
      const std::filesystem::path file = find_texture(m.name, model_dir);
      if (file.empty()) {
        missing_textures_.insert("not found: " + m.name);
        continue;
      }
      m.alpha_texture = texture_index(file);
      m.alpha_cutoff = 0.5f;  // STK's alpha test discards alpha < 0.5 (sp_alpha_test.frag)
    }
  }

  // The folders STK looks a texture up in, first match wins: the object's own
  // (the track's for the track's models), the track's, then the global textures
  // (data/textures/deprecated is pushed after data/textures, so searched first).
  // The skybox and GUI icon folders, also on STK's path, hold no foliage.
  std::vector<std::filesystem::path> search_folders(const std::filesystem::path& model_dir) const {
    std::vector<std::filesystem::path> folders{model_dir};
    if (model_dir != track_dir_) folders.push_back(track_dir_);
    folders.push_back(textures_dir_ / "deprecated");
    folders.push_back(textures_dir_);
    return folders;
  }

  // The shader of the material STK gives texture `name` (matched in lower case,
  // as STK does), from the first materials.xml that lists it; "" if none does.
  std::string stk_shader(const std::string& name, const std::filesystem::path& model_dir) {
    const std::string key = lower_ascii(std::filesystem::path(name).filename().string());
    for (const std::filesystem::path& folder : search_folders(model_dir)) {
      const auto& table = materials_in(folder);
      if (const auto it = table.find(key); it != table.end()) return it->second;
    }
    return "";
  }

  // name (lower case) -> shader of a folder's materials.xml; empty without one.
  const std::map<std::string, std::string>& materials_in(const std::filesystem::path& folder) {
    auto it = material_files_.find(folder.string());
    if (it != material_files_.end()) return it->second;
    std::map<std::string, std::string> table;
    const std::filesystem::path file = folder / "materials.xml";
    if (is_file(file)) {
      pugi::xml_document doc;
      const std::string xml = read_input_file(file, kMaxConfigFileBytes);
      const pugi::xml_parse_result parsed = doc.load_buffer(xml.data(), xml.size());
      if (!parsed)
        throw InputError(file.string(), "XML error at byte " + std::to_string(parsed.offset) + ": " +
                                            parsed.description());
      // A name listed twice: the later entry wins, as STK searches its list backwards.
      for (pugi::xml_node m : doc.child("materials").children("material"))
        if (const std::string name = m.attribute("name").as_string(); !name.empty())
          table[lower_ascii(name)] = m.attribute("shader").as_string();
    }
    return material_files_.emplace(folder.string(), std::move(table)).first->second;
  }

  std::filesystem::path find_texture(const std::string& name, const std::filesystem::path& model_dir) const {
    const std::filesystem::path file_name = std::filesystem::path(name).filename();
    if (file_name.empty()) return {};
    for (const std::filesystem::path& folder : search_folders(model_dir))
      if (is_file(folder / file_name)) return (folder / file_name).lexically_normal();
    return {};
  }

  // The texture read from `file` (once per file), or -1 if it cannot be read or
  // decoded: then the material stays opaque and the file is counted as missing.
  int32_t texture_index(const std::filesystem::path& file) {
    texture_files_.insert(file);
    if (!decode_textures_) return -1;
    if (const auto it = texture_index_.find(file.string()); it != texture_index_.end()) return it->second;
    int32_t index = -1;
    try {
      AlphaTexture texture = read_alpha_texture(file);
      index = int32_t(mesh_.alpha_textures.size());
      mesh_.alpha_textures.push_back(std::move(texture));
    } catch (const InputError&) {
      missing_textures_.insert(file.string());
    }
    texture_index_.emplace(file.string(), index);
    return index;
  }

  std::filesystem::path track_dir_, library_dir_, textures_dir_;
  bool decode_textures_;
  struct Model {
    std::unique_ptr<Mesh> mesh;  // as loaded, its alpha textures adopted
    uint32_t index;              // its mesh in mesh_.meshes, ~0u until first placed
  };
  std::map<std::string, Model> models_;
  std::map<std::pair<std::string, int32_t>, uint32_t> material_index_;
  std::map<std::string, std::map<std::string, std::string>> material_files_;  // by folder
  std::map<std::string, int32_t> texture_index_;  // file -> mesh_.alpha_textures index, -1 unreadable
  std::set<std::string> missing_textures_;  // files unreadable, or names found nowhere
  std::set<std::filesystem::path> texture_files_;  // every alpha-tested texture file found
  Mesh mesh_;
};

// Cameras on the driveline: quad centres 2 units up, each looking a few quads ahead.
std::vector<Camera> quad_cameras(const std::filesystem::path& quads_path) {
  std::vector<Camera> cameras;
  if (!path_exists(quads_path)) return cameras;
  pugi::xml_document doc;
  const pugi::xml_parse_result parsed = doc.load_file(quads_path.string().c_str());
  if (!parsed)
    throw InputError(quads_path.string(), "XML error at byte " + std::to_string(parsed.offset) + ": " +
                                              parsed.description());
  std::vector<std::array<vec3, 4>> quads;
  for (pugi::xml_node quad : doc.child("quads").children("quad")) {
    std::array<vec3, 4> corners;
    for (int k = 0; k < 4; ++k) {
      const std::string key = "p" + std::to_string(k);
      const std::string text = quad.attribute(key.c_str()).as_string();
      const std::string where = "quad " + std::to_string(quads.size()) + " " + key + "=\"" + text + "\"";
      // "i:j" refers to corner j of quad i.
      if (const size_t colon = text.find(':'); colon != std::string::npos) {
        uint64_t q = 0, c = 0;
        if (!parse_unsigned(std::string_view(text).substr(0, colon), 0, UINT64_MAX, q) ||
            !parse_unsigned(std::string_view(text).substr(colon + 1), 0, UINT64_MAX, c))
          throw InputError(quads_path.string(), where + ": expected i:j, two whole numbers (decimal digits only)");
        if (q >= quads.size() || c > 3)
          throw InputError(quads_path.string(), where + ": refers to a quad corner that does not exist yet");
        corners[size_t(k)] = quads[size_t(q)][size_t(c)];
      } else if (!parse_vec3(text.c_str(), corners[size_t(k)])) {
        throw InputError(quads_path.string(), where + ": not three finite numbers");
      }
    }
    quads.push_back(corners);
  }
  if (quads.empty()) return cameras;
  const size_t step = std::max<size_t>(1, quads.size() / kMaxQuadCameras);
  for (size_t q = 0; q < quads.size() && cameras.size() < kMaxQuadCameras; q += step) {
    auto centre = [&](size_t i) {
      const auto& c = quads[i % quads.size()];
      return mirror_z((c[0] + c[1] + c[2] + c[3]) * 0.25f + vec3(0.0f, kQuadCameraHeight, 0.0f));
    };
    Camera camera;
    camera.name = "quad" + std::to_string(q);
    camera.position = centre(q);
    // Look along the driveline: a few quads ahead, or back along it at the end.
    const size_t ahead = std::min(q + 3, quads.size() - 1);
    camera.target = ahead != q ? centre(ahead) : 2.0f * camera.position - centre(q > 0 ? q - 1 : q);
    if (glm::length(camera.target - camera.position) < 1e-3f) camera.target = camera.position + vec3(0, 0, -1);
    camera.target.y = camera.position.y;  // level view: driveline slopes tilt the horizon otherwise
    if (glm::length(camera.target - camera.position) < 1e-3f) camera.target = camera.position + vec3(0, 0, -1);
    cameras.push_back(camera);
  }
  return cameras;
}

}  // namespace

Mesh load_stk_track(const std::filesystem::path& track_dir) {
  const std::filesystem::path scene_xml = track_dir / "scene.xml";
  if (!path_exists(scene_xml)) throw InputError(track_dir.string(), "no scene.xml in this folder");
  TrackReader reader(track_dir, true);
  reader.read_scene(scene_xml, track_dir, glm::mat4(1.0f), 0);
  Mesh mesh = reader.take();
  uint64_t placed = 0;
  for (const Instance& i : mesh.instances) placed += mesh.meshes[i.mesh].triangle_count;
  if (placed == 0) throw InputError(scene_xml.string(), "the track has no geometry");
  mesh.suggested_cameras = quad_cameras(track_dir / "quads.xml");
  return mesh;
}

std::vector<std::filesystem::path> stk_track_alpha_texture_files(const std::filesystem::path& track_dir) {
  const std::filesystem::path scene_xml = track_dir / "scene.xml";
  if (!path_exists(scene_xml)) throw InputError(track_dir.string(), "no scene.xml in this folder");
  TrackReader reader(track_dir, false);
  reader.read_scene(scene_xml, track_dir, glm::mat4(1.0f), 0);
  const auto& files = reader.texture_files();
  return {files.begin(), files.end()};
}

}  // namespace rtsim
