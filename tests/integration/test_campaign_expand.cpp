// Campaign files: sweep expansion, ranges, groups, job identity and strict errors.
#include "integration/test_campaign_fake.h"

#include <rtsim/reports/campaign.h>
#include <rtsim/reports/campaign_runner.h>
#include <rtsim/reports/simulation_job.h>
#include <rtsim/workloads/error.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>

namespace rtsim {
namespace {

using test::fresh_folder;
using test::write_text;

Campaign parse(const std::string& text, const std::string& revision = "rev1") {
  const auto dir = fresh_folder("expand");
  return load_campaign(write_text(dir / "c.toml", text), revision);
}

std::string error_of(const std::string& text) {
  try {
    parse(text);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(CampaignExpand, CrossProductOfAxesAndOverrides) {
  const Campaign c = parse(R"(
[campaign]
name = "x"
[sweep]
scene = "interior"
builder = ["sah", "sbvh", "aobvh"]
preset = ["mobile", "desktop"]
seed = [1, 2]
[sweep.set]
"l2.size_bytes" = {from = 131072, to = 524288, factor = 2}
)");
  EXPECT_EQ(c.name, "x");
  ASSERT_EQ(c.jobs.size(), 3u * 2u * 2u * 3u);
  std::set<std::string> keys, labels;
  for (const CampaignJob& j : c.jobs) {
    keys.insert(j.key);
    labels.insert(j.label);
    EXPECT_EQ(j.fidelity, "functional");  // the default
    EXPECT_EQ(j.camera, "");  // the scene's first camera
    // One override, the L2's, but none at mobile's own 512 KiB: that point is the
    // plain mobile run (the sets below).
    ASSERT_LE(j.overrides.size(), 1u) << j.label;
  }
  EXPECT_EQ(keys.size(), c.jobs.size());
  EXPECT_EQ(labels.size(), c.jobs.size());
  std::map<std::string, std::set<std::string>> l2;  // preset -> its L2 sizes (the preset's own: "plain")
  for (const CampaignJob& j : c.jobs)
    l2[j.preset].insert(j.overrides.count("l2.size_bytes") ? j.overrides.at("l2.size_bytes") : "plain");
  EXPECT_EQ(l2["mobile"], (std::set<std::string>{"131072", "262144", "plain"}));
  EXPECT_EQ(l2["desktop"], (std::set<std::string>{"131072", "262144", "524288"}));
}

TEST(CampaignExpand, RangesAreInclusiveAndKeepTheirType) {
  const Campaign c = parse(R"(
[sweep]
scene = "cornell"
builder = "sah"
set.trv.units = {from = 2, to = 8, step = 3}
set.raygen.rays_per_cycle = {from = 0.5, to = 1.5, step = 0.25}
)");
  // A point at the preset's own value (mobile's raygen.rays_per_cycle is 1.0) is the
  // plain run: no override.
  std::set<std::string> units, rates;
  for (const CampaignJob& j : c.jobs) {
    units.insert(j.overrides.at("trv.units"));
    rates.insert(j.overrides.count("raygen.rays_per_cycle") ? j.overrides.at("raygen.rays_per_cycle") : "plain");
  }
  EXPECT_EQ(units, (std::set<std::string>{"2", "5", "8"}));
  EXPECT_EQ(rates, (std::set<std::string>{"0.5", "0.75", "plain", "1.25", "1.5"}));
  EXPECT_EQ(c.jobs.size(), 15u);
}

TEST(CampaignExpand, GroupsInheritTheSweepAndDeduplicate) {
  const Campaign c = parse(R"(
[sweep]
scene = "interior"
builder = ["sah", "aobvh"]
[[group]]
name = "builders"
[[group]]
name = "sah-only"
builder = "sah"
fidelity = ["functional", "cycle"]
)");
  // builders: 2 jobs; sah-only: 2 jobs, one of which (sah/functional) is already there.
  ASSERT_EQ(c.jobs.size(), 3u);
  EXPECT_EQ(c.jobs[0].group, "builders");
  EXPECT_EQ(c.jobs[2].group, "sah-only");
  EXPECT_EQ(c.jobs[2].fidelity, "cycle");
  EXPECT_EQ(c.groups, (std::vector<std::string>{"builders", "sah-only"}));
}

TEST(CampaignExpand, KeyDependsOnConfigurationAndRevisionOnly) {
  const std::string text = "[sweep]\nscene = \"interior\"\nbuilder = [\"sah\", \"osah\"]\n";
  const Campaign a = parse(text, "rev1"), b = parse(text, "rev1"), c = parse(text, "rev2");
  ASSERT_EQ(a.jobs.size(), 2u);
  EXPECT_EQ(a.jobs[0].key, b.jobs[0].key);
  EXPECT_NE(a.jobs[0].key, c.jobs[0].key);                  // new binary, new runs
  EXPECT_EQ(a.jobs[0].config_hash, c.jobs[0].config_hash);  // same configuration
  EXPECT_NE(a.jobs[0].config_hash, a.jobs[1].config_hash);
  // The campaign's name and group names are not part of a job's identity.
  const Campaign d = parse("[campaign]\nname = \"other\"\n" + text, "rev1");
  EXPECT_EQ(a.jobs[1].key, d.jobs[1].key);
}

TEST(CampaignExpand, PresetFilesAreHashedByContent) {
  const auto dir = fresh_folder("preset");
  write_text(dir / "hw.toml", "preset = \"mobile\"\n[trv]\nunits = 2\n");
  const auto file = write_text(dir / "c.toml",
                               "[sweep]\nscene = \"interior\"\nbuilder = \"sah\"\n"
                               "preset = [\"hw.toml\", \"mobile\"]\n");
  const Campaign before = load_campaign(file, "r");
  ASSERT_EQ(before.jobs.size(), 2u);
  EXPECT_EQ(before.jobs[0].preset_path, dir / "hw.toml");
  EXPECT_TRUE(before.jobs[1].preset_path.empty());
  const auto args = before.jobs[0].simulate_arguments("/out");
  EXPECT_NE(std::find(args.begin(), args.end(), (dir / "hw.toml").string()), args.end());
  write_text(dir / "hw.toml", "preset = \"mobile\"\n[trv]\nunits = 3\n");
  const Campaign after = load_campaign(file, "r");
  EXPECT_NE(before.jobs[0].key, after.jobs[0].key);
  EXPECT_EQ(before.jobs[1].key, after.jobs[1].key);
}

TEST(CampaignExpand, IdentityIsTheResolvedHardwareNotItsSpelling) {
  const Campaign c = parse(R"(
[sweep]
scene = "interior"
builder = "sah"
preset = "mobile"
set.trv.units = [4, 2]
[[group]]
name = "plain"
set = {}
[[group]]
name = "sweep"
)");
  // mobile has 4 TRV units: the override at its preset value is the plain job.
  ASSERT_EQ(c.jobs.size(), 2u);
  EXPECT_EQ(c.jobs[0].group, "plain");
  EXPECT_EQ(c.jobs[1].overrides.at("trv.units"), "2");
}

TEST(CampaignExpand, SimulateArgumentsCarryEveryAxis) {
  const Campaign c = parse(R"(
[sweep]
scene = "interior"
builder = "aobvh"
camera = "view2"
fidelity = "lt"
seed = 7
resolution = "64x48"
ao = 2
frames = 3
set."l1_node.size_bytes" = 8192
)");
  ASSERT_EQ(c.jobs.size(), 1u);
  const std::vector<std::string> expected = {
      "simulate", "--scene", "interior", "--builder", "aobvh", "--fidelity", "lt",
      "--config", "mobile", "--seed", "7", "--out-dir", "/o", "--camera", "view2",
      "--res", "64x48", "--ao", "2", "--frames", "3", "--set", "l1_node.size_bytes=8192"};
  EXPECT_EQ(c.jobs[0].simulate_arguments("/o"), expected);
  // The runner writes the merged hardware file instead: preset + typed overrides.
  EXPECT_EQ(c.jobs[0].hardware_toml, "preset = \"mobile\"\n\n[l1_node]\nsize_bytes = 8192\n");
  const auto with_file = c.jobs[0].simulate_arguments("/o", "/o/hardware.toml");
  EXPECT_EQ(with_file[8], "/o/hardware.toml");
  EXPECT_EQ(std::count(with_file.begin(), with_file.end(), "--set"), 0);
}

TEST(CampaignExpand, NodeFormatAxisBuildsTheTreeForItAndNamesUnknownFormats) {
  const Campaign c = parse(R"(
[sweep]
scene = "interior"
builder = "sah"
node_format = ["bvh2-64", "bvh8-80q"]
)");
  ASSERT_EQ(c.jobs.size(), 2u);
  EXPECT_NE(c.jobs[0].key, c.jobs[1].key);
  for (const CampaignJob& j : c.jobs) {
    const std::vector<std::string> args = j.simulate_arguments("/o");
    const auto at = std::find(args.begin(), args.end(), "--node-format");
    ASSERT_NE(at, args.end());
    EXPECT_EQ(*(at + 1), j.node_format);
    EXPECT_NE(j.label.find(j.node_format), std::string::npos) << j.label;
    // The memory image follows the format too: it is part of the job's hardware
    // (mobile's own bvh2-64 is the preset's, so its hardware needs no line for it).
    if (j.node_format == "bvh2-64")
      EXPECT_EQ(j.hardware_toml.find("node_format"), std::string::npos) << j.hardware_toml;
    else
      EXPECT_NE(j.hardware_toml.find("node_format = \"" + j.node_format + "\""), std::string::npos)
          << j.hardware_toml;
  }
  const std::string bad = error_of("[sweep]\nscene = \"interior\"\nbuilder = \"sah\"\nnode_format = \"bvh3\"\n");
  EXPECT_NE(bad.find("node_format"), std::string::npos) << bad;
  EXPECT_NE(bad.find("bvh8-80q"), std::string::npos) << bad;  // lists the known formats
}

// A preset whose memory.node_format is wide (the GPU presets' bvh6-64q) builds its
// trees for that width, as the axis does: a binary tree would not fit its records.
TEST(CampaignExpand, APresetsWideNodeFormatBuildsTheTreeForIt) {
  const Campaign c = parse(R"(
[sweep]
scene = "interior"
builder = "sah"
preset = ["mobile", "desktop-gpu"]
)");
  ASSERT_EQ(c.jobs.size(), 2u);
  for (const CampaignJob& j : c.jobs) {
    const std::vector<std::string> args = j.simulate_arguments("/o");
    const bool gpu = j.preset == "desktop-gpu";
    EXPECT_EQ(j.node_format, gpu ? "bvh6-64q" : "") << j.label;
    EXPECT_EQ(std::find(args.begin(), args.end(), "--node-format") != args.end(), gpu) << j.label;
  }
}

// The workload's diffuse bounces are an axis: each value its own job and label,
// passed to simulate; a campaign without the axis keeps its keys (the axis is absent
// from the resolved configuration, not 0).
TEST(CampaignExpand, DiffuseBouncesAreAnAxisThatLeavesOldKeysAlone) {
  const std::string plain = "[sweep]\nscene = \"interior\"\nbuilder = \"sah\"\n";
  const Campaign before = parse(plain);
  const Campaign c = parse(plain + "diffuse_bounces = [0, 3]\n");
  ASSERT_EQ(before.jobs.size(), 1u);
  ASSERT_EQ(c.jobs.size(), 2u);
  std::set<std::string> keys = {before.jobs[0].key};
  for (const CampaignJob& j : c.jobs) {
    keys.insert(j.key);
    const auto args = j.simulate_arguments("/o");
    const auto flag = std::find(args.begin(), args.end(), "--diffuse-bounces");
    ASSERT_NE(flag, args.end()) << j.label;
    ASSERT_NE(flag + 1, args.end());
    EXPECT_EQ(*(flag + 1), std::to_string(j.diffuse_bounces));
    EXPECT_NE(j.label.find("/diffuse" + std::to_string(j.diffuse_bounces)), std::string::npos) << j.label;
    EXPECT_EQ(j.resolved.at("diffuse_bounces"), std::to_string(j.diffuse_bounces));
  }
  EXPECT_EQ(keys.size(), 3u) << "0 bounces asked is its own job, beside the campaign that does not ask";
  const auto old_args = before.jobs[0].simulate_arguments("/o");
  EXPECT_EQ(std::count(old_args.begin(), old_args.end(), "--diffuse-bounces"), 0);
  EXPECT_FALSE(before.jobs[0].resolved.contains("diffuse_bounces"));
  const std::string bad = error_of(plain + "diffuse_bounces = 9\n");
  EXPECT_NE(bad.find("key 'diffuse_bounces'"), std::string::npos) << bad;
  EXPECT_NE(bad.find("[0, 8]"), std::string::npos) << bad;
  EXPECT_NE(error_of(plain + "diffuse_bounces = 1.5\n").find("integers"), std::string::npos);
}

// Alpha-tested materials as opaque is an axis: true passes --opaque and is its own
// job; false is the plain run (the same key as a campaign without the axis).
TEST(CampaignExpand, OpaqueIsAnAxisWhoseFalseIsThePlainRun) {
  const std::string plain = "[sweep]\nscene = \"foliage_alpha\"\nbuilder = \"sah\"\n";
  const Campaign before = parse(plain);
  const Campaign c = parse(plain + "opaque = [false, true]\n");
  ASSERT_EQ(c.jobs.size(), 2u);
  for (const CampaignJob& j : c.jobs) {
    const auto args = j.simulate_arguments("/o");
    EXPECT_EQ(std::count(args.begin(), args.end(), "--opaque"), j.opaque ? 1 : 0) << j.label;
    EXPECT_EQ(j.label.find("/opaque") != std::string::npos, j.opaque) << j.label;
    if (j.opaque) EXPECT_NE(j.key, before.jobs[0].key);
    else EXPECT_EQ(j.key, before.jobs[0].key);
  }
  EXPECT_NE(error_of(plain + "opaque = 1\n").find("true or false"), std::string::npos);
  // The opaque scene is another scene: its tree is cached apart, and built --opaque.
  ASSERT_NE(c.jobs[0].opaque, c.jobs[1].opaque);
  EXPECT_NE(cached_tree("/trees", c, c.jobs[0]), cached_tree("/trees", c, c.jobs[1]));
  BuildJob build;
  build.opaque = true;
  const auto build_args = build.arguments();
  EXPECT_EQ(std::count(build_args.begin(), build_args.end(), "--opaque"), 1);
}

TEST(CampaignExpand, InstancedIsAnAxisWhoseFalseIsThePlainRunAndWhoseTreesAreCachedApart) {
  const std::string plain = "[sweep]\nscene = \"forest_instanced\"\nbuilder = \"sah\"\n";
  const Campaign before = parse(plain);
  const Campaign c = parse(plain + "instanced = [false, true]\n");
  ASSERT_EQ(c.jobs.size(), 2u);
  for (const CampaignJob& j : c.jobs) {
    const auto args = j.simulate_arguments("/o");
    EXPECT_EQ(std::count(args.begin(), args.end(), "--instanced"), j.instanced ? 1 : 0) << j.label;
    EXPECT_EQ(j.label.find("/instanced") != std::string::npos, j.instanced) << j.label;
    if (j.instanced) EXPECT_NE(j.key, before.jobs[0].key);
    else EXPECT_EQ(j.key, before.jobs[0].key);
  }
  EXPECT_NE(error_of(plain + "instanced = \"yes\"\n").find("true or false"), std::string::npos);
  // The two-level tree is another tree: cached apart, and built --instanced.
  ASSERT_NE(c.jobs[0].instanced, c.jobs[1].instanced);
  EXPECT_NE(cached_tree("/trees", c, c.jobs[0]), cached_tree("/trees", c, c.jobs[1]));
  BuildJob build;
  build.instanced = true;
  const auto build_args = build.arguments();
  EXPECT_EQ(std::count(build_args.begin(), build_args.end(), "--instanced"), 1);
}

TEST(CampaignExpand, BadInputNamesFileAndKey) {
  EXPECT_NE(error_of("[sweep]\nscene = \"a\"\nbuilder = \"sah\"\nbuildr = \"x\"\n")
                .find("key 'sweep.buildr': is unknown"),
            std::string::npos);
  EXPECT_NE(error_of("[sweep]\nscene = \"a\"\nbuilder = \"sah\"\nfidelity = \"fast\"\n")
                .find("'fast' is not a fidelity level"),
            std::string::npos);
  EXPECT_NE(error_of("[sweep]\nscene = \"a\"\nbuilder = \"sah\"\n"
                     "set.trv.units = {from = 4, to = 2, step = 1}\n")
                .find("sweep.set.trv.units"),
            std::string::npos);
  EXPECT_NE(error_of("[sweep]\nscene = \"a\"\nbuilder = \"sah\"\n"
                     "set.trv.units = {from = 1, to = 2, stp = 1}\n")
                .find("unknown range key 'stp'"),
            std::string::npos);
  EXPECT_NE(error_of("[sweep]\nscene = \"a\"\nbuilder = []\n").find("empty list"),
            std::string::npos);
  EXPECT_NE(error_of("[sweep]\nscene = \"a\"\n").find("needs 'scene' and 'builder'"),
            std::string::npos);
  EXPECT_NE(error_of("[sweep]\nscene = \"a\"\nbuilder = \"sah\"\nresolution = \"64\"\n")
                .find("not a resolution"),
            std::string::npos);
  EXPECT_NE(error_of("[sweep]\nscene = \"a\"\nbuilder = \"sah\"\n"
                     "set.x = {from = 0, to = 1, step = 1e-9}\n")
                .find("more than"),
            std::string::npos);
  EXPECT_NE(error_of("[[group]]\nname = \"g\"\n[[group]]\nname = \"g\"\n").find("defined twice"),
            std::string::npos);
  // Every message names the file.
  EXPECT_NE(error_of("[sweep]\nscene = 3\nbuilder = {a = 1}\n").find("c.toml"), std::string::npos);
  // Hardware keys and presets are checked against the model before anything runs.
  const std::string unknown =
      error_of("[sweep]\nscene = \"a\"\nbuilder = \"sah\"\nset.l2.size_byte = 1024\n");
  EXPECT_NE(unknown.find("c.toml"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("l2.size_byte"), std::string::npos) << unknown;
  EXPECT_NE(error_of("[sweep]\nscene = \"a\"\nbuilder = \"sah\"\npreset = \"mobil\"\n")
                .find("mobil"),
            std::string::npos);
  EXPECT_NE(error_of("[sweep]\nscene = \"a\"\nbuilder = \"sah\"\nset.trv.units = 100000\n")
                .find("out of range"),
            std::string::npos);
}

}  // namespace
}  // namespace rtsim

namespace rtsim {
namespace {

TEST(CampaignExpand, BuilderParametersAreAxes) {
  const Campaign c = parse(R"(
[campaign]
name = "knobs"
[sweep]
scene = "interior"
builder = ["sah", "aobvh"]
[sweep.build]
max_leaf_size = [1, 8]
seed = [3, 4]
)");
  ASSERT_EQ(c.jobs.size(), 2u * 2u * 2u);
  std::set<std::string> keys;
  for (const CampaignJob& j : c.jobs) {
    keys.insert(j.key);
    ASSERT_EQ(j.build_settings.size(), 2u);
    EXPECT_NE(j.label.find("/build.max_leaf_size="), std::string::npos) << j.label;
    const auto args = j.simulate_arguments("out");
    const std::string leaf = "max_leaf_size=" + j.build_settings.at("max_leaf_size");
    EXPECT_NE(std::find(args.begin(), args.end(), leaf), args.end()) << j.label;
    EXPECT_EQ(j.seed, 1u);  // the workload's seed is not the builder's
  }
  EXPECT_EQ(keys.size(), c.jobs.size());
  // Without a build table the keys stay what they were before build axes existed.
  const Campaign plain = parse("[campaign]\nname = \"p\"\n[sweep]\nscene = \"interior\"\nbuilder = \"sah\"\n");
  EXPECT_FALSE(plain.jobs.at(0).resolved.contains("build"));
}

TEST(CampaignExpand, BadBuilderParametersNameFileAndKey) {
  const std::string unknown = error_of(R"(
[campaign]
name = "k"
[sweep]
scene = "interior"
builder = "sah"
build.leaf = [1]
)");
  EXPECT_NE(unknown.find("sweep.build.leaf"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("not a builder parameter"), std::string::npos) << unknown;
  const std::string range = error_of(R"(
[campaign]
name = "k"
[sweep]
scene = "interior"
builder = "sah"
build.t2 = [0]
)");
  EXPECT_NE(range.find("build.t2"), std::string::npos) << range;
  EXPECT_NE(range.find("positive"), std::string::npos) << range;
}

// A cached tree is named by what shapes it: sah on two cameras and two workload
// seeds is one tree; aobvh's seed and AO ray length make new ones; an AO length
// reaches the workload of every builder and the tree of those that cast AO rays.
TEST(CampaignExpand, TreesAreSharedByWhatShapesThemAndTheAoLengthReachesBoth) {
  const Campaign c = parse(R"(
[campaign]
name = "share"
[sweep]
scene = "interior"
builder = ["sah", "aobvh"]
camera = ["view1", "view2"]
seed = [1, 2]
ao_cutoff = [0.02, 0.2]
)");
  ASSERT_EQ(c.jobs.size(), 2u * 2u * 2u * 2u);
  std::set<std::string> sah_trees, ao_trees;
  for (const CampaignJob& j : c.jobs) {
    const auto args = j.simulate_arguments("out");
    const auto at = std::find(args.begin(), args.end(), "--ao-cutoff");
    ASSERT_NE(at, args.end()) << j.label;
    EXPECT_EQ(*(at + 1), j.ao_cutoff);
    const std::string tree = cached_tree("cache", c, j).string();
    if (j.builder == "sah") {
      EXPECT_FALSE(j.build_settings.count("ao_cutoff_relative")) << j.label;
      sah_trees.insert(tree);
    } else {
      EXPECT_EQ(j.build_settings.at("ao_cutoff_relative"), j.ao_cutoff) << j.label;
      ao_trees.insert(tree);
    }
  }
  EXPECT_EQ(sah_trees.size(), 1u);
  EXPECT_EQ(ao_trees.size(), 2u * 2u);  // seed x AO length; aobvh reads no camera
  EXPECT_NE(error_of("[campaign]\nname = \"a\"\n[sweep]\nscene = \"interior\"\nbuilder = \"sah\"\n"
                     "ao_cutoff = [0]\n")
                .find("ao_cutoff"),
            std::string::npos);
}

}  // namespace
}  // namespace rtsim
