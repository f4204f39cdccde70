// Scene-driven effects and determinism of the functional level.
#include "model/core_test_support.h"

#include <rtsim/builder/memory_image.h>
#include <rtsim/workloads/random.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/workloads/procedural.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

using namespace rtsim;

namespace {
// A floor, a box on it, a wall; materials: 0 diffuse, 1 mirror (the wall) when asked.
struct Room {
  Scene scene;
  Bvh bvh;
  std::unique_ptr<MemoryImage> image;
  std::unique_ptr<TraversalContext> context;
  Camera camera;
  Room(bool mirror, bool light) {
    test::add_material(scene, "diffuse", vec3(0.7f));
    test::add_material(scene, "mirror", vec3(0.9f), mirror ? 0.8f : 0.0f);
    MeshBuilder mb{scene};
    mb.material = 0;
    mb.quad({-5, 0, -5}, {-5, 0, 5}, {5, 0, 5}, {5, 0, -5});
    mb.box({-1, 0, -1}, {1, 2, 1});
    mb.material = 1;
    mb.quad({-5, 0, -4}, {5, 0, -4}, {5, 5, -4}, {-5, 5, -4});
    if (light) {
      Light l;
      l.position = vec3(0, 4, 3);
      scene.lights.push_back(l);
    }
    scene.ao.enabled = true;
    scene.ao.samples = 4;
    camera.name = "view1";
    camera.position = vec3(0, 3, 8);
    camera.target = vec3(0, 1, -3);
    scene.cameras.push_back(camera);
    bvh = test::median_bvh(scene);
    image = std::make_unique<MemoryImage>(scene, bvh);
    context = std::make_unique<TraversalContext>(scene, bvh, *image);
  }
  FrameRun run(const EffectSettings& s, AccessSink* sink = nullptr, uint32_t threads = 0) const {
    return run_frame(*context, camera, s, sink, threads);
  }
};
EffectSettings small() {
  EffectSettings s;
  s.width = 48;
  s.height = 32;
  return s;
}
uint64_t rays_of(const FrameRun& run, RayType t) { return run.per_type[ray_type_index(t)].rays; }

// A hash of the whole access stream, in order, step ends included.
struct StreamHash : AccessSink {
  uint64_t hash = 1, accesses = 0;
  void on_access(const MemoryAccess& a, RayType t) override {
    const uint64_t words[] = {a.address, a.bytes, uint64_t(a.kind), uint64_t(a.write), uint64_t(t)};
    hash = hash_bytes(hash, words, sizeof words);
    ++accesses;
  }
  void on_step_end() override { hash = mix64(hash ^ 0x5e9); }
};
}  // namespace

TEST(CoreEffects, DiffuseSceneWithAoYieldsExactlyPrimaryPlusAoRays) {
  Room room(false, false);
  const FrameRun run = room.run(small());
  const uint64_t primary_hits = run.per_type[ray_type_index(RayType::Primary)].hits;
  EXPECT_EQ(rays_of(run, RayType::Primary), 48u * 32u);
  EXPECT_GT(primary_hits, 0u);
  EXPECT_EQ(rays_of(run, RayType::Ao), 4 * primary_hits);
  EXPECT_EQ(run.total.rays, rays_of(run, RayType::Primary) + rays_of(run, RayType::Ao));
  EXPECT_FALSE(run.plan.on(RayType::Shadow));
  EXPECT_NE(run.plan.reason[ray_type_index(RayType::Shadow)].find("no lights"), std::string::npos);
  EXPECT_NE(run.plan.reason[ray_type_index(RayType::Reflection)].find("reflectance"), std::string::npos);
  for (size_t i = 0; i < run.rays.size(); ++i) {
    const Ray& r = run.rays[i];
    if (r.type != RayType::Ao) continue;
    ASSERT_LT(r.parent, i);
    EXPECT_EQ(run.rays[r.parent].type, RayType::Primary);
    EXPECT_FLOAT_EQ(r.tmax, room.scene.ao_cutoff());
    // Hemisphere facing the incoming primary ray.
    EXPECT_LT(glm::dot(r.direction, run.rays[r.parent].direction), 0.0f + 1e-6f + 1.0f);
  }
}

