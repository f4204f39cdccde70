// Scenes that keep their instances: flatten (the flat form every command sees),
// validation of meshes and instances, the descriptor's [[instance]] tables, the
// scene image of an instanced scene, the instanced forest, and the forms load_scene
// gives.
#include <rtsim/workloads/descriptor.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/procedural.h>
#include <rtsim/workloads/scene_cache.h>
#include <rtsim/workloads/scene_registry.h>
#include <rtsim/workloads/validate.h>

#include "workloads/test_files.h"

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace rtsim;
using rtsim::test::expect_input_error;
using rtsim::test::write_text;

namespace {

fs::path temp_dir(const std::string& name) { return rtsim::test::temp_dir("rtsim_test_instances_", name); }

glm::mat4 translation(const vec3& t) { return glm::translate(glm::mat4(1.0f), t); }
glm::mat4 scaling(const vec3& s) { return glm::scale(glm::mat4(1.0f), s); }

// Mesh 0: one triangle with texture coordinates (uv0, uv1, uv2); mesh 1: a unit quad,
// two triangles, of material 1. Instances: mesh 0 moved by (10, 0, 0); mesh 1 scaled
// by 2 and moved by (0, 5, 0); mesh 0 mirrored in x (scale -1, 1, 1).
const TriangleUv kUv = {glm::vec2(0.1f, 0.2f), glm::vec2(0.3f, 0.4f), glm::vec2(0.5f, 0.6f)};

Scene hand_made() {
  Scene s;
  s.name = "hand";
  s.materials = {Material{}, Material{}};
  s.materials[1].name = "second";
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0},                // mesh 0
                {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};  // mesh 1
  s.triangles = {{0, 1, 2}, {3, 4, 5}, {3, 5, 6}};
  s.material_ids = {0, 1, 1};
  s.triangle_uvs = {kUv, TriangleUv{}, TriangleUv{}};
  s.alpha_textures.push_back({"a", 1, 1, {255}});
  s.materials[0].alpha_texture = 0;
  s.meshes = {{"tri", 0, 3, 0, 1}, {"quad", 3, 4, 1, 2}};
  s.instances = {{0, translation({10, 0, 0})},
                 {1, translation({0, 5, 0}) * scaling(vec3(2.0f))},
                 {0, scaling({-1, 1, 1})}};
  s.cameras.push_back({"view1", {0, 0, 10}, {0, 0, 0}});
  return s;
}

TEST(Flatten, PlacesEveryInstanceInOrderAndSwapsTheWindingOfAMirror) {
  const Scene s = hand_made();
  EXPECT_TRUE(s.instanced());
  EXPECT_EQ(s.triangle_count(), 3u);
  EXPECT_EQ(s.instanced_triangle_count(), 4u);
  const Scene flat = flatten(s);
  EXPECT_FALSE(flat.instanced());
  EXPECT_TRUE(flat.meshes.empty());
  ASSERT_EQ(flat.triangle_count(), 4u);
  ASSERT_EQ(flat.vertices.size(), 3u + 4u + 3u);  // each instance's copy of its mesh's vertices
  const std::vector<vec3> want = {{10, 0, 0}, {11, 0, 0}, {10, 1, 0},                 // instance 0
                                  {0, 5, 2}, {2, 5, 2}, {2, 7, 2}, {0, 7, 2},        // instance 1
                                  {0, 0, 0}, {-1, 0, 0}, {0, 1, 0}};                 // instance 2
  for (size_t v = 0; v < want.size(); ++v) EXPECT_EQ(flat.vertices[v], want[v]) << "vertex " << v;
  EXPECT_EQ(flat.triangles[0], uvec3(0, 1, 2));
  EXPECT_EQ(flat.triangles[1], uvec3(3, 4, 5));
  EXPECT_EQ(flat.triangles[2], uvec3(3, 5, 6));
  EXPECT_EQ(flat.triangles[3], uvec3(7, 9, 8));  // mirrored: the last two swapped
  EXPECT_EQ(flat.material_ids, (std::vector<uint32_t>{0, 1, 1, 0}));
  ASSERT_EQ(flat.triangle_uvs.size(), 4u);
  EXPECT_EQ(flat.triangle_uvs[0], kUv);
  EXPECT_EQ(flat.triangle_uvs[3], (TriangleUv{kUv[0], kUv[2], kUv[1]}));  // the coordinates follow
  // A mirrored triangle still faces +z, as the original does.
  const vec3 n = glm::cross(flat.vertex(3, 1) - flat.vertex(3, 0), flat.vertex(3, 2) - flat.vertex(3, 0));
  EXPECT_GT(n.z, 0.0f);
  // Everything else is kept.
  EXPECT_EQ(flat.materials.size(), 2u);
  EXPECT_EQ(flat.alpha_textures.size(), 1u);
  EXPECT_EQ(flat.cameras.size(), 1u);
  // Bounds: the instances' boxes (exact here: the transforms keep boxes axis-aligned).
  const Aabb box = s.bounds(), flat_box = flat.bounds();
  EXPECT_EQ(box.lo, flat_box.lo);
  EXPECT_EQ(box.hi, flat_box.hi);
  EXPECT_EQ(s.instance_bounds(1).lo, vec3(0, 5, 2));
  EXPECT_EQ(s.instance_bounds(1).hi, vec3(2, 7, 2));
  EXPECT_EQ(s.alpha_tested_triangles(), 1u);     // unique
  EXPECT_EQ(flat.alpha_tested_triangles(), 2u);  // placed twice
}

