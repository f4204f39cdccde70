// Scenes: the load policy, procedural scenes, cameras.
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/procedural.h>
#include <rtsim/workloads/scene_registry.h>
#include <rtsim/workloads/validate.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>

using namespace rtsim;

namespace {
Scene two_triangles() {
  Scene s;
  s.name = "test";
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  s.triangles = {{0, 1, 2}, {1, 3, 2}};
  return s;
}
}  // namespace

TEST(Validate, DropsNonFiniteAndBadIndexKeepsDegenerate) {
  Scene s = two_triangles();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  s.vertices.push_back({nan, 0, 0});                    // 4
  s.vertices.push_back({std::numeric_limits<float>::infinity(), 0, 0});  // 5
  s.triangles.push_back({0, 1, 4});   // non-finite -> dropped
  s.triangles.push_back({5, 1, 2});   // non-finite -> dropped
  s.triangles.push_back({0, 1, 99});  // bad index -> dropped
  s.triangles.push_back({0, 0, 1});   // degenerate -> kept
  s.triangles.push_back({0, 1, 1});   // degenerate -> kept
  validate_scene(s);
  EXPECT_EQ(s.validation.input_triangles, 7u);
  EXPECT_EQ(s.validation.dropped_non_finite, 2u);
  EXPECT_EQ(s.validation.dropped_bad_index, 1u);
  EXPECT_EQ(s.validation.degenerate_kept, 2u);
  EXPECT_EQ(s.validation.non_finite_vertices, 2u);
  EXPECT_EQ(s.triangle_count(), 4u);
  EXPECT_EQ(s.material_ids.size(), 4u);
  for (const uvec3& t : s.triangles)
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(is_finite(s.vertices[t[k]]));
}

TEST(Validate, TinyTriangleIsNotDegenerate) {
  Scene s;
  s.name = "tiny";
  s.vertices = {{0, 0, 0}, {1e-20f, 0, 0}, {0, 1e-20f, 0}};
  s.triangles = {{0, 1, 2}};
  validate_scene(s);
  EXPECT_EQ(s.validation.degenerate_kept, 0u);
}

TEST(Validate, NoSurvivingTriangleIsAnError) {
  Scene s;
  s.name = "empty";
  EXPECT_THROW(validate_scene(s), InputError);
  s.vertices = {{0, 0, 0}};
  s.triangles = {{0, 0, 5}};
  try {
    validate_scene(s);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("empty"), std::string::npos) << e.what();
  }
}

TEST(Validate, MaterialIdOutOfRangeNamesTheTriangle) {
  Scene s = two_triangles();
  s.material_ids = {0, 3};
  try {
    validate_scene(s);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("triangle 1"), std::string::npos) << e.what();
  }
}

TEST(Procedural, ScenesAreDeterministicAndWellFormed) {
  for (const std::string& name : procedural_scene_names()) {
    SCOPED_TRACE(name);
    const Scene a = make_procedural_scene(name);
    const Scene b = make_procedural_scene(name);
    EXPECT_EQ(a.content_hash(), b.content_hash());
    EXPECT_GT(a.triangle_count(), 0u);
    EXPECT_EQ(a.validation.dropped_non_finite + a.validation.dropped_bad_index, 0u);
    EXPECT_NE(a.find_camera("view1"), nullptr);
    EXPECT_NE(a.find_camera("view2"), nullptr);
    EXPECT_EQ(a.material_ids.size(), a.triangle_count());
  }
}

TEST(Procedural, DefaultInteriorIsInTheIssuesSizeRange) {
  const auto start = std::chrono::steady_clock::now();
  const Scene s = load_scene(default_scene_name());
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_GE(s.triangle_count(), 100'000u);
  EXPECT_LE(s.triangle_count(), 300'000u);
  // Purely diffuse with AO and no lights: the workload of the patent (primary + AO rays).
  EXPECT_TRUE(s.lights.empty());
  EXPECT_TRUE(s.ao.enabled);
  for (const Material& m : s.materials) {
    EXPECT_EQ(m.reflectance, 0.0f);
    EXPECT_EQ(m.transmittance, 0.0f);
  }
  RecordProperty("load_seconds", std::to_string(seconds));
}

TEST(Camera, CentrePixelLooksAtTheTarget) {
  Camera c;
  c.position = {1, 2, 3};
  c.target = {1, 2, -7};
  const Camera::Ray r = c.primary_ray(50, 50, 100, 100, 0.0f, 0.0f);
  EXPECT_NEAR(r.direction.x, 0.0f, 1e-6f);
  EXPECT_NEAR(r.direction.y, 0.0f, 1e-6f);
  EXPECT_NEAR(r.direction.z, -1.0f, 1e-6f);
  EXPECT_NEAR(glm::length(c.primary_ray(0, 0, 100, 50).direction), 1.0f, 1e-5f);
  // Top-left pixel looks up and to the left.
  const Camera::Ray tl = c.primary_ray(0, 0, 100, 100);
  EXPECT_LT(tl.direction.x, 0.0f);
  EXPECT_GT(tl.direction.y, 0.0f);
}

TEST(Camera, LookingAlongUpStillGivesAFrame) {
  Camera c;
  c.position = {0, 0, 0};
  c.target = {0, 5, 0};
  const Camera::Ray r = c.primary_ray(3, 7, 10, 10);
  EXPECT_TRUE(is_finite(r.direction));
}

TEST(Registry, UnknownSceneNamesTheSceneAndTheFetchCommand) {
  try {
    load_scene("no-such-scene");
    FAIL();
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("no-such-scene"), std::string::npos);
    EXPECT_NE(what.find("scenes fetch"), std::string::npos);
  }
}
