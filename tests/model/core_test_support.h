#pragma once
// Helpers for the functional-core tests: a small median-split BVH builder so the
// core's tests do not depend on the production builders, and scene snippets.
#include <rtsim/builder/bvh.h>
#include <rtsim/workloads/scene.h>

#include <algorithm>
#include <numeric>
#include <vector>

namespace rtsim::test {

// Object-median split on the longest centroid axis; leaves of <= leaf_size.
inline Bvh median_bvh(const Scene& scene, uint32_t leaf_size = 4) {
  Bvh bvh;
  const uint32_t n = uint32_t(scene.triangle_count());
  std::vector<uint32_t> refs(n);
  std::iota(refs.begin(), refs.end(), 0u);
  bvh.nodes.reserve(2 * size_t(n) + 1);
  struct Job { uint32_t node, begin, end; };
  bvh.nodes.emplace_back();
  std::vector<Job> jobs{{0, 0, n}};
  while (!jobs.empty()) {
    const Job job = jobs.back();
    jobs.pop_back();
    Aabb box, centroids;
    for (uint32_t i = job.begin; i < job.end; ++i) {
      const Aabb tb = scene.triangle_bounds(refs[i]);
      box.extend(tb);
      centroids.extend(tb.centre());
    }
    bvh.nodes[job.node].bounds = box;
    if (job.end - job.begin <= leaf_size) {
      bvh.nodes[job.node].index = job.begin;
      bvh.nodes[job.node].count = job.end - job.begin;
      continue;
    }
    const vec3 e = centroids.extent();
    const int axis = e.x > e.y ? (e.x > e.z ? 0 : 2) : (e.y > e.z ? 1 : 2);
    const uint32_t mid = (job.begin + job.end) / 2;
    std::nth_element(refs.begin() + job.begin, refs.begin() + mid, refs.begin() + job.end,
                     [&](uint32_t a, uint32_t b) {
                       return scene.triangle_bounds(a).centre()[axis] < scene.triangle_bounds(b).centre()[axis];
                     });
    const uint32_t left = uint32_t(bvh.nodes.size());
    bvh.nodes.emplace_back();
    bvh.nodes.emplace_back();
    bvh.nodes[job.node].index = left;
    bvh.nodes[job.node].count = 0;
    bvh.nodes[job.node].children = 2;
    jobs.push_back({left + 1, mid, job.end});
    jobs.push_back({left, job.begin, mid});
  }
  bvh.prim_refs = refs;
  return bvh;
}

inline void add_material(Scene& scene, const std::string& name, vec3 albedo, float reflectance = 0.0f,
                         float transmittance = 0.0f) {
  Material m;
  m.name = name;
  m.albedo = albedo;
  m.reflectance = reflectance;
  m.transmittance = transmittance;
  scene.materials.push_back(m);
}

// Triangles added by MeshBuilder do not set material ids: fill the missing ones.
inline void set_material(Scene& scene, uint32_t material) {
  scene.material_ids.resize(scene.triangles.size(), material);
}

}  // namespace rtsim::test
