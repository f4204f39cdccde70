// SuperTuxKart alpha testing: SPM texture coordinates (two IEEE half floats a
// vertex), materials.xml shaders, the folders a texture is looked up in, PNG alpha
// channels, and what the track flattener and a scene descriptor make of them. The
// SPM bytes, the track folder and its PNGs (stb_image_write) are made here.
#include <rtsim/workloads/alpha_texture.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/mesh_loader.h>

#include <gtest/gtest.h>
#include <stb_image_write.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace rtsim;

namespace {

template <typename T>
void put(std::vector<uint8_t>& out, T value) {
  const auto* p = reinterpret_cast<const uint8_t*>(&value);
  out.insert(out.end(), p, p + sizeof(T));
}

fs::path temp_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("rtsim_test_stk_alpha_" + name + "_" +
                                                    std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void write_bytes(const fs::path& path, const std::vector<uint8_t>& bytes) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}
void write_text(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

// A PNG of `channels` channels (2: grey and alpha, 4: RGBA) whose alpha is `alpha`.
void write_png(const fs::path& path, int width, int height, int channels, const std::vector<uint8_t>& alpha) {
  ASSERT_EQ(alpha.size(), size_t(width) * size_t(height));
  std::vector<uint8_t> pixels(alpha.size() * size_t(channels), 90);
  for (size_t i = 0; i < alpha.size(); ++i) pixels[i * size_t(channels) + size_t(channels) - 1] = alpha[i];
  fs::create_directories(path.parent_path());
  ASSERT_TRUE(stbi_write_png(path.string().c_str(), width, height, channels, pixels.data(), width * channels));
}

template <typename F>
void expect_input_error(F&& f, std::initializer_list<std::string> fragments) {
  try {
    f();
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    for (const std::string& fragment : fragments)
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos)
          << "message '" << e.what() << "' lacks '" << fragment << "'";
  }
}

// Half floats used below, bit patterns written out so the test does not share the
// loader's conversion.
constexpr uint16_t kHalfZero = 0x0000, kHalfQuarter = 0x3400, kHalfHalf = 0x3800, kHalfThreeQuarters = 0x3a00,
                   kHalfOne = 0x3c00, kHalfMinusTwo = 0xc000, kHalfMax = 0x7bff /* 65504 */,
                   kHalfSmallest = 0x0001 /* 2^-24, subnormal */;

struct SpmVertex {
  vec3 position;
  uint16_t u = 0, v = 0;
};
struct SpmBuffer {
  std::vector<SpmVertex> vertices;
  std::vector<uint32_t> indices;
  uint16_t material = 0;
};
struct SpmMaterial {
  std::string texture1, texture2;
};

// Static SPM version 1. with_extras: normals, vertex colours and tangents, and every
// textured material has a texture 2 (a second UV whose bytes must not be taken for
// the first), so each optional field around the UV is exercised.
std::vector<uint8_t> make_spm(const std::vector<SpmMaterial>& materials, const std::vector<SpmBuffer>& buffers,
                              bool with_extras = false) {
  std::vector<uint8_t> out = {'S', 'P', uint8_t(1 << 3 | 2), uint8_t(with_extras ? 0x1 | 0x2 | 0x4 : 0)};
  for (int k = 0; k < 6; ++k) put(out, 0.0f);
  put(out, uint16_t(materials.size()));
  for (const SpmMaterial& m : materials) {
    out.push_back(uint8_t(m.texture1.size()));
    out.insert(out.end(), m.texture1.begin(), m.texture1.end());
    out.push_back(uint8_t(m.texture2.size()));
    out.insert(out.end(), m.texture2.begin(), m.texture2.end());
  }
  put(out, uint16_t(1));  // one section
  put(out, uint16_t(buffers.size()));
  for (const SpmBuffer& b : buffers) {
    put(out, uint32_t(b.vertices.size()));
    put(out, uint32_t(b.indices.size()));
    put(out, b.material);
    const SpmMaterial& m = materials.at(b.material);
    for (const SpmVertex& v : b.vertices) {
      for (int k = 0; k < 3; ++k) put(out, v.position[k]);
      if (with_extras) {
        put(out, uint32_t(0x12345678));  // packed normal
        out.insert(out.end(), {7, 1, 2, 3});  // a colour id other than 128, then RGB
      }
      if (!m.texture1.empty()) {
        put(out, v.u);
        put(out, v.v);
        if (!m.texture2.empty()) put(out, uint32_t(0x7e007e00));  // UV2: NaNs, never to be read as UV1
        if (with_extras) put(out, uint32_t(0xdeadbeef));          // packed tangent
      }
    }
    for (uint32_t i : b.indices) out.push_back(uint8_t(i));
  }
  return out;
}

// A triangle in the z = 0 plane with the given corner UVs.
SpmBuffer triangle(uint16_t material, std::array<std::array<uint16_t, 2>, 3> uv, float x = 0.0f) {
  SpmBuffer b;
  b.vertices = {{vec3(x, 0, 0), uv[0][0], uv[0][1]},
                {vec3(x + 1, 0, 0), uv[1][0], uv[1][1]},
                {vec3(x, 1, 0), uv[2][0], uv[2][1]}};
  b.indices = {0, 1, 2};
  b.material = material;
  return b;
}

void expect_uv(const TriangleUv& got, const TriangleUv& want) {
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(got[k].x, want[k].x) << "corner " << k;
    EXPECT_EQ(got[k].y, want[k].y) << "corner " << k;
  }
}

