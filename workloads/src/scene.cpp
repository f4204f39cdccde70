#include <rtsim/workloads/error.h>
#include <rtsim/workloads/host.h>
#include <rtsim/workloads/random.h>
#include <rtsim/workloads/scene.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <tuple>

namespace rtsim {

Camera::Ray Camera::primary_ray(uint32_t x, uint32_t y, uint32_t width, uint32_t height,
                                float jitter_x, float jitter_y) const {
  const vec3 forward = glm::normalize(target - position);
  vec3 right = glm::cross(forward, up);
  // A camera looking along `up` has no defined right vector; pick any perpendicular.
  if (glm::dot(right, right) < 1e-12f) right = glm::cross(forward, vec3(1, 0, 0));
  if (glm::dot(right, right) < 1e-12f) right = glm::cross(forward, vec3(0, 0, 1));
  right = glm::normalize(right);
  const vec3 true_up = glm::cross(right, forward);
  const float tan_half = std::tan(glm::radians(vertical_fov_deg) * 0.5f);
  const float aspect = float(width) / float(height);
  const float sx = (2.0f * (float(x) + jitter_x) / float(width) - 1.0f) * tan_half * aspect;
  const float sy = (1.0f - 2.0f * (float(y) + jitter_y) / float(height)) * tan_half;
  return {position, glm::normalize(forward + sx * right + sy * true_up)};
}

namespace {

// The object-space box of a mesh's triangles (not of its vertex range: a vertex no
// triangle uses is no surface, as in a flat scene's bounds).
Aabb mesh_object_bounds(const Scene& scene, const SceneMesh& mesh) {
  Aabb box;
  for (uint32_t t = mesh.first_triangle; t < mesh.first_triangle + mesh.triangle_count; ++t)
    for (int k = 0; k < 3; ++k) box.extend(scene.vertex(t, k));
  return box;
}

}  // namespace

Aabb transformed_box(const Aabb& box, const glm::mat4& m) {
  Aabb out;
  if (box.empty()) return out;
  for (int c = 0; c < 8; ++c) {
    const vec3 corner((c & 1) ? box.hi.x : box.lo.x, (c & 2) ? box.hi.y : box.lo.y, (c & 4) ? box.hi.z : box.lo.z);
    out.extend(vec3(m * glm::vec4(corner, 1.0f)));
  }
  return out;
}

std::string instance_transform_problem(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return "its transform is not finite";
  if (m[0][3] != 0.0f || m[1][3] != 0.0f || m[2][3] != 0.0f || m[3][3] != 1.0f)
    return "its transform is not affine (bottom row must be 0 0 0 1)";
  const double det = glm::determinant(glm::dmat3(glm::mat3(m)));
  if (!(std::fabs(det) > kMinInstanceDeterminant))
    return "its transform is singular (determinant " + std::to_string(det) + ", a zero or near-zero scale)";
  return "";
}

uint64_t Scene::instanced_triangle_count() const {
  if (!instanced()) return triangles.size();
  uint64_t n = 0;
  for (const Instance& i : instances) n += meshes[i.mesh].triangle_count;
  return n;
}

Aabb Scene::instance_bounds(uint32_t instance) const {
  const Instance& i = instances[instance];
  return transformed_box(mesh_object_bounds(*this, meshes[i.mesh]), i.object_to_world);
}

Aabb Scene::bounds() const {
  Aabb box;
  if (instanced()) {
    // The placed triangles' vertices, computed as flatten() computes them: the flat
    // scene's box exactly, so that the AO length (a fraction of the diagonal) and
    // every other scale taken from it are the same in both forms.
    for (uint32_t i = 0; i < instances.size(); ++i) {
      const SceneMesh& mesh = meshes[instances[i].mesh];
      for (uint32_t t = mesh.first_triangle; t < mesh.first_triangle + mesh.triangle_count; ++t)
        for (int k = 0; k < 3; ++k) box.extend(world_vertex(i, t, k));
    }
    return box;
  }
  for (const uvec3& t : triangles)
    for (int k = 0; k < 3; ++k) box.extend(vertices[t[k]]);
  return box;
}

Scene flatten(const Scene& scene) {
  if (!scene.instanced()) return scene;
  const std::string where = "scene '" + scene.name + "'";
  // Checked here, not only by validation: flatten also runs on a loader's scene
  // before validation (load_scene's flat form), and must not read past an array.
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const SceneMesh& mesh = scene.meshes[m];
    if (uint64_t(mesh.first_vertex) + mesh.vertex_count > scene.vertices.size() ||
        uint64_t(mesh.first_triangle) + mesh.triangle_count > scene.triangles.size())
      throw InputError(where + " mesh " + std::to_string(m) + " ('" + mesh.name + "')",
                       "its vertex or triangle range lies past the scene's arrays");
  }
  const size_t nt = scene.triangles.size();
  if (!scene.material_ids.empty() && scene.material_ids.size() != nt)
    throw InputError(where, "material id count " + std::to_string(scene.material_ids.size()) +
                                " differs from triangle count " + std::to_string(nt));
  if (!scene.triangle_uvs.empty() && scene.triangle_uvs.size() != nt)
    throw InputError(where, "texture coordinate count " + std::to_string(scene.triangle_uvs.size()) +
                                " differs from triangle count " + std::to_string(nt));
  // Where each instance's vertices and triangles start in the flat arrays.
  const size_t n = scene.instances.size();
  std::vector<uint64_t> vertex_at(n + 1, 0), triangle_at(n + 1, 0);
  for (size_t i = 0; i < n; ++i) {
    const uint32_t m = scene.instances[i].mesh;
    if (m >= scene.meshes.size())
      throw InputError(where + " instance " + std::to_string(i),
                       "mesh " + std::to_string(m) + " does not exist (" + std::to_string(scene.meshes.size()) +
                           " meshes)");
    vertex_at[i + 1] = vertex_at[i] + scene.meshes[m].vertex_count;
    triangle_at[i + 1] = triangle_at[i] + scene.meshes[m].triangle_count;
  }
  if (vertex_at[n] > UINT32_MAX || triangle_at[n] > UINT32_MAX)
    throw InputError(where, "its flat form would hold " + std::to_string(vertex_at[n]) + " vertices and " +
                                std::to_string(triangle_at[n]) + " triangles, past 32-bit indices");
  const uint64_t per_triangle = sizeof(uvec3) + (scene.material_ids.empty() ? 0 : 4) +
                                (scene.triangle_uvs.empty() ? 0 : sizeof(TriangleUv));
  check_memory_budget(saturating_add(saturating_mul(vertex_at[n], sizeof(vec3)),
                                     saturating_mul(triangle_at[n], per_triangle)),
                      where, "its flat form: every instance's copy of its mesh");

