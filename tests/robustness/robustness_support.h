#pragma once
// Shared helpers of the robustness suite: a double-precision reference for
// ray-triangle hits, scenes with a built tree and traversal context, and small
// scene snippets.
#include <rtsim/builder/build.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/core/traversal.h>
#include <rtsim/workloads/scene.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace rtsim::robust {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

inline Scene bare_scene(const std::string& name) {
  Scene s;
  s.name = name;
  s.source = "test:" + name;
  s.materials.push_back(Material{});
  Camera cam;
  cam.name = "view1";
  cam.position = vec3(0.0f, 0.0f, 5.0f);
  cam.target = vec3(0.0f);
  s.cameras.push_back(cam);
  return s;
}

inline uint32_t add_triangle(Scene& s, const vec3& a, const vec3& b, const vec3& c) {
  const uint32_t base = uint32_t(s.vertices.size());
  s.vertices.insert(s.vertices.end(), {a, b, c});
  s.triangles.push_back(uvec3(base, base + 1, base + 2));
  s.material_ids.push_back(0);
  return uint32_t(s.triangles.size() - 1);
}

// The reference verdict, computed in double from the float inputs. The ray line
// passes through the triangle when the three signed volumes det[v_i - o, v_j - o, d]
// (one per edge) do not have mixed signs and are not all zero: a ray through an
// edge or vertex hits (the same convention as the core). Differences of floats
// and the products here carry at most ~1e-16 relative error, and are exact for
// the dyadic inputs the exact-zero cases use.
struct ReferenceHit {
  bool hit = false;
  double t = std::numeric_limits<double>::infinity();
};

inline ReferenceHit reference_intersect(const vec3& of, const vec3& df, const vec3& v0f,
                                        const vec3& v1f, const vec3& v2f, double tmin = 0.0,
                                        double tmax = std::numeric_limits<double>::infinity()) {
  const dvec3 o(of), d(df), a = dvec3(v0f) - o, b = dvec3(v1f) - o, c = dvec3(v2f) - o;
  const double u = glm::dot(glm::cross(b, c), d);
  const double v = glm::dot(glm::cross(c, a), d);
  const double w = glm::dot(glm::cross(a, b), d);
  ReferenceHit r;
  if ((u < 0 || v < 0 || w < 0) && (u > 0 || v > 0 || w > 0)) return r;
  if (u + v + w == 0.0) return r;  // ray parallel to the plane (or triangle degenerate)
  const dvec3 n = glm::cross(dvec3(v1f) - dvec3(v0f), dvec3(v2f) - dvec3(v0f));
  const double denom = glm::dot(n, d);
  if (denom == 0.0) return r;
  const double t = glm::dot(n, a) / denom;
  if (!(t >= tmin && t <= tmax)) return r;
  r.hit = true;
  r.t = t;
  return r;
}

// Closest reference hit over every triangle of a scene (brute force).
struct ReferenceClosest {
  bool hit = false;
  double t = std::numeric_limits<double>::infinity();
  uint32_t prim = kNoPrim;
};
inline ReferenceClosest reference_closest(const Scene& scene, const vec3& o, const vec3& d,
                                          double tmin = 0.0) {
  ReferenceClosest best;
  for (uint32_t i = 0; i < scene.triangle_count(); ++i) {
    const ReferenceHit h =
        reference_intersect(o, d, scene.vertex(i, 0), scene.vertex(i, 1), scene.vertex(i, 2), tmin);
    if (h.hit && h.t < best.t) {
      best.hit = true;
      best.t = h.t;
      best.prim = i;
    }
  }
  return best;
}

// A scene with a built tree, its memory image and a traversal context.
struct TracedScene {
  Scene scene;
  Bvh bvh;
  std::unique_ptr<MemoryImage> image;
  std::unique_ptr<TraversalContext> context;

  explicit TracedScene(Scene s, const std::string& builder = "sah",
                       const TraversalConfig& traversal = {},
                       const MemoryLayoutConfig& layout = {})
      : scene(std::move(s)) {
    BuildParams p;
    p.builder = builder;
    apply_node_format(p, node_format(layout.node_format));  // a wide format gets a wide tree
    bvh = build_bvh(scene, p);
    image = std::make_unique<MemoryImage>(scene, bvh, layout);
    context = std::make_unique<TraversalContext>(scene, bvh, *image, traversal);
  }
  std::vector<TraceResult> trace(const std::vector<Ray>& rays) const {
    std::vector<TraceResult> results;
    trace_rays(*context, rays, results);
    return results;
  }
};

inline Ray make_ray(const vec3& o, const vec3& d, float tmin = 0.0f, float tmax = kInf) {
  Ray r;
  r.origin = o;
  r.direction = d;
  r.tmin = tmin;
  r.tmax = tmax;
  return r;
}

}  // namespace rtsim::robust
