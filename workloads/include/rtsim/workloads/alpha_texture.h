#pragma once
// The alpha channel of an image file (PNG and the other formats stb_image reads)
// as an AlphaTexture: what an alpha-tested material samples. Only the alpha is
// kept, 8 bits a texel, since foliage textures are large and colour is not needed.
#include <rtsim/workloads/scene.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace rtsim {

// Images wider or taller than this are refused (SuperTuxKart's largest are 4096).
constexpr uint32_t kMaxAlphaTextureSide = 16384;

// Decodes `bytes` (the file's contents; `file` names it in messages and becomes
// AlphaTexture::file). An image without an alpha channel is fully opaque (255).
// InputError naming the file if the bytes are no image stb_image can decode or the
// image is larger than kMaxAlphaTextureSide on a side.
AlphaTexture decode_alpha_texture(const std::vector<uint8_t>& bytes, const std::string& file);
// Reads and decodes a file (a regular file within kMaxDataFileBytes); InputError if not.
AlphaTexture read_alpha_texture(const std::filesystem::path& path);

}  // namespace rtsim
