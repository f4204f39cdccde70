#pragma once
// The Scene: what every later stage consumes. Triangles, materials, lights,
// named cameras and AO settings; validated once on load (see validate.h).
#include <rtsim/workloads/geometry.h>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace rtsim {

struct Material {
  std::string name = "default";
  vec3 albedo{0.7f};        // diffuse reflectance
  float reflectance = 0.0f;  // mirror weight; > 0 spawns reflection rays
  float transmittance = 0.0f;  // > 0 spawns refraction rays
  float ior = 1.5f;
  vec3 emission{0.0f};
  // Alpha-tested (foliage drawn as textured quads): a hit counts only where the
  // texture's alpha reaches alpha_cutoff; elsewhere the ray goes on (an any-hit
  // test). -1: opaque. Index into Scene::alpha_textures (Mesh::alpha_textures).
  int32_t alpha_texture = -1;
  float alpha_cutoff = 0.5f;  // of full alpha (255); STK's alphatest shader uses 0.5
  bool alpha_tested() const { return alpha_texture >= 0; }
};

// The alpha channel of an alpha-tested material's texture: 8 bits a texel,
// row-major, row 0 at texture coordinate t = 0. Sampled nearest, wrapping (repeat).
struct AlphaTexture {
  std::string file;  // where it was read from, for messages and `scenes info`
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> alpha;  // width * height
};

// A triangle's texture coordinates, one per vertex in the triangle's vertex order.
using TriangleUv = std::array<glm::vec2, 3>;

// Where an alpha test at barycentrics (u, v) samples its texture, and what it finds.
struct AlphaSample {
  uint32_t texture = 0;  // into Scene::alpha_textures
  uint32_t x = 0, y = 0;  // the texel
  bool opaque = true;     // alpha >= cutoff: the hit counts
};

// A surface's albedo: a triangle without a material reflects as the default material.
inline vec3 albedo_of(const Material* m) { return m ? m->albedo : Material{}.albedo; }

struct Light {
  enum class Kind { Point, Directional };
  Kind kind = Kind::Point;
  vec3 position{0.0f};   // Point
  vec3 direction{0.0f, -1.0f, 0.0f};  // Directional: direction the light travels
  vec3 intensity{1.0f};
};

// A pinhole camera. Primary ray for pixel (x, y) of a w x h image goes through
// the pixel centre (plus an optional jitter in [0,1)^2).
struct Camera {
  std::string name;
  vec3 position{0.0f};
  vec3 target{0.0f, 0.0f, -1.0f};
  vec3 up{0.0f, 1.0f, 0.0f};
  float vertical_fov_deg = 60.0f;

  struct Ray {
    vec3 origin;
    vec3 direction;  // unit length
  };
  Ray primary_ray(uint32_t x, uint32_t y, uint32_t width, uint32_t height, float jitter_x = 0.5f,
                  float jitter_y = 0.5f) const;
};

struct AoSettings {
  // The longest AO ray a run may ask for (simulate --ao-cutoff, a campaign's ao_cutoff).
  static constexpr double kMaxCutoffRelative = 10;
  bool enabled = true;
  float cutoff_relative = 0.05f;  // AO ray length as a fraction of the scene diagonal
  uint32_t samples = 4;           // AO rays per primary hit
};

// What validation found, reported by `rtsim scenes info`. Policy: triangles with a
// non-finite vertex or an out-of-range index are dropped; so are triangles with a
// coordinate beyond +-kMaxSceneCoordinate (1e18): Embree, the oracle and reference
// builder, aborts on geometry and rays past its range (1.844e18), and beyond ~1e19
// a triangle's area overflows float. Zero-area (degenerate) triangles are kept and
// counted, because a mesh may legitimately contain them and the traversal must
// cope with them anyway.
constexpr float kMaxSceneCoordinate = 1e18f;

struct ValidationReport {
  uint64_t input_triangles = 0;
  uint64_t dropped_non_finite = 0;
  uint64_t dropped_out_of_range = 0;  // finite, but a coordinate beyond kMaxSceneCoordinate
  uint64_t dropped_bad_index = 0;
  uint64_t degenerate_kept = 0;
  uint64_t non_finite_vertices = 0;
  // Faces a loader leaves out before triangles exist (Quake 3 maps: sky faces and
  // textures/common/ tool faces), so they are in no triangle count above.
  uint64_t dropped_sky_faces = 0;
  uint64_t dropped_tool_faces = 0;
};

// Instancing (docs/scene-descriptor.md "Instances"). An instanced scene stores
// each mesh once, in its own object space, as a range of the scene's vertices and
// triangles; instances place meshes in the world, each with an affine transform.
// A flat scene (every scene unless asked for its instances) has neither list and
// its triangles are in world space.
struct SceneMesh {
  std::string name;  // the model file or [[mesh]] name, for messages and `scenes info`
  uint32_t first_vertex = 0, vertex_count = 0;
  uint32_t first_triangle = 0, triangle_count = 0;  // their indices are into Scene::vertices
};

struct Instance {
  uint32_t mesh = 0;  // into Scene::meshes
  // Object to world; affine (bottom row 0 0 0 1), finite and invertible (validated).
  glm::mat4 object_to_world{1.0f};
};

// Why `object_to_world` cannot place an instance, or "" if it can: it must be finite,
// affine (bottom row 0 0 0 1) and invertible, |det| of its 3x3 (in double) above
// kMinInstanceDeterminant (a ray moved into object space divides by it).
constexpr double kMinInstanceDeterminant = 1e-30;
std::string instance_transform_problem(const glm::mat4& object_to_world);
// The world box of `box` placed by `m`: the box of its eight corners transformed.
Aabb transformed_box(const Aabb& box, const glm::mat4& m);

