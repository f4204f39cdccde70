#pragma once
#include <rtsim/workloads/scene.h>
#include <rtsim/workloads/scene_registry.h>  // SceneForm

#include <string>
#include <vector>

namespace rtsim {

// Built-in scenes: deterministic and generated in well under a second.
//   cornell   - a tiny Cornell box (tests)
//   interior  - the embedded default: a heavily occluded interior of rooms,
//               colonnades, arches and furniture (~100k-300k triangles)
//   foliage   - a high-overlap tree of many small, randomly oriented leaves
// What claim and the tests sweep by default.
std::vector<std::string> procedural_scene_names();
// Built-in instanced scenes, by name only (not swept: the 50m one's flat form
// takes about 2 GB):
//   forest_instanced     - four tree meshes (5-16k triangles each) and a ground,
//                          144 trees on a jittered grid (~1.4 M instanced triangles)
//   forest_instanced_50m - the same forest of 5,600 trees (~52 M instanced triangles)
std::vector<std::string> instanced_procedural_scene_names();
bool is_procedural_scene(const std::string& name);  // either list
// Validated, in the form asked (scene_in_form); throws InputError if unknown.
Scene make_procedural_scene(const std::string& name, SceneForm form = SceneForm::Flat);
// The forest of forest_instanced with `trees` trees (named forest_instanced_<trees>).
Scene make_forest_instanced(uint32_t trees, SceneForm form = SceneForm::Instanced);

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
