// Instanced scenes: the two-level tree (a BLAS per mesh, a TLAS over instances),
// its memory image, the core's Transform step, agreement with the flattened scene
// and with Embree's own instances, and the three levels counting the same XFM ops.
#include "sim_test_support.h"
#include "builder/scene_fixtures.h"

#include <rtsim/builder/build.h>
#include <rtsim/model/core/exact_referee.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/core/validate.h>
#include <rtsim/workloads/embree_scene.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/random.h>
#include <rtsim/workloads/validate.h>

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

using namespace rtsim;
using namespace rtsim::sim;
using namespace rtsim::sim::test;
using rtsim::test::instanced_town;

namespace {

// Rays from above and from the side through the town, seeded by index.
std::vector<Ray> town_rays(uint32_t count) {
  std::vector<Ray> rays;
  for (uint32_t i = 0; i < count; ++i) {
    KeyedRng rng(0x1257, {i});
    Ray r;
    r.origin = vec3(-1.0f + 5.5f * rng.next_float(), 1.5f + 2.0f * rng.next_float(), -1.0f + 5.5f * rng.next_float());
    const vec3 target(-0.5f + 4.5f * rng.next_float(), 0.3f * rng.next_float(), -0.5f + 4.5f * rng.next_float());
    r.direction = glm::normalize(target - r.origin);
    r.type = i % 3 == 0 ? RayType::Ao : RayType::Primary;
    if (r.type == RayType::Ao) r.tmax = 2.5f;
    rays.push_back(r);
  }
  return rays;
}

struct Town {
  Scene scene = instanced_town();
  Bvh bvh;
  std::unique_ptr<MemoryImage> image;
  std::unique_ptr<TraversalContext> context;
  explicit Town(const std::string& format = "bvh2-64", const std::string& builder = "sah") {
    BuildParams params;
    params.builder = builder;
    apply_node_format(params, node_format(format));
    bvh = build_bvh(scene, params);
    MemoryLayoutConfig layout;
    layout.node_format = format;
    image = std::make_unique<MemoryImage>(scene, bvh, layout);
    context = std::make_unique<TraversalContext>(scene, bvh, *image);
  }
};

}  // namespace

TEST(CoreInstances, ATwoLevelTreeHasATlasLeafPerInstanceAndABlasPerMesh) {
  const Town town;
  ASSERT_TRUE(town.bvh.two_level());
  EXPECT_EQ(town.bvh.blas_roots.size(), 2u);
  uint32_t instance_leaves = 0;
  std::vector<int> seen(town.scene.instances.size(), 0);
  for (uint32_t n = 0; n < town.bvh.tlas_nodes; ++n)
    if (town.bvh.is_instance_leaf(n)) {
      ++instance_leaves;
      ASSERT_EQ(town.bvh.nodes[n].count, 1u);
      ++seen[town.bvh.prim_refs[town.bvh.nodes[n].index]];
    }
  EXPECT_EQ(instance_leaves, town.scene.instances.size());
  for (int k : seen) EXPECT_EQ(k, 1);
  // The image stores each mesh's triangles once, and one record per instance.
  EXPECT_EQ(town.image->footprint().triangle_records, town.scene.triangle_count());
  EXPECT_EQ(town.image->footprint().instance_records, town.scene.instances.size());
  EXPECT_GT(town.image->footprint().tlas_node_records, 0u);
}

