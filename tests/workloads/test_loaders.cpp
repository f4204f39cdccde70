// Mesh loaders on tiny fixtures synthesised here: Quake 3 IBSP v46 (faces, a
// Bezier patch, skipped surfaces, spawn cameras, .pk3), SuperTuxKart .spm and a
// scene.xml track folder, and OBJ/PLY through assimp. Malformed inputs must
// give an InputError that names the file, never a crash.
#include <rtsim/workloads/descriptor.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/mesh_loader.h>
#include <rtsim/workloads/random.h>
#include <rtsim/workloads/validate.h>

#include "workloads/test_files.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <filesystem>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace rtsim;

namespace {

// ---------------------------------------------------------------- helpers
using rtsim::test::put;
template <typename T>
void poke(std::vector<uint8_t>& out, size_t offset, T value) {
  std::memcpy(out.data() + offset, &value, sizeof(T));
}

fs::path temp_dir(const std::string& name) { return rtsim::test::temp_dir("rtsim_test_loaders_", name); }
using rtsim::test::write_bytes;
using rtsim::test::write_text;

vec3 normal_of(const Mesh& mesh, size_t tri) {
  const uvec3 t = mesh.triangles[tri];
  return glm::cross(mesh.vertices[t.y] - mesh.vertices[t.x], mesh.vertices[t.z] - mesh.vertices[t.x]);
}

using rtsim::test::expect_input_error;

// ---------------------------------------------------------------- Quake 3 BSP
struct BspFace {
  int32_t texture = 0, type = 1, vertex = 0, n_vertices = 0, meshvert = 0, n_meshverts = 0;
  int32_t size_x = 0, size_y = 0;
};
struct BspVertex {
  vec3 position{0.0f}, normal{0.0f};
};

struct BspFixture {
  std::string entities =
      "{\n\"classname\" \"worldspawn\"\n}\n"
      "{\n\"classname\" \"info_player_deathmatch\"\n\"origin\" \"10 20 30\"\n\"angle\" \"90\"\n}\n";
  std::vector<std::pair<std::string, int32_t>> textures = {
      {"textures/base/wall", 0}, {"textures/common/caulk", 0}, {"textures/skies/sky", 0x4}};
  std::vector<BspVertex> vertices;
  std::vector<int32_t> meshverts;
  std::vector<BspFace> faces;
  size_t face_lump_offset = 0, vertex_lump_offset = 0, meshvert_lump_offset = 0;

  BspFixture() {
    // Face 0: unit quad in the Q3 ground plane z = 0, front side up (+Z), stored
    // clockwise as seen from the front, as Quake 3 does.
    for (vec3 p : {vec3(0, 0, 0), vec3(1, 0, 0), vec3(1, 1, 0), vec3(0, 1, 0)})
      vertices.push_back({p, vec3(0, 0, 1)});
    meshverts = {0, 2, 1, 0, 3, 2};
    faces.push_back({0, 1, 0, 4, 0, 6, 0, 0});
    // Face 1: a flat 3x3 patch at z = 5 whose normals point up.
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) vertices.push_back({vec3(float(i), float(j), 5.0f), vec3(0, 0, 1)});
    faces.push_back({0, 2, 4, 9, 0, 0, 3, 3});
    // Faces 2-4: caulk (skipped), sky (dropped by default), a billboard (skipped).
    faces.push_back({1, 1, 0, 4, 0, 6, 0, 0});
    faces.push_back({2, 1, 0, 4, 0, 6, 0, 0});
    faces.push_back({0, 4, 0, 4, 0, 0, 0, 0});
  }

  std::vector<uint8_t> build() {
    std::vector<std::vector<uint8_t>> lumps(17);
    lumps[0].assign(entities.begin(), entities.end());
    lumps[0].push_back(0);
    for (const auto& [name, flags] : textures) {
      std::vector<uint8_t> record(72, 0);
      std::memcpy(record.data(), name.data(), std::min<size_t>(name.size(), 63));
      poke(record, 64, flags);
      lumps[1].insert(lumps[1].end(), record.begin(), record.end());
    }
    for (const BspVertex& v : vertices) {
      std::vector<uint8_t> record(44, 0);
      for (int k = 0; k < 3; ++k) poke(record, 4 * size_t(k), v.position[k]);
      for (int k = 0; k < 3; ++k) poke(record, 28 + 4 * size_t(k), v.normal[k]);
      lumps[10].insert(lumps[10].end(), record.begin(), record.end());
    }
    for (int32_t m : meshverts) put(lumps[11], m);
    for (const BspFace& f : faces) {
      std::vector<uint8_t> record(104, 0);
      const int32_t fields[7] = {f.texture, 0, f.type, f.vertex, f.n_vertices, f.meshvert, f.n_meshverts};
      for (int k = 0; k < 7; ++k) poke(record, 4 * size_t(k), fields[k]);
      poke(record, 96, f.size_x);
      poke(record, 100, f.size_y);
      lumps[13].insert(lumps[13].end(), record.begin(), record.end());
    }
    std::vector<uint8_t> out = {'I', 'B', 'S', 'P'};
    put(out, int32_t(46));
    uint32_t offset = 8 + 17 * 8;
    for (int i = 0; i < 17; ++i) {
      if (i == 13) face_lump_offset = offset;
      if (i == 10) vertex_lump_offset = offset;
      if (i == 11) meshvert_lump_offset = offset;
      put(out, int32_t(offset));
      put(out, int32_t(lumps[size_t(i)].size()));
      offset += uint32_t(lumps[size_t(i)].size());
    }
    for (const auto& lump : lumps) out.insert(out.end(), lump.begin(), lump.end());
    return out;
  }
};

