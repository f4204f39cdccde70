// Issue 36 ("bad input round three") at the command line: each case of its list as a
// user meets it, with exit 2 and a message naming the flag, key or file and the
// reason, before any work where it can be checked up front. Unwritable folders are
// under /sys, which no one (root included) can create files in.
#include "integration/cli_runner.h"
#include "integration/test_campaign_fake.h"

#include <rtsim/builder/build.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/reports/child_process.h>
#include <rtsim/reports/results_store.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/procedural.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

namespace {

namespace fs = std::filesystem;
using rtsim::shell_quote;
using rtsim::test::fresh_folder;
using rtsim::test::write_text;

// rtsim in `cwd` with a time limit (a hang is a failure, not a stall), stdout and
// stderr together; `env` is put in front (VAR=value ...).
CliResult run_in(const fs::path& cwd, const std::string& args, int seconds = 120, const std::string& env = "") {
  return run_rtsim_command("cd " + shell_quote(cwd.string()) + " && " + env + " RTSIM_NO_PROGRESS=1 timeout " +
                           std::to_string(seconds) + " " + shell_quote(RTSIM_BINARY) + " " + args + " 2>&1");
}

bool has(const CliResult& r, const std::string& text) { return r.output.find(text) != std::string::npos; }
std::string first_line(const CliResult& r) { return r.output.substr(0, r.output.find('\n')); }

// Exit 2 and each of `words` in the message.
void expect_refused(const CliResult& r, std::initializer_list<std::string> words, const std::string& what) {
  EXPECT_EQ(r.exit_code, 2) << what << "\n" << r.output;
  for (const std::string& w : words) EXPECT_TRUE(has(r, w)) << what << ": no '" << w << "' in\n" << r.output;
}

// A closed unit cube, faces wound to face the inside, with a mirror material and the
// camera inside: every primary ray bounces until the bounce limit.
fs::path write_mirror_box(const fs::path& dir) {
  write_text(dir / "box.obj",
             "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
             "f 1 2 3\nf 1 3 4\nf 5 8 7\nf 5 7 6\nf 1 5 6\nf 1 6 2\n"
             "f 4 3 7\nf 4 7 8\nf 1 4 8\nf 1 8 5\nf 2 6 7\nf 2 7 3\n");
  return write_text(dir / "mirror.toml",
                    "name = \"mirror-box\"\n[[mesh]]\nfile = \"box.obj\"\nmaterial = \"mirror\"\n"
                    "[[material]]\nname = \"mirror\"\nreflectance = 1\n[ao]\nenabled = false\n"
                    "[[camera]]\nname = \"view1\"\nposition = [0.5, 0.5, 0.5]\ntarget = [0.5, 0.5, 0]\n");
}

const char* kCornellCampaign =
    "[campaign]\nname = \"%s\"\n[sweep]\nscene = \"cornell\"\nbuilder = \"sah\"\nresolution = \"8x8\"\n";
std::string campaign_text(const std::string& name) {
  std::string text = kCornellCampaign;
  text.replace(text.find("%s"), 2, name);
  return text;
}

// ---- the crash and the hang

// trace --rays-in F --out-dir D drew shaded.png from a shadow ray whose parent
// missed (surface_at with the no-hit index: exit 139). Ray 0's origin pushed to
// 1e30 (the float at byte 32), and its direction made (1e-45, 0, 0).
TEST(RoundThree, EditedRaysDrawPicturesWithoutCrashing) {
  const fs::path dir = fresh_folder("rays");
  ASSERT_EQ(run_in(dir, "trace --scene cornell --res 16x16 --rays-out good.rays").exit_code, 0);
  const std::string good = rtsim::read_input_file(dir / "good.rays", 1 << 24);
  for (int variant = 0; variant < 2; ++variant) {
    std::string bad = good;
    if (variant == 0) {
      const float far = 1e30f;
      std::memcpy(&bad[32], &far, 4);
    } else {
      const float direction[3] = {1e-45f, 0.0f, 0.0f};
      std::memcpy(&bad[48], direction, 12);
    }
    rtsim::write_file_atomic(dir / "bad.rays", bad);
    const fs::path pictures = dir / ("pictures" + std::to_string(variant));
    const CliResult r =
        run_in(dir, "trace --scene cornell --res 16x16 --rays-in bad.rays --out-dir " + pictures.string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_TRUE(fs::exists(pictures / "shaded.png")) << r.output;
  }
}

// --bounces had no bound and the counter is 8 bits: 256 in a closed mirror box never
// ended (memory +100 MB/s). The limit is refused past, and the box at the limit ends.
TEST(RoundThree, BouncesHaveALimitAndAMirrorBoxAtItEnds) {
  const fs::path dir = fresh_folder("bounces");
  write_mirror_box(dir);
  for (const char* flag : {"--bounces 256", "--bounces 65", "--max-depth 1000"}) {
    expect_refused(run_in(dir, std::string("trace --scene mirror.toml --res 8x8 ") + flag, 20),
                   {std::string(flag).substr(0, std::string(flag).find(' ')), "must be 0..64"}, flag);
    expect_refused(run_in(dir, std::string("simulate --scene mirror.toml --res 8x8 --out-dir o ") + flag, 20),
                   {"must be 0..64"}, flag);
  }
  EXPECT_FALSE(fs::exists(dir / "o"));
  const CliResult at_limit = run_in(dir, "trace --scene mirror.toml --res 8x8 --bounces 64 --json", 120);
  ASSERT_EQ(at_limit.exit_code, 0) << at_limit.output;
  const auto j = nlohmann::json::parse(at_limit.output);
  // At most 64 bounces a primary ray (65 closest-hit rays each); and they bounce (a
  // few leave the box through its edges, where the offset origin lands outside).
  EXPECT_LE(j["total"]["rays"].get<uint64_t>(), 64u * 65u);
  EXPECT_GT(j["per_type"]["reflection"]["rays"].get<uint64_t>(), 64u * 32u);
}

// ---- memory bounds

// Keys each inside their range multiply past the host's memory: refused before any
// model is built, naming the keys; the limit is RTSIM_MEMORY_LIMIT's when set.
TEST(RoundThree, AMachineThatCannotFitInMemoryIsRefusedNamingItsKeys) {
  const fs::path dir = fresh_folder("machine");
  write_text(dir / "caches.toml",
             "cores = 256\n[trv]\nunits = 256\n[ist]\nunits = 256\n[l1_node]\nsize_bytes = 1073741824\n"
             "[l1_triangle]\nsize_bytes = 1073741824\n");
  write_text(dir / "slots.toml", "cores = 256\n[trv]\nunits = 256\nray_slots = 4096\n");
  const CliResult caches = run_in(dir, "simulate --scene cornell --config caches.toml --out-dir o", 30);
  expect_refused(caches, {"hardware", "cores 256 x trv.units 256", "l1_node.size_bytes", "memory limit", "RTSIM_MEMORY_LIMIT"},
                 "1 GiB L1s");
  const CliResult slots = run_in(dir, "simulate --scene cornell --config slots.toml --out-dir o", 30);
  expect_refused(slots, {"trv.ray_slots 4096", "memory limit"}, "ray slots");
  EXPECT_FALSE(fs::exists(dir / "o"));
  // The limit is the variable's (and the flag's): the mobile preset fits 1 GiB, not 1 KiB.
  expect_refused(run_in(dir, "trace --scene cornell --res 8x8", 30, "RTSIM_MEMORY_LIMIT=1K"), {"memory limit of 1.0 KiB"},
                 "1K");
  expect_refused(run_in(dir, "--memory-limit 1K trace --scene cornell --res 8x8", 30), {"memory limit of 1.0 KiB"},
                 "--memory-limit");
  EXPECT_EQ(run_in(dir, "trace --scene cornell --res 8x8", 30, "RTSIM_MEMORY_LIMIT=1G").exit_code, 0);
  expect_refused(run_in(dir, "trace --scene cornell", 30, "RTSIM_MEMORY_LIMIT=0x10"), {"RTSIM_MEMORY_LIMIT", "'0x10'"},
                 "bad limit");
}

// A frame's rays (--res x --spp x bounces, two children a bounce in glass) are
// estimated before the build and refused above the limit, naming the flags.
TEST(RoundThree, AFrameThatCannotFitInMemoryIsRefusedBeforeTheBuild) {
  const fs::path dir = fresh_folder("frame");
  write_mirror_box(dir);
  const CliResult r = run_in(dir, "trace --scene mirror.toml --res 16384x16384 --spp 1024 --bounces 64", 30);
  expect_refused(r, {"--res x --spp x --bounces", "16384x16384 x 1024 spp", "64 bounces", "memory limit"}, "frame");
}

// A 2 GB file that is no BVH file was read whole (4.2 GB peak, 48 s) before its
// magic was looked at: with 1.2 GB of address space it is now refused by its magic
// (main ran out of memory: exit 1, std::bad_alloc).
TEST(RoundThree, ABigFileGivenToBvhIsRefusedByItsMagicWithoutReadingIt) {
  const fs::path dir = fresh_folder("bigbvh");
  const fs::path big = dir / "big.bin";
  { std::ofstream(big) << "not a tree"; }
  fs::resize_file(big, uint64_t(2) << 30);  // sparse
  const std::string limited = "cd " + shell_quote(dir.string()) + " && ulimit -v 1200000 && " + shell_quote(RTSIM_BINARY);
  if (run_rtsim_command(limited + " --version 2>&1").exit_code != 0) {
    fs::remove(big);
    GTEST_SKIP() << "rtsim cannot start in 1.2 GB of address space (a sanitizer build reserves terabytes)";
  }
  const CliResult r = run_rtsim_command(limited + " trace --scene cornell --bvh big.bin 2>&1");
  expect_refused(r, {"big.bin", "header.magic", "not an rtsim BVH file"}, "2 GB");
  fs::remove(big);
}

// ---- the tree cache

// A median tree copied over the cache's sah tree was served: rows labelled sah
// carried median's numbers. It is now moved aside and built again, and the rows
// equal those of a run that builds its own trees.
TEST(RoundThree, TheTreeCacheRebuildsATreeThatIsNotTheJobs) {
  const fs::path dir = fresh_folder("wrongtree");
  write_text(dir / "c.toml", campaign_text("wrongtree"));
  // No results cache: both runs must run their job (the second through the tree cache).
  ASSERT_EQ(run_in(dir, "campaign run c.toml --out-dir own --no-tree-cache --no-results-cache").exit_code, 0);
  ASSERT_EQ(run_in(dir, "campaign run c.toml --out-dir shared --tree-cache cache --no-results-cache").exit_code, 0);
  fs::path tree;
  for (const auto& e : fs::directory_iterator(dir / "cache"))
    if (e.path().extension() == ".bvh") tree = e.path();
  ASSERT_FALSE(tree.empty());
  ASSERT_EQ(run_in(dir, "build --scene cornell --builder median --out " + shell_quote(tree.string())).exit_code, 0);
  const CliResult again = run_in(dir, "campaign run c.toml --out-dir shared --tree-cache cache --force");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_TRUE(has(again, "is not this job's tree: it holds a tree built by 'median', the job asks for 'sah'"))
      << again.output;
  EXPECT_TRUE(fs::exists(fs::path(tree.string() + ".mismatch")));
  rtsim::ResultsStore own(dir / "own" / "results.sqlite"), shared(dir / "shared" / "results.sqlite");
  const auto a = own.rows("wrongtree"), b = shared.rows("wrongtree");
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(a[0]["stats_json"], b[0]["stats_json"]);
  rtsim::BvhFileHeader header;
  rtsim::load_bvh(tree, nullptr, &header);
  EXPECT_EQ(header.builder, "sah");
}

// A tree cache that is a file is refused; one that cannot be written (every job
// failed with "flock: cannot open lock file") gives a warning and jobs that build
// their own trees.
TEST(RoundThree, AnUnusableTreeCacheIsFoundBeforeTheFirstJob) {
  const fs::path dir = fresh_folder("cache");
  write_text(dir / "c.toml", campaign_text("cache"));
  write_text(dir / "file", "x");
  expect_refused(run_in(dir, "campaign run c.toml --out-dir w --tree-cache file"),
                 {"--tree-cache", "exists and is not a folder"}, "file");
  expect_refused(run_in(dir, "campaign run c.toml --out-dir w --tree-cache file/sub"),
                 {"--tree-cache", "is a file, not a folder"}, "under a file");
  const CliResult readonly = run_in(dir, "campaign run c.toml --out-dir w --tree-cache /sys/rtsim-trees");
  EXPECT_EQ(readonly.exit_code, 0) << readonly.output;
  EXPECT_TRUE(has(readonly, "the tree cache cannot be written")) << readonly.output;
  EXPECT_TRUE(has(readonly, "1 ok, 0 failed")) << readonly.output;
  expect_refused(run_in(dir, "claim --quick --tree-cache file --out-dir claim"), {"--tree-cache", "not a folder"},
                 "claim");
  EXPECT_FALSE(fs::exists(dir / "claim"));
}

// ---- paths, before any work

TEST(RoundThree, CampaignAndClaimPathsAreCheckedBeforeAnyJob) {
  const fs::path dir = fresh_folder("paths");
  write_text(dir / "c.toml", campaign_text("paths"));
  write_text(dir / "file", "x");
  const struct {
    const char* args;
    const char* names;
    const char* env;
  } cases[] = {
      {"campaign run c.toml --out-dir file", "/file: exists and is not a folder", ""},
      {"campaign run c.toml --out-dir /sys/rtsim-x", "--out-dir /sys/rtsim-x", ""},
      {"campaign run c.toml --out-dir /sys", "--out-dir /sys", ""},
      {"campaign run c.toml --out-dir w --db /sys/x.sqlite", "--db /sys/x.sqlite", ""},
      {"campaign emit c.toml --slurm --out-dir /sys/rtsim-x", "--out-dir /sys/rtsim-x", ""},
      {"campaign collect c.toml --out-dir w --db /sys/x.sqlite", "--db /sys/x.sqlite", ""},
      {"campaign job c.toml --key KEY --out-dir file", "/file: exists and is not a folder", ""},
      {"claim --quick --out-dir file", "--out-dir file", ""},
      {"campaign run c.toml --out-dir w", "RTSIM_CACHE", "RTSIM_CACHE=file"},
  };
  const CliResult list = run_in(dir, "campaign list c.toml");
  ASSERT_EQ(list.exit_code, 0) << list.output;
  const std::string key = list.output.substr(0, list.output.find(' '));
  for (const auto& c : cases) {
    std::string args = c.args;
    if (args.find("KEY") != std::string::npos) args.replace(args.find("KEY"), 3, key);
    const CliResult r = run_in(dir, args, 60, c.env);
    expect_refused(r, {c.names}, args);
    EXPECT_FALSE(has(r, "internal error")) << args << "\n" << r.output;
    EXPECT_FALSE(has(r, "ran 1")) << c.args;
  }
  EXPECT_FALSE(fs::exists(dir / "w" / "results.sqlite"));
}

// A campaign named .. wrote its folder beside the campaign file; 300 characters
// exited 1 (a file name too long).
TEST(RoundThree, ACampaignNameMustBeAFolderName) {
  const fs::path dir = fresh_folder("names");
  for (const std::string& name : {std::string(".."), std::string("."), std::string(300, 'a')}) {
    write_text(dir / "c.toml", campaign_text(name));
    expect_refused(run_in(dir, "campaign run c.toml"), {"c.toml: key 'campaign.name'"}, name.substr(0, 10));
  }
  EXPECT_FALSE(fs::exists(dir / "rtsim-campaigns"));
}

// ---- silent conflicts

TEST(RoundThree, AHardwareKeyUnderTwoSpellingsIsRefused) {
  const fs::path dir = fresh_folder("spellings");
  write_text(dir / "l2.toml", "\"l2.size_bytes\" = 262144\n[l2]\nsize_bytes = 131072\n");
  write_text(dir / "core.toml", "\"core.1.l1_node.size_bytes\" = 8192\n[core.1.l1_node]\nsize_bytes = 32768\n");
  write_text(dir / "lead.toml", "[core.01.l1_node]\nsize_bytes = 32768\n");
  expect_refused(run_in(dir, "trace --scene cornell --res 8x8 --config l2.toml"),
                 {"l2.toml: l2.size_bytes", "is set twice"}, "l2");
  expect_refused(run_in(dir, "trace --scene cornell --res 8x8 --config core.toml"),
                 {"core.toml: core.1.l1_node.size_bytes", "is set twice"}, "core");
  expect_refused(run_in(dir, "trace --scene cornell --res 8x8 --config lead.toml"), {"core.01", "leading zero"},
                 "core.01");
  write_text(dir / "tile.toml", "[raygen]\ntile = \"4294967304x8\"\n");
  expect_refused(run_in(dir, "trace --scene cornell --res 8x8 --config tile.toml"),
                 {"raygen.tile", "4294967304x8", "1..4096"}, "tile");
}

// A per-core override equal to the machine's caches changes nothing, so it changes
// no key either (the same simulation ran twice under two keys).
TEST(RoundThree, APerCoreOverrideEqualToTheMachineIsNoOverride) {
  const rtsim::sim::HardwareConfig machine = rtsim::sim::load_hardware_config("mobile");
  // core 0: the mobile machine has one core.
  const std::string same = "[core.0.l1_node]\nsize_bytes = " + std::to_string(machine.l1_node.size_bytes) + "\n";
  const std::string other = "[core.0.l1_node]\nsize_bytes = " + std::to_string(machine.l1_node.size_bytes * 2) + "\n";
  EXPECT_EQ(rtsim::sim::to_json(rtsim::sim::parse_hardware_config(same, "same.toml")), rtsim::sim::to_json(machine));
  EXPECT_NE(rtsim::sim::to_json(rtsim::sim::parse_hardware_config(other, "other.toml")), rtsim::sim::to_json(machine));

  const fs::path dir = fresh_folder("percore");
  write_text(dir / "c.toml", campaign_text("percore") + "[[group]]\nname = \"plain\"\n[[group]]\nname = \"same\"\n"
                                                        "set.core.0.l1_node.size_bytes = " +
                                 std::to_string(machine.l1_node.size_bytes) + "\n");
  const CliResult list = run_in(dir, "campaign list c.toml --json");
  ASSERT_EQ(list.exit_code, 0) << list.output;
  // One job: the groups' jobs have one key now, and a campaign runs a key once (main
  // listed two, 'plain' and 'same', with two keys).
  const auto jobs = nlohmann::json::parse(list.output);
  EXPECT_EQ(jobs.size(), 1u) << list.output;
}

// --rays-in fixes the rays: --ao, --spp and --bounces were ignored but recorded.
TEST(RoundThree, FlagsThatMakeRaysAreRefusedWithRaysIn) {
  const fs::path dir = fresh_folder("raysin");
  ASSERT_EQ(run_in(dir, "trace --scene cornell --res 8x8 --rays-out r.rays").exit_code, 0);
  for (const char* flag : {"--ao 2", "--spp 2", "--bounces 1"}) {
    const std::string name = std::string(flag).substr(0, std::string(flag).find(' '));
    expect_refused(run_in(dir, std::string("trace --scene cornell --res 8x8 --rays-in r.rays ") + flag),
                   {name, "has no effect with --rays-in"}, flag);
    expect_refused(run_in(dir, std::string("simulate --scene cornell --res 8x8 --rays-in r.rays --out-dir o ") + flag),
                   {name, "has no effect with --rays-in"}, flag);
  }
  EXPECT_FALSE(fs::exists(dir / "o"));
}

// --bvh ignored --builder, and took a tree naming a builder that does not exist (or
// one that is not even UTF-8: exit 1 from the JSON library).
TEST(RoundThree, ASavedTreeMustBeTheBuilderItClaimsAndOneThatExists) {
  const fs::path dir = fresh_folder("bvh");
  ASSERT_EQ(run_in(dir, "build --scene cornell --builder median --out median.bvh").exit_code, 0);
  expect_refused(run_in(dir, "trace --scene cornell --res 8x8 --bvh median.bvh --builder sah"),
                 {"--builder", "'sah' does not match the saved tree", "built by 'median'"}, "mismatch");
  EXPECT_EQ(run_in(dir, "trace --scene cornell --res 8x8 --bvh median.bvh --builder median").exit_code, 0);
  EXPECT_EQ(run_in(dir, "trace --scene cornell --res 8x8 --bvh median.bvh").exit_code, 0);
  expect_refused(run_in(dir, "trace --scene cornell --res 8x8 --builder nosuch"), {"--builder", "unknown builder 'nosuch'"},
                 "unknown builder");

  const rtsim::Scene scene = rtsim::make_procedural_scene("cornell");
  rtsim::BuildParams params;
  const rtsim::Bvh bvh = rtsim::build_bvh(scene, params);
  for (const std::string& name : {std::string("nosuch"), std::string("sa\xff\xfe")}) {
    rtsim::BvhFileHeader header;
    header.scene_hash = scene.content_hash();
    header.triangle_count = scene.triangle_count();
    header.builder = name;
    header.params_json = rtsim::build_params_json(params);
    rtsim::save_bvh(dir / "odd.bvh", bvh, header);
    for (const char* command : {"trace --scene cornell --res 8x8 --bvh odd.bvh",
                                "simulate --scene cornell --res 8x8 --bvh odd.bvh --out-dir o"})
      expect_refused(run_in(dir, command), {"odd.bvh: header.builder", "is not a builder this rtsim knows"}, name);
  }
}

// claim --quick replaced --replicates 0 and --res 0x0 silently.
TEST(RoundThree, ClaimQuickHidesNoFlag) {
  const fs::path dir = fresh_folder("claim");
  expect_refused(run_in(dir, "claim --quick --replicates 0 --out-dir c"), {"--replicates", "at least 2"}, "0");
  expect_refused(run_in(dir, "claim --quick --res 0x0 --out-dir c"), {"--res", "'0x0'"}, "0x0");
  expect_refused(run_in(dir, "claim --quick --replicates 4 --out-dir c"), {"--replicates", "--quick sets it"}, "4");
  EXPECT_FALSE(fs::exists(dir / "c"));
  EXPECT_TRUE(has(run_in(dir, "claim --help"), "--retry-failed"));
}

// A line break in --sbatch-option became a line of the batch script.
TEST(RoundThree, AnSbatchOptionIsOneLine) {
  const fs::path dir = fresh_folder("sbatch");
  write_text(dir / "c.toml", campaign_text("sbatch"));
  const CliResult r = run_in(dir, "campaign emit c.toml --slurm --sbatch-option=\"$(printf -- '--partition=a\\nrm -rf ~')\"");
  expect_refused(r, {"--sbatch-option", "must be one line"}, "newline");
  EXPECT_FALSE(fs::exists(dir / "rtsim-campaigns" / "sbatch" / "slurm"));
}

}  // namespace
