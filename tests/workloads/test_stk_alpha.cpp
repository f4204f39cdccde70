// SuperTuxKart alpha testing: SPM texture coordinates (two IEEE half floats a
// vertex), materials.xml shaders, the folders a texture is looked up in, PNG alpha
// channels, and what the track flattener and a scene descriptor make of them. The
// SPM bytes, the track folder and its PNGs (stb_image_write) are made here.
#include <rtsim/workloads/alpha_texture.h>
#include <rtsim/workloads/descriptor.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/mesh_loader.h>

#include "workloads/test_files.h"

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

using rtsim::test::put;

fs::path temp_dir(const std::string& name) { return rtsim::test::temp_dir("rtsim_test_stk_alpha_", name); }
using rtsim::test::write_bytes;
using rtsim::test::write_text;

// A PNG of `channels` channels (2: grey and alpha, 4: RGBA) whose alpha is `alpha`.
void write_png(const fs::path& path, int width, int height, int channels, const std::vector<uint8_t>& alpha) {
  ASSERT_EQ(alpha.size(), size_t(width) * size_t(height));
  std::vector<uint8_t> pixels(alpha.size() * size_t(channels), 90);
  for (size_t i = 0; i < alpha.size(); ++i) pixels[i * size_t(channels) + size_t(channels) - 1] = alpha[i];
  fs::create_directories(path.parent_path());
  ASSERT_TRUE(stbi_write_png(path.string().c_str(), width, height, channels, pixels.data(), width * channels));
}

using rtsim::test::expect_input_error;

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

// ---------------------------------------------------------------- STK track
const std::vector<uint8_t> kTrackLeafAlpha = {0, 64, 128, 255, 10, 20, 200, 40};  // 4 x 2
const std::vector<uint8_t> kLibraryLeafAlpha = {255, 0};                          // 2 x 1
const std::vector<uint8_t> kBushAlpha = {1, 2, 3, 4};                              // 2 x 2, grey + alpha
const std::vector<uint8_t> kGlobalAlpha = {200};                                   // 1 x 1

// data/tracks/t: the track model has an opaque, an alpha-tested (leaf.png), an
// alpha-blended and an alpha-tested material whose PNG exists nowhere. Library
// lib1 (mirrored by a negative scale) names its own Bush.png in upper case in
// its materials.xml, the track's leaf.png (found in the track folder) and a
// global texture; lib2 has a leaf.png of its own, which wins over the track's.
fs::path make_track(const fs::path& root) {
  const fs::path data = root / "data", track = data / "tracks/t";
  const std::array<std::array<uint16_t, 2>, 3> leaf_uv = {{{kHalfQuarter, kHalfHalf},
                                                           {kHalfThreeQuarters, kHalfHalf},
                                                           {kHalfQuarter, kHalfOne}}};
  write_bytes(track / "ground.spm",
              make_spm({{"ground.png", ""}, {"leaf.png", ""}, {"blend.png", ""}, {"gone.png", ""}},
                       {triangle(0, {}), triangle(1, leaf_uv, 2), triangle(2, {}, 4), triangle(3, {}, 6)}));
  write_text(track / "materials.xml", R"(<?xml version="1.0"?>
<materials>
  <material name="ground.png" normal-map="ground_nm.png"/>
  <material name="leaf.png" shader="alphatest" ignore="Y"/>
  <material name="blend.png" shader="alphablend"/>
  <material name="gone.png" shader="alphatest"/>
</materials>
)");
  write_png(track / "leaf.png", 4, 2, 4, kTrackLeafAlpha);
  write_png(track / "blend.png", 1, 1, 4, {0});
  write_text(track / "scene.xml", R"(<?xml version="1.0"?>
<scene>
  <track model="ground.spm" x="0" y="0" z="0"/>
  <library name="lib1" xyz="0 0 10" hpr="0 0 0" scale="-1 1 1"/>
  <library name="lib2" xyz="0 0 20"/>
</scene>
)");
  const fs::path lib1 = data / "library/lib1";
  write_bytes(lib1 / "bush.spm", make_spm({{"bush.png", ""}, {"leaf.png", ""}, {"global.png", ""}},
                                          {triangle(0, leaf_uv), triangle(1, leaf_uv, 2), triangle(2, {}, 4)}));
  write_text(lib1 / "materials.xml", "<materials><material name=\"Bush.png\" shader=\"alphatest\"/></materials>");
  write_png(lib1 / "bush.png", 2, 2, 2, kBushAlpha);
  write_text(lib1 / "node.xml", "<scene><object type=\"animation\" model=\"bush.spm\"/></scene>");
  const fs::path lib2 = data / "library/lib2";
  write_bytes(lib2 / "leafy.spm", make_spm({{"leaf.png", ""}}, {triangle(0, {})}));
  write_text(lib2 / "materials.xml", "<materials><material name=\"leaf.png\" shader=\"alphatest\"/></materials>");
  write_png(lib2 / "leaf.png", 2, 1, 4, kLibraryLeafAlpha);
  write_text(lib2 / "node.xml", "<scene><object type=\"animation\" model=\"leafy.spm\"/></scene>");
  write_text(data / "textures/materials.xml",
             "<materials><material name=\"global.png\" shader=\"alphatest\"/></materials>");
  write_png(data / "textures/global.png", 1, 1, 4, kGlobalAlpha);
  return track;
}

