#include <rtsim/model/core/intersect.h>
#include <rtsim/model/core/ray_generation.h>
#include <rtsim/workloads/host.h>
#include <rtsim/workloads/random.h>

#include <algorithm>
#include <cmath>
#include <string>

namespace rtsim {

namespace {
// The key that keeps diffuse bounces' random numbers apart from AO's (whose keys are
// {pixel, sample, bounce, k} with bounce <= kMaxBounces).
constexpr uint64_t kDiffuseKey = 0xD1FFu;

bool any_triangle_material(const Scene& scene, bool (*pred)(const Material&)) {
  std::vector<char> used(scene.materials.size(), 0);
  for (uint32_t id : scene.material_ids)
    if (id < used.size()) used[id] = 1;
  for (size_t m = 0; m < scene.materials.size(); ++m)
    if (used[m] && pred(scene.materials[m])) return true;
  return false;
}
}  // namespace

EffectPlan plan_effects(const Scene& scene, const EffectSettings& settings) {
  EffectPlan plan;
  plan.max_depth = settings.max_depth;
  plan.ao_length = scene.ao_cutoff();
  auto set = [&](RayType t, bool on, std::string why) {
    plan.enabled[ray_type_index(t)] = on;
    plan.reason[ray_type_index(t)] = std::move(why);
  };
  set(RayType::Primary, true,
      std::to_string(settings.spp) + " per pixel from the camera, closest hit");
  if (const size_t alpha = scene.alpha_tested_triangles()) {
    plan.anyhit = true;
    plan.anyhit_reason = std::to_string(alpha) + " alpha-tested triangles (" +
                         std::to_string(scene.alpha_textures.size()) +
                         " alpha textures): their hits run an alpha test, reading UVs and a texel";
  } else if (scene.alpha_made_opaque > 0) {
    plan.anyhit_reason = std::to_string(scene.alpha_made_opaque) +
                         " alpha-tested triangles made opaque for this run (--opaque)";
  } else {
    plan.anyhit_reason = "no triangle's material is alpha-tested";
  }

  // AO: the run's --ao overrides the scene; otherwise the scene's ao settings decide.
  if (settings.ao_samples == 0) {
    set(RayType::Ao, false, "switched off for this run (--ao 0)");
  } else if (settings.ao_samples < 0 && !scene.ao.enabled) {
    set(RayType::Ao, false, "the scene has ao.enabled = false and the run did not ask (--ao N)");
  } else {
    plan.ao_samples = settings.ao_samples > 0 ? uint32_t(settings.ao_samples) : scene.ao.samples;
    if (plan.ao_samples == 0)
      set(RayType::Ao, false, "the scene asks for 0 AO samples");
    else if (!(plan.ao_length > 0.0f))
      set(RayType::Ao, false, "the AO cutoff is 0 (empty or flat scene)");
    else
      set(RayType::Ao, true,
          std::to_string(plan.ao_samples) + " per primary hit, any hit, length " +
              std::to_string(plan.ao_length));
  }
  if (!plan.on(RayType::Ao)) plan.ao_samples = 0;

  if (scene.lights.empty())
    set(RayType::Shadow, false, "the scene has no lights");
  else if (!settings.shadows)
    set(RayType::Shadow, false, "switched off for this run");
  else
    set(RayType::Shadow, true,
        "one per light facing the surface, from every closest-hit ray's hit, any hit");

  const bool mirrors = any_triangle_material(scene, [](const Material& m) { return m.reflectance > 0.0f; });
  const bool glass = any_triangle_material(scene, [](const Material& m) { return m.transmittance > 0.0f; });
  if (!mirrors)
    set(RayType::Reflection, false, "no triangle's material has reflectance > 0");
  else if (!settings.reflections)
    set(RayType::Reflection, false, "switched off for this run");
  else if (settings.max_depth == 0)
    set(RayType::Reflection, false, "max depth is 0");
  else
    set(RayType::Reflection, true, "from hits on materials with reflectance > 0, up to depth " +
                                       std::to_string(settings.max_depth));
  if (!glass)
    set(RayType::Refraction, false, "no triangle's material has transmittance > 0");
  else if (!settings.refractions)
    set(RayType::Refraction, false, "switched off for this run");
  else if (settings.max_depth == 0)
    set(RayType::Refraction, false, "max depth is 0");
  else
    set(RayType::Refraction, true, "from hits on materials with transmittance > 0, up to depth " +
                                       std::to_string(settings.max_depth));
  plan.diffuse_bounces = std::min(settings.diffuse_bounces, kMaxDiffuseBounces);
  plan.russian_roulette = settings.russian_roulette;
  for (uint32_t depth = 1; depth <= kMaxDiffuseBounces; ++depth) {
    if (depth > plan.diffuse_bounces)
      set(diffuse_ray_type(depth), false,
          plan.diffuse_bounces == 0 ? "no diffuse bounces asked (--diffuse-bounces 0)"
                                    : "deeper than --diffuse-bounces " + std::to_string(plan.diffuse_bounces));
    else
      set(diffuse_ray_type(depth), true,
          "diffuse bounce " + std::to_string(depth) + " of " + std::to_string(plan.diffuse_bounces) +
              ", cosine-weighted from the " + (depth == 1 ? std::string("primary") : "previous bounce's") +
              " hit, closest hit" +
              (plan.russian_roulette && depth > 1 ? ", russian roulette by albedo" : ""));
  }
  return plan;
}

Ray make_primary_ray(const Camera& camera, const EffectSettings& settings, uint32_t x, uint32_t y,
                     uint32_t sample) {
  const uint32_t pixel = y * settings.width + x;
  float jx = 0.5f, jy = 0.5f;
  if (settings.spp > 1) {
    KeyedRng rng(settings.seed, {pixel, sample, 0, 0});
    jx = rng.next_float();
    jy = rng.next_float();
  }
  const Camera::Ray cr = camera.primary_ray(x, y, settings.width, settings.height, jx, jy);
  Ray ray;
  ray.origin = cr.origin;
  ray.direction = cr.direction;
  ray.tmin = 0.0f;
  ray.tmax = std::numeric_limits<float>::infinity();
  ray.type = RayType::Primary;
  ray.pixel = pixel;
  ray.sample = sample;
  return ray;
}

uint64_t max_frame_rays(const Scene& scene, const EffectPlan& plan, uint64_t primary_rays) {
  uint64_t branching = 0;  // children of one hit, at most
  for (const Material& m : scene.materials)
    branching = std::max<uint64_t>(branching, (plan.on(RayType::Reflection) && m.reflectance > 0.0f ? 1 : 0) +
                                                  (plan.on(RayType::Refraction) && m.transmittance > 0.0f ? 1 : 0));
  // Closest-hit rays per primary: 1 + k + k^2 + ... + k^max_depth.
  uint64_t closest = 0, level = 1;
  for (uint32_t depth = 0; depth <= plan.max_depth && level > 0; ++depth) {
    closest = saturating_add(closest, level);
    level = saturating_mul(level, branching);
  }
  const uint64_t shadows = plan.on(RayType::Shadow) ? scene.lights.size() : 0;
  closest = saturating_add(closest, plan.diffuse_bounces);  // one diffuse path per primary
  const uint64_t per_primary = saturating_add(saturating_mul(closest, 1 + shadows), plan.ao_samples);
  return saturating_mul(per_primary, primary_rays);
}

std::vector<Ray> generate_primary_rays(const Camera& camera, const EffectSettings& settings) {
  std::vector<Ray> rays;
  rays.reserve(size_t(settings.width) * settings.height * settings.spp);
  for (uint32_t y = 0; y < settings.height; ++y)
    for (uint32_t x = 0; x < settings.width; ++x)
      for (uint32_t s = 0; s < settings.spp; ++s) rays.push_back(make_primary_ray(camera, settings, x, y, s));
  return rays;
}

namespace {
// The hit triangle's vertex k in world space: an instance's through its transform,
// computed as flatten() computes the flat scene's vertices.
vec3 hit_vertex(const Scene& scene, const HitRecord& hit, int k) {
  return hit.instance == kNoInstance ? scene.vertex(hit.prim, k) : scene.world_vertex(hit.instance, hit.prim, k);
}
// Its winding normal (v1-v0)x(v2-v0) in world space, front-facing as flatten() keeps
// a mirrored instance's triangles.
vec3 hit_winding(const Scene& scene, const HitRecord& hit) {
  const vec3 v0 = hit_vertex(scene, hit, 0);
  const vec3 n = glm::cross(hit_vertex(scene, hit, 1) - v0, hit_vertex(scene, hit, 2) - v0);
  const bool mirrored = hit.instance != kNoInstance &&
                        glm::determinant(glm::mat3(scene.instances[hit.instance].object_to_world)) < 0.0f;
  return mirrored ? -n : n;
}
}  // namespace

SurfaceHit surface_at(const Scene& scene, const Ray& ray, const HitRecord& hit) {
  SurfaceHit s;
  const vec3 v0 = hit_vertex(scene, hit, 0), v1 = hit_vertex(scene, hit, 1), v2 = hit_vertex(scene, hit, 2);
  // From barycentrics, not origin + t * direction: no error growing with t.
  s.position = (1.0f - hit.u - hit.v) * v0 + hit.u * v1 + hit.v * v2;
  const vec3 n = glm::cross(v1 - v0, v2 - v0);
  const float len = glm::length(n);
  s.normal = len > 0.0f && std::isfinite(len) ? n / len : -glm::normalize(ray.direction);
  if (glm::dot(s.normal, ray.direction) > 0.0f) s.normal = -s.normal;
  const uint32_t m = hit.prim < scene.material_ids.size() ? scene.material_ids[hit.prim] : 0;
  s.material = m < scene.materials.size() ? &scene.materials[m] : nullptr;
  return s;
}

float roulette_keep_probability(const vec3& albedo) {
  return std::clamp(std::max({albedo.x, albedo.y, albedo.z}), 0.05f, 0.95f);
}

void spawn_secondary_rays(const Scene& scene, const EffectPlan& plan, const EffectSettings& settings,
                          const Ray& ray, uint32_t ray_index, const HitRecord& hit,
                          std::vector<Ray>& out) {
  if (!hit.hit() || ray.type == RayType::Ao || ray.type == RayType::Shadow) return;
  const SurfaceHit s = surface_at(scene, ray, hit);
  const vec3 front = offset_ray_origin(s.position, s.normal);  // the side the ray came from
  Ray child;
  child.bounce = uint8_t(std::min<uint32_t>(ray.bounce + 1u, 255u));
  child.pixel = ray.pixel;
  child.sample = ray.sample;
  child.parent = ray_index;
  child.tmin = 0.0f;

  if (ray.type == RayType::Primary && plan.on(RayType::Ao)) {
    child.type = RayType::Ao;
    child.origin = front;
    child.tmax = plan.ao_length;
    for (uint32_t k = 0; k < plan.ao_samples; ++k) {
      KeyedRng rng(settings.seed, {ray.pixel, ray.sample, ray.bounce, k});
      const float r1 = rng.next_float(), r2 = rng.next_float();
      child.direction = cosine_hemisphere_direction(s.normal, r1, r2);
      out.push_back(child);
    }
  }
  if (plan.on(RayType::Shadow)) {
    child.type = RayType::Shadow;
    child.origin = front;
    for (const Light& light : scene.lights) {
      vec3 to_light;
      float tmax;
      if (light.kind == Light::Kind::Point) {
        to_light = light.position - front;
        const float dist = glm::length(to_light);
        if (!(dist > 0.0f)) continue;
        to_light /= dist;
        // Stop just short of the light: a light placed on a surface must not shadow itself.
        tmax = dist * (1.0f - 1e-4f);
      } else {
        to_light = -glm::normalize(light.direction);
        tmax = std::numeric_limits<float>::infinity();
      }
      if (!(glm::dot(to_light, s.normal) > 0.0f)) continue;  // light behind the surface: unlit, no ray
      child.direction = to_light;
      child.tmax = tmax;
      out.push_back(child);
    }
  }
  const uint32_t depth = diffuse_depth(ray.type);  // 0: the primary hit or a specular one
  if ((ray.type == RayType::Primary || depth > 0) && depth < plan.diffuse_bounces) {
    KeyedRng rng(settings.seed, {ray.pixel, ray.sample, kDiffuseKey, depth + 1});
    const float r1 = rng.next_float(), r2 = rng.next_float();
    bool survives = true;
    if (plan.russian_roulette && depth >= 1) {
      survives = rng.next_float() < roulette_keep_probability(albedo_of(s.material));
    }
    if (survives) {
      child.type = diffuse_ray_type(depth + 1);
      child.origin = front;
      child.direction = cosine_hemisphere_direction(s.normal, r1, r2);
      child.tmax = std::numeric_limits<float>::infinity();
      out.push_back(child);
    }
  }
  if (depth > 0 || !s.material || ray.bounce >= plan.max_depth) return;
  const vec3 d = glm::normalize(ray.direction);
  const float cos_i = -glm::dot(d, s.normal);  // > 0: normal faces the incoming ray
  if (plan.on(RayType::Reflection) && s.material->reflectance > 0.0f) {
    child.type = RayType::Reflection;
    child.origin = front;
    child.direction = glm::normalize(d + 2.0f * cos_i * s.normal);
    child.tmax = std::numeric_limits<float>::infinity();
    out.push_back(child);
  }
  if (plan.on(RayType::Refraction) && s.material->transmittance > 0.0f) {
    // Entering when the ray meets the triangle's front (counter-clockwise) side.
    const vec3 winding = hit_winding(scene, hit);
    const bool entering = glm::dot(winding, ray.direction) < 0.0f;
    const float ior = s.material->ior > 0.0f ? s.material->ior : 1.0f;
    const float eta = entering ? 1.0f / ior : ior;
    const float k = 1.0f - eta * eta * (1.0f - cos_i * cos_i);
    if (k >= 0.0f) {  // otherwise total internal reflection: no refracted ray
      child.type = RayType::Refraction;
      child.origin = offset_ray_origin(s.position, -s.normal);
      child.direction = glm::normalize(eta * d + (eta * cos_i - std::sqrt(k)) * s.normal);
      child.tmax = std::numeric_limits<float>::infinity();
      out.push_back(child);
    }
  }
}

}  // namespace rtsim