TEST(Q3Bsp, CountsFacesAndPatchTrianglesAndSkipsCommonSkyAndBillboards) {
  BspFixture fixture;
  const std::vector<uint8_t> bytes = fixture.build();
  MeshOptions options;
  options.bsp_patch_level = 5;
  EXPECT_EQ(parse_q3bsp(bytes, "fixture.bsp", options).triangles.size(), 2u + 2u * 5u * 5u);
  options.bsp_patch_level = 2;
  EXPECT_EQ(parse_q3bsp(bytes, "fixture.bsp", options).triangles.size(), 2u + 2u * 2u * 2u);
  options.bsp_drop_sky = false;  // the sky quad comes back, the caulk and billboard do not
  EXPECT_EQ(parse_q3bsp(bytes, "fixture.bsp", options).triangles.size(), 4u + 2u * 2u * 2u);
}

// What the loader leaves out is counted, so that `scenes info` can say so
// (sky and textures/common faces vanished without a trace before).
TEST(Q3Bsp, LeftOutSkyAndToolFacesAreCounted) {
  BspFixture fixture;
  const std::vector<uint8_t> bytes = fixture.build();
  MeshOptions options;
  const Mesh dropped = parse_q3bsp(bytes, "fixture.bsp", options);
  EXPECT_EQ(dropped.dropped_sky_faces, 1u);
  EXPECT_EQ(dropped.dropped_tool_faces, 1u);
  options.bsp_drop_sky = false;
  const Mesh kept = parse_q3bsp(bytes, "fixture.bsp", options);
  EXPECT_EQ(kept.dropped_sky_faces, 0u);
  EXPECT_EQ(kept.dropped_tool_faces, 1u);
}

TEST(Q3Bsp, LeftOutSkyAndToolFacesAreCountedInTheScene) {
  BspFixture fixture;
  const std::vector<uint8_t> bytes = fixture.build();
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("rtsim_bsp_counts_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "map.bsp", std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                                         std::streamsize(bytes.size()));
  std::ofstream(dir / "scene.toml") << "[[mesh]]\nfile = \"map.bsp\"\n[[mesh]]\nfile = \"map.bsp\"\n"
                                       "[[camera]]\nname = \"view1\"\nposition = [0, 0, 300]\ntarget = [0, 0, 0]\n";
  const Scene scene = load_scene_descriptor(dir / "scene.toml");
  EXPECT_EQ(scene.validation.dropped_sky_faces, 2u);  // one per mesh
  EXPECT_EQ(scene.validation.dropped_tool_faces, 2u);
  std::filesystem::remove_all(dir);
}

TEST(Q3Bsp, ConvertsToYUpAndMakesEveryTriangleCounterClockwiseFromTheFront) {
  BspFixture fixture;
  const Mesh mesh = parse_q3bsp(fixture.build(), "fixture.bsp");
  ASSERT_EQ(mesh.triangles.size(), mesh.material_ids.size());
  // Both the quad and the patch face Q3 +Z, which is +Y after conversion.
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const vec3 n = glm::normalize(normal_of(mesh, t));
    EXPECT_GT(n.y, 0.99f) << "triangle " << t;
  }
  // The patch lies at Q3 z = 5 -> y = 5, and Q3 y in [0, 2] -> z in [-2, 0].
  for (size_t t = 2; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const vec3 v = mesh.vertices[mesh.triangles[t][k]];
      EXPECT_FLOAT_EQ(v.y, 5.0f);
      EXPECT_LE(v.z, 0.0f);
      EXPECT_GE(v.z, -2.0f);
    }
}

TEST(Q3Bsp, PatchOrientationFollowsTheControlNormals) {
  BspFixture fixture;
  for (size_t v = 4; v < 13; ++v) fixture.vertices[v].normal = vec3(0, 0, -1);
  const Mesh mesh = parse_q3bsp(fixture.build(), "fixture.bsp");
  for (size_t t = 2; t < mesh.triangles.size(); ++t) EXPECT_LT(normal_of(mesh, t).y, 0.0f);
}

TEST(Q3Bsp, SpawnPointsBecomeCamerasFortyUnitsUpLookingAlongTheirAngle) {
  BspFixture fixture;
  const Mesh mesh = parse_q3bsp(fixture.build(), "fixture.bsp");
  ASSERT_EQ(mesh.suggested_cameras.size(), 1u);
  const Camera& c = mesh.suggested_cameras[0];
  // Q3 (10, 20, 30 + 40) -> Y-up (10, 70, -20); yaw 90 looks along Q3 +Y -> -Z.
  EXPECT_NEAR(c.position.x, 10.0f, 1e-4f);
  EXPECT_NEAR(c.position.y, 70.0f, 1e-4f);
  EXPECT_NEAR(c.position.z, -20.0f, 1e-4f);
  const vec3 look = glm::normalize(c.target - c.position);
  EXPECT_NEAR(look.z, -1.0f, 1e-4f);
  EXPECT_EQ(c.up, vec3(0, 1, 0));
}

