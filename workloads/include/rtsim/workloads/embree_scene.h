#pragma once
// Embree is the oracle and the fast ray caster. This wraps one committed Embree
// scene of a rtsim::Scene's triangles; geometry id 0, primitive id = triangle index.
// An instanced scene (Scene::instances) becomes Embree's own two levels: one
// scene per mesh, placed by RTC_GEOMETRY_TYPE_INSTANCE geometries (geometry id =
// instance index); hits report the instance and the scene's triangle index.
// Alpha-tested triangles count only where their texel is opaque (an intersection
// filter runs Scene::alpha_sample): every user of Embree (the builders' AO and
// visibility rays, validation, previews) sees the surfaces the accelerator sees.
// The scene must then outlive the EmbreeScene.
#include <rtsim/workloads/scene.h>

#include <embree3/rtcore.h>

#include <memory>
#include <string>
#include <vector>

namespace rtsim {

struct EmbreeHit {
  bool hit = false;
  float t = 0.0f;
  uint32_t prim = ~0u;
  float u = 0.0f, v = 0.0f;
  vec3 geometric_normal{0.0f};  // unnormalised, as Embree reports it (in world space)
  uint32_t instance = ~0u;      // instanced scenes: the instance hit (prim is its mesh's triangle)
};

class EmbreeScene {
 public:
  // oracle: Embree's high-quality tree, for the reference traces and every query
  // whose answer could depend on tie-breaking (which of two equally near triangles
  // is hit). fast: its low-quality (Morton) tree, a sixth of the build time, for
  // passes that cast few rays per build and read only hit distances (the AO pass).
  enum class Quality { oracle, fast };
  explicit EmbreeScene(const Scene& scene, Quality quality = Quality::oracle);
  // On a device of its own with this Embree configuration, e.g.
  // "tri_accel=bvh4.triangle4" to pin Embree's own tree to BVH4 (benchmarks).
  EmbreeScene(const Scene& scene, const std::string& device_config);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  // Thread-safe: Embree queries on a committed scene may run concurrently.
  EmbreeHit intersect(const vec3& origin, const vec3& direction, float tmin, float tmax) const;
  bool occluded(const vec3& origin, const vec3& direction, float tmin, float tmax) const;

  RTCDevice device() const { return device_; }
  RTCScene handle() const { return scene_; }

  // A triangle geometry's source (its alpha filter's user data): the scene, and the
  // first triangle of its mesh (0 in a flat scene).
  struct MeshGeometry {
    const Scene* scene;
    uint32_t first_triangle;
  };

 private:
  void build(const Scene& scene, const std::string& device_config, Quality quality);
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  // Each mesh's Embree scene (instanced scenes), and every triangle geometry's source.
  std::vector<RTCScene> mesh_scenes_;
  std::vector<MeshGeometry> mesh_geometry_;
  const Scene* source_ = nullptr;
};

// One device per process is enough; Embree reports errors through this callback,
// which turns them into std::runtime_error at the next call.
RTCDevice shared_embree_device();

}  // namespace rtsim
