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
enum class RayType : uint8_t { Primary = 0, Ao = 1, Shadow = 2, Reflection = 3, Refraction = 4 };
constexpr int kRayTypeCount = 5;
constexpr std::array<RayType, kRayTypeCount> kAllRayTypes = {
    RayType::Primary, RayType::Ao, RayType::Shadow, RayType::Reflection, RayType::Refraction};
const char* ray_type_name(RayType type);  // "primary", "ao", "shadow", "reflection", "refraction"
inline int ray_type_index(RayType type) { return int(type); }

constexpr uint32_t kNoParent = ~0u;
constexpr uint32_t kNoPrim = ~0u;

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
  uint32_t prim = kNoPrim;  // scene triangle index
  float u = 0.0f, v = 0.0f;
  bool hit() const { return prim != kNoPrim; }
};

// Closest-hit rays want the nearest surface; any-hit rays (AO, shadow) stop at the first.
enum class TraversalMode : uint8_t { ClosestHit, AnyHit };
inline TraversalMode traversal_mode_for(RayType type) {
  return (type == RayType::Ao || type == RayType::Shadow) ? TraversalMode::AnyHit
                                                          : TraversalMode::ClosestHit;
}

}  // namespace rtsim
