// The scene image (scene_cache.h): a scene parsed once loads from its image, an
// edited input file is parsed again, and a damaged image is never trusted.
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/procedural.h>
#include <rtsim/workloads/scene_cache.h>
#include <rtsim/workloads/scene_registry.h>

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace rtsim {
namespace {

namespace fs = std::filesystem;

void expect_same_scene(const Scene& a, const Scene& b) {
  EXPECT_EQ(a.content_hash(), b.content_hash());
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.licence, b.licence);
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (size_t i = 0; i < a.cameras.size(); ++i) {
    EXPECT_EQ(a.cameras[i].name, b.cameras[i].name);
    EXPECT_EQ(a.cameras[i].position, b.cameras[i].position);
    EXPECT_EQ(a.cameras[i].target, b.cameras[i].target);
    EXPECT_EQ(a.cameras[i].up, b.cameras[i].up);
    EXPECT_EQ(a.cameras[i].vertical_fov_deg, b.cameras[i].vertical_fov_deg);
  }
  ASSERT_EQ(a.lights.size(), b.lights.size());
  for (size_t i = 0; i < a.lights.size(); ++i) {
    EXPECT_EQ(a.lights[i].kind, b.lights[i].kind);
    EXPECT_EQ(a.lights[i].position, b.lights[i].position);
    EXPECT_EQ(a.lights[i].intensity, b.lights[i].intensity);
  }
  ASSERT_EQ(a.materials.size(), b.materials.size());
  for (size_t i = 0; i < a.materials.size(); ++i) EXPECT_EQ(a.materials[i].name, b.materials[i].name);
  EXPECT_EQ(a.ao.enabled, b.ao.enabled);
  EXPECT_EQ(a.ao.cutoff_relative, b.ao.cutoff_relative);
  EXPECT_EQ(a.ao.samples, b.ao.samples);
  EXPECT_EQ(a.validation.degenerate_kept, b.validation.degenerate_kept);
  EXPECT_EQ(a.validation.input_triangles, b.validation.input_triangles);
}

TEST(SceneImage, RoundTripsEveryField) {
  Scene scene = make_procedural_scene("cornell");  // lights, materials, two cameras
  scene.licence = "CC0 test";
  scene.ao.samples = 7;
  scene.validation.degenerate_kept = 3;
  const std::optional<Scene> back = scene_from_image(scene_image(scene, "k1"), "k1");
  ASSERT_TRUE(back);
  expect_same_scene(scene, *back);
}

TEST(SceneImage, ADamagedTruncatedOrOtherKeysImageIsRefused) {
  const Scene scene = make_procedural_scene("cornell");
  const std::string image = scene_image(scene, "k1");
  EXPECT_FALSE(scene_from_image(image, "k2")) << "another key";
  EXPECT_FALSE(scene_from_image(image.substr(0, image.size() - 1), "k1")) << "truncated";
  EXPECT_FALSE(scene_from_image(image + "x", "k1")) << "trailing bytes";
  for (size_t at : {size_t(3), image.size() / 2, image.size() - 5}) {
    std::string damaged = image;
    damaged[at] = char(damaged[at] ^ 0x5A);
    EXPECT_FALSE(scene_from_image(damaged, "k1")) << "byte " << at;
  }
  EXPECT_FALSE(scene_from_image("", "k1"));
}

class SceneCache : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rtsim_scene_cache_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "cache");
    ::setenv("RTSIM_CACHE", (dir_ / "cache").c_str(), 1);
    ::unsetenv("RTSIM_SCENE_CACHE");
    write_mesh(2);
    write_file_atomic(dir_ / "s.toml",
                      "name = \"cached\"\n[[mesh]]\nfile = \"m.obj\"\n[[camera]]\nname = \"view1\"\n"
                      "position = [0.5, 0.5, 3]\ntarget = [0.5, 0.5, 0]\n");
  }
  void TearDown() override { fs::remove_all(dir_); }
  // `quads` unit squares in a row, two triangles each.
  void write_mesh(int quads) {
    std::string obj;
    for (int q = 0; q < quads; ++q) {
      const float x = float(q);
      obj += "v " + std::to_string(x) + " 0 0\nv " + std::to_string(x + 1) + " 0 0\nv " + std::to_string(x + 1) +
             " 1 0\nv " + std::to_string(x) + " 1 0\n";
      const int b = 4 * q + 1;
      obj += "f " + std::to_string(b) + " " + std::to_string(b + 1) + " " + std::to_string(b + 2) + "\n";
      obj += "f " + std::to_string(b) + " " + std::to_string(b + 2) + " " + std::to_string(b + 3) + "\n";
    }
    write_file_atomic(dir_ / "m.obj", obj);
  }
  fs::path image() const { return scene_image_path(scene_files_hash((dir_ / "s.toml").string())); }
  fs::path dir_;
};

TEST_F(SceneCache, TheSecondLoadReadsTheImageAndAnEditedMeshIsParsedAgain) {
  const std::string path = (dir_ / "s.toml").string();
  const Scene first = load_scene(path);
  EXPECT_EQ(first.triangle_count(), 4u);
  ASSERT_TRUE(is_file(image())) << "the first load writes the image";
  // The image, not the mesh, answers the second load: a scene that differs from the
  // files in a way the parser could not produce shows it.
  Scene marked = first;
  marked.licence = "from the image";
  write_file_atomic(image(), scene_image(marked, scene_files_hash(path)));
  const Scene second = load_scene(path);
  EXPECT_EQ(second.licence, "from the image");
  EXPECT_EQ(second.content_hash(), first.content_hash());
  // Another mesh is another key: parsed again, and its own image written.
  const fs::path old_image = image();
  write_mesh(3);
  const Scene edited = load_scene(path);
  EXPECT_EQ(edited.triangle_count(), 6u);
  EXPECT_NE(image(), old_image);
  EXPECT_TRUE(is_file(image()));
}

TEST_F(SceneCache, ADamagedImageIsParsedAgainAndRewritten) {
  const std::string path = (dir_ / "s.toml").string();
  const Scene first = load_scene(path);
  std::string bytes;
  {
    std::ifstream in(image(), std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  bytes[bytes.size() / 2] = char(bytes[bytes.size() / 2] ^ 1);
  write_file_atomic(image(), bytes);
  const Scene again = load_scene(path);
  EXPECT_EQ(again.content_hash(), first.content_hash());
  std::ifstream in(image(), std::ios::binary);
  const std::string rewritten((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(rewritten, bytes) << "the damaged image is replaced";
  EXPECT_TRUE(scene_from_image(rewritten, scene_files_hash(path)));
}

TEST_F(SceneCache, OffMeansNoImage) {
  ::setenv("RTSIM_SCENE_CACHE", "off", 1);
  load_scene((dir_ / "s.toml").string());
  EXPECT_FALSE(is_file(image()));
}

}  // namespace
}  // namespace rtsim