TEST(Q3Bsp, MalformedFilesGiveInputErrorsNamingFileAndField) {
  BspFixture fixture;
  const std::vector<uint8_t> good = fixture.build();
  const std::string name = "fixture.bsp";

  expect_input_error([&] { parse_q3bsp(std::vector<uint8_t>(good.begin(), good.begin() + 100), name); },
                     {name, "header"});
  std::vector<uint8_t> bad = good;
  bad[0] = 'X';
  expect_input_error([&] { parse_q3bsp(bad, name); }, {name, "IBSP"});
  bad = good;
  poke(bad, 4, int32_t(47));
  expect_input_error([&] { parse_q3bsp(bad, name); }, {name, "version 47"});
  bad = good;
  poke(bad, 8 + 13 * 8, int32_t(good.size()));  // faces lump starts at the end of the file
  expect_input_error([&] { parse_q3bsp(bad, name); }, {name, "lump 13 (faces)", "outside the file"});
  bad = std::vector<uint8_t>(good.begin(), good.end() - 10);  // the last lump is cut short
  expect_input_error([&] { parse_q3bsp(bad, name); }, {name, "lump"});
  bad = good;
  poke(bad, fixture.meshvert_lump_offset + 4, int32_t(7));  // face 0 has 4 vertices
  expect_input_error([&] { parse_q3bsp(bad, name); }, {name, "face 0", "meshvert"});
  bad = good;
  poke(bad, fixture.vertex_lump_offset + 44 + 4, std::numeric_limits<float>::quiet_NaN());
  expect_input_error([&] { parse_q3bsp(bad, name); }, {name, "vertex 1", "non-finite"});
  bad = good;
  poke(bad, fixture.face_lump_offset + 104 * 1, int32_t(9));  // texture index
  expect_input_error([&] { parse_q3bsp(bad, name); }, {name, "face 1", "texture index 9"});
  bad = good;
  poke(bad, fixture.face_lump_offset + 104 * 1 + 96, int32_t(4));  // even patch width
  expect_input_error([&] { parse_q3bsp(bad, name); }, {name, "face 1", "patch size"});
  bad = good;
  poke(bad, fixture.face_lump_offset + 104 * 0 + 16, int32_t(1000));  // n_vertexes
  expect_input_error([&] { parse_q3bsp(bad, name); }, {name, "face 0", "out of range"});
}

// Every prefix and many random corruptions must load or throw InputError: the
// parser is a pure function of the bytes, never a crash or a hang.
TEST(Q3Bsp, TruncationsAndByteFlipsNeverCrash) {
  BspFixture fixture;
  const std::vector<uint8_t> good = fixture.build();
  size_t errors = 0;
  for (size_t n = 0; n < good.size(); n += 3) {
    try {
      parse_q3bsp(std::vector<uint8_t>(good.begin(), good.begin() + long(n)), "cut.bsp");
    } catch (const InputError&) {
      ++errors;
    }
  }
  EXPECT_GT(errors, 0u);
  for (uint64_t trial = 0; trial < 3000; ++trial) {
    KeyedRng rng(7, {trial});
    std::vector<uint8_t> bytes = good;
    for (int flips = 0; flips < 4; ++flips)
      bytes[rng.next_u64() % bytes.size()] = uint8_t(rng.next_u64());
    try {
      const Mesh mesh = parse_q3bsp(bytes, "flip.bsp");
      for (const uvec3& t : mesh.triangles)
        for (int k = 0; k < 3; ++k) ASSERT_LT(t[k], mesh.vertices.size());
    } catch (const InputError&) {
    }
  }
}

