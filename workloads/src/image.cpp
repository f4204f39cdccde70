#include <rtsim/workloads/files.h>
#include <rtsim/workloads/image.h>

// The implementation comes compiled in Debian's libstb.
#include <stb_image_write.h>

#include <cmath>
#include <stdexcept>

namespace rtsim {

namespace {
float to_srgb(float c) {
  c = std::clamp(c, 0.0f, 1.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}
void append_bytes(void* context, void* data, int size) {
  static_cast<std::ostream*>(context)->write(static_cast<const char*>(data), size);
}
}  // namespace

void write_png(const std::filesystem::path& path, const Image& image, bool srgb) {
  if (image.width == 0 || image.height == 0)
    throw std::runtime_error(path.string() + ": cannot write an empty image");
  std::vector<unsigned char> bytes(size_t(image.width) * image.height * 3);
  for (size_t i = 0; i < image.pixels.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      const float v = srgb ? to_srgb(image.pixels[i][c]) : std::clamp(image.pixels[i][c], 0.0f, 1.0f);
      bytes[3 * i + c] = (unsigned char)std::lround(v * 255.0f);
    }
  write_file_atomic(path, [&](std::ostream& out) {
    if (!stbi_write_png_to_func(append_bytes, &out, int(image.width), int(image.height), 3,
                                bytes.data(), int(image.width) * 3))
      throw std::runtime_error(path.string() + ": PNG encoding failed");
  });
}

vec3 heat_colour(float t) {
  // Piecewise-linear through a few viridis-like stops.
  static const vec3 stops[] = {{0.267f, 0.005f, 0.329f}, {0.229f, 0.322f, 0.546f},
                               {0.128f, 0.567f, 0.551f}, {0.369f, 0.789f, 0.383f},
                               {0.993f, 0.906f, 0.144f}};
  if (!std::isfinite(t)) t = 0.0f;
  t = std::clamp(t, 0.0f, 1.0f) * 4.0f;
  const int i = std::min(int(t), 3);
  return glm::mix(stops[i], stops[i + 1], t - float(i));
}

Image heatmap(const std::vector<float>& values, uint32_t width, uint32_t height, float max_value) {
  Image image(width, height);
  const float scale = max_value > 0.0f ? 1.0f / max_value : 0.0f;
  for (size_t i = 0; i < image.pixels.size() && i < values.size(); ++i)
    image.pixels[i] = heat_colour(values[i] * scale);
  return image;
}

}  // namespace rtsim
