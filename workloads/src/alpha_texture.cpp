// Alpha channels of textures, decoded with stb_image. The implementation comes
// compiled in Debian's libstb (as stb_image_write's for image.cpp), so this file
// does not define STB_IMAGE_IMPLEMENTATION.
#include <rtsim/workloads/alpha_texture.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>

#include <stb_image.h>

#include <climits>
#include <memory>

namespace rtsim {

namespace {

std::string stb_reason() {
  const char* reason = stbi_failure_reason();  // may be null: nothing recorded
  return reason ? reason : "no reason given";
}

}  // namespace

AlphaTexture decode_alpha_texture(const std::vector<uint8_t>& bytes, const std::string& file) {
  if (bytes.size() > size_t(INT_MAX)) throw InputError(file, "image file too large to decode");
  const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
  const int length = int(bytes.size());
  int width = 0, height = 0, channels = 0;
  // The header first: refuse a huge image before allocating its pixels.
  if (!stbi_info_from_memory(data, length, &width, &height, &channels))
    throw InputError(file, "not an image stb_image can read (" + stb_reason() + ")");
  if (width <= 0 || height <= 0 || uint32_t(width) > kMaxAlphaTextureSide ||
      uint32_t(height) > kMaxAlphaTextureSide)
    throw InputError(file, "image is " + std::to_string(width) + " x " + std::to_string(height) +
                               " (at most " + std::to_string(kMaxAlphaTextureSide) + " on a side)");
  // Four channels forced: RGBA whatever the file holds (grey, grey+alpha, RGB get
  // alpha 255 where they have none), so the alpha is always channel 3.
  const std::unique_ptr<stbi_uc, void (*)(void*)> pixels(
      stbi_load_from_memory(data, length, &width, &height, &channels, 4), stbi_image_free);
  if (!pixels) throw InputError(file, "cannot decode the image (" + stb_reason() + ")");
  AlphaTexture texture;
  texture.file = file;
  texture.width = uint32_t(width);
  texture.height = uint32_t(height);
  // stb's row 0 is the top of the image; STK (OpenGL) samples the file's first row
  // at t = 0, which is AlphaTexture's row 0: no flip.
  const size_t texels = size_t(width) * size_t(height);
  texture.alpha.resize(texels);
  for (size_t i = 0; i < texels; ++i) texture.alpha[i] = pixels.get()[4 * i + 3];
  return texture;
}

AlphaTexture read_alpha_texture(const std::filesystem::path& path) {
  const std::string bytes = read_input_file(path, kMaxDataFileBytes);
  return decode_alpha_texture(std::vector<uint8_t>(bytes.begin(), bytes.end()), path.string());
}

}  // namespace rtsim
