#include <rtsim/workloads/error.h>
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

Aabb Scene::bounds() const {
  Aabb box;
  for (const uvec3& t : triangles)
    for (int k = 0; k < 3; ++k) box.extend(vertices[t[k]]);
  return box;
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
  return h;
}

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
  alpha_made_opaque += alpha_tested_triangles();
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
  const Aabb box = scene.bounds();
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
  const size_t n = scene.triangles.size();
  const bool has_materials = scene.material_ids.size() == n;
  for (size_t i = n; i > 1; --i) {
    KeyedRng rng(seed, {0x5348'5546ull, i});
    const size_t j = size_t(rng.next_u64() % i);
    std::swap(scene.triangles[i - 1], scene.triangles[j]);
    if (has_materials) std::swap(scene.material_ids[i - 1], scene.material_ids[j]);
    if (scene.triangle_uvs.size() == n) std::swap(scene.triangle_uvs[i - 1], scene.triangle_uvs[j]);
  }
}

}  // namespace rtsim