TEST(Flatten, AFlatSceneIsReturnedUnchanged) {
  const Scene scene = make_procedural_scene("cornell");
  const Scene flat = flatten(scene);
  EXPECT_EQ(flat.content_hash(), scene.content_hash());
  EXPECT_EQ(flat.vertices, scene.vertices);
  EXPECT_EQ(flat.triangles, scene.triangles);
  EXPECT_EQ(flat.material_ids, scene.material_ids);
}

TEST(Flatten, ARotatedInstanceIsTheTransformAppliedToEachVertex) {
  Scene s = hand_made();
  s.instances[1].object_to_world = glm::rotate(translation({3, 4, 5}), 0.7f, glm::normalize(vec3(1, 2, 3)));
  const Scene flat = flatten(s);
  for (uint32_t k = 0; k < 4; ++k)
    EXPECT_EQ(flat.vertices[3 + k], vec3(s.instances[1].object_to_world * glm::vec4(s.vertices[3 + k], 1.0f)));
  EXPECT_EQ(flat.vertex(1, 0), s.world_vertex(1, 1, 0));
  EXPECT_EQ(flat.vertex(2, 2), s.world_vertex(1, 2, 2));
}

TEST(InstancedScene, TheContentHashCoversMeshesAndInstances) {
  const Scene s = hand_made();
  Scene moved = s;
  moved.instances[0].object_to_world = translation({10, 0, 1});
  EXPECT_NE(moved.content_hash(), s.content_hash());
  Scene other_mesh = s;
  other_mesh.instances[2].mesh = 1;
  EXPECT_NE(other_mesh.content_hash(), s.content_hash());
  Scene renamed = s;
  renamed.meshes[0].name = "another name";
  EXPECT_EQ(renamed.content_hash(), s.content_hash());  // names are for messages
  // The same triangles with no instances hash as a flat scene always did.
  Scene bare = s;
  bare.meshes.clear();
  bare.instances.clear();
  EXPECT_NE(bare.content_hash(), s.content_hash());
  Scene flat_copy;
  flat_copy.vertices = bare.vertices;
  flat_copy.triangles = bare.triangles;
  flat_copy.material_ids = bare.material_ids;
  flat_copy.materials = bare.materials;
  flat_copy.alpha_textures = bare.alpha_textures;
  flat_copy.triangle_uvs = bare.triangle_uvs;
  EXPECT_EQ(flat_copy.content_hash(), bare.content_hash());
}

