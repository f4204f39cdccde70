// Quake 3 IBSP version 46 levels (OpenArena maps): polygon and mesh faces,
// Bezier patches tessellated to triangles, spawn points as cameras.
//
// Coordinates: Quake 3 is Z-up; we return Y-up via (x, y, z) -> (x, z, -y), a
// proper rotation, so handedness is kept. Quake 3 faces are clockwise seen
// from the front, so every polygon/mesh triangle is reversed here.
#include "byte_reader.h"

#include <rtsim/workloads/mesh_loader.h>

#include <cmath>
#include <map>

namespace rtsim {

namespace {

using detail::ByteReader;

constexpr int kLumpCount = 17;
constexpr uint32_t kHeaderSize = 8 + kLumpCount * 8;
const char* const kLumpNames[kLumpCount] = {
    "entities", "textures", "planes",  "nodes",   "leafs",     "leaffaces",
    "leafbrushes", "models", "brushes", "brushsides", "vertexes", "meshverts",
    "effects",  "faces",    "lightmaps", "lightvols", "visdata"};
enum Lump { kEntities = 0, kTextures = 1, kVertexes = 10, kMeshverts = 11, kFaces = 13 };
// Vertex: position[3] at 0, texcoord[2][2] at 12, normal[3] at 28, colour[4] at 40.
constexpr uint32_t kTextureSize = 72, kVertexSize = 44, kFaceSize = 104;
constexpr int32_t kSurfaceSky = 0x4;
constexpr float kSpawnEyeHeight = 40.0f;  // Quake units above a spawn origin

vec3 to_y_up(const vec3& q3) { return vec3(q3.x, q3.z, -q3.y); }

struct LumpRange {
  uint32_t offset = 0, length = 0;
};

struct Texture {
  std::string name;
  int32_t flags = 0;
};

struct BspVertex {
  vec3 position;
  vec3 normal;
};

// Reads a lump's directory entry and checks it against the buffer and its record size.
LumpRange read_lump(const ByteReader& in, int index, uint32_t record_size) {
  const uint64_t entry = 8 + uint64_t(index) * 8;
  const int32_t offset = in.at<int32_t>(entry, std::string("lump ") + kLumpNames[index] + " offset");
  const int32_t length = in.at<int32_t>(entry + 4, std::string("lump ") + kLumpNames[index] + " length");
  const std::string name = std::string("lump ") + std::to_string(index) + " (" + kLumpNames[index] + ")";
  if (offset < 0 || length < 0)
    in.fail(entry, name + ": negative offset " + std::to_string(offset) + " or length " +
                       std::to_string(length));
  if (uint64_t(offset) + uint64_t(length) > in.size())
    in.fail(entry, name + ": range [" + std::to_string(offset) + ", " +
                       std::to_string(uint64_t(offset) + uint64_t(length)) +
                       ") lies outside the file (" + std::to_string(in.size()) + " bytes)");
  if (record_size > 1 && uint32_t(length) % record_size != 0)
    in.fail(entry, name + ": length " + std::to_string(length) + " is not a multiple of the " +
                       std::to_string(record_size) + "-byte record");
  return {uint32_t(offset), uint32_t(length)};
}

// The entity lump is text: { "key" "value" ... } blocks.
using Entity = std::map<std::string, std::string>;

std::vector<Entity> parse_entities(const ByteReader& in, LumpRange lump) {
  const char* text = reinterpret_cast<const char*>(in.data(lump.offset));
  const size_t n = lump.length;
  std::vector<Entity> entities;
  size_t i = 0;
  auto skip_space = [&] {
    while (i < n && (text[i] == ' ' || text[i] == '\t' || text[i] == '\n' || text[i] == '\r')) ++i;
  };
  auto fail = [&](const std::string& reason) {
    in.fail(lump.offset + i, "lump 0 (entities): " + reason);
  };
  auto quoted = [&]() {
    if (i >= n || text[i] != '"') fail("expected a quoted string");
    const size_t start = ++i;
    while (i < n && text[i] != '"' && text[i] != '\0') ++i;
    if (i >= n || text[i] != '"') fail("unterminated string");
    return std::string(text + start, i++ - start);
  };
  while (true) {
    skip_space();
    if (i >= n || text[i] == '\0') break;  // the lump is NUL-terminated in real files
    if (text[i] != '{') fail(std::string("expected '{', found '") + text[i] + "'");
    ++i;
    Entity entity;
    while (true) {
      skip_space();
      if (i >= n) fail("entity not closed with '}'");
      if (text[i] == '}') {
        ++i;
        break;
      }
      std::string key = quoted();
      skip_space();
      entity[key] = quoted();
    }
    entities.push_back(std::move(entity));
  }
  return entities;
}

bool parse_floats(const std::string& s, float* out, int count) {
  const char* p = s.c_str();
  for (int k = 0; k < count; ++k) {
    char* end = nullptr;
    out[k] = std::strtof(p, &end);
    if (end == p || !std::isfinite(out[k])) return false;
    p = end;
  }
  return true;
}

std::vector<Camera> spawn_cameras(const ByteReader& in, LumpRange lump) {
  std::vector<Camera> cameras;
  for (const Entity& e : parse_entities(in, lump)) {
    const auto cls = e.find("classname");
    if (cls == e.end() || cls->second.rfind("info_player_", 0) != 0) continue;
    const auto origin = e.find("origin");
    float o[3];
    if (origin == e.end() || !parse_floats(origin->second, o, 3))
      throw InputError(in.file(), "lump 0 (entities): " + cls->second +
                                      " has no valid \"origin\" (three numbers)");
    float yaw_deg = 0.0f, pitch_deg = 0.0f;
    if (const auto angle = e.find("angle"); angle != e.end()) parse_floats(angle->second, &yaw_deg, 1);
    if (const auto angles = e.find("angles"); angles != e.end()) {
      float a[3];
      if (parse_floats(angles->second, a, 3)) pitch_deg = a[0], yaw_deg = a[1];
    }
    const float yaw = glm::radians(yaw_deg), pitch = glm::radians(pitch_deg);
    // Quake: yaw around +Z from +X, positive pitch looks down.
    const vec3 look_q3(std::cos(yaw) * std::cos(pitch), std::sin(yaw) * std::cos(pitch), -std::sin(pitch));
    Camera camera;
    const vec3 eye_q3 = vec3(o[0], o[1], o[2] + kSpawnEyeHeight);
    camera.position = to_y_up(eye_q3);
    camera.target = to_y_up(eye_q3 + 100.0f * look_q3);
    camera.up = vec3(0.0f, 1.0f, 0.0f);
    camera.vertical_fov_deg = 70.0f;
    cameras.push_back(camera);
  }
  return cameras;
}

// Quadratic Bernstein weights at t.
inline void bernstein2(float t, float w[3]) {
  const float s = 1.0f - t;
  w[0] = s * s;
  w[1] = 2.0f * s * t;
  w[2] = t * t;
}

// Tessellates one 3x3 biquadratic patch into (level+1)^2 vertices and 2*level^2
// triangles, oriented to agree with the control points' normals (the file's
// normals are the one reliable statement of which side is the front).
void tessellate_patch(const BspVertex* control[3][3], int level, std::vector<vec3>& vertices,
                      std::vector<uvec3>& triangles, std::vector<uint32_t>& material_ids,
                      uint32_t material) {
  const uint32_t base = uint32_t(vertices.size());
  std::vector<vec3> normals;
  normals.reserve(size_t(level + 1) * (level + 1));
  for (int r = 0; r <= level; ++r) {
    float wv[3];
    bernstein2(float(r) / float(level), wv);
    for (int c = 0; c <= level; ++c) {
      float wu[3];
      bernstein2(float(c) / float(level), wu);
      vec3 p(0.0f), n(0.0f);
      for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i) {
          p += (wv[j] * wu[i]) * control[j][i]->position;
          n += (wv[j] * wu[i]) * control[j][i]->normal;
        }
      vertices.push_back(p);
      normals.push_back(n);
    }
  }
  const uint32_t stride = uint32_t(level + 1);
  const size_t first = triangles.size();
  double agreement = 0.0;
  for (int r = 0; r < level; ++r)
    for (int c = 0; c < level; ++c) {
      const uint32_t a = base + uint32_t(r) * stride + uint32_t(c);
      const uint32_t b = a + 1, d = a + stride, e = d + 1;
      for (const uvec3 tri : {uvec3(a, b, e), uvec3(a, e, d)}) {
        const vec3 geometric = glm::cross(vertices[tri.y] - vertices[tri.x], vertices[tri.z] - vertices[tri.x]);
        const vec3 smooth = normals[tri.x - base] + normals[tri.y - base] + normals[tri.z - base];
        agreement += double(glm::dot(geometric, smooth));
        triangles.push_back(tri);
        material_ids.push_back(material);
      }
    }
  if (agreement < 0.0)
    for (size_t t = first; t < triangles.size(); ++t) std::swap(triangles[t].y, triangles[t].z);
}

}  // namespace