TEST(CoreInstances, InstancedTracesHitWhatTheFlattenedSceneHitsInEveryFormat) {
  const Scene flat = flatten(instanced_town());
  ASSERT_EQ(flat.triangle_count(), instanced_town().instanced_triangle_count());
  BuildParams params;
  params.builder = "sah";
  const Bvh flat_bvh = build_bvh(flat, params);
  const MemoryImage flat_image(flat, flat_bvh);
  const TraversalContext flat_context(flat, flat_bvh, flat_image);
  // Instance i's triangles start at offset[i] in the flattened scene.
  const Scene instanced = instanced_town();
  std::vector<uint32_t> offset;
  uint32_t at = 0;
  for (const Instance& inst : instanced.instances) offset.push_back(at), at += instanced.meshes[inst.mesh].triangle_count;
  const std::vector<Ray> rays = town_rays(3000);
  for (const char* format : {"bvh2-64", "bvh2-32", "bvh4-128", "bvh6-64q", "bvh8-80q"}) {
    SCOPED_TRACE(format);
    const Town town(format);
    RayTraversal two(*town.context), one(flat_context);
    uint32_t hits = 0, any_hits = 0, transforms = 0;
    for (const Ray& r : rays) {
      const HitRecord a = trace_ray(two, r);
      const HitRecord b = trace_ray(one, r);
      ASSERT_EQ(a.hit(), b.hit());
      transforms += two.counters().xfm_ops;
      any_hits += a.hit();
      if (a.hit()) EXPECT_GE(two.counters().xfm_ops, 1u);  // a surface lies in some instance
      EXPECT_EQ(two.counters().instance_bytes, two.counters().xfm_ops * MemoryImage::kInstanceRecordBytes);
      EXPECT_LE(two.counters().tlas_trv_ops, two.counters().trv_ops);
      if (!a.hit() || traversal_mode_for(r.type) == TraversalMode::AnyHit) continue;
      ++hits;
      // The same surface, at the same distance up to the transform's rounding.
      const SceneMesh& mesh = town.scene.meshes[town.scene.instances[a.instance].mesh];
      EXPECT_EQ(offset[a.instance] + (a.prim - mesh.first_triangle), b.prim);
      EXPECT_NEAR(a.t, b.t, 1e-4f * b.t);
    }
    EXPECT_GT(hits, 1000u);
    EXPECT_GT(transforms, any_hits);  // rays enter instances they miss, too
  }
}

TEST(CoreInstances, AgreesWithEmbreeInstancesUnderTheExactReferee) {
  const Town town("bvh6-64q");
  const std::vector<Ray> rays = town_rays(4000);
  std::vector<TraceResult> results;
  trace_rays(*town.context, rays, results);
  const EmbreeScene embree(town.scene);
  ValidationRule rule;
  rule.absolute_bound = 1e-6f * town.scene.diagonal();
  const ValidationResult v = validate_against_embree(embree, rays, results, rule, 0, &town.scene);
  EXPECT_EQ(v.core_wrong, 0u);
  EXPECT_LE(v.disagreements, 2u);  // rays through shared edges at most
  // Embree reports the instance and the scene's triangle the core names.
  uint32_t same = 0, hits = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    if (traversal_mode_for(rays[i].type) == TraversalMode::AnyHit || !results[i].hit.hit()) continue;
    const EmbreeHit e = embree.intersect(rays[i].origin, rays[i].direction, rays[i].tmin, rays[i].tmax);
    ++hits;
    same += e.instance == results[i].hit.instance && e.prim == results[i].hit.prim;
  }
  EXPECT_GE(same, hits - 2);
}

TEST(CoreInstances, TheTransformIsItsOwnStepReadingTheInstanceRecordThroughTheNodeCache) {
  const Town town("bvh4-128");
  RayTraversal trv(*town.context);
  Ray r = town_rays(1)[0];
  r.type = RayType::Primary;
  r.tmax = std::numeric_limits<float>::infinity();
  r.origin = vec3(0.0f, 3.0f, 0.0f);
  r.direction = vec3(0.0f, -1.0f, 0.0f);  // straight down onto instance 0's grid
  trv.reset(r);
  uint32_t transforms = 0;
  while (!trv.done()) {
    if (trv.action() == TraversalAction::Transform) {
      ++transforms;
      ASSERT_EQ(trv.step_reads().size(), 1u);
      const MemoryAccess& a = trv.step_reads()[0];
      EXPECT_EQ(a.kind, AccessKind::Instance);
      EXPECT_EQ(a.bytes, MemoryImage::kInstanceRecordBytes);
      EXPECT_EQ(a.address, town.image->instance_address(trv.instance()));
      EXPECT_EQ(requester_of(a.kind), Requester::Trv);
      EXPECT_FALSE(trv.in_blas());
      trv.process();
      EXPECT_TRUE(trv.in_blas());
      continue;
    }
    trv.process();
  }
  EXPECT_GE(transforms, 1u);
  EXPECT_TRUE(trv.hit().hit());
  EXPECT_EQ(trv.hit().instance, 0u);
  EXPECT_EQ(trv.counters().xfm_ops, transforms);
}

TEST(CoreInstances, AShortStackSpillingAcrossBothLevelsKeepsTheHits) {
  const Town town("bvh2-64");
  TraversalConfig tight;
  tight.stack_limit = 1;
  const TraversalContext spilling(town.scene, town.bvh, *town.image, tight);
  RayTraversal deep(*town.context), shallow(spilling);
  uint64_t refills = 0;
  for (const Ray& r : town_rays(1500)) {
    const HitRecord a = trace_ray(deep, r), b = trace_ray(shallow, r);
    ASSERT_EQ(a.hit(), b.hit());
    if (a.hit() && traversal_mode_for(r.type) == TraversalMode::ClosestHit) {
      EXPECT_EQ(a.prim, b.prim);
      EXPECT_EQ(a.instance, b.instance);
      EXPECT_EQ(a.t, b.t);
    }
    refills += shallow.counters().stack_refills;
  }
  EXPECT_GT(refills, 0u);
}