TEST(InstancedScene, ShufflingKeepsEachMeshsTrianglesInItsRange) {
  Scene s = hand_made();
  // A bigger mesh 1: 40 triangles, so that the shuffle moves something.
  for (uint32_t i = 0; i < 38; ++i) {
    s.triangles.push_back({3 + i % 2, 5, 6 - i % 2});
    s.material_ids.push_back(1);
    s.triangle_uvs.push_back(TriangleUv{glm::vec2(float(i)), glm::vec2(0), glm::vec2(0)});
  }
  s.meshes[1].triangle_count = 40;
  validate_scene(s);
  Scene shuffled = s;
  shuffle_triangles(shuffled, 7);
  EXPECT_NE(shuffled.content_hash(), s.content_hash());
  ASSERT_EQ(shuffled.meshes.size(), 2u);
  EXPECT_EQ(shuffled.meshes[1].first_triangle, 1u);
  EXPECT_EQ(shuffled.meshes[1].triangle_count, 40u);
  EXPECT_EQ(shuffled.triangles[0], s.triangles[0]);  // mesh 0 alone in its range
  for (uint32_t t = 1; t < 41; ++t) {
    EXPECT_GE(shuffled.triangles[t].x, 3u);  // mesh 1's triangles stay in mesh 1
    EXPECT_EQ(shuffled.material_ids[t], 1u);
  }
  validate_scene(shuffled);  // still a valid instanced scene
  // The flat forms hold the same triangles (with their coordinates), in another order.
  const auto sorted = [](const Scene& scene) {
    const Scene flat = flatten(scene);
    std::vector<std::vector<float>> out;
    for (uint32_t t = 0; t < flat.triangle_count(); ++t) {
      std::vector<float> key;
      for (int k = 0; k < 3; ++k)
        for (int a = 0; a < 3; ++a) key.push_back(flat.vertex(t, k)[a]);
      key.push_back(flat.triangle_uvs[t][0].x);
      out.push_back(key);
    }
    std::sort(out.begin(), out.end());
    return out;
  };
  EXPECT_EQ(sorted(shuffled), sorted(s));
  // Seeded: the same seed gives the same order.
  Scene again = s;
  shuffle_triangles(again, 7);
  EXPECT_EQ(again.content_hash(), shuffled.content_hash());
}

TEST(InstancedScene, MakeOpaqueCountsThePlacedTriangles) {
  Scene s = hand_made();
  Scene flat = flatten(s);
  s.make_opaque();
  flat.make_opaque();
  EXPECT_EQ(s.alpha_made_opaque, 2u);  // the alpha-tested triangle, placed twice
  EXPECT_EQ(flat.alpha_made_opaque, s.alpha_made_opaque);
  EXPECT_TRUE(s.alpha_textures.empty());
  EXPECT_TRUE(s.triangle_uvs.empty());
  EXPECT_EQ(s.alpha_tested_triangles(), 0u);
  EXPECT_TRUE(s.instanced());  // the instances stay
  EXPECT_EQ(flatten(s).content_hash(), flat.content_hash());
}

// ---------------------------------------------------------------- validation
TEST(ValidateInstances, BadInstancesAreRefusedNamingTheInstance) {
  {
    Scene s = hand_made();
    s.instances[2].mesh = 5;
    expect_input_error([&] { validate_scene(s); }, {"scene 'hand' instance 2", "mesh 5", "2 meshes"});
  }
  {
    Scene s = hand_made();
    s.instances[1].object_to_world = scaling({1, 0, 1});
    expect_input_error([&] { validate_scene(s); }, {"instance 1", "'quad'", "singular"});
  }
  {
    Scene s = hand_made();
    s.instances[2].object_to_world = scaling(vec3(1e-11f));  // |det| 1e-33
    expect_input_error([&] { validate_scene(s); }, {"instance 2", "singular"});
  }
  for (const float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    Scene s = hand_made();
    s.instances[0].object_to_world[3][1] = bad;
    expect_input_error([&] { validate_scene(s); }, {"instance 0", "not finite"});
  }
  {
    Scene s = hand_made();
    s.instances[0].object_to_world[0][3] = 0.5f;  // a projective row
    expect_input_error([&] { validate_scene(s); }, {"instance 0", "not affine"});
  }
  {
    Scene s = hand_made();
    s.instances[1].object_to_world = scaling(vec3(1e15f)) * translation({1e5f, 0, 0});
    expect_input_error([&] { validate_scene(s); }, {"instance 1", "beyond +-1e18"});
  }
}