Mesh parse_q3bsp(const std::vector<uint8_t>& bytes, const std::string& file_name,
                 const MeshOptions& options) {
  const ByteReader in(bytes, file_name);
  in.require(0, kHeaderSize, "header");
  if (std::memcmp(in.data(0), "IBSP", 4) != 0) in.fail(0, "not a Quake 3 level (magic is not \"IBSP\")");
  const int32_t version = in.at<int32_t>(4, "version");
  if (version != 46)
    in.fail(4, "unsupported IBSP version " + std::to_string(version) + " (expected 46, Quake 3)");
  if (options.bsp_patch_level < 1 || options.bsp_patch_level > 64)
    throw InputError(file_name, "patch level " + std::to_string(options.bsp_patch_level) +
                                    " is outside [1, 64]");

  const LumpRange entity_lump = read_lump(in, kEntities, 1);
  const LumpRange texture_lump = read_lump(in, kTextures, kTextureSize);
  const LumpRange vertex_lump = read_lump(in, kVertexes, kVertexSize);
  const LumpRange meshvert_lump = read_lump(in, kMeshverts, 4);
  const LumpRange face_lump = read_lump(in, kFaces, kFaceSize);

  std::vector<Texture> textures(texture_lump.length / kTextureSize);
  for (size_t t = 0; t < textures.size(); ++t) {
    const uint64_t at = texture_lump.offset + t * kTextureSize;
    const char* name = reinterpret_cast<const char*>(in.data(at));
    textures[t].name.assign(name, strnlen(name, 64));
    textures[t].flags = in.at<int32_t>(at + 64, "texture flags");
  }

  const size_t vertex_count = vertex_lump.length / kVertexSize;
  std::vector<BspVertex> bsp_vertices(vertex_count);
  for (size_t v = 0; v < vertex_count; ++v) {
    const uint64_t at = vertex_lump.offset + v * kVertexSize;
    for (int k = 0; k < 3; ++k) {
      bsp_vertices[v].position[k] = in.at<float>(at + 4 * k, "vertex position");
      bsp_vertices[v].normal[k] = in.at<float>(at + 28 + 4 * k, "vertex normal");
    }
    if (!is_finite(bsp_vertices[v].position))
      in.fail(at, "lump 10 (vertexes): vertex " + std::to_string(v) + " has a non-finite coordinate");
    if (!is_finite(bsp_vertices[v].normal)) bsp_vertices[v].normal = vec3(0.0f);
  }
  const size_t meshvert_count = meshvert_lump.length / 4;

  Mesh mesh;
  std::map<int32_t, uint32_t> material_of_texture;
  auto material_for = [&](int32_t texture) {
    auto it = material_of_texture.find(texture);
    if (it != material_of_texture.end()) return it->second;
    Material m;
    m.name = textures[size_t(texture)].name;
    mesh.materials.push_back(m);
    return material_of_texture[texture] = uint32_t(mesh.materials.size() - 1);
  };
  // Polygon/mesh faces reference the file's vertices directly; they are appended
  // first, and patch vertices (generated) after them.
  for (const BspVertex& v : bsp_vertices) mesh.vertices.push_back(v.position);

  const size_t face_count = face_lump.length / kFaceSize;
  const int level = options.bsp_patch_level;
  for (size_t f = 0; f < face_count; ++f) {
    const uint64_t at = face_lump.offset + f * kFaceSize;
    const std::string face = "lump 13 (faces): face " + std::to_string(f);
    const int32_t texture = in.at<int32_t>(at + 0, "face texture");
    const int32_t type = in.at<int32_t>(at + 8, "face type");
    const int32_t vertex = in.at<int32_t>(at + 12, "face vertex");
    const int32_t n_vertices = in.at<int32_t>(at + 16, "face n_vertexes");
    const int32_t meshvert = in.at<int32_t>(at + 20, "face meshvert");
    const int32_t n_meshverts = in.at<int32_t>(at + 24, "face n_meshverts");
    const int32_t size_x = in.at<int32_t>(at + 96, "face size[0]");
    const int32_t size_y = in.at<int32_t>(at + 100, "face size[1]");

    if (type < 1 || type > 4) in.fail(at + 8, face + ": unknown face type " + std::to_string(type));
    if (type == 4) continue;  // billboard sprite: no surface
    if (texture < 0 || size_t(texture) >= textures.size())
      in.fail(at, face + ": texture index " + std::to_string(texture) + " out of range (" +
                      std::to_string(textures.size()) + " textures)");
    const Texture& tex = textures[size_t(texture)];
    if (tex.name.rfind("textures/common/", 0) == 0) {  // clip, caulk, triggers...
      ++mesh.dropped_tool_faces;
      continue;
    }
    if (options.bsp_drop_sky && (tex.flags & kSurfaceSky)) {
      ++mesh.dropped_sky_faces;
      continue;
    }
    if (vertex < 0 || n_vertices < 0 || uint64_t(vertex) + uint64_t(n_vertices) > vertex_count)
      in.fail(at + 12, face + ": vertices [" + std::to_string(vertex) + ", +" +
                           std::to_string(n_vertices) + ") out of range (" +
                           std::to_string(vertex_count) + " vertices)");
    const uint32_t material = material_for(texture);

    if (type == 1 || type == 3) {
      if (meshvert < 0 || n_meshverts < 0 || uint64_t(meshvert) + uint64_t(n_meshverts) > meshvert_count)
        in.fail(at + 20, face + ": meshverts [" + std::to_string(meshvert) + ", +" +
                             std::to_string(n_meshverts) + ") out of range (" +
                             std::to_string(meshvert_count) + " meshverts)");
      if (n_meshverts % 3 != 0)
        in.fail(at + 24, face + ": n_meshverts " + std::to_string(n_meshverts) + " is not a multiple of 3");
      uint32_t corner[3];
      for (int32_t k = 0; k < n_meshverts; ++k) {
        const int32_t offset =
            in.at<int32_t>(meshvert_lump.offset + 4 * (uint64_t(meshvert) + uint64_t(k)), "meshvert");
        if (offset < 0 || offset >= n_vertices)
          in.fail(meshvert_lump.offset + 4 * (uint64_t(meshvert) + uint64_t(k)),
                  face + ": meshvert " + std::to_string(meshvert + k) + " = " + std::to_string(offset) +
                      " is outside the face's " + std::to_string(n_vertices) + " vertices");
        corner[k % 3] = uint32_t(vertex + offset);
        if (k % 3 == 2) {
          // Clockwise in the file: swap two corners for counter-clockwise.
          mesh.triangles.emplace_back(corner[0], corner[2], corner[1]);
          mesh.material_ids.push_back(material);
        }
      }
    } else {  // type 2: Bezier patch grid
      if (size_x < 3 || size_y < 3 || size_x % 2 == 0 || size_y % 2 == 0)
        in.fail(at + 96, face + ": patch size " + std::to_string(size_x) + " x " +
                             std::to_string(size_y) + " is not odd and at least 3 x 3");
      if (int64_t(size_x) * int64_t(size_y) > int64_t(n_vertices))
        in.fail(at + 96, face + ": patch size " + std::to_string(size_x) + " x " +
                             std::to_string(size_y) + " needs more than its " +
                             std::to_string(n_vertices) + " vertices");
      for (int32_t py = 0; py + 2 < size_y; py += 2)
        for (int32_t px = 0; px + 2 < size_x; px += 2) {
          const BspVertex* control[3][3];
          for (int j = 0; j < 3; ++j)
            for (int i = 0; i < 3; ++i)
              control[j][i] = &bsp_vertices[size_t(vertex) + size_t(py + j) * size_t(size_x) + size_t(px + i)];
          tessellate_patch(control, level, mesh.vertices, mesh.triangles, mesh.material_ids, material);
        }
    }
  }
  if (mesh.triangles.empty()) throw InputError(file_name, "no drawable faces (all skipped or none present)");
  for (vec3& v : mesh.vertices) v = to_y_up(v);
  mesh.suggested_cameras = spawn_cameras(in, entity_lump);
  return mesh;
}

}  // namespace rtsim