// ---------------------------------------------------------------- zip (.pk3)
uint32_t crc32_of(const std::vector<uint8_t>& data) {
  uint32_t crc = 0xFFFFFFFFu;
  for (uint8_t byte : data) {
    crc ^= byte;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

// A minimal stored (uncompressed) zip archive, enough for libzip to read.
std::vector<uint8_t> make_zip(const std::vector<std::pair<std::string, std::vector<uint8_t>>>& members) {
  std::vector<uint8_t> out, central;
  for (const auto& [name, data] : members) {
    const uint32_t offset = uint32_t(out.size()), crc = crc32_of(data), size = uint32_t(data.size());
    put(out, uint32_t(0x04034b50));
    put(out, uint16_t(20)); put(out, uint16_t(0)); put(out, uint16_t(0));  // version, flags, stored
    put(out, uint16_t(0)); put(out, uint16_t(0x21));                       // time, date
    put(out, crc); put(out, size); put(out, size);
    put(out, uint16_t(name.size())); put(out, uint16_t(0));
    out.insert(out.end(), name.begin(), name.end());
    out.insert(out.end(), data.begin(), data.end());
    put(central, uint32_t(0x02014b50));
    put(central, uint16_t(20)); put(central, uint16_t(20)); put(central, uint16_t(0)); put(central, uint16_t(0));
    put(central, uint16_t(0)); put(central, uint16_t(0x21));
    put(central, crc); put(central, size); put(central, size);
    put(central, uint16_t(name.size())); put(central, uint16_t(0)); put(central, uint16_t(0));
    put(central, uint16_t(0)); put(central, uint16_t(0)); put(central, uint32_t(0)); put(central, offset);
    central.insert(central.end(), name.begin(), name.end());
  }
  const uint32_t central_offset = uint32_t(out.size());
  out.insert(out.end(), central.begin(), central.end());
  put(out, uint32_t(0x06054b50));
  put(out, uint16_t(0)); put(out, uint16_t(0));
  put(out, uint16_t(members.size())); put(out, uint16_t(members.size()));
  put(out, uint32_t(central.size())); put(out, central_offset); put(out, uint16_t(0));
  return out;
}

TEST(Pk3, LoadsTheNamedMapAndNamesArchiveAndMemberWhenItIsMissing) {
  const fs::path dir = temp_dir("pk3");
  BspFixture fixture;
  const std::vector<uint8_t> bsp = fixture.build();
  const fs::path pk3 = dir / "maps.pk3";
  write_bytes(pk3, make_zip({{"maps/arena.bsp", bsp}, {"readme.txt", {'h', 'i'}}}));

  MeshOptions options;
  options.pk3_map = "arena";
  EXPECT_EQ(load_mesh(pk3, options).triangles.size(), parse_q3bsp(bsp, "x").triangles.size());
  EXPECT_EQ(load_mesh(pk3).triangles.size(), 52u);  // a single map needs no name

  options.pk3_map = "oacmpdm1";
  expect_input_error([&] { load_mesh(pk3, options); }, {pk3.string(), "maps/oacmpdm1.bsp"});
  expect_input_error([&] { read_zip_member(pk3, "nothing"); }, {pk3.string(), "nothing"});
  const fs::path not_zip = dir / "broken.pk3";
  write_text(not_zip, "this is not a zip archive");
  expect_input_error([&] { load_mesh(not_zip, options); }, {not_zip.string()});
  fs::remove_all(dir);
}

// Issue 36: a member whose header declares 3 GB made a 1 KB archive allocate
// 2.9 GB (read_zip_member trusted stat.size). Refused by what deflate can reach
// from the compressed bytes, naming archive and member, before any allocation.
TEST(Pk3, AMemberDeclaringMoreThanItsBytesCanHoldIsRefused) {
  const fs::path dir = temp_dir("pk3-huge");
  std::vector<uint8_t> zip = make_zip({{"maps/arena.bsp", std::vector<uint8_t>(1000, 'x')}});
  const uint32_t declared = 3000000000u;
  for (size_t at = 0; at + 4 <= zip.size(); ++at) {
    uint32_t signature;
    std::memcpy(&signature, &zip[at], 4);
    if (signature == 0x04034b50) std::memcpy(&zip[at + 22], &declared, 4);  // local header
    if (signature == 0x02014b50) std::memcpy(&zip[at + 24], &declared, 4);  // central directory
  }
  const fs::path pk3 = dir / "huge.pk3";
  write_bytes(pk3, zip);
  expect_input_error([&] { read_zip_member(pk3, "maps/arena.bsp"); },
                     {pk3.string() + ":maps/arena.bsp", "declares 3000000000 bytes from 1000 compressed"});
  fs::remove_all(dir);
}

// Issue 36: a descriptor naming one OBJ 300 times loads it once (each load forks
// an assimp child, 64 ms: 3,000 references took over a minute), and every
// reference still gets its own placed copy.
TEST(Descriptor, AMeshNamedManyTimesIsLoadedOnce) {
  const fs::path dir = temp_dir("many-references");
  write_text(dir / "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  std::string text = "name = \"many\"\n";
  for (int i = 0; i < 300; ++i) text += "[[mesh]]\nfile = \"tri.obj\"\ntranslate = [" + std::to_string(i) + ", 0, 0]\n";
  text += "[[camera]]\nname = \"view1\"\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\n";
  write_text(dir / "scene.toml", text);
  const uint64_t before = mesh_files_loaded();
  const Scene scene = load_scene_descriptor(dir / "scene.toml");
  EXPECT_EQ(mesh_files_loaded() - before, 1u);
  ASSERT_EQ(scene.triangle_count(), 300u);
  EXPECT_EQ(scene.vertex(299, 0).x, 299.0f);  // the last copy where its table put it
  EXPECT_EQ(scene.vertex(0, 1).x, 1.0f);
  fs::remove_all(dir);
}

// ---------------------------------------------------------------- SuperTuxKart .spm
struct SpmBuffer {
  std::vector<vec3> positions;
  std::vector<uint32_t> indices;
  uint16_t material = 0;
};

// Static SPM with normals, vertex colours (first vertex coloured, the rest white)
// and one textured material, so every optional vertex field is exercised.
std::vector<uint8_t> make_spm(const std::vector<SpmBuffer>& buffers, uint8_t version = 1) {
  std::vector<uint8_t> out = {'S', 'P', uint8_t(version << 3 | 2), uint8_t(0x1 | 0x2)};
  for (int k = 0; k < 6; ++k) put(out, 0.0f);
  put(out, uint16_t(1));  // one material: texture 1 "a.png", no texture 2
  out.push_back(5);
  for (char c : std::string("a.png")) out.push_back(uint8_t(c));
  out.push_back(0);
  put(out, uint16_t(1));  // one section
  put(out, uint16_t(buffers.size()));
  for (const SpmBuffer& b : buffers) {
    put(out, uint32_t(b.positions.size()));
    put(out, uint32_t(b.indices.size()));
    put(out, b.material);
    for (size_t v = 0; v < b.positions.size(); ++v) {
      for (int k = 0; k < 3; ++k) put(out, b.positions[v][k]);
      put(out, uint32_t(0));  // packed normal
      if (v == 0) {
        out.push_back(7);  // colour id != 128: three colour bytes follow
        out.insert(out.end(), {1, 2, 3});
      } else {
        out.push_back(128);  // white
      }
      put(out, uint32_t(0));  // uv (half floats)
    }
    for (uint32_t i : b.indices) {
      if (b.positions.size() > 255) put(out, uint16_t(i));
      else out.push_back(uint8_t(i));
    }
  }
  return out;
}

SpmBuffer quad_buffer(float z = 0.0f) {
  return {{vec3(0, 0, z), vec3(1, 0, z), vec3(1, 1, z), vec3(0, 1, z)}, {0, 1, 2, 0, 2, 3}, 0};
}

TEST(Spm, ReadsBuffersMirrorsZAndReversesWinding) {
  const Mesh mesh = parse_spm(make_spm({quad_buffer(3.0f), quad_buffer(5.0f)}), "quad.spm");
  ASSERT_EQ(mesh.triangles.size(), 4u);
  ASSERT_EQ(mesh.vertices.size(), 8u);
  EXPECT_EQ(mesh.vertices[0], vec3(0, 0, -3));
  EXPECT_EQ(mesh.vertices[4], vec3(0, 0, -5));
  EXPECT_EQ(mesh.triangles[0], uvec3(0, 2, 1));
  EXPECT_EQ(mesh.triangles[2], uvec3(4, 6, 5));  // second buffer indices are rebased
  ASSERT_EQ(mesh.materials.size(), 1u);
  EXPECT_EQ(mesh.materials[0].name, "a.png");
}

TEST(Spm, SixteenBitIndicesAboveTwoHundredFiftyFiveVertices) {
  SpmBuffer big;
  for (int i = 0; i < 300; ++i) big.positions.push_back(vec3(float(i), 0, 0));
  big.positions[299].y = 1.0f;
  big.indices = {0, 299, 298};
  const Mesh mesh = parse_spm(make_spm({big}), "big.spm");
  ASSERT_EQ(mesh.triangles.size(), 1u);
  EXPECT_EQ(mesh.triangles[0], uvec3(0, 298, 299));
}

TEST(Spm, MalformedFilesGiveInputErrorsNamingFileAndField) {
  const std::string name = "quad.spm";
  const std::vector<uint8_t> good = make_spm({quad_buffer()});
  expect_input_error([&] { parse_spm({'X', 'P', 10, 0}, name); }, {name, "magic"});
  expect_input_error([&] { parse_spm(make_spm({quad_buffer()}, 2), name); }, {name, "version 2"});
  expect_input_error([&] { parse_spm(std::vector<uint8_t>(good.begin(), good.end() - 2), name); },
                     {name, "index", "past the end"});
  SpmBuffer bad_index = quad_buffer();
  bad_index.indices[4] = 9;
  expect_input_error([&] { parse_spm(make_spm({bad_index}), name); }, {name, "index 4 = 9", "out of range"});
  SpmBuffer nan = quad_buffer();
  nan.positions[2].y = std::numeric_limits<float>::quiet_NaN();
  expect_input_error([&] { parse_spm(make_spm({nan}), name); }, {name, "vertex 2", "non-finite"});
  SpmBuffer bad_material = quad_buffer();
  bad_material.material = 3;
  expect_input_error([&] { parse_spm(make_spm({bad_material}), name); }, {name, "material id 3"});

  for (uint64_t trial = 0; trial < 3000; ++trial) {
    KeyedRng rng(11, {trial});
    std::vector<uint8_t> bytes = good;
    bytes.resize(size_t(rng.next_u64() % (bytes.size() + 1)) | 1);
    bytes[rng.next_u64() % bytes.size()] = uint8_t(rng.next_u64());
    try {
      const Mesh mesh = parse_spm(bytes, "flip.spm");
      for (const uvec3& t : mesh.triangles)
        for (int k = 0; k < 3; ++k) ASSERT_LT(t[k], mesh.vertices.size());
    } catch (const InputError&) {
    }
  }
}

// ---------------------------------------------------------------- SuperTuxKart track
SpmBuffer triangle_buffer() { return {{vec3(1, 0, 0), vec3(0, 1, 0), vec3(0, 0, 0)}, {0, 1, 2}, 0}; }

fs::path make_track(const fs::path& root) {
  const fs::path track = root / "data/tracks/tiny";
  write_bytes(track / "ground.spm", make_spm({triangle_buffer()}));
  write_bytes(track / "high.spm", make_spm({quad_buffer()}));
  write_bytes(track / "low.spm", make_spm({triangle_buffer()}));
  write_bytes(track / "tri.spm", make_spm({triangle_buffer()}));
  write_bytes(root / "data/library/lib1/leaf.spm", make_spm({triangle_buffer()}));
  write_text(root / "data/library/lib1/node.xml",
             "<scene><object type=\"animation\" model=\"leaf.spm\" xyz=\"0 0 0\" hpr=\"0 0 0\" "
             "scale=\"1 1 1\"/></scene>");
  write_text(track / "scene.xml", R"(<?xml version="1.0"?>
<scene>
  <lod>
    <group name="g">
      <static-object lod_distance="50" lod_group="g" model="low.spm" xyz="0 0 0"/>
      <static-object lod_distance="10" lod_group="g" model="high.spm" xyz="0 0 0"/>
    </group>
  </lod>
  <track model="ground.spm" x="0" y="0" z="0">
    <static-object lod_instance="true" lod_group="g" xyz="5 0 0" hpr="0 0 0" scale="1 1 1"/>
    <static-object model="physics_only_missing.spm" interaction="physics-only" xyz="0 0 0"/>
    <animated-texture name="x.png" dy="0.5"/>
  </track>
  <object type="animation" model="tri.spm" xyz="0 10 0" hpr="0 90 0" scale="2 2 2"/>
  <object type="animation" model="reverse_missing.spm" if="isTrackReverse" xyz="0 0 0"/>
  <object type="billboard" texture="halo.png" xyz="0 0 0"/>
  <library name="lib1" xyz="100 0 0" hpr="0 0 0" scale="1 1 1"/>
  <library name="gfx_not_there" xyz="0 0 0"/>
</scene>
)");
  write_text(track / "quads.xml", R"(<quads>
  <quad p0="0 0 0" p1="2 0 0" p2="2 0 2" p3="0 0 2"/>
  <quad p0="0:3" p1="0:2" p2="2 0 6" p3="0 0 6"/>
</quads>
)");
  return track;
}

bool has_vertex(const Mesh& mesh, const vec3& v) {
  for (const uvec3& t : mesh.triangles)
    for (int k = 0; k < 3; ++k)
      if (glm::length(mesh.vertices[t[k]] - v) < 1e-4f) return true;
  return false;
}

TEST(StkTrack, FlattensTrackObjectsLodAndLibrariesSkippingPhysicsReverseAndGfx) {
  const fs::path root = temp_dir("track");
  const fs::path track = make_track(root);
  const Mesh mesh = flatten(load_stk_track(track));
  // ground 1 + most detailed LOD (high, 2) + tri 1 + library leaf 1.
  EXPECT_EQ(mesh.triangles.size(), 5u);
  EXPECT_EQ(load_mesh(track / "scene.xml").triangles.size(), 5u);  // dispatch by file name
  EXPECT_EQ(load_mesh(track).triangles.size(), 5u);                // and by folder

  // tri.spm's (1,0,0) under T(0,10,0) * Ry(90) * S(2) is (0,10,-2) in Irrlicht
  // space, (0,10,2) after the mirror.
  EXPECT_TRUE(has_vertex(mesh, vec3(0, 10, 2)));
  EXPECT_TRUE(has_vertex(mesh, vec3(101, 0, 0)));  // library leaf moved by the library's xyz
  EXPECT_TRUE(has_vertex(mesh, vec3(6, 1, 0)));    // LOD instance at x = 5
  fs::remove_all(root);
}

// make_track with models placed again: tri.spm three more times (rotated, mirrored,
// collapsed by a zero scale, as mines' warning sign is), high.spm under a library-like
// parent, so that instancing has meshes used more than once.
fs::path make_reused_track(const fs::path& root) {
  const fs::path track = make_track(root);
  write_text(track / "scene.xml", R"(<?xml version="1.0"?>
<scene>
  <track model="ground.spm" x="1.5" y="-2" z="0.25">
    <static-object model="tri.spm" xyz="3 1 -2" hpr="10 20 30" scale="1.5 0.5 2"/>
  </track>
  <object type="animation" model="tri.spm" xyz="0 10 0" hpr="0 90 0" scale="2 2 2"/>
  <object type="animation" model="high.spm" xyz="-4 0.5 7" hpr="0 -33 0" scale="-1 1 1"/>
  <object type="animation" model="tri.spm" xyz="-24.1 -0.72 -88.27" hpr="0 -17.9 0" scale="0 0 0" interaction="ghost"/>
  <object type="animation" model="high.spm" xyz="0.1 0.2 0.3" hpr="45 0 12.5"/>
  <library name="lib1" xyz="100 0 0" hpr="0 15 0" scale="1 1 1"/>
  <library name="lib1" xyz="-100 0 0" hpr="0 0 0" scale="1 -1 1"/>
</scene>
)");
  return track;
}

Mesh flat_track(const fs::path& track) { return flatten(load_stk_track(track)); }

// The flat track, bit for bit as the loader made it before tracks kept their
// instances (hashes recorded then): flattening must reproduce it exactly.
TEST(StkTrack, TheFlatTrackIsBitForBitWhatTheLoaderMadeBefore) {
  const fs::path root = temp_dir("track_pinned");
  const Mesh tiny = flat_track(make_track(root));
  EXPECT_EQ(tiny.triangles.size(), 5u);
  EXPECT_EQ(tiny.vertices.size(), 13u);
  EXPECT_EQ(rtsim::test::geometry_hash(tiny), 0x19c71113b482edcaull);
  fs::remove_all(root);
  const Mesh reused = flat_track(make_reused_track(root));
  EXPECT_EQ(reused.triangles.size(), 10u);
  EXPECT_EQ(reused.vertices.size(), 26u);
  EXPECT_EQ(rtsim::test::geometry_hash(reused), 0x9d70a4943c4abd47ull);
  fs::remove_all(root);
}

// A descriptor placing an OBJ three times (mirrored, rotated and scaled, with its
// material overridden) and a track: the flat scene bit for bit as it was before
// scenes kept their instances (hash recorded then).
fs::path make_pinned_descriptor(const fs::path& root) {
  make_reused_track(root);
  write_text(root / "quad.obj",
             "mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0.5\nv 0 1 0\nv 7 7 7\nusemtl red\nf 1 2 3 4\n");
  write_text(root / "quad.mtl", "newmtl red\nKd 0.8 0.1 0.1\n");
  write_text(root / "scene.toml", R"(name = "pinned"
[[material]]
name = "grey"
[[mesh]]
file = "quad.obj"
translate = [0.1, -3, 2]
[[mesh]]
file = "data/tracks/tiny/scene.xml"
[[mesh]]
file = "quad.obj"
scale = [-1, 2, 0.5]
rotate_deg = [10, 20, 30]
[[mesh]]
file = "quad.obj"
material = "grey"
translate = [5, 5, 5]
rotate_deg = [0, 45, 0]
scale = 3
[[camera]]
name = "view1"
position = [0, 5, 5]
target = [0, 0, 0]
)");
  return root / "scene.toml";
}

TEST(Descriptor, TheFlatSceneIsBitForBitWhatItWasBefore) {
  const fs::path root = temp_dir("descriptor_pinned");
  const Scene scene = load_scene_descriptor(make_pinned_descriptor(root));
  EXPECT_EQ(scene.triangle_count(), 16u);
  EXPECT_EQ(scene.content_hash(), 0x02af6f2c9c33026eull);
  EXPECT_EQ(rtsim::test::geometry_hash(scene), 0xf5fc6f19d2428b9dull);
  fs::remove_all(root);
}

TEST(StkTrack, KeepsEachModelOnceAndEachPlacementAsAnInstance) {
  const fs::path root = temp_dir("track_instances");
  const Mesh mesh = load_stk_track(make_reused_track(root));
  // ground, tri, high, tri collapsed by its zero scale (a mesh of its own), lib1's leaf.
  ASSERT_EQ(mesh.meshes.size(), 5u);
  EXPECT_EQ(mesh.triangles.size(), 6u);
  EXPECT_NE(mesh.meshes[0].name.find("ground.spm"), std::string::npos);
  EXPECT_NE(mesh.meshes[3].name.find("tri.spm (placed flat)"), std::string::npos);
  // The track's model, its object, 3 track objects, the collapsed one, high again,
  // and lib1's leaf for each of the two libraries.
  ASSERT_EQ(mesh.instances.size(), 8u);
  EXPECT_EQ(mesh.instances[0].mesh, 0u);
  EXPECT_EQ(mesh.instances[1].mesh, 1u);
  EXPECT_EQ(mesh.instances[2].mesh, 1u);
  EXPECT_EQ(mesh.instances[4].mesh, 3u);
  EXPECT_EQ(mesh.instances[4].object_to_world, glm::mat4(1.0f));
  EXPECT_EQ(mesh.instances[5].mesh, 2u);
  EXPECT_EQ(mesh.instances[7].mesh, 4u);
  // The first placement is the track's own: T(1.5, -2, 0.25) in Irrlicht space, z mirrored.
  EXPECT_EQ(vec3(mesh.instances[0].object_to_world[3]), vec3(1.5f, -2.0f, -0.25f));
  for (const Instance& i : mesh.instances) EXPECT_EQ(instance_transform_problem(i.object_to_world), "");
  fs::remove_all(root);
}

TEST(Descriptor, ATrackKeepsItsInstancesAndItsFlatFormIsTheOldFlatScene) {
  const fs::path root = temp_dir("descriptor_instanced");
  const fs::path path = make_pinned_descriptor(root);
  const Scene s = load_scene_descriptor(path, SceneForm::Instanced);
  ASSERT_TRUE(s.instanced());
  EXPECT_EQ(s.instances.size(), 3u + 8u);  // three quad.obj tables and the track's eight
  EXPECT_EQ(s.instanced_triangle_count(), 16u);
  Scene flat = flatten(s);
  validate_scene(flat);
  EXPECT_EQ(flat.content_hash(), 0x02af6f2c9c33026eull);  // TheFlatSceneIsBitForBitWhatItWasBefore's

  // [[instance]] tables placing the track twice, the second time mirrored.
  write_text(root / "twice.toml", R"(name = "twice"
[[mesh]]
name = "tiny"
file = "data/tracks/tiny/scene.xml"
[[instance]]
mesh = "tiny"
[[instance]]
mesh = "tiny"
translate = [0, 0, 50]
scale = [1, 1, -1]
[[camera]]
name = "view1"
position = [0, 5, 5]
target = [0, 0, 0]
)");
  const Scene twice = load_scene_descriptor(root / "twice.toml", SceneForm::Instanced);
  EXPECT_EQ(twice.meshes.size(), 5u);
  EXPECT_EQ(twice.instances.size(), 16u);
  const Scene twice_flat = load_scene_descriptor(root / "twice.toml");
  ASSERT_EQ(twice_flat.triangle_count(), 20u);
  const Mesh track = flat_track(root / "data/tracks/tiny");
  for (uint32_t t = 0; t < 10; ++t) {  // the first copy is the flat track itself, bit for bit
    EXPECT_EQ(twice_flat.triangles[t], track.triangles[t]);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(twice_flat.vertex(t, k), track.vertices[track.triangles[t][k]]);
  }
  fs::remove_all(root);
}

TEST(StkTrack, CamerasSitTwoUnitsAboveQuadCentresLookingAlongTheDriveline) {
  const fs::path root = temp_dir("track_cameras");
  const Mesh mesh = load_stk_track(make_track(root));
  ASSERT_EQ(mesh.suggested_cameras.size(), 2u);
  EXPECT_EQ(mesh.suggested_cameras[0].position, vec3(1, 2, -1));
  EXPECT_EQ(mesh.suggested_cameras[1].position, vec3(1, 2, -4));
  // Quad 0 looks towards quad 1: -Z after the mirror.
  EXPECT_LT((mesh.suggested_cameras[0].target - mesh.suggested_cameras[0].position).z, 0.0f);
  fs::remove_all(root);
}

TEST(StkTrack, MissingModelsBrokenXmlAndBadAttributesNameTheFile) {
  const fs::path root = temp_dir("track_errors");
  const fs::path track = make_track(root);
  fs::remove(track / "tri.spm");
  expect_input_error([&] { load_stk_track(track); }, {(track / "scene.xml").string(), "tri.spm"});

  write_text(track / "scene.xml", "<scene><track model=\"ground.spm\"></scene>");
  expect_input_error([&] { load_stk_track(track); }, {(track / "scene.xml").string(), "XML"});

  write_text(track / "scene.xml", "<scene><object model=\"ground.spm\" xyz=\"1 nan 2\"/></scene>");
  expect_input_error([&] { load_stk_track(track); }, {(track / "scene.xml").string(), "xyz"});

  write_text(track / "scene.xml", "<scene><library name=\"nowhere\"/></scene>");
  expect_input_error([&] { load_stk_track(track); }, {(track / "scene.xml").string(), "nowhere"});

  write_text(track / "scene.xml", "<scene><object model=\"ground.spm\"/></scene>");
  write_text(track / "quads.xml", "<quads><quad p0=\"5:1\" p1=\"0 0 0\" p2=\"0 0 0\" p3=\"0 0 0\"/></quads>");
  expect_input_error([&] { load_stk_track(track); }, {(track / "quads.xml").string(), "quad 0"});
  fs::remove_all(root);
}

TEST(StkTrack, LibrariesThatIncludeThemselvesStopWithAnError) {
  const fs::path root = temp_dir("track_cycle");
  const fs::path track = make_track(root);
  write_text(root / "data/library/lib1/node.xml", "<scene><library name=\"lib1\"/></scene>");
  expect_input_error([&] { load_stk_track(track); }, {"lib1", "nested"});
  fs::remove_all(root);
}

// ---------------------------------------------------------------- assimp
TEST(Assimp, LoadsObjAndPlyTriangulatingPolygons) {
  const fs::path dir = temp_dir("assimp");
  write_text(dir / "quad.obj",
             "mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl red\nf 1 2 3 4\n");
  write_text(dir / "quad.mtl", "newmtl red\nKd 0.8 0.1 0.1\n");
  const Mesh obj = load_mesh(dir / "quad.obj");
  ASSERT_EQ(obj.triangles.size(), 2u);
  EXPECT_GT(normal_of(obj, 0).z, 0.0f);  // counter-clockwise stays counter-clockwise
  const Material& red = obj.materials.at(obj.material_ids[0]);
  EXPECT_NEAR(red.albedo.x, 0.8f, 1e-5f);
  EXPECT_NEAR(red.albedo.y, 0.1f, 1e-5f);

  write_text(dir / "two.ply",
             "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
             "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
             "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n");
  EXPECT_EQ(load_mesh(dir / "two.ply").triangles.size(), 2u);

  write_text(dir / "broken.ply", "ply\nformat ascii 1.0\nelement vertex 4\nend_header\n1 2\n");
  expect_input_error([&] { load_mesh(dir / "broken.ply"); }, {(dir / "broken.ply").string()});
  expect_input_error([&] { load_mesh(dir / "absent.obj"); }, {(dir / "absent.obj").string(), "no such"});
  fs::remove_all(dir);
}

TEST(LoadMesh, DispatchesBspAndSpmByExtension) {
  const fs::path dir = temp_dir("dispatch");
  BspFixture fixture;
  write_bytes(dir / "level.BSP", fixture.build());
  EXPECT_EQ(load_mesh(dir / "level.BSP").triangles.size(), 52u);
  write_bytes(dir / "quad.spm", make_spm({quad_buffer()}));
  EXPECT_EQ(load_mesh(dir / "quad.spm").triangles.size(), 2u);
  expect_input_error([&] { read_file_bytes(dir / "missing.bin"); }, {"missing.bin"});
  fs::remove_all(dir);
}

}  // namespace
