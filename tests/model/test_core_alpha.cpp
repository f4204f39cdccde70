// Alpha-tested geometry: the core's any-hit stage (an AlphaTest step), its reads,
// its agreement with Embree's intersection filter, the three levels, and the
// texture caches built only where a scene calls for them.
#include "sim_test_support.h"

#include <rtsim/builder/build.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/model/core/exact_referee.h>
#include <rtsim/model/core/validate.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/procedural.h>
#include <rtsim/workloads/scene_cache.h>
#include <rtsim/workloads/validate.h>

#include <gtest/gtest.h>

using namespace rtsim;
using namespace rtsim::sim;
using namespace rtsim::sim::test;

namespace {

// Two unit quads facing +z, one behind the other: the front one alpha-tested with
// a 2x1 texture whose left texel is clear and right one opaque, the back one opaque.
Scene two_cards() {
  Scene s;
  s.name = "two_cards";
  Material front, back;
  front.name = "front";
  front.alpha_texture = 0;
  back.name = "back";
  s.materials = {front, back};
  AlphaTexture t;
  t.file = "test";
  t.width = 2, t.height = 1;
  t.alpha = {0, 255};
  s.alpha_textures.push_back(t);
  for (float z : {0.0f, -1.0f}) {
    const uint32_t base = uint32_t(s.vertices.size());
    s.vertices.insert(s.vertices.end(), {vec3(-1, -1, z), vec3(1, -1, z), vec3(1, 1, z), vec3(-1, 1, z)});
    s.triangles.push_back(uvec3(base, base + 1, base + 2));
    s.triangles.push_back(uvec3(base, base + 2, base + 3));
    const uint32_t m = z == 0.0f ? 0 : 1;
    s.material_ids.insert(s.material_ids.end(), {m, m});
  }
  // s runs with x (u = 0 at x = -1), t with y.
  s.triangle_uvs = {{glm::vec2(0, 0), glm::vec2(1, 0), glm::vec2(1, 1)},
                    {glm::vec2(0, 0), glm::vec2(1, 1), glm::vec2(0, 1)},
                    {}, {}};
  Camera c;
  c.name = "view1";
  c.position = vec3(0, 0, 3);
  c.target = vec3(0, 0, 0);
  s.cameras.push_back(c);
  validate_scene(s);
  return s;
}

struct Cards {
  Scene scene = two_cards();
  Bvh bvh;
  std::unique_ptr<MemoryImage> image;
  std::unique_ptr<TraversalContext> context;
  Cards() {
    BuildParams params;
    params.builder = "sah";
    bvh = build_bvh(scene, params);
    image = std::make_unique<MemoryImage>(scene, bvh);
    context = std::make_unique<TraversalContext>(scene, bvh, *image);
  }
};

Ray ray_at(float x, RayType type = RayType::Primary) {
  Ray r;
  r.origin = vec3(x, 0.1f, 2.0f);
  r.direction = vec3(0, 0, -1);
  r.type = type;
  return r;
}

}  // namespace

TEST(CoreAlpha, AClearTexelLetsTheRayThroughToTheSurfaceBehind) {
  Cards w;
  RayTraversal trv(*w.context);
  const HitRecord through = trace_ray(trv, ray_at(-0.5f));
  ASSERT_TRUE(through.hit());
  EXPECT_FLOAT_EQ(through.t, 3.0f);  // the back card
  EXPECT_EQ(w.scene.material_ids[through.prim], 1u);
  EXPECT_EQ(trv.counters().anyhit_tests, 1u);
  EXPECT_EQ(trv.counters().anyhit_rejects, 1u);
  EXPECT_EQ(trv.counters().uv_bytes, MemoryImage::kUvRecordBytes);
  EXPECT_EQ(trv.counters().texel_bytes, MemoryImage::kTexelBytes);

  const HitRecord stopped = trace_ray(trv, ray_at(0.5f));
  ASSERT_TRUE(stopped.hit());
  EXPECT_FLOAT_EQ(stopped.t, 2.0f);  // the front card's opaque texel
  EXPECT_EQ(w.scene.material_ids[stopped.prim], 0u);
  EXPECT_EQ(trv.counters().anyhit_tests, 1u);
  EXPECT_EQ(trv.counters().anyhit_rejects, 0u);
}

TEST(CoreAlpha, AnAnyHitRayEndsOnlyAtAnAcceptedHit) {
  Cards w;
  RayTraversal trv(*w.context);
  Ray ao = ray_at(-0.5f, RayType::Ao);
  ao.tmax = 2.5f;  // reaches the front card only
  EXPECT_FALSE(trace_ray(trv, ao).hit());
  EXPECT_EQ(trv.counters().anyhit_tests, 1u);
  ao.origin.x = 0.5f;
  EXPECT_TRUE(trace_ray(trv, ao).hit());
}

