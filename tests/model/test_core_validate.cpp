// The functional core agrees with Embree on the public procedural scenes, with
// the production SAH builder, for primary and AO rays.
#include <rtsim/builder/build.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/model/core/validate.h>
#include <rtsim/workloads/scene_registry.h>

#include <gtest/gtest.h>

using namespace rtsim;

namespace {
void expect_agreement(const std::string& scene_name, uint32_t width, uint32_t height) {
  const Scene scene = load_scene(scene_name);
  BuildParams params;
  params.builder = "sah";
  const Bvh bvh = build_bvh(scene, params);
  const MemoryImage image(scene, bvh);
  const TraversalContext context(scene, bvh, image);
  EmbreeScene embree(scene);
  EffectSettings settings;
  settings.width = width;
  settings.height = height;
  settings.ao_samples = 4;
  for (const Camera& camera : scene.cameras) {
    const FrameRun run = run_frame(context, camera, settings);
    EXPECT_GT(run.per_type[ray_type_index(RayType::Ao)].rays, 0u);
    ValidationRule rule;
    rule.absolute_bound = 1e-6f * scene.diagonal();
    const ValidationResult v = validate_against_embree(embree, run.rays, run.results, rule);
    EXPECT_EQ(v.rays, run.rays.size());
    EXPECT_EQ(v.disagreements, 0u) << scene_name << " camera " << camera.name << ": "
                                   << (v.examples.empty() ? "" : v.examples.front());
  }
}
}  // namespace

TEST(CoreValidate, CornellAgreesWithEmbree) { expect_agreement("cornell", 96, 96); }
TEST(CoreValidate, InteriorAgreesWithEmbree) { expect_agreement("interior", 96, 64); }