  Scene flat;
  flat.name = scene.name;
  flat.source = scene.source;
  flat.licence = scene.licence;
  flat.materials = scene.materials;
  flat.alpha_textures = scene.alpha_textures;
  flat.alpha_made_opaque = scene.alpha_made_opaque;
  flat.lights = scene.lights;
  flat.cameras = scene.cameras;
  flat.ao = scene.ao;
  flat.validation = scene.validation;
  flat.vertices.resize(size_t(vertex_at[n]));
  flat.triangles.resize(size_t(triangle_at[n]));
  if (!scene.material_ids.empty()) flat.material_ids.resize(size_t(triangle_at[n]));
  if (!scene.triangle_uvs.empty()) flat.triangle_uvs.resize(size_t(triangle_at[n]));
  // Each instance writes its own slice: the result does not depend on the threads.
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      const Instance& instance = scene.instances[i];
      const SceneMesh& mesh = scene.meshes[instance.mesh];
      const glm::mat4& m = instance.object_to_world;
      // The loaders' own expressions, so that the flat scene is theirs bit for bit.
      const bool flips = glm::determinant(glm::mat3(m)) < 0.0f;
      vec3* v = flat.vertices.data() + vertex_at[i];
      for (uint32_t k = 0; k < mesh.vertex_count; ++k)
        v[k] = vec3(m * glm::vec4(scene.vertices[mesh.first_vertex + k], 1.0f));
      // Unsigned arithmetic: an index outside the mesh (left for validation to drop)
      // lands where it did in the loaders' flat arrays.
      const uint32_t shift = uint32_t(vertex_at[i]) - mesh.first_vertex;
      for (uint32_t k = 0; k < mesh.triangle_count; ++k) {
        const size_t from = size_t(mesh.first_triangle) + k, to = size_t(triangle_at[i]) + k;
        uvec3 t = scene.triangles[from] + uvec3(shift);
        if (flips) std::swap(t.y, t.z);
        flat.triangles[to] = t;
        if (!scene.material_ids.empty()) flat.material_ids[to] = scene.material_ids[from];
        if (!scene.triangle_uvs.empty()) {
          TriangleUv uv = scene.triangle_uvs[from];
          if (flips) std::swap(uv[1], uv[2]);  // the coordinates follow their vertices
          flat.triangle_uvs[to] = uv;
        }
      }
    }
  });
  return flat;
}

