#pragma once
// Rays and hits: what ray generation produces, what the traversal consumes and
// what the ray file stores. Shared by the functional core and the SystemC model.
#include <rtsim/workloads/geometry.h>

#include <array>
#include <cstdint>
#include <limits>
#include <string>

namespace rtsim {

// The effect a ray serves. The order is part of the ray file format: append only.
// Diffuse<k>: a path tracer's k-th cosine-weighted diffuse bounce (--diffuse-bounces);
// each depth is its own type, so the stats split them.
enum class RayType : uint8_t {
  Primary = 0, Ao = 1, Shadow = 2, Reflection = 3, Refraction = 4,
  Diffuse1 = 5, Diffuse2, Diffuse3, Diffuse4, Diffuse5, Diffuse6, Diffuse7, Diffuse8
};
constexpr uint32_t kMaxDiffuseBounces = 8;  // Diffuse1 .. Diffuse8
constexpr int kRayTypeCount = 5 + int(kMaxDiffuseBounces);
constexpr std::array<RayType, kRayTypeCount> kAllRayTypes = {
    RayType::Primary,  RayType::Ao,       RayType::Shadow,   RayType::Reflection, RayType::Refraction,
    RayType::Diffuse1, RayType::Diffuse2, RayType::Diffuse3, RayType::Diffuse4,   RayType::Diffuse5,
    RayType::Diffuse6, RayType::Diffuse7, RayType::Diffuse8};
// "primary", "ao", "shadow", "reflection", "refraction", "diffuse1" .. "diffuse8"
const char* ray_type_name(RayType type);
inline int ray_type_index(RayType type) { return int(type); }
// The diffuse bounce's depth (1..kMaxDiffuseBounces), 0 for any other type.
inline uint32_t diffuse_depth(RayType type) {
  const uint32_t d = uint32_t(type) - uint32_t(RayType::Diffuse1) + 1;
  return d >= 1 && d <= kMaxDiffuseBounces ? d : 0;
}
// The type of the diffuse bounce at depth (1..kMaxDiffuseBounces).
inline RayType diffuse_ray_type(uint32_t depth) { return RayType(uint32_t(RayType::Diffuse1) + depth - 1); }

constexpr uint32_t kNoParent = ~0u;
constexpr uint32_t kNoPrim = ~0u;
constexpr uint32_t kNoInstance = ~0u;

struct Ray {
  vec3 origin{0.0f};
  float tmin = 0.0f;
  vec3 direction{0.0f, 0.0f, -1.0f};  // need not be unit length; t is in units of it
  float tmax = std::numeric_limits<float>::infinity();
  RayType type = RayType::Primary;
  uint8_t bounce = 0;        // 0 for primary rays, parent's bounce + 1 otherwise
  uint32_t pixel = 0;        // y * width + x of the image the ray contributes to
  uint32_t sample = 0;       // sample index within the pixel
  uint32_t parent = kNoParent;  // index of the ray whose hit spawned this one (in its ray set)
};

// Closest (or, for any-hit rays, some) hit. Barycentrics follow Embree: the hit
// point is (1-u-v)*v0 + u*v1 + v*v2.
struct HitRecord {
  float t = std::numeric_limits<float>::infinity();
  uint32_t prim = kNoPrim;  // scene triangle index (instanced scenes: of the instance's mesh)
  float u = 0.0f, v = 0.0f;
  uint32_t instance = kNoInstance;  // instanced scenes: the instance hit
  bool hit() const { return prim != kNoPrim; }
};

// Closest-hit rays (primary, reflection, refraction, diffuse) want the nearest surface;
// any-hit rays (AO, shadow) stop at the first.
enum class TraversalMode : uint8_t { ClosestHit, AnyHit };
inline TraversalMode traversal_mode_for(RayType type) {
  return (type == RayType::Ao || type == RayType::Shadow) ? TraversalMode::AnyHit
                                                          : TraversalMode::ClosestHit;
}

}  // namespace rtsim
