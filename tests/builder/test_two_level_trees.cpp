// Two-level trees as files, checks and metrics: a saved TLAS + BLASes load back
// whole, the structural checks catch what a broken two-level tree gets wrong, and
// the world-space SAH cost agrees with a one-level tree where the two must agree.
#include <rtsim/builder/build.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/builder/metrics.h>
#include <rtsim/builder/validate_bvh.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/random.h>

#include "builder/scene_fixtures.h"

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <unistd.h>

namespace rtsim {
namespace {

namespace fs = std::filesystem;

std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}
void write_bytes(const fs::path& p, const std::string& bytes) { std::ofstream(p, std::ios::binary) << bytes; }

// The error's text, or "" if `f` did not throw an InputError.
template <class F>
std::string input_error_of(F f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

class TwoLevelTrees : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rtsim_two_level_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(TwoLevelTrees, ASavedTwoLevelTreeLoadsBackWhole) {
  const Scene scene = test::instanced_town();
  for (const char* builder : {"sah", "sbvh", "aobvh"}) {
    BuildParams p;
    p.builder = builder;
    p.width = 4;
    const Bvh bvh = build_bvh(scene, p);
    ASSERT_TRUE(bvh.two_level());
    const fs::path file = dir_ / (std::string(builder) + ".bvh");
    save_bvh(file, bvh, scene, p);
    BvhFileHeader header;
    const Bvh loaded = load_bvh(file, &scene, &header);
    EXPECT_TRUE(test::same_tree(bvh, loaded)) << builder;
    EXPECT_EQ(loaded.tlas_nodes, bvh.tlas_nodes);
    EXPECT_EQ(loaded.blas_roots, bvh.blas_roots);
    EXPECT_EQ(header.instance_count, scene.instances.size());
    EXPECT_EQ(header.version, kBvhFileVersion);
  }
}

TEST_F(TwoLevelTrees, ATreeOfTheOtherFormIsRefusedSayingWhich) {
  const Scene instanced = test::instanced_town();
  const Scene flat = flatten(instanced);
  const BuildParams p;
  save_bvh(dir_ / "two.bvh", build_bvh(instanced, p), instanced, p);
  save_bvh(dir_ / "one.bvh", build_bvh(flat, p), flat, p);
  std::string what = input_error_of([&] { load_bvh(dir_ / "two.bvh", &flat); });
  EXPECT_NE(what.find("header.scene_hash"), std::string::npos) << what;
  EXPECT_NE(what.find("add --instanced"), std::string::npos) << what;
  what = input_error_of([&] { load_bvh(dir_ / "one.bvh", &instanced); });
  EXPECT_NE(what.find("leave out --instanced"), std::string::npos) << what;
}

TEST_F(TwoLevelTrees, BrokenLevelsInTheFileAreRefusedNamingTheField) {
  const Scene scene = test::instanced_town();
  const BuildParams p;
  const Bvh bvh = build_bvh(scene, p);
  // A BLAS root inside the TLAS, and one past the end: each refused by name.
  for (const uint32_t bad : {1u, uint32_t(bvh.nodes.size())}) {
    Bvh broken = bvh;
    broken.blas_roots[1] = bad;
    save_bvh(dir_ / "broken.bvh", broken, scene, p);
    const std::string what = input_error_of([&] { load_bvh(dir_ / "broken.bvh", &scene); });
    EXPECT_NE(what.find("blas_roots[1]"), std::string::npos) << what;
  }
  // A TLAS leaf naming an instance that does not exist: refused without the scene too.
  Bvh broken = bvh;
  for (uint32_t i = 0; i < broken.tlas_nodes; ++i)
    if (broken.nodes[i].is_leaf()) {
      broken.prim_refs[broken.nodes[i].index] = uint32_t(scene.instances.size());
      break;
    }
  save_bvh(dir_ / "instance.bvh", broken, scene, p);
  const std::string what = input_error_of([&] { load_bvh(dir_ / "instance.bvh"); });
  EXPECT_NE(what.find("references["), std::string::npos) << what;
  EXPECT_NE(what.find("instance " + std::to_string(scene.instances.size()) + " does not exist"), std::string::npos)
      << what;
}

TEST_F(TwoLevelTrees, AVersionTwoFileStillLoads) {
  // Version 2 is version 3 without the two-level block (20 bytes of zeros for a
  // one-level tree after the reference count), with its own checksum.
  const Scene scene = test::triangle_soup(400);
  BuildParams p;
  const Bvh bvh = build_bvh(scene, p);
  save_bvh(dir_ / "v3.bvh", bvh, scene, p);
  std::string bytes = read_bytes(dir_ / "v3.bvh");
  size_t at = 8 + 4 + 8 + 8;
  for (int text = 0; text < 2; ++text) {
    uint32_t length;
    std::memcpy(&length, bytes.data() + at, 4);
    at += 4 + length;
  }
  at += 16;  // node and reference counts
  ASSERT_EQ(bytes.substr(at, 20), std::string(20, '\0'));
  bytes.erase(at, 20);
  bytes[8] = 2;
  bytes.resize(bytes.size() - 8);
  const uint64_t sum = hash_bytes(0x4256'4846'494C'4531ull, bytes.data(), bytes.size());
  bytes.append(reinterpret_cast<const char*>(&sum), 8);
  write_bytes(dir_ / "v2.bvh", bytes);
  BvhFileHeader header;
  EXPECT_TRUE(test::same_tree(bvh, load_bvh(dir_ / "v2.bvh", &scene, &header)));
  EXPECT_EQ(header.version, 2u);
}

TEST(TwoLevelValidation, EveryBuilderThatBuildsBlasesPassesTheChecks) {
  const Scene scene = test::instanced_town();
  for (const char* builder : {"sah", "median", "sbvh", "osah", "aobvh", "aosbvh", "embree", "embree-sbvh"}) {
    BuildParams p;
    p.builder = builder;
    const Bvh bvh = build_bvh(scene, p);
    const BvhValidation v = validate_bvh(bvh, scene, limits_for(p));
    EXPECT_TRUE(v.ok()) << builder << ":\n" << v.summary();
  }
}

TEST(TwoLevelValidation, WhatABrokenTwoLevelTreeGetsWrongIsNamed) {
  const Scene scene = test::instanced_town();
  const BuildParams p;
  const Bvh good = build_bvh(scene, p);
  const BvhLimits limits = limits_for(p);
  const auto problems = [&](const Bvh& bvh) { return validate_bvh(bvh, scene, limits).summary(); };
  std::vector<uint32_t> tlas_leaves;
  for (uint32_t i = 0; i < good.tlas_nodes; ++i)
    if (good.nodes[i].is_leaf()) tlas_leaves.push_back(i);
  ASSERT_GE(tlas_leaves.size(), 2u);
  const uint32_t first_leaf = tlas_leaves[0], second_leaf = tlas_leaves[1];
  {  // One instance twice, another never.
    Bvh b = good;
    b.prim_refs[b.nodes[second_leaf].index] = b.prim_refs[b.nodes[first_leaf].index];
    const std::string s = problems(b);
    EXPECT_NE(s.find("referenced 2 times by the TLAS"), std::string::npos) << s;
    EXPECT_NE(s.find("referenced 0 times by the TLAS"), std::string::npos) << s;
  }
  {  // A BLAS leaf holding a triangle of the other mesh.
    Bvh b = good;
    const uint32_t root = b.blas_roots[1];
    uint32_t leaf = root;
    while (!b.nodes[leaf].is_leaf()) leaf = b.nodes[leaf].index;
    b.prim_refs[b.nodes[leaf].index] = scene.meshes[0].first_triangle;
    const std::string s = problems(b);
    EXPECT_NE(s.find("BLAS of mesh 1"), std::string::npos) << s;
    EXPECT_NE(s.find("is not one of this tree's"), std::string::npos) << s;
  }
  {  // A TLAS leaf box that does not hold its instance.
    Bvh b = good;
    b.nodes[first_leaf].bounds.hi = b.nodes[first_leaf].bounds.lo + vec3(1e-3f);
    const std::string s = problems(b);
    EXPECT_NE(s.find("outside the leaf box"), std::string::npos) << s;
  }
  {  // The other form's tree.
    const std::string s = validate_bvh(good, flatten(scene), limits).summary();
    EXPECT_NE(s.find("a two-level tree for a flat scene"), std::string::npos) << s;
  }
}

// One instance: the TLAS is its leaf, and the tree the rays walk is the BLAS placed.
// Under a translation and a uniform scale every area scales alike, so the
// world-space cost is the mesh's one-level tree's cost; a rotation changes the
// placed boxes, and with them the cost.
TEST(TwoLevelMetrics, OneInstanceCostsItsMeshTreeUnderTranslationAndUniformScale) {
  const Scene town = test::instanced_town();
  Scene one = town;
  one.instances.resize(1);
  one.instances[0].mesh = 0;
  const auto cost_of = [](const Scene& s) {
    const BuildParams p;
    BuildReport r;
    const Bvh bvh = build_bvh(s, p, &r);
    return compute_metrics(bvh, s, p, r, false);
  };
  one.instances[0].object_to_world = glm::scale(glm::translate(glm::mat4(1.0f), vec3(3, -2, 7)), vec3(2.5f));
  const BvhMetrics placed = cost_of(one);
  one.instances[0].object_to_world = glm::mat4(1.0f);
  const Scene mesh_alone = flatten(one);  // mesh 0 in object space, one-level
  const BvhMetrics alone = cost_of(mesh_alone);
  EXPECT_NEAR(placed.sah_cost, alone.sah_cost, 1e-4 * alone.sah_cost);
  EXPECT_EQ(placed.instances, 1u);
  EXPECT_EQ(placed.placed_triangles, town.meshes[0].triangle_count);
  EXPECT_EQ(placed.max_depth, alone.max_depth + 1);  // the instance leaf, then the BLAS
  one.instances[0].object_to_world = glm::rotate(glm::mat4(1.0f), 0.7f, vec3(0.3f, 1, 0.2f));
  EXPECT_GT(std::fabs(cost_of(one).sah_cost - alone.sah_cost), 1e-3 * alone.sah_cost);
}

TEST(TwoLevelMetrics, TheCostCountsEveryPlacement) {
  // The same mesh placed twice, far apart: each placement adds its BLAS's cost.
  const Scene town = test::instanced_town();
  Scene two = town;
  two.instances.resize(2);
  two.instances[0].mesh = two.instances[1].mesh = 0;
  two.instances[0].object_to_world = glm::mat4(1.0f);
  two.instances[1].object_to_world = glm::translate(glm::mat4(1.0f), vec3(10, 0, 0));
  const BuildParams p;
  BuildReport r;
  const Bvh bvh = build_bvh(two, p, &r);
  const BvhMetrics m = compute_metrics(bvh, two, p, r, false);
  EXPECT_EQ(m.instances, 2u);
  EXPECT_EQ(m.placed_triangles, 2u * town.meshes[0].triangle_count);
  EXPECT_EQ(m.references, town.meshes[0].triangle_count + town.meshes[1].triangle_count);
  // Cost = (2*T1*A(root) + 2 * BLAS sum) / A(root): over 2 BLAS costs scaled by area.
  const double root = bvh.root().bounds.area();
  Scene alone = two;
  alone.instances.resize(1);
  BuildReport ra;
  const Bvh one_bvh = build_bvh(alone, p, &ra);
  const double blas_sum = compute_metrics(one_bvh, alone, p, ra, false).sah_cost * one_bvh.root().bounds.area();
  EXPECT_NEAR(m.sah_cost, (2.0 * root + 2.0 * blas_sum) / root, 1e-4 * m.sah_cost);
}

}  // namespace
}  // namespace rtsim

namespace rtsim {
namespace {

// The first `tlas_nodes` nodes and their instance references: the TLAS alone.
bool same_tlas(const Bvh& a, const Bvh& b) {
  if (a.tlas_nodes != b.tlas_nodes) return false;
  for (uint32_t i = 0; i < a.tlas_nodes; ++i) {
    const BvhNode &x = a.nodes[i], &y = b.nodes[i];
    if (x.index != y.index || x.count != y.count || x.children != y.children ||
        std::memcmp(&x.bounds, &y.bounds, sizeof(Aabb)) != 0)
      return false;
    if (x.is_leaf() && a.prim_refs[x.index] != b.prim_refs[y.index]) return false;
  }
  return true;
}

// AO-BVH weights its TLAS by each instance's occlusion: with every value equal the
// weights are all 1 and the TLAS is SAH's; with the meshes' values apart it is not.
TEST(TwoLevelAoBvh, TheTlasIsWeightedByTheInstancesOcclusion) {
  const Scene scene = test::instanced_town();
  BuildParams sah;
  const Bvh reference = build_bvh(scene, sah);
  BuildParams ao;
  ao.builder = "aobvh";
  ao.occlusion_values.assign(scene.triangle_count(), 0.5f);
  EXPECT_TRUE(same_tlas(build_bvh(scene, ao), reference));
  for (uint32_t t = 0; t < scene.triangle_count(); ++t)
    ao.occlusion_values[t] = t < scene.meshes[1].first_triangle ? 0.0f : 1.0f;  // grids closed, boxes open
  EXPECT_FALSE(same_tlas(build_bvh(scene, ao), reference));
}

}  // namespace
}  // namespace rtsim
