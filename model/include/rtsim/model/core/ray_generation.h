#pragma once
// Ray generation driven by the scene: primary rays from a named camera, and the
// secondary rays (AO, shadow, reflection, refraction) that the scene's materials
// and lights call for. All randomness from KeyedRng(seed, {pixel, sample,
// bounce, k}), so every ray is fixed by its ids whatever the thread count.
#include <rtsim/model/core/ray.h>
#include <rtsim/workloads/scene.h>

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace rtsim {

// The most reflection/refraction bounces a run may ask for (--bounces, documented in
// docs/robustness.md). Ray::bounce counts them; it must hold the limit + 1 without
// wrapping, or a closed mirror box never stops spawning.
constexpr uint32_t kMaxBounces = 64;
static_assert(kMaxBounces + 1 < std::numeric_limits<decltype(Ray::bounce)>::max(),
              "Ray::bounce must count up to kMaxBounces + 1");

struct EffectSettings {
  uint32_t width = 256, height = 256;
  uint32_t spp = 1;     // samples per pixel; > 1 jitters inside the pixel
  uint64_t seed = 1;
  int ao_samples = -1;  // < 0: the scene decides (ao.enabled, ao.samples); 0: off; N > 0: on, N rays
  bool shadows = true;       // run-level switches: an effect runs only if the scene calls for it
  bool reflections = true;   // AND the run allows it
  bool refractions = true;
  uint32_t max_depth = 2;    // reflection/refraction bounces after the primary hit
  // A path tracer's diffuse bounces from each primary hit (0: none, up to
  // kMaxDiffuseBounces); with russian_roulette a bounce past the first survives with
  // the probability of the surface's largest albedo channel (in 0.05..0.95).
  uint32_t diffuse_bounces = 0;
  bool russian_roulette = false;
};

// Which effects run for one (scene, settings), and why the others do not.
struct EffectPlan {
  std::array<bool, kRayTypeCount> enabled{};
  std::array<std::string, kRayTypeCount> reason{};  // why on / why off, one line each
  uint32_t ao_samples = 0;
  float ao_length = 0.0f;  // scene.ao_cutoff()
  uint32_t max_depth = 0;
  uint32_t diffuse_bounces = 0;
  bool russian_roulette = false;
  // The any-hit stage (and its texture caches) is built only for a scene with
  // alpha-tested materials; the reason says why it is or is not.
  bool anyhit = false;
  std::string anyhit_reason;
  bool on(RayType t) const { return enabled[ray_type_index(t)]; }
};
EffectPlan plan_effects(const Scene& scene, const EffectSettings& settings);

// The most rays one frame can spawn, before it is traced: per primary ray its AO
// rays, and down to plan.max_depth bounces every closest-hit ray's shadow rays (one
// per light) and children (reflection and refraction where a material of the scene
// has them: up to two per hit, so 2^bounces in glass), and its diffuse bounces with
// their shadow rays. Saturates at UINT64_MAX.
uint64_t max_frame_rays(const Scene& scene, const EffectPlan& plan, uint64_t primary_rays);

// Primary ray of (x, y, sample): through the pixel centre for spp == 1, jittered
// by KeyedRng(seed, {pixel, sample, 0, 0}) otherwise. tmin 0, tmax inf.
Ray make_primary_ray(const Camera& camera, const EffectSettings& settings, uint32_t x, uint32_t y,
                     uint32_t sample);
// All primary rays, pixel-major (pixel = y * width + x), then sample.
std::vector<Ray> generate_primary_rays(const Camera& camera, const EffectSettings& settings);

// The surface a ray hit: position from barycentrics (no t rounding), unit
// geometric normal turned to face the incoming ray, and the material.
struct SurfaceHit {
  vec3 position{0.0f};
  vec3 normal{0.0f, 1.0f, 0.0f};
  const Material* material = nullptr;
};
SurfaceHit surface_at(const Scene& scene, const Ray& ray, const HitRecord& hit);

// Appends the secondary rays a finished ray spawns (parent = ray_index): AO
// rays from primary hits; shadow rays (one per light on the lit side) from every
// closest-hit ray's hit; mirror/refraction rays from primary, reflection and
// refraction hits below max depth; one diffuse bounce (cosine-weighted about the
// normal, closest hit, KeyedRng(seed, {pixel, sample, kDiffuseKey, depth})) from a
// primary hit and from each diffuse bounce's hit below diffuse_bounces. A diffuse
// bounce's hit spawns no mirror or refraction ray: a path continues diffusely. AO and
// shadow rays spawn nothing. Origins are offset robustly.
void spawn_secondary_rays(const Scene& scene, const EffectPlan& plan, const EffectSettings& settings,
                          const Ray& ray, uint32_t ray_index, const HitRecord& hit,
                          std::vector<Ray>& out);

// Russian roulette: the chance that a diffuse bounce past the first continues from a
// surface of this albedo (its largest channel, clamped to 0.05..0.95). The shading
// divides what a surviving bounce brings back by it, so the picture stays unbiased.
float roulette_keep_probability(const vec3& albedo);

// cosine_hemisphere_direction: rtsim/workloads/geometry.h.

}  // namespace rtsim