TEST(CoreEffects, AoOffRemovesAoRaysAndAoCountOverridesTheScene) {
  Room room(false, false);
  EffectSettings s = small();
  s.ao_samples = 0;
  FrameRun run = room.run(s);
  EXPECT_EQ(rays_of(run, RayType::Ao), 0u);
  EXPECT_EQ(run.total.rays, 48u * 32u);
  room.scene.ao.enabled = false;
  s.ao_samples = -1;
  run = room.run(s);
  EXPECT_EQ(rays_of(run, RayType::Ao), 0u);
  EXPECT_NE(run.plan.reason[ray_type_index(RayType::Ao)].find("ao.enabled"), std::string::npos);
  s.ao_samples = 2;
  run = room.run(s);
  EXPECT_EQ(rays_of(run, RayType::Ao), 2 * run.per_type[0].hits);
}

TEST(CoreEffects, NoLightMeansNoShadowRaysAndALightAddsThem) {
  Room dark(false, false), lit(false, true);
  EXPECT_EQ(rays_of(dark.run(small()), RayType::Shadow), 0u);
  const FrameRun run = lit.run(small());
  EXPECT_GT(rays_of(run, RayType::Shadow), 0u);
  EXPECT_LE(rays_of(run, RayType::Shadow), run.per_type[0].hits);  // one light: at most one per hit
}

TEST(CoreEffects, OneMirrorSpawnsReflectionRaysOnlyFromItsHits) {
  Room room(true, false);
  const FrameRun run = room.run(small());
  EXPECT_GT(rays_of(run, RayType::Reflection), 0u);
  EXPECT_EQ(rays_of(run, RayType::Refraction), 0u);
  for (size_t i = 0; i < run.rays.size(); ++i) {
    if (run.rays[i].type != RayType::Reflection) continue;
    const uint32_t parent = run.rays[i].parent;
    ASSERT_TRUE(run.results[parent].hit.hit());
    EXPECT_EQ(room.scene.material_ids[run.results[parent].hit.prim], 1u);
    EXPECT_LE(run.rays[i].bounce, 2);
  }
  // Every primary hit on the mirror spawned exactly one reflection ray.
  uint64_t mirror_hits = 0;
  for (size_t i = 0; i < run.rays.size(); ++i)
    if (run.rays[i].type == RayType::Primary && run.results[i].hit.hit() &&
        room.scene.material_ids[run.results[i].hit.prim] == 1)
      ++mirror_hits;
  uint64_t from_primary = 0;
  for (const Ray& r : run.rays)
    if (r.type == RayType::Reflection && r.bounce == 1) ++from_primary;
  EXPECT_EQ(from_primary, mirror_hits);
}

TEST(CoreEffects, SecondaryRaysDoNotHitTheirOwnSurface) {
  Room room(true, true);
  const FrameRun run = room.run(small());
  for (size_t i = 0; i < run.rays.size(); ++i) {
    const Ray& r = run.rays[i];
    if (r.parent == kNoParent || !run.results[i].hit.hit()) continue;
    EXPECT_NE(run.results[i].hit.prim, run.results[r.parent].hit.prim) << i;
  }
}

