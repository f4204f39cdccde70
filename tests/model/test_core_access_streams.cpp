// The traversal core's access streams, held against a stored digest: for every
// builder and every node format, the same rays (primary, AO and one diffuse bounce
// on `foliage`) make the same accesses in the same order, step by step, with the
// same hits. The digests were stored before issue 39 part 3 changed the core
// (tests/model/golden/access-streams.tsv, the core of commit d6d3e7a), so a faster core
// must keep every address, size, kind, direction and step boundary it had.
//
// RTSIM_WRITE_GOLDEN=1 writes the file instead of comparing (for a deliberate change
// of the streams, which the commit must then explain).
#include <rtsim/builder/build.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/workloads/scene_registry.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace {

using namespace rtsim;

// FNV-1a over everything the core hands a memory model, and each ray's hit.
class StreamDigest : public AccessSink {
 public:
  void on_access(const MemoryAccess& a, RayType type) override {
    mix(a.address), mix(a.bytes), mix(uint64_t(a.kind)), mix(a.write), mix(uint64_t(type));
    ++accesses;
  }
  void on_step_end() override { mix(0x5e9u); }
  void end_ray(const HitRecord& hit) {
    uint32_t t = 0;
    std::memcpy(&t, &hit.t, 4);
    mix(hit.prim), mix(t);
  }
  void mix(uint64_t v) {
    for (int i = 0; i < 8; ++i) hash = (hash ^ ((v >> (8 * i)) & 0xff)) * 0x100000001b3ull;
  }
  uint64_t hash = 0xcbf29ce484222325ull;
  uint64_t accesses = 0;
};

std::string hex(uint64_t v) {
  std::ostringstream s;
  s << std::hex << v;
  return s.str();
}

std::string golden_path(const std::string& file) {
  return std::string(RTSIM_SOURCE_DIR) + "/tests/model/golden/" + file;
}

// The trees of `builders` x `formats` on `scene_name` against golden/<file>.
void check_streams(const std::string& scene_name, const std::string& file,
                   const std::vector<std::string>& builders, const std::vector<NodeFormat>& formats) {
  const std::string kGolden = golden_path(file);
  const Scene scene = load_scene(scene_name);
  const bool write = std::getenv("RTSIM_WRITE_GOLDEN") != nullptr;
  std::map<std::string, std::string> stored;
  std::string stored_scene;
  if (!write) {
    std::ifstream in(kGolden);
    ASSERT_TRUE(in) << kGolden;
    std::string line;
    ASSERT_TRUE(std::getline(in, line));
    ASSERT_EQ(line.rfind("# scene_hash\t", 0), 0u) << line;
    stored_scene = line.substr(line.find('\t') + 1);
    // A procedural scene's vertices follow the compiler's floating point (clang
    // builds other last bits than gcc): another scene is not this test's to judge.
    if (stored_scene != hex(scene.content_hash()))
      GTEST_SKIP() << "this build generates " << scene_name << " with hash " << hex(scene.content_hash())
                   << ", the digests are of " << stored_scene;
    while (std::getline(in, line)) {
      const size_t tab = line.find('\t', line.find('\t') + 1);
      ASSERT_NE(tab, std::string::npos) << line;
      stored[line.substr(0, tab)] = line.substr(tab + 1);
    }
  }
  // One ray set for every tree: made once on the SAH tree (hits, and so the AO and
  // diffuse rays, would otherwise differ where trees break ties differently).
  std::vector<Ray> rays;
  {
    BuildParams params;
    const Bvh bvh = build_bvh(scene, params);
    const MemoryImage image(scene, bvh, MemoryLayoutConfig{});
    const TraversalContext context(scene, bvh, image);
    EffectSettings settings;
    settings.width = settings.height = 32;
    settings.ao_samples = 2;
    settings.diffuse_bounces = 1;
    rays = run_frame(context, scene.cameras.front(), settings).rays;
  }
  ASSERT_GT(rays.size(), 2000u);
  std::ostringstream out;
  out << "# scene_hash\t" << hex(scene.content_hash()) << "\n";
  size_t compared = 0;
  for (const std::string& builder : builders)
    for (const NodeFormat& format : formats) {
      BuildParams params;
      params.builder = builder;
      apply_node_format(params, format);
      const Bvh bvh = build_bvh(scene, params);
      MemoryLayoutConfig layout;
      layout.node_format = format.name;
      const MemoryImage image(scene, bvh, layout);
      const TraversalContext context(scene, bvh, image);
      RayTraversal traversal(context);
      StreamDigest digest;
      for (const Ray& r : rays) digest.end_ray(trace_ray(traversal, r, &digest));
      const std::string key = builder + "\t" + format.name;
      const std::string value = std::to_string(rays.size()) + "\t" + std::to_string(digest.accesses) + "\t" +
                                hex(digest.hash);
      out << key << "\t" << value << "\n";
      if (write) continue;
      ASSERT_EQ(stored.count(key), 1u) << "no stored stream for " << builder << " " << format.name;
      EXPECT_EQ(value, stored[key]) << builder << " " << format.name << " (rays, accesses, digest)";
      ++compared;
    }
  if (write) {
    const std::string tmp = kGolden + ".tmp";
    std::ofstream(tmp) << out.str();
    std::filesystem::rename(tmp, kGolden);
    GTEST_SKIP() << "wrote " << kGolden;
  }
  EXPECT_EQ(compared, stored.size()) << "every stored stream is checked";
}

TEST(CoreAccessStreams, EveryBuilderAndFormatKeepsItsStoredStream) {
  check_streams("foliage", "access-streams.tsv", builder_names(), node_formats());
}

// The any-hit stage's stream too (its UV and texel reads, step by step): alpha-tested
// foliage on a binary and a wide quantized tree of two builders, stored when the
// stage was added (issue 40 part 4).
TEST(CoreAccessStreams, AlphaTestedFoliageKeepsItsStoredStream) {
  check_streams("foliage_alpha", "access-streams-alpha.tsv", {"sah", "aobvh"},
                {node_format("bvh2-64"), node_format("bvh6-64q")});
}

}  // namespace
