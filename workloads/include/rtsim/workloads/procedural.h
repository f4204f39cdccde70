#pragma once
#include <rtsim/workloads/scene.h>

#include <string>
#include <vector>

namespace rtsim {

// Built-in scenes: deterministic and generated in well under a second.
//   cornell   - a tiny Cornell box (tests)
//   interior  - the embedded default: a heavily occluded interior of rooms,
//               colonnades, arches and furniture (~100k-300k triangles)
//   foliage   - a high-overlap tree of many small, randomly oriented leaves
std::vector<std::string> procedural_scene_names();
bool is_procedural_scene(const std::string& name);
Scene make_procedural_scene(const std::string& name);  // throws InputError if unknown

// Building blocks, also used by tests.
struct MeshBuilder {
  Scene& scene;
  uint32_t material = 0;
  void triangle(const vec3& a, const vec3& b, const vec3& c);
  void quad(const vec3& a, const vec3& b, const vec3& c, const vec3& d);  // a,b,c,d counter-clockwise
  void box(const vec3& lo, const vec3& hi);  // outward-facing
  void cylinder(const vec3& base, float radius, float height, int segments);
  void sphere(const vec3& centre, float radius, int rings, int segments);
};

}  // namespace rtsim