TEST(CoreDeterminism, IdenticalResultsAndCacheStatsForEveryThreadCount) {
  const Scene scene = make_procedural_scene("cornell");
  const Bvh bvh = test::median_bvh(scene);
  const MemoryImage image(scene, bvh);
  const TraversalContext context(scene, bvh, image);
  EffectSettings s = small();
  s.spp = 2;
  const Camera& camera = scene.cameras.front();
  StreamHash caches_1, caches_2, caches_all;
  const FrameRun a = run_frame(context, camera, s, &caches_1, 1);
  const FrameRun b = run_frame(context, camera, s, &caches_2, 2);
  const FrameRun c = run_frame(context, camera, s, &caches_all, 0);
  ASSERT_EQ(a.rays.size(), b.rays.size());
  ASSERT_EQ(a.rays.size(), c.rays.size());
  for (size_t i = 0; i < a.rays.size(); ++i) {
    ASSERT_EQ(a.rays[i].direction, b.rays[i].direction);
    ASSERT_EQ(a.rays[i].direction, c.rays[i].direction);
    ASSERT_EQ(a.results[i].hit.prim, b.results[i].hit.prim);
    ASSERT_EQ(a.results[i].hit.t, c.results[i].hit.t);
    ASSERT_EQ(a.results[i].counters.ops(), b.results[i].counters.ops());
  }
  EXPECT_EQ(a.total.ops(), c.total.ops());
  // The access stream the cache model sees is the same, access for access.
  EXPECT_EQ(caches_1.hash, caches_2.hash);
  EXPECT_EQ(caches_1.hash, caches_all.hash);
  EXPECT_GT(caches_1.accesses, a.total.node_fetches);
}

// Diffuse bounces (--diffuse-bounces): a path of closest-hit rays, one per primary hit.
namespace {
FrameRun cornell_run(const EffectSettings& s, uint32_t threads = 0) {
  static const Scene scene = make_procedural_scene("cornell");
  static const Bvh bvh = test::median_bvh(scene);
  static const MemoryImage image(scene, bvh);
  static const TraversalContext context(scene, bvh, image);
  return run_frame(context, scene.cameras.front(), s, nullptr, threads);
}
uint64_t hits_of(const FrameRun& run, RayType t) { return run.per_type[ray_type_index(t)].hits; }
}  // namespace

TEST(CoreDiffuse, OffByDefaultWithTheReasonInThePlan) {
  Room room(false, false);
  const FrameRun run = room.run(small());
  for (uint32_t depth = 1; depth <= kMaxDiffuseBounces; ++depth) {
    EXPECT_FALSE(run.plan.on(diffuse_ray_type(depth)));
    EXPECT_EQ(rays_of(run, diffuse_ray_type(depth)), 0u);
  }
  EXPECT_NE(run.plan.reason[ray_type_index(RayType::Diffuse1)].find("--diffuse-bounces 0"), std::string::npos);
  EXPECT_FALSE(small().russian_roulette);
}

TEST(CoreDiffuse, EachDepthIsSpawnedOncePerHitOfThePreviousDepth) {
  EffectSettings s = small();
  s.diffuse_bounces = 2;
  const FrameRun run = cornell_run(s);
  const uint64_t d1 = rays_of(run, RayType::Diffuse1), d2 = rays_of(run, RayType::Diffuse2);
  EXPECT_GT(d1, 0u);
  EXPECT_EQ(d1, hits_of(run, RayType::Primary));
  EXPECT_EQ(d2, hits_of(run, RayType::Diffuse1));
  EXPECT_EQ(rays_of(run, RayType::Diffuse3), 0u);  // deeper than asked
  EXPECT_TRUE(run.plan.on(RayType::Diffuse2));
  EXPECT_FALSE(run.plan.on(RayType::Diffuse3));
  EXPECT_NE(run.plan.reason[ray_type_index(RayType::Diffuse3)].find("deeper than --diffuse-bounces 2"),
            std::string::npos);
  // Every diffuse ray is a closest-hit ray whose parent is the previous depth.
  for (size_t i = 0; i < run.rays.size(); ++i) {
    const uint32_t depth = diffuse_depth(run.rays[i].type);
    if (depth == 0) continue;
    ASSERT_NE(run.rays[i].parent, kNoParent);
    const RayType parent = run.rays[run.rays[i].parent].type;
    EXPECT_EQ(parent, depth == 1 ? RayType::Primary : diffuse_ray_type(depth - 1)) << i;
    EXPECT_EQ(traversal_mode_for(run.rays[i].type), TraversalMode::ClosestHit);
  }
}

