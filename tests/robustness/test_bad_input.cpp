// Garbage scenes: random bit-pattern floats (NaN, infinities, denormals, 1e38)
// and garbage indices through the load policy, every builder and the traversal.
// Run under ASan + UBSan too (scripts/test-sanitizers.sh), where "no crash"
// also means no invalid memory access and no undefined behaviour.
#include "robustness/robustness_support.h"

#include <rtsim/builder/validate_bvh.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/random.h>
#include <rtsim/workloads/validate.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

namespace rtsim {
namespace {

using namespace robust;

float bit_pattern_float(KeyedRng& rng) {
  const uint32_t bits = uint32_t(rng.next_u64());
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

// Scene `id`: a mix of wild bit patterns and ordinary coordinates (so that some
// triangles survive the policy), indices mostly in range, sometimes anything.
Scene garbage_scene(uint32_t id) {
  KeyedRng rng(1234, {id});
  Scene s = bare_scene("garbage-" + std::to_string(id));
  const uint32_t vertex_count = uint32_t(rng.next_u64() % 48);
  const uint32_t triangle_count = 1 + uint32_t(rng.next_u64() % 48);
  const uint32_t wildness = uint32_t(rng.next_u64() % 4);  // 0: all bit patterns .. 3: mostly tame
  for (uint32_t v = 0; v < vertex_count; ++v) {
    vec3 p;
    for (int a = 0; a < 3; ++a)
      p[a] = (rng.next_u64() % 4 < wildness) ? rng.next_float() * 2.0f - 1.0f : bit_pattern_float(rng);
    s.vertices.push_back(p);
  }
  for (uint32_t t = 0; t < triangle_count; ++t) {
    uvec3 tri;
    for (int k = 0; k < 3; ++k) {
      const uint64_t r = rng.next_u64();
      tri[k] = (r % 8 == 0 || vertex_count == 0) ? uint32_t(r >> 32) : uint32_t((r >> 8) % vertex_count);
    }
    s.triangles.push_back(tri);
    s.material_ids.push_back(0);
  }
  if (rng.next_u64() % 10 == 0) {  // a garbage camera: the policy must refuse it by name
    s.cameras.front().position = vec3(bit_pattern_float(rng), bit_pattern_float(rng), bit_pattern_float(rng));
  }
  return s;
}

// Property: for 1000 garbage scenes, validate_scene either refuses the scene with
// an InputError or leaves only triangles with in-range indices and finite
// vertices; every builder then either refuses with an InputError or returns a
// tree that passes validate_bvh; tracing primary and random rays through each
// tree finishes, and every reported hit has a finite t in [tmin, tmax] and a
// valid primitive id. Nothing crashes (and, under the sanitizers, nothing is UB).
TEST(RobustBadInput, ThousandGarbageScenesThroughValidateEveryBuilderAndTraversal) {
  uint64_t refused_scenes = 0, built = 0, refused_builds = 0, rays_traced = 0, hits = 0;
  for (uint32_t id = 0; id < 1000; ++id) {
    Scene scene = garbage_scene(id);
    try {
      validate_scene(scene);
    } catch (const InputError& e) {
      ++refused_scenes;
      EXPECT_NE(std::string(e.what()).find("garbage-"), std::string::npos) << e.what();
      continue;
    }
    for (const uvec3& t : scene.triangles)
      for (int k = 0; k < 3; ++k) {
        ASSERT_LT(t[k], scene.vertices.size()) << scene.name;
        ASSERT_TRUE(is_finite(scene.vertices[t[k]])) << scene.name;
      }
    std::vector<Ray> rays;
    KeyedRng rng(99, {id});
    for (uint32_t r = 0; r < 24; ++r) {
      const vec3 target = scene.vertex(uint32_t(rng.next_u64() % scene.triangle_count()), int(r % 3));
      const vec3 o(rng.next_float() * 4 - 2, rng.next_float() * 4 - 2, rng.next_float() * 4 - 2);
      rays.push_back(make_ray(o, target - o));  // may be zero, huge or overflow to inf: all allowed
    }
    for (const std::string& builder : builder_names()) {
      BuildParams p;
      p.builder = builder;
      p.ao_rays = 4;
      p.osah_width = p.osah_height = 16;
      Bvh bvh;
      try {
        bvh = build_bvh(scene, p);
      } catch (const InputError&) {
        ++refused_builds;
        continue;
      }
      ++built;
      const BvhValidation v = validate_bvh(bvh, scene, limits_for(p));
      EXPECT_TRUE(v.ok()) << builder << " on " << scene.name << ":\n" << v.summary();
      if (!v.ok()) continue;
      const MemoryImage image(scene, bvh);
      const TraversalContext context(scene, bvh, image);
      std::vector<TraceResult> results;
      trace_rays(context, rays, results, nullptr, 1);
      for (size_t r = 0; r < rays.size(); ++r) {
        ++rays_traced;
        const HitRecord& h = results[r].hit;
        if (!h.hit()) continue;
        ++hits;
        EXPECT_LT(h.prim, scene.triangle_count());
        EXPECT_TRUE(std::isfinite(h.t) && h.t >= rays[r].tmin && h.t <= rays[r].tmax)
            << builder << " on " << scene.name << " ray " << r << " t " << h.t;
      }
    }
  }
  // The mix must exercise both outcomes of the policy and reach the builders.
  EXPECT_GT(refused_scenes, 50u);
  EXPECT_GT(built, 1000u);
  EXPECT_GT(hits, 100u);
  RecordProperty("refused_scenes", int(refused_scenes));
  RecordProperty("trees_built", int(built));
  RecordProperty("builds_refused", int(refused_builds));
  RecordProperty("rays_traced", int(rays_traced));
}

}  // namespace
}  // namespace rtsim