TEST(ValidateInstances, MeshesMustCoverTheTrianglesInOrder) {
  {
    Scene s = hand_made();
    s.meshes[1].first_triangle = 2;
    expect_input_error([&] { validate_scene(s); }, {"mesh 1 ('quad')", "starts at triangle 2"});
  }
  {
    Scene s = hand_made();
    s.meshes[1].triangle_count = 1;
    expect_input_error([&] { validate_scene(s); }, {"cover 2 of its 3 triangles"});
  }
  {
    Scene s = hand_made();
    s.meshes[1].vertex_count = 9;
    expect_input_error([&] { validate_scene(s); }, {"mesh 1 ('quad')", "vertices run past"});
  }
  {
    Scene s = hand_made();
    s.instances.clear();
    expect_input_error([&] { validate_scene(s); }, {"2 meshes but no instance"});
  }
}

TEST(ValidateInstances, DroppedTrianglesKeepTheMeshRangesRight) {
  Scene s = hand_made();
  // Mesh 0 gains a triangle naming a vertex of mesh 1 (outside its own) and one with
  // a non-finite vertex; mesh 1 one on a degenerate line.
  s.vertices.push_back({std::numeric_limits<float>::quiet_NaN(), 0, 0});  // 7, in mesh 1's range now
  s.meshes[1].vertex_count = 5;
  s.triangles.insert(s.triangles.begin() + 1, {{0, 1, 4}, {0, 1, 2}});
  s.material_ids.insert(s.material_ids.begin() + 1, {0, 0});
  s.triangle_uvs.insert(s.triangle_uvs.begin() + 1, {TriangleUv{}, kUv});
  s.triangles.push_back({3, 7, 4});
  s.triangles.push_back({3, 4, 4});
  s.material_ids.insert(s.material_ids.end(), {1, 1});
  s.triangle_uvs.insert(s.triangle_uvs.end(), {TriangleUv{}, TriangleUv{}});
  s.meshes[0].triangle_count = 3;
  s.meshes[1].first_triangle = 3;
  s.meshes[1].triangle_count = 4;
  validate_scene(s);
  EXPECT_EQ(s.validation.input_triangles, 7u);
  EXPECT_EQ(s.validation.dropped_bad_index, 1u);
  EXPECT_EQ(s.validation.dropped_non_finite, 1u);
  EXPECT_EQ(s.validation.degenerate_kept, 1u);
  ASSERT_EQ(s.triangle_count(), 5u);
  EXPECT_EQ(s.meshes[0].first_triangle, 0u);
  EXPECT_EQ(s.meshes[0].triangle_count, 2u);
  EXPECT_EQ(s.meshes[1].first_triangle, 2u);
  EXPECT_EQ(s.meshes[1].triangle_count, 3u);
  EXPECT_EQ(s.triangle_uvs[1], kUv);
  EXPECT_EQ(s.instanced_triangle_count(), 2u + 3u + 2u);
  EXPECT_EQ(flatten(s).triangle_count(), 7u);
}