// The material of the triangle whose first vertex lies at `at`.
const Material& material_at(const Mesh& mesh, const vec3& at, size_t* triangle = nullptr) {
  for (size_t t = 0; t < mesh.triangles.size(); ++t)
    if (glm::length(mesh.vertices[mesh.triangles[t].x] - at) < 1e-4f) {
      if (triangle) *triangle = t;
      return mesh.materials.at(mesh.material_ids.at(t));
    }
  ADD_FAILURE() << "no triangle starts at " << at.x << " " << at.y << " " << at.z;
  static const Material none;
  return none;
}

const AlphaTexture& texture_of(const Mesh& mesh, const Material& m) {
  static const AlphaTexture none;
  if (!m.alpha_tested() || size_t(m.alpha_texture) >= mesh.alpha_textures.size()) {
    ADD_FAILURE() << "material " << m.name << " has no alpha texture";
    return none;
  }
  return mesh.alpha_textures[size_t(m.alpha_texture)];
}

TEST(StkAlpha, AlphaTestedMaterialsGetTheirTexturesCutoffAndCoordinates) {
  const fs::path root = temp_dir("track");
  const fs::path track = make_track(root);
  const Mesh mesh = flatten(load_stk_track(track));
  ASSERT_EQ(mesh.triangles.size(), 8u);  // track 4, lib1 3, lib2 1
  ASSERT_EQ(mesh.triangle_uvs.size(), mesh.triangles.size());

  // Opaque: no shader, alphablend (blending is no alpha test), and the PNG found nowhere.
  EXPECT_FALSE(material_at(mesh, vec3(0, 0, 0)).alpha_tested());
  EXPECT_FALSE(material_at(mesh, vec3(4, 0, 0)).alpha_tested());
  EXPECT_FALSE(material_at(mesh, vec3(6, 0, 0)).alpha_tested());
  EXPECT_EQ(mesh.alpha_textures_missing, 1u);

  size_t leaf_triangle = 0;
  const Material& leaf = material_at(mesh, vec3(2, 0, 0), &leaf_triangle);
  EXPECT_EQ(leaf.name, "leaf.png");
  EXPECT_EQ(leaf.alpha_cutoff, 0.5f);
  const AlphaTexture& leaf_texture = texture_of(mesh, leaf);
  EXPECT_EQ(leaf_texture.file, (track / "leaf.png").lexically_normal().string());
  EXPECT_EQ(leaf_texture.width, 4u);
  EXPECT_EQ(leaf_texture.height, 2u);
  EXPECT_EQ(leaf_texture.alpha, kTrackLeafAlpha);
  // File order (0.25,0.5) (0.75,0.5) (0.25,1); the loader's winding swap takes 1 and 2 along.
  const glm::vec2 a(0.25f, 0.5f), b(0.75f, 0.5f), c(0.25f, 1.0f);
  expect_uv(mesh.triangle_uvs[leaf_triangle], {a, c, b});

  // lib1 is mirrored (scale -1 in x): its triangles' vertices, and coordinates, swap back.
  // Irrlicht x is negated, so the triangle that started at x = 0 starts at x = 0 still.
  size_t bush_triangle = 0;
  const Material& bush = material_at(mesh, vec3(0, 0, -10), &bush_triangle);
  EXPECT_EQ(bush.name, "bush.png");  // Bush.png in materials.xml: names match in any case
  EXPECT_EQ(texture_of(mesh, bush).alpha, kBushAlpha);
  expect_uv(mesh.triangle_uvs[bush_triangle], {a, b, c});

  // lib1's leaf.png is the track's (found in the track folder): one material, one texture.
  const Material& lib1_leaf = material_at(mesh, vec3(-2, 0, -10));
  EXPECT_EQ(&lib1_leaf, &leaf);
  EXPECT_EQ(texture_of(mesh, material_at(mesh, vec3(-4, 0, -10))).alpha, kGlobalAlpha);  // data/textures

  // lib2's own leaf.png wins over the track's: the same name, another texture and material.
  const Material& lib2_leaf = material_at(mesh, vec3(0, 0, -20));
  EXPECT_EQ(lib2_leaf.name, "leaf.png");
  EXPECT_NE(lib2_leaf.alpha_texture, leaf.alpha_texture);
  EXPECT_EQ(texture_of(mesh, lib2_leaf).alpha, kLibraryLeafAlpha);
  EXPECT_EQ(mesh.alpha_textures.size(), 4u);  // track leaf, bush, global, lib2 leaf: each file once

  // What `scenes fetch` copies: the same four files, none decoded.
  std::vector<fs::path> files = stk_track_alpha_texture_files(track);
  std::vector<std::string> names;
  for (const fs::path& f : files) names.push_back(f.lexically_relative(root / "data").generic_string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, std::vector<std::string>({"library/lib1/bush.png", "library/lib2/leaf.png",
                                             "textures/global.png", "tracks/t/leaf.png"}));
  fs::remove_all(root);
}

