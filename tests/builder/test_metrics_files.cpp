// Quality metrics and BVH files.
#include <rtsim/builder/build.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/builder/metrics.h>
#include <rtsim/workloads/error.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "builder/scene_fixtures.h"

namespace rtsim {
namespace {

namespace fs = std::filesystem;

TEST(Metrics, SahBeatsMedianAndSweepIsAtLeastAsGoodAsBinned) {
  const Scene scene = test::triangle_soup(8000);
  BuildParams p;
  const double binned = sah_cost(build_bvh(scene, p), p.t1, p.t2);
  p.bins = 0;
  const double sweep = sah_cost(build_bvh(scene, p), p.t1, p.t2);
  p = BuildParams{};
  p.builder = "median";
  const double median = sah_cost(build_bvh(scene, p), p.t1, p.t2);
  EXPECT_LT(binned, median);
  EXPECT_LE(sweep, binned * 1.01);
}

TEST(Metrics, SingleLeafCostIsTrianglesTimesT2) {
  const Scene scene = test::triangle_soup(3);
  BuildParams p;
  p.t2 = 0.1f;  // a node test (2*T1 = 2) costs more than testing all three
  const Bvh bvh = build_bvh(scene, p);
  ASSERT_TRUE(bvh.root().is_leaf());
  EXPECT_NEAR(sah_cost(bvh, p.t1, p.t2), 3 * 0.1, 1e-6);
}

// Two triangles, hand-made tree: leaf A, leaf B; B's box cuts a 0.1 x 0.1 square out of A.
TEST(Metrics, EndPointOverlapMatchesAHandComputation) {
  Scene scene = test::empty_scene("epo");
  test::add_triangle(scene, vec3(0, 0, 0), vec3(2, 0, 0), vec3(0, 2, 0));
  test::add_triangle(scene, vec3(0.5f, 0.5f, -1), vec3(0.6f, 0.5f, 1), vec3(0.5f, 0.6f, 1));
  Bvh bvh;
  bvh.nodes.resize(3);
  bvh.nodes[0] = {scene.bounds(), 1, 0, 2};
  bvh.nodes[1] = {scene.triangle_bounds(0), 0, 1};
  bvh.nodes[2] = {scene.triangle_bounds(1), 1, 1};
  bvh.prim_refs = {0, 1};
  const double area_b = 0.5 * glm::length(glm::cross(dvec3(0.1, 0, 2), dvec3(0, 0.1, 2)));
  const double expected = 0.01 / (2.0 + area_b);  // c(leaf B) = T2 * 1
  EXPECT_NEAR(end_point_overlap(bvh, scene, 1.0f, 1.0f), expected, 1e-6);
  // SAH cost by hand: 2*T1 + P_A * 1 + P_B * 1.
  const double root = scene.bounds().area();
  const double cost = 2.0 + scene.triangle_bounds(0).area() / root + scene.triangle_bounds(1).area() / root;
  EXPECT_NEAR(sah_cost(bvh, 1.0f, 1.0f), cost, 1e-6);
}

// Triangle 1 is in two leaves that meet at the root; triangle 2 in two leaves
// that meet at node 2; triangle 0 in one: two nodes split spatially.
TEST(Metrics, SpatialSplitsAreTheNodesWhereATrianglesLeavesBranch) {
  Bvh bvh;
  const Aabb box{vec3(0.0f), vec3(1.0f)};
  bvh.nodes = {BvhNode{box, 1, 0, 2},   // 0: root
               BvhNode{box, 0, 2, 0},   // 1: leaf {0, 1}
               BvhNode{box, 3, 0, 2},   // 2: inner
               BvhNode{box, 2, 2, 0},   // 3: leaf {1, 2}
               BvhNode{box, 4, 1, 0}};  // 4: leaf {2}
  bvh.prim_refs = {0, 1, 1, 2, 2};
  EXPECT_EQ(count_spatial_splits(bvh), 2u);
  bvh.prim_refs = {0, 1, 2, 3, 4};
  EXPECT_EQ(count_spatial_splits(bvh), 0u);
}

// The same count for every builder, ours and Embree's, read off the tree.
TEST(Metrics, EveryReferenceSplittingBuilderReportsItsSpatialSplits) {
  const Scene scene = test::triangle_soup(3000, 5, 0.3f);
  for (const char* builder : {"sah", "sbvh", "embree", "embree-sbvh"}) {
    BuildParams p;
    p.builder = builder;
    BuildReport report;
    const Bvh bvh = build_bvh(scene, p, &report);
    EXPECT_EQ(report.spatial_splits, count_spatial_splits(bvh)) << builder;
    EXPECT_EQ(report.spatial_splits > 0, bvh.prim_refs.size() > scene.triangle_count()) << builder;
  }
}

TEST(Metrics, ReportCountsAreConsistent) {
  const Scene scene = test::triangle_soup(2000, 3, 0.2f);
  for (const char* builder : {"sah", "sbvh", "median"}) {
    BuildParams p;
    p.builder = builder;
    BuildReport report;
    const Bvh bvh = build_bvh(scene, p, &report);
    const BvhMetrics m = compute_metrics(bvh, scene, p, report);
    EXPECT_EQ(m.nodes, m.inner_nodes + m.leaves);
    EXPECT_EQ(m.leaves, m.inner_nodes + 1);
    uint64_t refs = 0;
    for (size_t k = 0; k < m.leaf_size_histogram.size(); ++k) refs += k * m.leaf_size_histogram[k];
    EXPECT_EQ(refs, m.references);
    EXPECT_GT(m.epo, 0.0);
    EXPECT_GE(m.max_depth, m.average_leaf_depth);
    EXPECT_DOUBLE_EQ(m.sah_cost, m.weighted_cost);
    EXPECT_GT(m.peak_memory_bytes, 0u);
    EXPECT_NE(metrics_json(m).find("\"sah_cost\""), std::string::npos);
  }
}

class BvhFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rtsim_bvh_file_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string read(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  void write(const fs::path& p, const std::string& bytes) {
    std::ofstream(p, std::ios::binary) << bytes;
  }
  void expect_refused(const fs::path& p, const Scene* scene, const std::string& field) {
    try {
      load_bvh(p, scene);
      ADD_FAILURE() << "accepted a bad file, expected an error about " << field;
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(p.string()), std::string::npos) << what;
      EXPECT_NE(what.find(field), std::string::npos) << what;
    }
  }
  fs::path dir_;
};

TEST_F(BvhFileTest, RoundTripKeepsTheTreeAndHeader) {
  const Scene scene = test::triangle_soup(3000, 3, 0.2f);
  for (const char* builder : {"sah", "sbvh"}) {
    BuildParams p;
    p.builder = builder;
    const Bvh bvh = build_bvh(scene, p);
    const fs::path file = dir_ / (std::string(builder) + ".bvh");
    save_bvh(file, bvh, scene, p);
    BvhFileHeader header;
    const Bvh loaded = load_bvh(file, &scene, &header);
    EXPECT_TRUE(test::same_tree(bvh, loaded));
    EXPECT_EQ(header.builder, builder);
    EXPECT_EQ(header.scene_hash, scene.content_hash());
    EXPECT_EQ(header.version, kBvhFileVersion);
    EXPECT_NE(header.params_json.find("max_leaf_size"), std::string::npos);
  }
}

TEST_F(BvhFileTest, BadFilesAreRefusedNamingFileAndField) {
  const Scene scene = test::triangle_soup(500);
  const BuildParams p;
  const fs::path good = dir_ / "good.bvh";
  save_bvh(good, build_bvh(scene, p), scene, p);
  const std::string bytes = read(good);

  const fs::path truncated = dir_ / "truncated.bvh";
  write(truncated, bytes.substr(0, bytes.size() / 2));
  expect_refused(truncated, &scene, "truncated");

  const fs::path corrupt = dir_ / "corrupt.bvh";
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x5a;
  write(corrupt, flipped);
  expect_refused(corrupt, &scene, "checksum");

  const fs::path magic = dir_ / "magic.bvh";
  write(magic, "NOTABVH!" + bytes.substr(8));
  expect_refused(magic, &scene, "header.magic");

  const fs::path version = dir_ / "version.bvh";
  std::string v2 = bytes;
  v2[8] = 99;
  write(version, v2);
  expect_refused(version, &scene, "header.version");

  const Scene other = test::triangle_soup(500, 99);
  expect_refused(good, &other, "header.scene_hash");

  expect_refused(dir_ / "missing.bvh", &scene, "no such file");
  write(dir_ / "empty.bvh", "");
  expect_refused(dir_ / "empty.bvh", &scene, "header.magic");
}

}  // namespace
}  // namespace rtsim
