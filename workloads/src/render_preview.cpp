#include <rtsim/workloads/embree_scene.h>
#include <rtsim/workloads/render_preview.h>

#include <tbb/parallel_for.h>

#include <limits>

namespace rtsim {

Image render_preview(const Scene& scene, const Camera& camera, uint32_t width, uint32_t height) {
  EmbreeScene embree(scene);
  Image image(width, height);
  tbb::parallel_for(uint32_t(0), height, [&](uint32_t y) {
    for (uint32_t x = 0; x < width; ++x) {
      const Camera::Ray ray = camera.primary_ray(x, y, width, height);
      const EmbreeHit hit =
          embree.intersect(ray.origin, ray.direction, 0.0f, std::numeric_limits<float>::infinity());
      vec3 colour(0.08f);
      if (hit.hit) {
        vec3 n = hit.geometric_normal;
        const float len = glm::length(n);
        n = len > 0.0f ? n / len : vec3(0.0f);
        const bool front = glm::dot(n, ray.direction) < 0.0f;
        const float facing = std::abs(glm::dot(n, ray.direction));
        colour = front ? (0.5f * glm::abs(n) + 0.5f) * (0.3f + 0.7f * facing)
                       : vec3(0.6f, 0.1f, 0.1f) * (0.3f + 0.7f * facing);
      }
      image.at(x, y) = colour;
    }
  });
  return image;
}

}  // namespace rtsim