struct Scene {
  std::string name;
  std::string source;  // file or "procedural:<name>"
  std::string licence;  // shown by `scenes info`/`fetch`
  std::vector<vec3> vertices;
  std::vector<uvec3> triangles;
  std::vector<uint32_t> material_ids;  // one per triangle
  std::vector<Material> materials;
  // Alpha testing: the textures alpha-tested materials name, and one TriangleUv per
  // triangle (empty when no material is alpha-tested).
  std::vector<AlphaTexture> alpha_textures;
  std::vector<TriangleUv> triangle_uvs;
  // Triangles make_opaque turned opaque (a run's --opaque), for its effect plan to
  // say; not part of the content (hash, cache).
  uint64_t alpha_made_opaque = 0;
  // Instancing: both empty for a flat scene. Every triangle belongs to one mesh
  // (meshes cover the triangles in order); a mesh no instance places is allowed.
  std::vector<SceneMesh> meshes;
  std::vector<Instance> instances;
  std::vector<Light> lights;
  std::vector<Camera> cameras;
  AoSettings ao;
  ValidationReport validation;

  size_t triangle_count() const { return triangles.size(); }  // instanced: unique (object-space) triangles
  bool instanced() const { return !instances.empty(); }
  // Triangles the world holds: the sum over instances of their mesh's triangles
  // (triangle_count() for a flat scene). What flatten() produces.
  uint64_t instanced_triangle_count() const;
  // Instanced scenes: triangle `tri` (of instance's mesh) vertex k in world space.
  vec3 world_vertex(uint32_t instance, uint32_t tri, int k) const {
    return vec3(instances[instance].object_to_world * glm::vec4(vertex(tri, k), 1.0f));
  }
  // World to object: the inverse in double, stored as float - what the hardware's
  // instance record holds, and what the model, its referee and Embree's check use.
  glm::mat4 world_to_object(uint32_t instance) const {
    return glm::mat4(glm::inverse(glm::dmat4(instances[instance].object_to_world)));
  }
  // The world box of an instance: its mesh's object box transformed (the box of
  // the eight corners, so it may be larger than the placed triangles' own box).
  Aabb instance_bounds(uint32_t instance) const;
  vec3 vertex(uint32_t tri, int k) const { return vertices[triangles[tri][k]]; }
  Aabb triangle_bounds(uint32_t tri) const {
    return Aabb::of_triangle(vertex(tri, 0), vertex(tri, 1), vertex(tri, 2));
  }
  Aabb bounds() const;  // in world space: an instanced scene's placed triangles, the flat scene's box exactly
  float diagonal() const { return bounds().diagonal(); }
  float ao_cutoff() const { return ao.cutoff_relative * diagonal(); }
  // The triangle's material is alpha-tested (so a hit on it needs an any-hit test).
  bool alpha_tested(uint32_t tri) const {
    return !alpha_textures.empty() && materials[material_ids[tri]].alpha_tested();
  }
  size_t alpha_tested_triangles() const;  // unique: an instanced scene's meshes once each
  // The any-hit test of a hit at barycentrics (u, v) (Embree's convention, ray.h) on
  // alpha-tested triangle `tri`: the texel at the interpolated coordinates. One
  // definition for the model's any-hit stage and Embree's intersection filter.
  AlphaSample alpha_sample(uint32_t tri, float u, float v) const;
  // Makes every material opaque (drops the textures and coordinates): the same
  // geometry as an opaque scene, for comparison. alpha_made_opaque counts placed
  // triangles (an instanced scene's as its flat form would), so both forms agree.
  void make_opaque();
  const Camera* find_camera(const std::string& camera_name) const;
  const Camera& camera(const std::string& camera_name) const;  // throws InputError
  // The camera a command uses when none is named: view1 if there is one, else the
  // first; InputError if the scene has none. One rule everywhere, so that a tree
  // built for a camera (OSAH) and the rays traced through it agree.
  const Camera& default_camera() const;
  // A 64-bit hash of geometry and materials: keys caches and BVH files to a scene.
  uint64_t content_hash() const;
};

// The flat scene of the same content: every instance's triangles in world space,
// instance by instance, each mesh's vertices and triangles in their stored order
// (a mirroring transform swaps a triangle's last two vertices, with their texture
// coordinates, to keep it front-facing). Materials, textures, cameras and lights are
// kept; meshes and instances are dropped. A flat scene is returned unchanged.
Scene flatten(const Scene& scene);

// A strict order of a scene's triangles by their geometry alone: the centroid of
// the bounds, then the bounds, then the vertices as stored; exact duplicates by
// material, then by index. Builders break ties with it and the memory layout orders
// a leaf's triangles by it, so that no result depends on the file's face order.
bool triangle_geometric_less(const Scene& scene, uint32_t a, uint32_t b);

// The scene's triangle indices in an order fixed by the geometry alone: by the Morton
// code of each triangle's bounds centre (2^21 cells per axis of the scene's box),
// ties by triangle_geometric_less. The builders see the triangles in this order
// (build_bvh), so that the same geometry in another face order gives the same tree,
// float sums included. An instanced scene's triangles are ordered in object space,
// on a grid over their own box.
std::vector<uint32_t> geometric_order(const Scene& scene);

// A 64-bit key of a triangle's vertices (in their stored order): keys the random
// rays a builder casts from a triangle, so they follow its geometry, not its index.
uint64_t triangle_geometry_key(const Scene& scene, uint32_t tri);

// Permutes the triangles (with their material ids) by a seeded shuffle: the same
// geometry in another face order, to check that results do not depend on it. An
// instanced scene is shuffled within each mesh's range, the ranges kept (a flat
// scene's permutation is what it always was).
void shuffle_triangles(Scene& scene, uint64_t seed);

}  // namespace rtsim