Mesh flat_track(const fs::path& track) { return flatten(load_stk_track(track)); }

// The flat track and its descriptor scene, bit for bit as they were before tracks
// kept their instances (hashes recorded then).
TEST(StkAlpha, TheFlatTrackAndItsSceneAreBitForBitWhatTheyWereBefore) {
  const fs::path root = temp_dir("pinned");
  const fs::path track = make_track(root);
  const Mesh mesh = flat_track(track);
  EXPECT_EQ(rtsim::test::geometry_hash(mesh), 0xf1af7d1f5a58d348ull);
  write_text(root / "scene.toml", "name = \"t\"\n[[mesh]]\nfile = \"data/tracks/t/scene.xml\"\n"
                                  "[[camera]]\nname = \"view1\"\nposition = [0, 5, 5]\ntarget = [0, 0, 0]\n");
  const Scene scene = load_scene_descriptor(root / "scene.toml");
  EXPECT_EQ(scene.content_hash(), 0x1621bb9c01359fe1ull);
  EXPECT_EQ(rtsim::test::geometry_hash(scene), 0xf1af7d1f5a58d348ull);
  fs::remove_all(root);
}

TEST(StkAlpha, ASceneDescriptorKeepsTheTexturesAndSamplesThem) {
  const fs::path root = temp_dir("descriptor");
  make_track(root);
  write_text(root / "scene.toml", R"(name = "t"
[[mesh]]
file = "data/tracks/t/scene.xml"
[[camera]]
name = "view1"
position = [0, 5, 5]
target = [0, 0, 0]
)");
  const Scene scene = load_scene_descriptor(root / "scene.toml");
  EXPECT_EQ(scene.alpha_textures.size(), 4u);
  EXPECT_EQ(scene.alpha_tested_triangles(), 5u);  // leaf, bush, lib1 leaf, global, lib2 leaf
  uint32_t leaf = ~0u;
  for (uint32_t t = 0; t < scene.triangle_count(); ++t)
    if (glm::length(scene.vertex(t, 0) - vec3(2, 0, 0)) < 1e-4f) leaf = t;
  ASSERT_NE(leaf, ~0u);
  ASSERT_TRUE(scene.alpha_tested(leaf));
  // The leaf's coordinates are (a, c, b) = (0.25,0.5) (0.25,1) (0.75,0.5): at
  // barycentrics (u, v) they are (0.25 + 0.5 v, 0.5 + 0.5 u).
  const AlphaSample cut = scene.alpha_sample(leaf, 0.0f, 0.0f);  // (0.25, 0.5): texel (1, 1), alpha 20
  EXPECT_EQ(cut.x, 1u);
  EXPECT_EQ(cut.y, 1u);
  EXPECT_FALSE(cut.opaque);
  const AlphaSample kept = scene.alpha_sample(leaf, 0.0f, 0.6f);  // (0.55, 0.5): texel (2, 1), alpha 200
  EXPECT_EQ(kept.x, 2u);
  EXPECT_EQ(kept.y, 1u);
  EXPECT_TRUE(kept.opaque);
  fs::remove_all(root);
}

TEST(StkAlpha, MissingOrUndecodableTexturesLeaveMaterialsOpaqueAndAreCounted) {
  const fs::path root = temp_dir("missing");
  const fs::path track = make_track(root);
  fs::remove(track / "leaf.png");  // lib1's leaf.png then is found nowhere either
  write_text(root / "data/library/lib2/leaf.png", "truncated");
  const Mesh mesh = flatten(load_stk_track(track));
  EXPECT_FALSE(material_at(mesh, vec3(2, 0, 0)).alpha_tested());
  EXPECT_FALSE(material_at(mesh, vec3(0, 0, -20)).alpha_tested());
  // gone.png and leaf.png found nowhere, lib2's leaf.png undecodable.
  EXPECT_EQ(mesh.alpha_textures_missing, 3u);
  EXPECT_EQ(mesh.alpha_textures.size(), 2u);  // bush and global are still read
  EXPECT_EQ(mesh.triangles.size(), 8u);       // the geometry is all there

  // With no texture at all the track is as opaque as before: no coordinates kept.
  fs::remove(root / "data/library/lib1/bush.png");
  fs::remove(root / "data/textures/global.png");
  const Mesh opaque = load_stk_track(track);
  EXPECT_TRUE(opaque.alpha_textures.empty());
  EXPECT_TRUE(opaque.triangle_uvs.empty());
  for (const Material& m : opaque.materials) EXPECT_FALSE(m.alpha_tested());
  EXPECT_EQ(opaque.alpha_textures_missing, 5u);

  write_text(track / "materials.xml", "<materials><material name=\"x\"</materials>");
  expect_input_error([&] { load_stk_track(track); }, {(track / "materials.xml").string(), "XML"});
  fs::remove_all(root);
}

}  // namespace