TEST(CoreAlpha, TheStepReadsTheUvRecordThenTheTexelItPicks) {
  Cards w;
  RayTraversal trv(*w.context);
  trv.reset(ray_at(0.5f));
  while (!trv.done() && trv.action() != TraversalAction::AlphaTest) trv.process();
  ASSERT_EQ(trv.action(), TraversalAction::AlphaTest);
  const std::vector<MemoryAccess>& reads = trv.step_reads();
  ASSERT_EQ(reads.size(), 2u);
  EXPECT_EQ(trv.step_independent_reads(), 1u);  // the texel's address needs the UVs
  EXPECT_EQ(reads[0].kind, AccessKind::Uv);
  EXPECT_EQ(reads[0].bytes, MemoryImage::kUvRecordBytes);
  EXPECT_EQ(reads[1].kind, AccessKind::Texel);
  EXPECT_EQ(reads[1].address, w.image->texel_address(0, 1, 0));  // the right (opaque) texel
  EXPECT_GE(reads[0].address, w.image->end_address() - w.image->footprint().uv_bytes -
                                  w.image->footprint().texture_bytes - 4096);
}

TEST(CoreAlpha, AnOpaqueSceneHasNoUvOrTextureRegionAndItsFootprintIsUnchanged) {
  Cards w;
  Scene opaque = w.scene;
  opaque.make_opaque();
  const MemoryImage image(opaque, w.bvh);
  EXPECT_FALSE(image.has_alpha_data());
  EXPECT_EQ(image.footprint().uv_bytes + image.footprint().texture_bytes, 0u);
  EXPECT_TRUE(w.image->has_alpha_data());
  EXPECT_EQ(w.image->footprint().total_bytes(),
            image.footprint().total_bytes() + w.image->footprint().uv_bytes + w.image->footprint().texture_bytes);
  EXPECT_EQ(image.end_address(), w.image->slot_address(0) - image.slot_address(0) + image.end_address());
}

TEST(CoreAlpha, FoliageAgreesWithEmbreesFilterAndTheAlphaTestMatters) {
  const Scene scene = make_procedural_scene("foliage_alpha");
  Scene opaque = scene;
  opaque.make_opaque();
  BuildParams params;
  params.builder = "sah";
  const Bvh bvh = build_bvh(scene, params);
  EffectSettings settings;
  settings.width = settings.height = 64;
  settings.ao_samples = 2;
  const auto trace = [&](const Scene& s) {
    const MemoryImage image(s, bvh);
    const TraversalContext context(s, bvh, image);
    FrameRun run = run_frame(context, s.camera("view1"), settings);
    const EmbreeScene embree(s);
    ValidationRule rule;
    rule.absolute_bound = 1e-6f * s.diagonal();
    const ValidationResult v = validate_against_embree(embree, run.rays, run.results, rule, 0, &s);
    return std::make_pair(run.total, v);
  };
  const auto [alpha, alpha_check] = trace(scene);
  const auto [solid, solid_check] = trace(opaque);
  EXPECT_EQ(alpha_check.core_wrong, 0u);
  EXPECT_EQ(solid_check.core_wrong, 0u);
  EXPECT_GT(alpha.anyhit_tests, 1000u);
  EXPECT_GT(alpha.anyhit_rejects, 0u);
  EXPECT_LT(alpha.anyhit_rejects, alpha.anyhit_tests);
  EXPECT_EQ(solid.anyhit_tests, 0u);
  EXPECT_EQ(alpha.texel_bytes, alpha.anyhit_tests * MemoryImage::kTexelBytes);
  // Leaves let light through: fewer AO rays are occluded than on opaque cards.
  EXPECT_NE(alpha.hits, solid.hits);
}

TEST(CoreAlpha, TheRefereeDropsClearTexelsAndKeepsOpaqueOnes) {
  const Scene s = two_cards();
  const ExactReferee referee(s, 1e-4f, 0.0f);
  const auto prims = [&](float x) {
    std::vector<uint32_t> out;
    for (const RefereeCandidate& c : referee.candidates(ray_at(x))) out.push_back(s.material_ids[c.prim]);
    return out;
  };
  EXPECT_EQ(prims(-0.5f), std::vector<uint32_t>{1u});  // only the back card
  const std::vector<uint32_t> both = prims(0.5f);
  EXPECT_EQ(both.size(), 2u);
}

namespace {
std::map<std::string, double> simulate_at(const Scene& scene, const Bvh& bvh, Fidelity level) {
  return small_run_stats(scene, bvh, level, 20);
}
}  // namespace