TEST(CoreDiffuse, DirectionsAreCosineWeightedAboutTheParentsNormal) {
  EffectSettings s = small();
  s.diffuse_bounces = 1;
  const FrameRun run = cornell_run(s);
  static const Scene scene = make_procedural_scene("cornell");
  double sum = 0.0, sum_sq = 0.0;
  uint64_t n = 0;
  for (size_t i = 0; i < run.rays.size(); ++i) {
    const Ray& r = run.rays[i];
    if (r.type != RayType::Diffuse1) continue;
    const Ray& parent = run.rays[r.parent];
    const SurfaceHit surface = surface_at(scene, parent, run.results[r.parent].hit);
    const double c = glm::dot(glm::normalize(r.direction), surface.normal);
    ASSERT_GT(c, 0.0) << "diffuse ray " << i << " leaves below its surface";
    sum += c;
    sum_sq += c * c;
    ++n;
  }
  ASSERT_GT(n, 1000u);
  // For a cosine-weighted hemisphere E[cos] = 2/3 and Var[cos] = 1/2 - 4/9 = 1/18.
  const double mean = sum / double(n), se = std::sqrt((sum_sq / double(n) - mean * mean) / double(n));
  EXPECT_NEAR(mean, 2.0 / 3.0, 5.0 * se);
  EXPECT_NEAR(sum_sq / double(n) - mean * mean, 1.0 / 18.0, 0.01);
}

TEST(CoreDiffuse, RussianRouletteKeepsAboutTheAlbedoFractionOfDeeperBounces) {
  EffectSettings s = small();
  s.diffuse_bounces = 3;
  const FrameRun all = cornell_run(s);
  s.russian_roulette = true;
  const FrameRun rr = cornell_run(s);
  // The first bounce never plays roulette; the same keyed numbers give the same rays.
  EXPECT_EQ(rays_of(rr, RayType::Diffuse1), rays_of(all, RayType::Diffuse1));
  const uint64_t offered = hits_of(rr, RayType::Diffuse1), kept = rays_of(rr, RayType::Diffuse2);
  ASSERT_GT(offered, 500u);
  EXPECT_LT(kept, offered);
  EXPECT_GT(kept, 0u);
  // Each offered bounce survives with its surface's largest albedo channel (clamped
  // to 0.05..0.95): the kept count is a sum of those Bernoulli trials.
  static const Scene scene = make_procedural_scene("cornell");
  double expected = 0.0, variance = 0.0;
  for (size_t i = 0; i < rr.rays.size(); ++i) {
    if (rr.rays[i].type != RayType::Diffuse1 || !rr.results[i].hit.hit()) continue;
    const vec3 albedo = scene.materials[scene.material_ids[rr.results[i].hit.prim]].albedo;
    const double keep = std::clamp(std::max({albedo.x, albedo.y, albedo.z}), 0.05f, 0.95f);
    expected += keep;
    variance += keep * (1.0 - keep);
  }
  EXPECT_NEAR(double(kept), expected, 5.0 * std::sqrt(variance));
  EXPECT_LT(rays_of(rr, RayType::Diffuse3), rays_of(all, RayType::Diffuse3));
}

TEST(CoreDiffuse, SameRaysWhateverTheThreadCount) {
  EffectSettings s = small();
  s.diffuse_bounces = 3;
  s.russian_roulette = true;
  const FrameRun a = cornell_run(s, 1), b = cornell_run(s, 2);
  ASSERT_EQ(a.rays.size(), b.rays.size());
  for (size_t i = 0; i < a.rays.size(); ++i) {
    ASSERT_EQ(a.rays[i].type, b.rays[i].type) << i;
    ASSERT_EQ(a.rays[i].direction, b.rays[i].direction) << i;
    ASSERT_EQ(a.results[i].hit.prim, b.results[i].hit.prim) << i;
  }
  EXPECT_EQ(a.total.ops(), b.total.ops());
}
