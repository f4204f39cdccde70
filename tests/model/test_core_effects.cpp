// Scene-driven effects and determinism of the functional level.
#include "model/core_test_support.h"

#include <rtsim/builder/memory_image.h>
#include <rtsim/workloads/random.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/workloads/procedural.h>

#include <gtest/gtest.h>

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
