#pragma once
// Small scenes for builder tests, including the hard cases the builders must survive.
#include <rtsim/builder/bvh.h>
#include <rtsim/workloads/random.h>
#include <rtsim/workloads/scene.h>
#include <rtsim/workloads/validate.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <cstring>
#include <string>

namespace rtsim::test {

inline Scene empty_scene(const std::string& name) {
  Scene s;
  s.name = name;
  s.source = "test:" + name;
  s.materials.push_back(Material{});
  Camera cam;
  cam.name = "view1";
  cam.position = vec3(0.5f, 0.5f, 3.0f);
  cam.target = vec3(0.5f, 0.5f, 0.0f);
  s.cameras.push_back(cam);
  return s;
}

inline void add_triangle(Scene& s, const vec3& a, const vec3& b, const vec3& c) {
  const uint32_t base = uint32_t(s.vertices.size());
  s.vertices.push_back(a);
  s.vertices.push_back(b);
  s.vertices.push_back(c);
  s.triangles.push_back(uvec3(base, base + 1, base + 2));
  s.material_ids.push_back(0);
}

// Random small triangles in the unit cube (a "soup" with clusters of varying density).
inline Scene triangle_soup(uint32_t count, uint64_t seed = 7, float size = 0.05f) {
  Scene s = empty_scene("soup");
  for (uint32_t i = 0; i < count; ++i) {
    KeyedRng rng(seed, {i});
    // Squaring one coordinate clusters triangles towards x = 0.
    const float x = rng.next_float();
    const vec3 c(x * x, rng.next_float(), rng.next_float());
    vec3 v[3];
    for (auto& p : v)
      p = c + size * vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f);
    add_triangle(s, v[0], v[1], v[2]);
  }
  return s;
}

// Every triangle has exactly the same box centre (dyadic offsets keep the
// arithmetic exact), with boxes of many shapes.
inline Scene one_centroid_scene(uint32_t count) {
  Scene s = empty_scene("one-centroid");
  for (uint32_t i = 0; i < count; ++i) {
    const vec3 d(float(1 + i % 8) / 16.0f, float(1 + (i / 8) % 8) / 16.0f, 0.25f);
    add_triangle(s, vec3(0.5f) + d, vec3(0.5f) - d, vec3(0.5f));
  }
  return s;
}

// All triangles in the plane z = 0: the root box is flat.
inline Scene coplanar_scene(uint32_t count) {
  Scene s = empty_scene("coplanar");
  for (uint32_t i = 0; i < count; ++i) {
    KeyedRng rng(3, {i});
    const vec3 c(rng.next_float(), rng.next_float(), 0.0f);
    add_triangle(s, c, c + vec3(0.02f, 0, 0), c + vec3(0, 0.02f, 0));
  }
  return s;
}

// Every vertex at one point: every box is a point, every area zero.
inline Scene one_point_scene(uint32_t count) {
  Scene s = empty_scene("one-point");
  for (uint32_t i = 0; i < count; ++i) add_triangle(s, vec3(0.25f), vec3(0.25f), vec3(0.25f));
  return s;
}

// Zero-area triangles (collinear vertices) mixed with normal ones.
inline Scene zero_area_scene(uint32_t count) {
  Scene s = triangle_soup(count / 2, 11);
  s.name = "zero-area";
  for (uint32_t i = 0; i < count - count / 2; ++i) {
    KeyedRng rng(5, {i});
    const vec3 a(rng.next_float(), rng.next_float(), rng.next_float());
    const vec3 d(0.01f, 0.02f, 0.0f);
    add_triangle(s, a, a + d, a + 2.0f * d);
  }
  return s;
}

inline bool same_tree(const Bvh& a, const Bvh& b) {
  if (a.nodes.size() != b.nodes.size() || a.prim_refs != b.prim_refs) return false;
  if (a.tlas_nodes != b.tlas_nodes || a.blas_roots != b.blas_roots) return false;
  for (size_t i = 0; i < a.nodes.size(); ++i) {
    const BvhNode &x = a.nodes[i], &y = b.nodes[i];
    if (x.index != y.index || x.count != y.count || x.children != y.children ||
        std::memcmp(&x.bounds, &y.bounds, sizeof(Aabb)) != 0)
      return false;
  }
  return true;
}

// Two meshes (a bumpy grid and a closed box) placed eight times each, rotated,
// scaled non-uniformly, some mirrored, on a 4x4 layout; a flat camera above.
inline Scene instanced_town() {
  Scene s;
  s.name = "little_town";
  s.materials.push_back(Material{});
  const auto add_mesh = [&](const std::string& name, const std::vector<vec3>& v, const std::vector<uvec3>& t) {
    SceneMesh m;
    m.name = name;
    m.first_vertex = uint32_t(s.vertices.size()), m.vertex_count = uint32_t(v.size());
    m.first_triangle = uint32_t(s.triangles.size()), m.triangle_count = uint32_t(t.size());
    for (const vec3& p : v) s.vertices.push_back(p);
    for (const uvec3& tri : t) s.triangles.push_back(tri + uvec3(m.first_vertex)), s.material_ids.push_back(0);
    s.meshes.push_back(m);
  };
  std::vector<vec3> grid;
  std::vector<uvec3> grid_tris;
  const int n = 12;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x)
      grid.push_back(vec3(x / float(n) - 0.5f, 0.15f * std::sin(x * 1.3f) * std::cos(y * 0.7f), y / float(n) - 0.5f));
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const uint32_t a = uint32_t(y * (n + 1) + x), b = a + 1, c = a + uint32_t(n + 1), d = c + 1;
      grid_tris.push_back(uvec3(a, c, b));
      grid_tris.push_back(uvec3(b, c, d));
    }
  add_mesh("grid", grid, grid_tris);
  std::vector<vec3> box;
  for (int k = 0; k < 8; ++k) box.push_back(vec3(k & 1 ? 0.3f : -0.3f, k & 2 ? 0.6f : 0.0f, k & 4 ? 0.3f : -0.3f));
  add_mesh("box", box,
           {uvec3(0, 2, 1), uvec3(1, 2, 3), uvec3(4, 5, 6), uvec3(5, 7, 6), uvec3(0, 1, 4), uvec3(1, 5, 4),
            uvec3(2, 6, 3), uvec3(3, 6, 7), uvec3(0, 4, 2), uvec3(2, 4, 6), uvec3(1, 3, 5), uvec3(3, 7, 5)});
  for (uint32_t i = 0; i < 16; ++i) {
    Instance inst;
    inst.mesh = i % 2;
    glm::mat4 m = glm::translate(glm::mat4(1.0f), vec3(float(i % 4) * 1.1f, 0.05f * float(i), float(i / 4) * 1.1f));
    m = glm::rotate(m, 0.4f * float(i), vec3(0, 1, 0));
    m = glm::scale(m, vec3(1.0f + 0.1f * float(i % 3), 1.0f + 0.2f * float(i % 2), i % 5 == 0 ? -0.9f : 0.8f));
    inst.object_to_world = m;
    s.instances.push_back(inst);
  }
  Camera c;
  c.name = "view1";
  c.position = vec3(1.6f, 3.0f, -2.0f);
  c.target = vec3(1.6f, 0.0f, 1.6f);
  s.cameras.push_back(c);
  validate_scene(s);
  return s;
}

}  // namespace rtsim::test
