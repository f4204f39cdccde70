#pragma once
// Small scenes for builder tests, including the hard cases the builders must survive.
#include <rtsim/builder/bvh.h>
#include <rtsim/workloads/random.h>
#include <rtsim/workloads/scene.h>

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
  for (size_t i = 0; i < a.nodes.size(); ++i) {
    const BvhNode &x = a.nodes[i], &y = b.nodes[i];
    if (x.index != y.index || x.count != y.count ||
        std::memcmp(&x.bounds, &y.bounds, sizeof(Aabb)) != 0)
      return false;
  }
  return true;
}

}  // namespace rtsim::test