// ---------------------------------------------------------------- descriptor
fs::path write_instanced_descriptor(const fs::path& dir, const std::string& instances) {
  write_text(dir / "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  write_text(dir / "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
  write_text(dir / "scene.toml", "name = \"inst\"\n"
                                 "[[mesh]]\nname = \"tri\"\nfile = \"tri.obj\"\ntranslate = [0, 0, 1]\n"
                                 "[[mesh]]\nfile = \"quad.obj\"\n"
                                 "[[mesh]]\nname = \"unused\"\nfile = \"tri.obj\"\n" +
                                     instances +
                                     "[[camera]]\nname = \"view1\"\nposition = [0, 0, 9]\ntarget = [0, 0, 0]\n");
  return dir / "scene.toml";
}

TEST(DescriptorInstances, InstancesPlaceNamedMeshesAfterTheirOwnTransform) {
  const fs::path dir = temp_dir("descriptor");
  const fs::path path = write_instanced_descriptor(
      dir, "[[instance]]\nmesh = \"tri\"\ntranslate = [5, 0, 0]\n"
           "[[instance]]\nmesh = \"tri\"\nscale = [-1, 1, 1]\n"
           "[[instance]]\nmesh = \"quad.obj\"\nrotate_deg = [0, 90, 0]\n");
  const Scene s = load_scene_descriptor(path, SceneForm::Instanced);
  ASSERT_TRUE(s.instanced());
  ASSERT_EQ(s.meshes.size(), 3u);  // defined once each, the unused one too
  ASSERT_EQ(s.instances.size(), 3u);
  EXPECT_EQ(s.meshes[0].name, "tri");
  EXPECT_EQ(s.meshes[1].name, "quad.obj");  // named by its file
  EXPECT_EQ(s.triangle_count(), 1u + 2u + 1u);
  EXPECT_EQ(s.instanced_triangle_count(), 1u + 1u + 2u);
  EXPECT_EQ(s.instances[0].mesh, 0u);
  EXPECT_EQ(s.instances[2].mesh, 1u);
  // The mesh's own transform first, then the instance's.
  EXPECT_EQ(s.world_vertex(0, 0, 1), vec3(6, 0, 1));
  EXPECT_EQ(s.world_vertex(1, 0, 1), vec3(-1, 0, 1));
  const Scene flat = load_scene_descriptor(path);  // the flat form
  EXPECT_FALSE(flat.instanced());
  ASSERT_EQ(flat.triangle_count(), 4u);
  EXPECT_EQ(flat.vertex(0, 1), vec3(6, 0, 1));
  EXPECT_EQ(flat.triangles[1], uvec3(3, 5, 4));  // the mirrored one swapped
  EXPECT_EQ(flat.content_hash(), flatten(s).content_hash());
  fs::remove_all(dir);
}

TEST(DescriptorInstances, AnUnknownOrDoubledMeshNameIsRefused) {
  const fs::path dir = temp_dir("unknown");
  const fs::path path = write_instanced_descriptor(dir, "[[instance]]\nmesh = \"tri\"\n[[instance]]\nmesh = \"tree\"\n");
  expect_input_error([&] { load_scene_descriptor(path); },
                     {path.string(), "instance[1].mesh", "no [[mesh]] named 'tree'", "'tri', 'quad.obj', 'unused'"});
  write_text(dir / "scene.toml", "[[mesh]]\nfile = \"tri.obj\"\n[[mesh]]\nfile = \"tri.obj\"\n"
                                 "[[instance]]\nmesh = \"tri.obj\"\n"
                                 "[[camera]]\nname = \"view1\"\nposition = [0, 0, 9]\ntarget = [0, 0, 0]\n");
  expect_input_error([&] { load_scene_descriptor(path); }, {"mesh[1].file", "'tri.obj' is defined twice"});
  write_text(dir / "scene.toml", "[[mesh]]\nfile = \"tri.obj\"\n[[instance]]\nmesh = \"tri.obj\"\nshear = 1\n"
                                 "[[camera]]\nname = \"view1\"\nposition = [0, 0, 9]\ntarget = [0, 0, 0]\n");
  expect_input_error([&] { load_scene_descriptor(path); }, {"instance[0].shear", "unknown"});
  write_text(dir / "scene.toml", "[[mesh]]\nfile = \"tri.obj\"\n[[instance]]\nscale = 2\n"
                                 "[[camera]]\nname = \"view1\"\nposition = [0, 0, 9]\ntarget = [0, 0, 0]\n");
  expect_input_error([&] { load_scene_descriptor(path); }, {"instance[0].mesh", "required"});
  write_text(dir / "scene.toml", "[[mesh]]\nfile = \"tri.obj\"\n[[instance]]\nmesh = \"tri.obj\"\nscale = 0\n"
                                 "[[camera]]\nname = \"view1\"\nposition = [0, 0, 9]\ntarget = [0, 0, 0]\n");
  expect_input_error([&] { load_scene_descriptor(path); }, {"instance[0].scale", "non-zero"});
  fs::remove_all(dir);
}

TEST(DescriptorInstances, WithoutInstanceTablesEachMeshTablePlacesItsFile) {
  const fs::path dir = temp_dir("legacy");
  write_text(dir / "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  std::string text = "[[material]]\nname = \"grey\"\n";
  for (int i = 0; i < 4; ++i)
    text += "[[mesh]]\nfile = \"tri.obj\"\nmaterial = \"grey\"\ntranslate = [" + std::to_string(i) + ", 0, 0]\n";
  text += "[[mesh]]\nfile = \"tri.obj\"\n[[mesh]]\nfile = \"tri.obj\"\n";  // their own materials, each table anew
  text += "[[camera]]\nname = \"view1\"\nposition = [0, 0, 9]\ntarget = [0, 0, 0]\n";
  write_text(dir / "scene.toml", text);
  const Scene s = load_scene_descriptor(dir / "scene.toml", SceneForm::Instanced);
  ASSERT_TRUE(s.instanced());
  EXPECT_EQ(s.instances.size(), 6u);
  EXPECT_EQ(s.meshes.size(), 3u);  // the four "grey" placements share one mesh
  EXPECT_EQ(s.instanced_triangle_count(), 6u);
  const Scene flat = load_scene_descriptor(dir / "scene.toml");
  EXPECT_EQ(flat.triangle_count(), 6u);
  EXPECT_EQ(flat.vertex(3, 0), vec3(3, 0, 0));
  EXPECT_NE(flat.material_ids[4], flat.material_ids[5]);  // each table's own copy of the file's material
  // One placement is no instancing.
  write_text(dir / "scene.toml", "[[mesh]]\nfile = \"tri.obj\"\nscale = 2\n"
                                 "[[camera]]\nname = \"view1\"\nposition = [0, 0, 9]\ntarget = [0, 0, 0]\n");
  const Scene single = load_scene_descriptor(dir / "scene.toml", SceneForm::Instanced);
  EXPECT_FALSE(single.instanced());
  EXPECT_EQ(single.vertex(0, 1), vec3(2, 0, 0));
  fs::remove_all(dir);
}

// ---------------------------------------------------------------- scene image
TEST(InstancedImage, RoundTripsMeshesAndInstancesAndRefusesADamagedOne) {
  Scene s = hand_made();
  const std::string image = scene_image(s, "k");
  const std::optional<Scene> back = scene_from_image(image, "k");
  ASSERT_TRUE(back);
  EXPECT_EQ(back->content_hash(), s.content_hash());
  ASSERT_EQ(back->meshes.size(), 2u);
  EXPECT_EQ(back->meshes[1].name, "quad");
  EXPECT_EQ(back->meshes[1].first_triangle, 1u);
  ASSERT_EQ(back->instances.size(), 3u);
  EXPECT_EQ(back->instances[1].object_to_world, s.instances[1].object_to_world);
  // Damage anywhere is found (the checksum), in the instances too.
  for (size_t at : {size_t(40), image.size() / 2, image.size() - 30, image.size() - 1}) {
    std::string damaged = image;
    damaged[at] = char(damaged[at] ^ 0x21);
    EXPECT_FALSE(scene_from_image(damaged, "k")) << "byte " << at;
  }
  EXPECT_FALSE(scene_from_image(image.substr(0, image.size() - 4), "k"));
  // A flat scene still round-trips, its empty lists included.
  const Scene flat = make_procedural_scene("cornell");
  const std::optional<Scene> flat_back = scene_from_image(scene_image(flat, "f"), "f");
  ASSERT_TRUE(flat_back);
  EXPECT_FALSE(flat_back->instanced());
  EXPECT_EQ(flat_back->content_hash(), flat.content_hash());
}

class InstancedSceneCache : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rtsim_instanced_cache_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "cache");
    ::setenv("RTSIM_CACHE", (dir_ / "cache").c_str(), 1);
    ::unsetenv("RTSIM_SCENE_CACHE");
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(InstancedSceneCache, BothFormsComeFromOneImageAsFromTheFiles) {
  const fs::path path = write_instanced_descriptor(
      dir_, "[[instance]]\nmesh = \"tri\"\n[[instance]]\nmesh = \"quad.obj\"\nscale = [1, 1, -1]\n");
  const Scene parsed_flat = load_scene_descriptor(path), parsed = load_scene_descriptor(path, SceneForm::Instanced);
  const Scene first = load_scene(path.string(), SceneForm::Instanced);  // parses, writes the image
  const fs::path image = scene_image_path(scene_files_hash(path.string()));
  ASSERT_TRUE(is_file(image));
  const Scene second = load_scene(path.string(), SceneForm::Instanced), flat = load_scene(path.string());
  for (const Scene* s : {&first, &second}) {
    EXPECT_TRUE(s->instanced());
    EXPECT_EQ(s->content_hash(), parsed.content_hash());
    EXPECT_EQ(s->instances.size(), 2u);
  }
  EXPECT_FALSE(flat.instanced());
  EXPECT_EQ(flat.content_hash(), parsed_flat.content_hash());
  // A damaged image is parsed again and rewritten.
  std::string bytes;
  {
    std::ifstream in(image, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  bytes[bytes.size() - 10] = char(bytes[bytes.size() - 10] ^ 1);
  write_file_atomic(image, bytes);
  const Scene again = load_scene(path.string(), SceneForm::Instanced);
  EXPECT_EQ(again.content_hash(), parsed.content_hash());
  std::ifstream in(image, std::ios::binary);
  const std::string rewritten((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(rewritten, bytes);
}

// ---------------------------------------------------------------- forms and the forest
TEST(SceneForms, AFlatSceneComesFlatInEitherForm) {
  const Scene s = load_scene("cornell", SceneForm::Instanced);
  EXPECT_FALSE(s.instanced());
  EXPECT_EQ(s.content_hash(), load_scene("cornell").content_hash());
}

TEST(ForestInstanced, KeepsItsTreesOnceAndPlacesThemDeterministically) {
  const Scene a = load_scene("forest_instanced", SceneForm::Instanced);
  const Scene b = make_procedural_scene("forest_instanced", SceneForm::Instanced);
  ASSERT_TRUE(a.instanced());
  EXPECT_EQ(a.content_hash(), b.content_hash());
  EXPECT_EQ(a.meshes.size(), 5u);  // four trees and the ground
  EXPECT_EQ(a.instances.size(), 145u);
  for (uint32_t m = 0; m < 4; ++m) {
    EXPECT_GE(a.meshes[m].triangle_count, 5000u) << a.meshes[m].name;
    EXPECT_LE(a.meshes[m].triangle_count, 20000u) << a.meshes[m].name;
  }
  EXPECT_GE(a.instanced_triangle_count(), 1'000'000u);
  EXPECT_LE(a.instanced_triangle_count(), 2'000'000u);
  EXPECT_EQ(a.validation.dropped_bad_index + a.validation.dropped_non_finite, 0u);
  EXPECT_NE(a.find_camera("view1"), nullptr);
  EXPECT_NE(a.find_camera("view2"), nullptr);
  EXPECT_TRUE(a.ao.enabled);
  // Its flat form: every placed triangle, the same content however it is reached.
  const Scene flat = load_scene("forest_instanced");
  EXPECT_FALSE(flat.instanced());
  EXPECT_EQ(flat.triangle_count(), a.instanced_triangle_count());
  EXPECT_EQ(flat.content_hash(), flatten(a).content_hash());
  EXPECT_EQ(flat.content_hash(), make_procedural_scene("forest_instanced").content_hash());
  // The placement's size is a parameter.
  const Scene small = make_forest_instanced(10);
  EXPECT_EQ(small.instances.size(), 11u);
}

TEST(ForestInstanced, TheFiftyMillionForestHoldsFiftyMillionTriangles) {
  const Scene s = make_procedural_scene("forest_instanced_50m", SceneForm::Instanced);
  EXPECT_GE(s.instanced_triangle_count(), 50'000'000u);
  EXPECT_EQ(s.triangle_count(), load_scene("forest_instanced", SceneForm::Instanced).triangle_count());
}

}  // namespace