// ---------------------------------------------------------------- SPM coordinates
TEST(SpmUv, HalfFloatCoordinatesFollowTheLoadersVertexOrder) {
  for (const bool extras : {false, true}) {
    SCOPED_TRACE(extras ? "with normals, colours, tangents and a UV2" : "plain");
    SpmBuffer quad;
    quad.vertices = {{vec3(0, 0, 0), kHalfQuarter, kHalfHalf},
                     {vec3(1, 0, 0), kHalfOne, kHalfMinusTwo},
                     {vec3(1, 1, 0), kHalfMax, kHalfSmallest},
                     {vec3(0, 1, 0), kHalfThreeQuarters, kHalfZero}};
    quad.indices = {0, 1, 2, 0, 2, 3};
    const std::vector<SpmMaterial> materials = {{"leaf.png", extras ? "light.png" : ""}, {"", ""}};
    SpmBuffer untextured = triangle(1, {});
    const Mesh mesh = parse_spm(make_spm(materials, {quad, untextured}, extras), "uv.spm");
    ASSERT_EQ(mesh.triangles.size(), 3u);
    ASSERT_EQ(mesh.triangle_uvs.size(), 3u);
    const glm::vec2 uv0(0.25f, 0.5f), uv1(1.0f, -2.0f), uv2(65504.0f, std::ldexp(1.0f, -24)), uv3(0.75f, 0.0f);
    // The file's (0, 1, 2) becomes (0, 2, 1): the coordinates are swapped with the vertices.
    EXPECT_EQ(mesh.triangles[0], uvec3(0, 2, 1));
    expect_uv(mesh.triangle_uvs[0], {uv0, uv2, uv1});
    expect_uv(mesh.triangle_uvs[1], {uv0, uv3, uv2});
    expect_uv(mesh.triangle_uvs[2], {glm::vec2(0), glm::vec2(0), glm::vec2(0)});  // no texture, no UV bytes
    EXPECT_EQ(mesh.vertices[4], vec3(0, 0, 0));  // the untextured buffer read from the right offset
    for (const Material& m : mesh.materials) EXPECT_FALSE(m.alpha_tested());  // no materials.xml here
  }
}

TEST(SpmUv, ATruncatedCoordinateNamesTheSameFieldAsBefore) {
  std::vector<uint8_t> bytes = make_spm({{"leaf.png", ""}}, {triangle(0, {})});
  // Cut inside the last vertex's UV: 3 index bytes, then 2 of the 4 UV bytes.
  bytes.resize(bytes.size() - 3 - 2);
  expect_input_error([&] { parse_spm(bytes, "cut.spm"); }, {"cut.spm", "vertex uv", "past the end"});
}

// ---------------------------------------------------------------- PNG alpha
TEST(AlphaTexture, ReadsTheAlphaChannelRowMajorWhateverTheChannelCount) {
  const fs::path dir = temp_dir("png");
  const std::vector<uint8_t> alpha = {0, 64, 128, 255, 10, 20, 30, 40};
  write_png(dir / "rgba.png", 4, 2, 4, alpha);
  write_png(dir / "grey_alpha.png", 4, 2, 2, alpha);
  for (const char* name : {"rgba.png", "grey_alpha.png"}) {
    const AlphaTexture t = read_alpha_texture(dir / name);
    EXPECT_EQ(t.width, 4u);
    EXPECT_EQ(t.height, 2u);
    EXPECT_EQ(t.alpha, alpha) << name;
    EXPECT_EQ(t.file, (dir / name).string());
  }
  write_png(dir / "grey.png", 2, 1, 1, {7, 8});  // no alpha channel: opaque
  EXPECT_EQ(read_alpha_texture(dir / "grey.png").alpha, std::vector<uint8_t>({255, 255}));
  write_text(dir / "junk.png", "not a png at all");
  expect_input_error([&] { read_alpha_texture(dir / "junk.png"); }, {"junk.png", "not an image"});
  expect_input_error([&] { read_alpha_texture(dir / "absent.png"); }, {"absent.png"});
  fs::remove_all(dir);
}

}  // namespace