const Camera* Scene::find_camera(const std::string& camera_name) const {
  for (const Camera& c : cameras)
    if (c.name == camera_name) return &c;
  return nullptr;
}

const Camera& Scene::camera(const std::string& camera_name) const {
  if (const Camera* c = find_camera(camera_name)) return *c;
  std::string names;
  for (const Camera& c : cameras) names += (names.empty() ? "" : ", ") + c.name;
  throw InputError("scene '" + name + "'",
                   "no camera named '" + camera_name + "' (cameras: " + names + ")");
}


const Camera& Scene::default_camera() const {
  if (const Camera* c = find_camera("view1")) return *c;
  if (cameras.empty()) throw InputError("scene '" + name + "'", "has no cameras");
  return cameras.front();
}

uint64_t Scene::content_hash() const {
  uint64_t h = 0x5254'5349'4D00'0001ull;
  h = hash_bytes(h, vertices.data(), vertices.size() * sizeof(vec3));
  h = hash_bytes(h, triangles.data(), triangles.size() * sizeof(uvec3));
  h = hash_bytes(h, material_ids.data(), material_ids.size() * sizeof(uint32_t));
  for (const Material& m : materials) {
    const float f[] = {m.albedo.x, m.albedo.y, m.albedo.z, m.reflectance, m.transmittance,
                       m.ior, m.emission.x, m.emission.y, m.emission.z};
    h = hash_bytes(h, f, sizeof f);
  }
  // Alpha testing only where there is some: an opaque scene keeps the hash it had.
  if (!alpha_textures.empty()) {
    for (const Material& m : materials) {
      const float f[] = {float(m.alpha_texture), m.alpha_cutoff};
      h = hash_bytes(h, f, sizeof f);
    }
    for (const AlphaTexture& t : alpha_textures) {
      const uint32_t size[] = {t.width, t.height};
      h = hash_bytes(h, size, sizeof size);
      h = hash_bytes(h, t.alpha.data(), t.alpha.size());
    }
    h = hash_bytes(h, triangle_uvs.data(), triangle_uvs.size() * sizeof(TriangleUv));
  }
  // Instancing only where there is some: a flat scene keeps the hash it had. The
  // meshes' ranges and the transforms, not the names (those are for messages).
  if (instanced()) {
    for (const SceneMesh& m : meshes) {
      const uint32_t range[] = {m.first_vertex, m.vertex_count, m.first_triangle, m.triangle_count};
      h = hash_bytes(h, range, sizeof range);
    }
    for (const Instance& i : instances) {
      h = hash_bytes(h, &i.mesh, sizeof i.mesh);
      h = hash_bytes(h, &i.object_to_world[0][0], sizeof(glm::mat4));
    }
  }
  return h;
}

// Unique triangles: an instanced scene's meshes once each, however often placed.
size_t Scene::alpha_tested_triangles() const {
  if (alpha_textures.empty()) return 0;
  size_t n = 0;
  for (uint32_t t = 0; t < triangles.size(); ++t) n += alpha_tested(t);
  return n;
}

AlphaSample Scene::alpha_sample(uint32_t tri, float u, float v) const {
  const Material& m = materials[material_ids[tri]];
  const AlphaTexture& texture = alpha_textures[size_t(m.alpha_texture)];
  const TriangleUv& uv = triangle_uvs[tri];
  const glm::vec2 st = (1.0f - u - v) * uv[0] + u * uv[1] + v * uv[2];
  // Nearest texel, repeating: the fraction of each coordinate picks the texel.
  const auto texel = [](float c, uint32_t size) {
    const float f = c - std::floor(c);  // [0, 1]; 1 only from rounding
    return std::min(size - 1, uint32_t(f * float(size)));
  };
  AlphaSample s;
  s.texture = uint32_t(m.alpha_texture);
  s.x = std::isfinite(st.x) ? texel(st.x, texture.width) : 0;
  s.y = std::isfinite(st.y) ? texel(st.y, texture.height) : 0;
  s.opaque = float(texture.alpha[size_t(s.y) * texture.width + s.x]) >= m.alpha_cutoff * 255.0f;
  return s;
}

void Scene::make_opaque() {
  // Counted in the world, instance by instance: the flat and instanced forms of one
  // scene report the same number.
  if (instanced() && !alpha_textures.empty()) {
    std::vector<uint64_t> per_mesh(meshes.size(), 0);
    for (size_t m = 0; m < meshes.size(); ++m)
      for (uint32_t t = meshes[m].first_triangle; t < meshes[m].first_triangle + meshes[m].triangle_count; ++t)
        per_mesh[m] += alpha_tested(t);
    for (const Instance& i : instances) alpha_made_opaque += per_mesh[i.mesh];
  } else {
    alpha_made_opaque += alpha_tested_triangles();
  }
  for (Material& m : materials) m.alpha_texture = -1;
  alpha_textures.clear();
  triangle_uvs.clear();
}

