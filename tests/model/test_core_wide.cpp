// Traversal over every node format: the same hits as the binary tree, one TRV op
// per node whatever its width, box tests per child, decoded (quantized) boxes.
#include "model/core_test_support.h"

#include <rtsim/builder/build.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/builder/node_format.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/core/traversal.h>
#include <rtsim/workloads/procedural.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/random.h>

#include <gtest/gtest.h>

#include <memory>

using namespace rtsim;

namespace {

struct FormatScene {
  Bvh bvh;
  std::unique_ptr<MemoryImage> image;
  std::unique_ptr<TraversalContext> context;
  FormatScene(const Scene& scene, const std::string& format, const std::string& builder = "sah",
              const TraversalConfig& traversal = {}) {
    BuildParams p;
    p.builder = builder;
    p.threads = 1;
    apply_node_format(p, node_format(format));
    bvh = build_bvh(scene, p);
    MemoryLayoutConfig layout;
    layout.node_format = format;
    image = std::make_unique<MemoryImage>(scene, bvh, layout);
    context = std::make_unique<TraversalContext>(scene, bvh, *image, traversal);
  }
};

// Rays from outside the scene's box at it, and some from inside, any-hit every 3rd.
std::vector<Ray> rays_into(const Scene& scene, size_t count) {
  Aabb box;
  for (uint32_t t = 0; t < scene.triangle_count(); ++t) box.extend(scene.triangle_bounds(t));
  std::vector<Ray> rays(count);
  for (size_t i = 0; i < count; ++i) {
    KeyedRng rng(5, {i});
    const vec3 a(rng.next_float(), rng.next_float(), rng.next_float());
    const vec3 b(rng.next_float(), rng.next_float(), rng.next_float());
    const vec3 from = box.lo + (i % 2 ? a : 1.5f * a - 0.25f) * box.extent();
    const vec3 to = box.lo + b * box.extent();
    rays[i].origin = from;
    rays[i].direction = to - from;
    if (i % 13 == 0) rays[i].direction[i % 3] = 0.0f;
    rays[i].type = i % 3 == 0 ? RayType::Ao : RayType::Primary;
    rays[i].pixel = uint32_t(i);
  }
  return rays;
}

Scene soup(uint32_t count, uint64_t seed, vec3 offset = vec3(0.0f)) {
  Scene s;
  s.name = "soup";
  test::add_material(s, "grey", vec3(0.5f));
  for (uint32_t i = 0; i < count; ++i) {
    KeyedRng rng(seed, {i});
    const vec3 c = offset + vec3(rng.next_float(), rng.next_float(), rng.next_float());
    const uint32_t base = uint32_t(s.vertices.size());
    for (int k = 0; k < 3; ++k)
      s.vertices.push_back(c + 0.04f * vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f,
                                            rng.next_float() - 0.5f));
    s.triangles.push_back(uvec3(base, base + 1, base + 2));
    s.material_ids.push_back(0);
  }
  return s;
}

TEST(CoreWide, EveryFormatFindsTheBinaryTreesHits) {
  // Near the origin, and far from it where half floats and 8-bit planes are coarse.
  for (const vec3 offset : {vec3(0.0f), vec3(3000.0f, -120.0f, 77.0f)}) {
    const Scene scene = soup(3000, 2, offset);
    const std::vector<Ray> rays = rays_into(scene, 6000);
    const FormatScene reference(scene, "bvh2-64");
    std::vector<TraceResult> expected;
    trace_rays(*reference.context, rays, expected);
    for (const NodeFormat& format : node_formats())
      for (const std::string builder : {"sah", "sbvh", "embree"}) {
        SCOPED_TRACE(format.name + " " + builder);
        const FormatScene fs(scene, format.name, builder);
        std::vector<TraceResult> got;
        trace_rays(*fs.context, rays, got);
        uint64_t hits = 0;
        for (size_t i = 0; i < rays.size(); ++i) {
          ASSERT_EQ(got[i].hit.hit(), expected[i].hit.hit()) << "ray " << i;
          if (rays[i].type == RayType::Primary) ASSERT_EQ(got[i].hit.t, expected[i].hit.t) << "ray " << i;
          hits += got[i].hit.hit();
          const RayCounters& c = got[i].counters;
          EXPECT_EQ(c.node_fetches, c.trv_ops);
          EXPECT_EQ(c.node_bytes, c.node_fetches * format.record_bytes);
          EXPECT_LE(c.box_tests, c.trv_ops * format.width);
        }
        EXPECT_GT(hits, rays.size() / 4);
      }
  }
}

