#pragma once
// RGB float images written as PNG (stb_image_write), and the colour scale used by
// every heatmap so that pictures from different runs compare by eye.
#include <rtsim/workloads/geometry.h>

#include <filesystem>
#include <vector>

namespace rtsim {

struct Image {
  uint32_t width = 0, height = 0;
  std::vector<vec3> pixels;  // linear RGB in [0,1], row-major from the top
  Image() = default;
  Image(uint32_t w, uint32_t h) : width(w), height(h), pixels(size_t(w) * h, vec3(0.0f)) {}
  vec3& at(uint32_t x, uint32_t y) { return pixels[size_t(y) * width + x]; }
  const vec3& at(uint32_t x, uint32_t y) const { return pixels[size_t(y) * width + x]; }
};

// Writes atomically (temp + rename); throws std::runtime_error naming the file.
void write_png(const std::filesystem::path& path, const Image& image, bool srgb = true);

// A perceptually ordered colour scale (dark blue -> green -> yellow) for t in [0,1].
vec3 heat_colour(float t);

// Heatmap of per-pixel values on a fixed scale [0, max_value] (shared across builders).
Image heatmap(const std::vector<float>& values, uint32_t width, uint32_t height, float max_value);

}  // namespace rtsim