TEST(CoreInstances, AoBvhBuildsItsBlasesFromWorldSpaceOcclusionAndRdhRefuses) {
  const Scene scene = instanced_town();
  BuildParams params;
  params.builder = "aobvh";
  BuildReport report;
  const Bvh bvh = build_bvh(scene, params, &report);
  EXPECT_TRUE(bvh.two_level());
  EXPECT_EQ(report.weights.size(), scene.triangle_count());
  EXPECT_GT(report.ao_rays, 0u);
  EXPECT_GT(report.placement_spread, 0.0);  // placements differ: neighbours occlude some
  EXPECT_LT(report.mean_occlusion, 1.0);
  params.builder = "rdh";
  EXPECT_THROW(build_bvh(scene, params), InputError);
}

namespace {
std::map<std::string, double> simulate_town(const Scene& scene, const Bvh& bvh, Fidelity level) {
  return small_run_stats(scene, bvh, level, 24);
}
}  // namespace

// trace's xfm_heatmap.png: every ray's transforms credited to its pixel, so the
// picture adds up to the frame's XFM ops (one sample per pixel), and a pixel whose
// rays enter more instances is brighter.
TEST(CoreInstances, TheXfmPictureAddsUpToTheFramesTransforms) {
  const Town town;
  EffectSettings settings;
  settings.width = settings.height = 32;
  settings.ao_samples = 2;
  const FrameRun run = run_frame(*town.context, town.scene.camera("view1"), settings);
  ASSERT_GT(run.total.xfm_ops, 0u);
  const std::vector<float> xfm = xfm_per_pixel(run);
  ASSERT_EQ(xfm.size(), 32u * 32u);
  double sum = 0;
  for (float v : xfm) sum += v;
  EXPECT_DOUBLE_EQ(sum, double(run.total.xfm_ops));
  std::vector<uint64_t> by_pixel(xfm.size(), 0);
  for (size_t i = 0; i < run.rays.size(); ++i) by_pixel[run.rays[i].pixel] += run.results[i].counters.xfm_ops;
  for (size_t p = 0; p < xfm.size(); ++p) EXPECT_EQ(xfm[p], float(by_pixel[p])) << p;
}

TEST(SimInstances, EveryLevelCountsTheSameTlasXfmAndBlasWork) {
  const Town town;
  const auto functional = simulate_town(town.scene, town.bvh, Fidelity::Functional);
  const auto lt = simulate_town(town.scene, town.bvh, Fidelity::Lt);
  const auto cycle = simulate_town(town.scene, town.bvh, Fidelity::Cycle);
  ASSERT_GT(functional.at("ops.xfm_ops"), 0);
  for (const char* key : {"ops.xfm_ops", "ops.tlas_trv_ops", "ops.blas_trv_ops", "ops.trv", "ops.ist",
                          "fetches.instance_bytes", "per_type.ao.xfm_ops", "rays.total", "memory.instance_bytes"}) {
    SCOPED_TRACE(key);
    EXPECT_EQ(functional.at(key), lt.at(key));
    EXPECT_EQ(functional.at(key), cycle.at(key));
  }
  EXPECT_EQ(functional.at("ops.tlas_trv_ops") + functional.at("ops.blas_trv_ops"), functional.at("ops.trv"));
  EXPECT_GT(cycle.at("energy.xfm.pj"), 0);
  // The transforms take TRV pipeline passes: more passes than node fetches.
  EXPECT_GE(cycle.at("machine.trv_passes"), cycle.at("ops.trv") + cycle.at("ops.xfm_ops"));
  // A flat scene's run has none of these stats.
  const Scene flat = flatten(town.scene);
  BuildParams params;
  params.builder = "sah";
  const Bvh flat_bvh = build_bvh(flat, params);
  const auto plain = simulate_town(flat, flat_bvh, Fidelity::Functional);
  EXPECT_EQ(plain.count("ops.xfm_ops"), 0u);
  EXPECT_EQ(plain.count("memory.instance_bytes"), 0u);
  EXPECT_EQ(plain.at("ops.ist") > 0, true);
}
