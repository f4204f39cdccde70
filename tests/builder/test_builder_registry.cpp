// The builder registry: every entry builds a valid tree, the parameter table drives
// checks and settings, and BVH-file metadata comes from it.
#include "builder/scene_fixtures.h"

#include <rtsim/builder/builder_registry.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/builder/validate_bvh.h>
#include <rtsim/workloads/error.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <iterator>
#include <set>

namespace rtsim {
namespace {

std::string error_of(BuildParams& p, const std::string& key, const std::string& value) {
  try {
    set_build_parameter(p, key, value);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(BuilderRegistry, EveryEntryBuildsAValidTreeUnderItsName) {
  const Scene scene = test::triangle_soup(300);
  std::set<std::string> names;
  for (const BuilderInfo& info : builder_registry()) {
    SCOPED_TRACE(info.name);
    EXPECT_TRUE(names.insert(info.name).second) << "duplicate name";
    EXPECT_FALSE(info.display_name.empty());
    ASSERT_NE(info.build, nullptr);
    BuildParams p;
    p.builder = info.name;
    BuildReport report;
    const Bvh bvh = build_bvh(scene, p, &report);
    EXPECT_EQ(report.builder, info.name);
    const BvhValidation v = validate_bvh(bvh, scene, limits_for(p));
    EXPECT_TRUE(v.ok()) << v.summary();
    if (!info.splits_references) EXPECT_EQ(bvh.prim_refs.size(), scene.triangle_count());
  }
  EXPECT_EQ(builder_names().size(), builder_registry().size());
}

TEST(BuilderRegistry, UnknownBuilderListsTheKnownOnes) {
  BuildParams p;
  p.builder = "sahh";
  try {
    build_bvh(test::triangle_soup(20), p);
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("unknown builder 'sahh'"), std::string::npos) << what;
    EXPECT_NE(what.find("aobvh"), std::string::npos) << what;
  }
}

TEST(BuilderRegistry, EveryParameterRoundTripsAsText) {
  for (const BuilderParameter& parameter : builder_parameters()) {
    SCOPED_TRACE(parameter.key);
    BuildParams p;
    const std::string text = build_parameter_text(p, parameter);
    BuildParams q;
    set_build_parameter(q, parameter.key, text);
    EXPECT_EQ(build_parameter_text(q, parameter), text);
    EXPECT_EQ(find_builder_parameter(parameter.key), &parameter);
  }
}

TEST(BuilderRegistry, SettingsChangeTheFieldAndBadOnesNameTheKey) {
  BuildParams p;
  apply_build_setting(p, "max_leaf_size=8");
  EXPECT_EQ(p.max_leaf_size, 8u);
  set_build_parameter(p, "t2", "0.25");
  EXPECT_FLOAT_EQ(p.t2, 0.25f);
  set_build_parameter(p, "ao_normalise", "off");
  EXPECT_FALSE(p.ao_normalise);
  BuildParams q;
  EXPECT_NE(error_of(q, "max_leaf", "8").find("build.max_leaf: unknown builder parameter"), std::string::npos);
  EXPECT_NE(error_of(q, "t1", "-1").find("build.t1: must be a positive finite number"), std::string::npos);
  EXPECT_NE(error_of(q, "t1", "1x").find("build.t1: expected a decimal number"), std::string::npos);
  EXPECT_NE(error_of(q, "max_leaf_size", "2.5").find("decimal digits only"), std::string::npos);
  // The strict reader (numbers.h), as on the command line: no octal, hex, sign or
  // empty value, and no wrap (max_leaf_size=010 gave 10 and --max-leaf-size 010 gave 8).
  for (const char* bad : {"010", "0x10", "+2", "-1", "", " 2", "18446744073709551616"})
    EXPECT_NE(error_of(q, "max_leaf_size", bad).find("build.max_leaf_size: "), std::string::npos) << bad;
  for (const char* bad : {"0x1p3", "+2", "nan", "inf", "1e999", ".5", ""})
    EXPECT_NE(error_of(q, "t2", bad).find("build.t2: "), std::string::npos) << bad;
  // A seed keeps every digit (strtod kept 53 bits of them).
  BuildParams seeded;
  set_build_parameter(seeded, "seed", "18446744073709551615");
  EXPECT_EQ(seeded.seed, UINT64_MAX);
  EXPECT_NE(error_of(q, "ao_weight_floor", "1.5").find("must be in [0, 1]"), std::string::npos);
  EXPECT_NE(error_of(q, "bins", "1").find("must be 0 (full sweep) or 2..256"), std::string::npos);
  EXPECT_NE(error_of(q, "ao_normalise", "maybe").find("on/off"), std::string::npos);
  // A rejected value leaves the other fields as they were.
  EXPECT_EQ(q.max_leaf_size, BuildParams{}.max_leaf_size);
  try {
    apply_build_setting(q, "max_leaf_size");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not KEY=VALUE"), std::string::npos) << e.what();
  }
}

TEST(BuilderRegistry, FileMetadataHoldsExactlyTheParametersTheBuilderReads) {
  BuildParams p;
  p.builder = "sah";
  const nlohmann::json sah = nlohmann::json::parse(build_params_json(p));
  EXPECT_EQ(sah.size(), 6u);  // builder, t1, t2, max_leaf_size, max_depth, bins (no width)
  EXPECT_FALSE(sah.contains("seed"));  // sah draws no random numbers
  EXPECT_FALSE(sah.contains("ao_rays"));
  EXPECT_FALSE(sah.contains("threads"));  // never changes the tree
  p.builder = "aobvh";
  const nlohmann::json ao = nlohmann::json::parse(build_params_json(p));
  EXPECT_EQ(ao.at("ao_rays"), p.ao_rays);
  EXPECT_EQ(ao.at("seed"), p.seed);  // its AO rays are seeded
  EXPECT_EQ(ao.at("occlusion_values_supplied"), false);
  EXPECT_FALSE(ao.contains("sbvh_alpha"));
  p.builder = "osah";
  EXPECT_EQ(nlohmann::json::parse(build_params_json(p)).at("camera"), "view1");
  p.width = 4;
  EXPECT_EQ(nlohmann::json::parse(build_params_json(p)).at("width"), 4);
}

TEST(BuilderRegistry, ASettingChangesTheTree) {
  const Scene scene = test::triangle_soup(400);
  BuildParams a;
  BuildParams b;
  apply_build_setting(b, "max_leaf_size=1");
  EXPECT_NE(bvh_content_hash(build_bvh(scene, a)), bvh_content_hash(build_bvh(scene, b)));
}

}  // namespace
}  // namespace rtsim

namespace rtsim {
namespace {

TEST(BuilderRegistry, DocsListEveryBuilderAndParameter) {
  std::ifstream in(std::string(RTSIM_SOURCE_DIR) + "/docs/builders.md");
  ASSERT_TRUE(in) << "docs/builders.md";
  const std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const BuilderInfo& b : builder_registry())
    EXPECT_NE(doc.find("| `" + b.name + "` | " + b.display_name), std::string::npos) << b.name;
  for (const BuilderParameter& p : builder_parameters()) {
    EXPECT_NE(doc.find("| `" + p.key + "` |"), std::string::npos) << p.key;
    if (!p.flag.empty()) EXPECT_NE(doc.find("`" + p.flag + "`"), std::string::npos) << p.flag;
  }
}

}  // namespace
}  // namespace rtsim
