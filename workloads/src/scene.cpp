#include <rtsim/workloads/error.h>
#include <rtsim/workloads/random.h>
#include <rtsim/workloads/scene.h>

#include <cmath>
#include <cstring>

namespace rtsim {

Camera::Ray Camera::primary_ray(uint32_t x, uint32_t y, uint32_t width, uint32_t height,
                                float jitter_x, float jitter_y) const {
  const vec3 forward = glm::normalize(target - position);
  vec3 right = glm::cross(forward, up);
  // A camera looking along `up` has no defined right vector; pick any perpendicular.
  if (glm::dot(right, right) < 1e-12f) right = glm::cross(forward, vec3(1, 0, 0));
  if (glm::dot(right, right) < 1e-12f) right = glm::cross(forward, vec3(0, 0, 1));
  right = glm::normalize(right);
  const vec3 true_up = glm::cross(right, forward);
  const float tan_half = std::tan(glm::radians(vertical_fov_deg) * 0.5f);
  const float aspect = float(width) / float(height);
  const float sx = (2.0f * (float(x) + jitter_x) / float(width) - 1.0f) * tan_half * aspect;
  const float sy = (1.0f - 2.0f * (float(y) + jitter_y) / float(height)) * tan_half;
  return {position, glm::normalize(forward + sx * right + sy * true_up)};
}

Aabb Scene::bounds() const {
  Aabb box;
  for (const uvec3& t : triangles)
    for (int k = 0; k < 3; ++k) box.extend(vertices[t[k]]);
  return box;
}

const Camera* Scene::find_camera(const std::string& camera_name) const {
  for (const Camera& c : cameras)
    if (c.name == camera_name) return &c;
  return nullptr;
}

const Camera& Scene::camera(const std::string& camera_name) const {
  if (const Camera* c = find_camera(camera_name)) return *c;
  std::string names;
  for (const Camera& c : cameras) names += (names.empty() ? "" : ", ") + c.name;
  throw InputError("scene '" + name + "'",
                   "no camera named '" + camera_name + "' (cameras: " + names + ")");
}


const Camera& Scene::default_camera() const {
  if (const Camera* c = find_camera("view1")) return *c;
  if (cameras.empty()) throw InputError("scene '" + name + "'", "has no cameras");
  return cameras.front();
}

uint64_t Scene::content_hash() const {
  uint64_t h = 0x5254'5349'4D00'0001ull;
  h = hash_bytes(h, vertices.data(), vertices.size() * sizeof(vec3));
  h = hash_bytes(h, triangles.data(), triangles.size() * sizeof(uvec3));
  h = hash_bytes(h, material_ids.data(), material_ids.size() * sizeof(uint32_t));
  for (const Material& m : materials) {
    const float f[] = {m.albedo.x, m.albedo.y, m.albedo.z, m.reflectance, m.transmittance,
                       m.ior, m.emission.x, m.emission.y, m.emission.z};
    h = hash_bytes(h, f, sizeof f);
  }
  return h;
}

}  // namespace rtsim