bool triangle_geometric_less(const Scene& scene, uint32_t a, uint32_t b) {
  const Aabb ba = scene.triangle_bounds(a), bb = scene.triangle_bounds(b);
  const auto key = [](const Aabb& box) {
    const vec3 c = box.centre();
    return std::make_tuple(c.x, c.y, c.z, box.lo.x, box.lo.y, box.lo.z, box.hi.x, box.hi.y, box.hi.z);
  };
  const auto ka = key(ba), kb = key(bb);
  if (ka != kb) return ka < kb;
  for (int k = 0; k < 3; ++k) {
    const vec3 va = scene.vertex(a, k), vb = scene.vertex(b, k);
    for (int axis = 0; axis < 3; ++axis)
      if (va[axis] != vb[axis]) return va[axis] < vb[axis];
  }
  // Exact duplicates: the material (which one a ray hits decides the shading), then
  // the index, where nothing tells them apart.
  if (scene.material_ids.size() == scene.triangles.size() && scene.material_ids[a] != scene.material_ids[b])
    return scene.material_ids[a] < scene.material_ids[b];
  return a < b;
}

std::vector<uint32_t> geometric_order(const Scene& scene) {
  // The Morton code of the bounds' centre on a 2^21 grid over the scene's box nearly
  // always decides, so the sort compares integers held beside the index; only
  // triangles in one cell look at their geometry. Any order fixed by the geometry
  // would do; this one also keeps neighbours near each other for the builder.
  struct Key {
    uint64_t code;
    uint32_t tri;
  };
  const size_t n = scene.triangle_count();
  // The triangles' own box: an instanced scene's triangles are in object space.
  Aabb box;
  if (scene.instanced()) {
    for (uint32_t t = 0; t < n; ++t) box.extend(scene.triangle_bounds(t));
  } else {
    box = scene.bounds();
  }
  std::vector<Key> keys(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) {
      keys[t] = Key{morton_code(scene.triangle_bounds(uint32_t(t)).centre(), box, 1u << 21), uint32_t(t)};
    }
  });
  tbb::parallel_sort(keys.begin(), keys.end(), [&](const Key& a, const Key& b) {
    if (a.code != b.code) return a.code < b.code;
    return triangle_geometric_less(scene, a.tri, b.tri);
  });
  std::vector<uint32_t> order(n);
  for (size_t i = 0; i < n; ++i) order[i] = keys[i].tri;
  return order;
}

uint64_t triangle_geometry_key(const Scene& scene, uint32_t tri) {
  float v[9];
  for (int k = 0; k < 3; ++k) {
    const vec3 p = scene.vertex(tri, k);
    // +0.0f turns -0 into 0: the two compare equal, so they must key alike.
    v[3 * k] = p.x + 0.0f, v[3 * k + 1] = p.y + 0.0f, v[3 * k + 2] = p.z + 0.0f;
  }
  return hash_bytes(0x5452'4947'454Full, v, sizeof v);
}

void shuffle_triangles(Scene& scene, uint64_t seed) {
  // Fisher-Yates with one keyed draw per position: the permutation is fixed by the seed.
  // An instanced scene is shuffled within each mesh's range, so the meshes keep
  // their triangles (and the flat form is the same triangles in another order).
  const size_t n = scene.triangles.size();
  const bool has_materials = scene.material_ids.size() == n;
  const bool has_uvs = scene.triangle_uvs.size() == n;
  const auto shuffle_range = [&](size_t first, size_t count) {
    for (size_t i = count; i > 1; --i) {
      KeyedRng rng(seed, {0x5348'5546ull, first + i});
      const size_t a = first + i - 1, b = first + size_t(rng.next_u64() % i);
      std::swap(scene.triangles[a], scene.triangles[b]);
      if (has_materials) std::swap(scene.material_ids[a], scene.material_ids[b]);
      if (has_uvs) std::swap(scene.triangle_uvs[a], scene.triangle_uvs[b]);
    }
  };
  if (!scene.instanced()) {
    shuffle_range(0, n);
    return;
  }
  for (const SceneMesh& m : scene.meshes) {
    if (uint64_t(m.first_triangle) + m.triangle_count > n)
      throw InputError("scene '" + scene.name + "' mesh '" + m.name + "'", "its triangle range lies past the scene's triangles");
    shuffle_range(m.first_triangle, m.triangle_count);
  }
}

}  // namespace rtsim