TEST(CoreWide, WiderTreesTakeFewerTrvOpsAndMoreBoxTestsPerOp) {
  const Scene scene = soup(5000, 8);
  const std::vector<Ray> rays = rays_into(scene, 4000);
  auto totals = [&](const std::string& format) {
    const FormatScene fs(scene, format);
    std::vector<TraceResult> r;
    trace_rays(*fs.context, rays, r);
    CounterTotals t;
    for (const TraceResult& x : r) t.add(x.counters, x.hit.hit());
    return t;
  };
  const CounterTotals two = totals("bvh2-64"), four = totals("bvh4-128"), eight = totals("bvh8-80q");
  EXPECT_LT(four.trv_ops, two.trv_ops);
  EXPECT_LT(eight.trv_ops, four.trv_ops);
  EXPECT_EQ(two.box_tests, 2 * two.trv_ops);
  EXPECT_GT(double(four.box_tests) / double(four.trv_ops), 2.5);
  EXPECT_GT(double(eight.box_tests) / double(eight.trv_ops), double(four.box_tests) / double(four.trv_ops));
}

TEST(CoreWide, QuantizedBoxesAreTestedAsDecodedAndContainTheExactOnes) {
  for (const Scene& scene : {soup(2000, 4, vec3(1000.0f)), make_procedural_scene("interior")})
  for (const std::string format : {"bvh4-64h", "bvh6-64q", "bvh8-80q"}) {
    const FormatScene fs(scene, format);
    bool any_looser = false;
    for (uint32_t n = 0; n < fs.bvh.nodes.size(); ++n) {
      const BvhNode& node = fs.bvh.nodes[n];
      if (node.is_leaf() || !fs.image->has_record(n)) continue;
      const Aabb* decoded = fs.image->record_boxes(n);
      for (uint32_t k = 0; k < node.children; ++k) {
        const Aabb& exact = fs.bvh.nodes[node.index + k].bounds;
        ASSERT_TRUE(decoded[k].contains(exact))
            << format << " node " << n << " child " << k << "/" << node.children << " exact lo "
            << exact.lo.x << " " << exact.lo.y << " " << exact.lo.z << " hi " << exact.hi.x << " "
            << exact.hi.y << " " << exact.hi.z << " decoded lo " << decoded[k].lo.x << " "
            << decoded[k].lo.y << " " << decoded[k].lo.z << " hi " << decoded[k].hi.x << " "
            << decoded[k].hi.y << " " << decoded[k].hi.z;
        any_looser |= decoded[k].area() > exact.area();
      }
    }
    EXPECT_TRUE(any_looser) << format << ": the decoded boxes are the exact ones (no quantization?)";
  }
}

TEST(CoreWide, ShortStackSpillsKeepWideResultsExact) {
  const Scene scene = soup(3000, 6);
  const std::vector<Ray> rays = rays_into(scene, 3000);
  TraversalConfig shallow;
  shallow.stack_limit = 2;
  for (const std::string format : {"bvh4-128", "bvh8-80q"}) {
    const FormatScene deep(scene, format), spill(scene, format, "sah", shallow);
    std::vector<TraceResult> a, b;
    trace_rays(*deep.context, rays, a);
    trace_rays(*spill.context, rays, b);
    uint64_t overflows = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      ASSERT_EQ(a[i].hit.prim, b[i].hit.prim) << format << " ray " << i;
      EXPECT_EQ(a[i].counters.ops(), b[i].counters.ops());
      overflows += b[i].counters.stack_overflows;
    }
    EXPECT_GT(overflows, 0u) << format;
  }
}

TEST(CoreWide, ATreeWiderThanItsFormatIsRefusedByName) {
  const Scene scene = soup(500, 1);
  const FormatScene wide(scene, "bvh8-80q");
  MemoryLayoutConfig layout;
  layout.node_format = "bvh4-128";
  try {
    MemoryImage image(scene, wide.bvh, layout);
    FAIL() << "an 8-wide tree was laid out as 4-wide records";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("memory.node_format"), std::string::npos) << e.what();
  }
  layout.node_format = "bvh2-32";
  EXPECT_THROW(MemoryImage image(scene, wide.bvh, layout), InputError);
}

}  // namespace