TEST(SimAlpha, EveryLevelRunsTheSameAlphaTestsAndOnlyAlphaScenesBuildTheStage) {
  const Scene scene = make_procedural_scene("foliage_alpha");
  BuildParams params;
  params.builder = "sah";
  const Bvh bvh = build_bvh(scene, params);
  const auto functional = simulate_at(scene, bvh, Fidelity::Functional);
  const auto lt = simulate_at(scene, bvh, Fidelity::Lt);
  const auto cycle = simulate_at(scene, bvh, Fidelity::Cycle);
  ASSERT_GT(functional.at("anyhit.tests"), 0);
  for (const char* key : {"anyhit.tests", "anyhit.rejects", "ops.trv", "ops.ist", "fetches.texel_bytes",
                          "fetches.uv_bytes", "per_type.ao.anyhit_tests", "rays.total"}) {
    ASSERT_TRUE(lt.count(key) && cycle.count(key)) << key;
    EXPECT_EQ(functional.at(key), lt.at(key)) << key;
    EXPECT_EQ(functional.at(key), cycle.at(key)) << key;
  }
  // The alpha tests take the IST pipeline at every level alike (rates of 1 per cycle:
  // no rounding between the levels' sums).
  for (const char* key : {"per_type.primary.ist_busy_cycles", "per_type.ao.ist_busy_cycles"}) {
    EXPECT_DOUBLE_EQ(functional.at(key), cycle.at(key)) << key;
    EXPECT_DOUBLE_EQ(lt.at(key), cycle.at(key)) << key;
  }
  for (const auto* stats : {&functional, &lt, &cycle}) {
    EXPECT_GT(stats->at("l1_texture.all.accesses"), 0);
    EXPECT_GT(stats->at("core0.ist0.anyhit_tests"), 0);
    EXPECT_GT(stats->at("energy.anyhit.pj"), 0);
    EXPECT_GT(stats->at("energy.l1_texture.pj"), 0);
  }
  // The same geometry opaque: no any-hit stage, no texture cache, no stats of theirs.
  Scene opaque = scene;
  opaque.make_opaque();
  const auto plain = simulate_at(opaque, bvh, Fidelity::Cycle);
  EXPECT_FALSE(plain.count("anyhit.tests"));
  EXPECT_FALSE(plain.count("l1_texture.all.accesses"));
  EXPECT_FALSE(plain.count("energy.anyhit.pj"));
  EXPECT_FALSE(plain.count("memory.texture_bytes"));
}

TEST(SimAlpha, TheEffectPlanSaysWhyTheStageIsBuiltOrNot) {
  const Scene scene = two_cards();
  EXPECT_TRUE(plan_effects(scene, {}).anyhit);
  EXPECT_NE(plan_effects(scene, {}).anyhit_reason.find("2 alpha-tested triangles"), std::string::npos);
  Scene opaque = scene;
  opaque.make_opaque();
  EXPECT_FALSE(plan_effects(opaque, {}).anyhit);
  EXPECT_NE(plan_effects(opaque, {}).anyhit_reason.find("2 alpha-tested triangles made opaque"), std::string::npos);
  EXPECT_NE(plan_effects(make_procedural_scene("cornell"), {}).anyhit_reason.find("no triangle"), std::string::npos);
}

TEST(SceneAlpha, BadAlphaDataIsRefusedNamingTheField) {
  Scene s = two_cards();
  s.materials[1].alpha_texture = 3;
  EXPECT_THROW(validate_scene(s), InputError);
  s = two_cards();
  s.triangle_uvs.pop_back();
  EXPECT_THROW(validate_scene(s), InputError);
  s = two_cards();
  s.alpha_textures[0].alpha.pop_back();
  try {
    validate_scene(s);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("alpha texture 'test'"), std::string::npos) << e.what();
  }
}

// A tree saved for the alpha-tested scene is not the opaque scene's, and the
// refusal says which flag is likely missing.
TEST(SceneAlpha, ATreeOfTheOtherVariantIsRefusedNamingOpaque) {
  Cards w;
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() /
      ("rtsim_alpha_tree_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + ".bvh");
  save_bvh(file, w.bvh, w.scene, BuildParams{});
  Scene opaque = w.scene;
  opaque.make_opaque();
  try {
    load_bvh(file, &opaque);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("without --opaque"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(load_bvh(file, &w.scene));
  std::filesystem::remove(file);
}

TEST(SceneAlpha, TheSceneCacheKeepsTexturesAndCoordinates) {
  const Scene s = two_cards();
  const std::string bytes = scene_image(s, "key");
  const std::optional<Scene> read = scene_from_image(bytes, "key");
  ASSERT_TRUE(read.has_value());
  const Scene& back = *read;
  EXPECT_EQ(back.content_hash(), s.content_hash());
  ASSERT_EQ(back.alpha_textures.size(), 1u);
  EXPECT_EQ(back.alpha_textures[0].alpha, s.alpha_textures[0].alpha);
  EXPECT_EQ(back.triangle_uvs.size(), s.triangle_uvs.size());
  EXPECT_EQ(back.materials[0].alpha_texture, 0);
  Scene changed = s;
  changed.alpha_textures[0].alpha[0] = 255;
  EXPECT_NE(changed.content_hash(), s.content_hash());
}
