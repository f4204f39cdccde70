// Issue 15 at the command line: every case of its "Why" list as a user meets it,
// with the exit code and a message naming the file, key or flag; output paths
// checked before any work; campaigns that cannot serve stale results; one
// spelling per concept with the old ones kept as warned aliases.
#include "integration/cli_runner.h"
#include "integration/test_campaign_fake.h"

#include <rtsim/builder/build.h>
#include <rtsim/reports/child_process.h>
#include <rtsim/workloads/files.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

namespace {

namespace fs = std::filesystem;
using rtsim::shell_quote;
using rtsim::test::fresh_folder;
using rtsim::test::write_text;

// rtsim in `cwd` with a time limit (a hang is a failure, not a stall); stdout and
// stderr together unless `stdout_only`.
CliResult run_in(const fs::path& cwd, const std::string& args, int seconds = 300, bool stdout_only = false) {
  return run_rtsim_command("cd " + shell_quote(cwd.string()) + " && RTSIM_NO_PROGRESS=1 timeout " +
                           std::to_string(seconds) + " " + shell_quote(RTSIM_BINARY) + " " + args +
                           (stdout_only ? " 2>/dev/null" : " 2>&1"));
}

bool has(const CliResult& r, const std::string& text) { return r.output.find(text) != std::string::npos; }

const char* kTriangleObj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
const char* kCameras =
    "[[camera]]\nname = \"view1\"\nposition = [0.3, 0.3, 2]\ntarget = [0.3, 0.3, 0]\n"
    "[[camera]]\nname = \"view2\"\nposition = [1, 1, 2]\ntarget = [0.3, 0.3, 0]\n";

// A PLY of n x n quads (2 n^2 faces), ASCII.
std::string grid_ply(int n) {
  std::ostringstream s;
  s << "ply\nformat ascii 1.0\nelement vertex " << (n + 1) * (n + 1)
    << "\nproperty float x\nproperty float y\nproperty float z\nelement face " << 2 * n * n
    << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) s << float(x) / n << " " << float(y) / n << " 0\n";
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const int a = y * (n + 1) + x, b = a + 1, c = a + n + 2, d = a + n + 1;
      s << "3 " << a << " " << b << " " << c << "\n3 " << a << " " << c << " " << d << "\n";
    }
  return s.str();
}

fs::path scene_with(const fs::path& dir, const std::string& mesh_file, const std::string& cameras = kCameras) {
  return write_text(dir / "scene.toml", "name = \"t\"\n[[mesh]]\nfile = \"" + mesh_file + "\"\n" + cameras);
}

// ---------------------------------------------------------------- crashes

// Before: exit 134 (ai_assert in assimp's TriangulateProcess.cpp) for every cut.
TEST(BadInputRoundTwo, TruncatedPlyExitsTwoNamingTheFile) {
  const fs::path dir = fresh_folder("ply");
  const std::string full = grid_ply(20);
  for (size_t cut : {full.size() / 3, full.size() / 2, full.size() - 7}) {
    write_text(dir / "cut.ply", full.substr(0, cut));
    scene_with(dir, "cut.ply");
    const CliResult r = run_in(dir, "scenes info scene.toml");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_TRUE(has(r, "cut.ply: PLY body ends early")) << r.output;
  }
  write_text(dir / "full.ply", full);
  scene_with(dir, "full.ply");
  EXPECT_EQ(run_in(dir, "scenes info scene.toml").exit_code, 0);
}

// Before: exit 0, loaded as 1000 triangles.
TEST(BadInputRoundTwo, PlyAnnouncingMoreFacesThanItHoldsExitsTwo) {
  const fs::path dir = fresh_folder("ply1000");
  write_text(dir / "short.ply",
             "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
             "element face 1000\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  scene_with(dir, "short.ply");
  const CliResult r = run_in(dir, "build --scene scene.toml");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r, "announces 1000 'face' elements, the body holds 1")) << r.output;
}

// Before: half of `scenes info`, then "internal error: [json.exception.type_error.305]", exit 1;
// with --json exit 0 and no cameras key.
TEST(BadInputRoundTwo, DescriptorWithoutCamerasExitsTwoUpFront) {
  const fs::path dir = fresh_folder("nocam");
  write_text(dir / "tri.obj", kTriangleObj);
  scene_with(dir, "tri.obj", "");
  for (const char* args : {"scenes info scene.toml", "scenes info scene.toml --json"}) {
    const CliResult r = run_in(dir, args);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_TRUE(has(r, "scene.toml: key 'camera': at least one [[camera]] is required")) << r.output;
    EXPECT_FALSE(has(r, "internal error")) << r.output;
    EXPECT_FALSE(has(r, "triangles")) << "printed half a summary: " << r.output;
  }
}

// ---------------------------------------------------------------- unbounded reads

// Before: a FIFO blocked for ever; /dev/zero grew to gigabytes.
TEST(BadInputRoundTwo, DescriptorThatIsAFifoOrADeviceExitsTwoAtOnce) {
  const fs::path dir = fresh_folder("fifo");
  ASSERT_EQ(::mkfifo((dir / "fifo.toml").c_str(), 0600), 0);
  fs::create_symlink("/dev/zero", dir / "zero.toml");
  for (const char* name : {"fifo.toml", "zero.toml"}) {
    const auto start = std::chrono::steady_clock::now();
    const CliResult r = run_in(dir, std::string("scenes info ") + name, 20);
    EXPECT_EQ(r.exit_code, 2) << name << ": " << r.output;
    EXPECT_TRUE(has(r, "is not a regular file")) << r.output;
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
  }
  // The same guard on every reader: a FIFO as hardware file or campaign.
  EXPECT_EQ(run_in(dir, "simulate --scene cornell --config fifo.toml --out-dir o", 20).exit_code, 2);
  EXPECT_EQ(run_in(dir, "campaign list fifo.toml", 20).exit_code, 2);
}

// ---------------------------------------------------------------- silent acceptance

// Before: exit 0 at 64x64 (sscanf %u wrapped 2^32 + 64).
TEST(BadInputRoundTwo, ResolutionsThatWouldWrapExitTwo) {
  const fs::path dir = fresh_folder("res");
  for (const char* cmd : {"trace --scene cornell --res 4294967360x64", "simulate --scene cornell --res 64x4294967360 --out-dir o",
                          "table1 --scene cornell --res 4294967360x64 --no-cycle", "scenes render cornell --res 64x64junk"}) {
    const CliResult r = run_in(dir, cmd);
    EXPECT_EQ(r.exit_code, 2) << cmd << ": " << r.output;
    EXPECT_TRUE(has(r, "--res")) << r.output;
  }
  write_text(dir / "c.toml", "[sweep]\nscene = \"cornell\"\nbuilder = \"sah\"\nresolution = \"4294967360x64\"\n");
  const CliResult c = run_in(dir, "campaign list c.toml");
  EXPECT_EQ(c.exit_code, 2) << c.output;
  EXPECT_TRUE(has(c, "key 'resolution'")) << c.output;
}

// Before: a folder as --config ran with the defaults, exit 0; `[clock_mhz]` was ignored.
TEST(BadInputRoundTwo, FolderOrEmptyTableAsHardwareConfigExitsTwo) {
  const fs::path dir = fresh_folder("config");
  fs::create_directories(dir / "cfg");
  const CliResult folder = run_in(dir, "simulate --scene cornell --res 8x8 --config cfg --out-dir o");
  EXPECT_EQ(folder.exit_code, 2) << folder.output;
  EXPECT_TRUE(has(folder, "cfg: is a folder, not a file")) << folder.output;
  write_text(dir / "empty.toml", "[clock_mhz]\n");
  const CliResult table = run_in(dir, "simulate --scene cornell --res 8x8 --config empty.toml --out-dir o");
  EXPECT_EQ(table.exit_code, 2) << table.output;
  EXPECT_TRUE(has(table, "empty.toml: clock_mhz: must be a number")) << table.output;
  // An empty section of real keys stays harmless.
  write_text(dir / "section.toml", "[l2]\n");
  EXPECT_EQ(run_in(dir, "simulate --scene cornell --res 8x8 --config section.toml --out-dir o").exit_code, 0);
}

// Before: last wins, exit 0 (TOML refuses the same).
TEST(BadInputRoundTwo, DuplicateJsonKeysExitTwo) {
  const fs::path dir = fresh_folder("dup");
  write_text(dir / "tri.obj", kTriangleObj);
  write_text(dir / "s.json", R"({"name": "a", "name": "b", "mesh": [{"file": "tri.obj"}],
      "camera": [{"name": "view1", "position": [0, 0, 1], "target": [0, 0, 0]}]})");
  const CliResult scene = run_in(dir, "scenes info s.json");
  EXPECT_EQ(scene.exit_code, 2) << scene.output;
  EXPECT_TRUE(has(scene, "s.json: key 'name': is defined twice")) << scene.output;
  write_text(dir / "c.json", R"({"campaign": {"name": "d", "name": "e"}, "sweep": {"scene": "cornell", "builder": "sah"}})");
  const CliResult campaign = run_in(dir, "campaign list c.json");
  EXPECT_EQ(campaign.exit_code, 2) << campaign.output;
  EXPECT_TRUE(has(campaign, "key 'campaign.name': is defined twice")) << campaign.output;
}

// Before: one of the two values silently dropped, exit 0.
TEST(BadInputRoundTwo, CampaignOverrideSetTwiceExitsTwo) {
  const fs::path dir = fresh_folder("set2");
  write_text(dir / "c.toml", "[sweep]\nscene = \"cornell\"\nbuilder = \"sah\"\n[sweep.set]\n"
                             "\"l2.size_bytes\" = 1024\nl2.size_bytes = 2048\n");
  const CliResult r = run_in(dir, "campaign list c.toml");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r, "key 'sweep.set.l2.size_bytes': is set twice")) << r.output;
}

// Before: `up` along the view direction was replaced silently, exit 0.
TEST(BadInputRoundTwo, UpParallelToTheViewExitsTwo) {
  const fs::path dir = fresh_folder("up");
  write_text(dir / "tri.obj", kTriangleObj);
  scene_with(dir, "tri.obj", "[[camera]]\nname = \"view1\"\nposition = [0, 0, 2]\ntarget = [0, 0, 0]\nup = [0, 0, -3]\n");
  const CliResult r = run_in(dir, "scenes info scene.toml");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r, "key 'camera[0].up': is parallel to the view direction")) << r.output;
}

// ---------------------------------------------------------------- output paths and exit codes

// Before: "internal error", exit 1, and simulate found out only after simulating.
// Now exit 2 at once: a cycle-level 4096x4096 run would take many minutes.
TEST(BadInputRoundTwo, WrongOutputPathsExitTwoBeforeAnyWork) {
  const fs::path dir = fresh_folder("out");
  write_text(dir / "file", "x");
  const struct {
    std::string args, flag;
  } cases[] = {
      {"simulate --scene interior --fidelity cycle --res 4096x4096 --out-dir file", "--out-dir file"},
      {"simulate --scene interior --fidelity cycle --res 4096x4096 --out-dir /sys/kernel/rtsim-test", "--out-dir"},
      {"simulate --scene interior --fidelity cycle --res 4096x4096 --out-dir file/sub", "'file' is a file"},
      {"trace --scene interior --res 4096x4096 --out-dir file", "--out-dir file"},
      {"trace --scene interior --res 4096x4096 --rays-out /sys/kernel/x.rays", "--rays-out"},
      {"build --scene interior --builder sbvh --out /sys/kernel/x.bvh", "--out /sys/kernel/x.bvh"},
      {"build --scene interior --builder sbvh --out .", "is a folder"},
      {"build --scene interior --all --out-dir file", "--out-dir file"},
      {"table1 --scene interior --out-dir file", "--out-dir file"},
      {"accuracy --scene interior --out-dir file", "--out-dir file"},
      {"scenes render interior --out /sys/kernel/x.png", "--out"},
  };
  for (const auto& c : cases) {
    const auto start = std::chrono::steady_clock::now();
    const CliResult r = run_in(dir, c.args, 60);
    EXPECT_EQ(r.exit_code, 2) << c.args << ": " << r.output;
    EXPECT_TRUE(has(r, c.flag)) << c.args << ": " << r.output;
    EXPECT_FALSE(has(r, "internal error")) << r.output;
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(20)) << c.args;
  }
  // Nothing was left behind by the refused commands.
  EXPECT_FALSE(fs::exists("/sys/kernel/rtsim-test"));
}

// Before: a text file was "internal error: file is not a database", exit 1; another
// program's database got rtsim's schema written into it.
TEST(BadInputRoundTwo, ReportOnAForeignFileExitsTwoAndChangesNothing) {
  const fs::path dir = fresh_folder("report");
  write_text(dir / "text.sqlite", std::string(200, 'x'));
  const CliResult text = run_in(dir, "report text.sqlite --out-dir r1 --no-figures");
  EXPECT_EQ(text.exit_code, 2) << text.output;
  EXPECT_TRUE(has(text, "text.sqlite: is not an SQLite database")) << text.output;
  ASSERT_EQ(rtsim::test::shell("sqlite3 " + shell_quote((dir / "other.sqlite").string()) +
                               " 'CREATE TABLE mine(x); INSERT INTO mine VALUES(1);'"),
            0);
  const std::string before = rtsim::read_input_file(dir / "other.sqlite", 1 << 20);
  const CliResult other = run_in(dir, "report other.sqlite --out-dir r2 --no-figures");
  EXPECT_EQ(other.exit_code, 2) << other.output;
  EXPECT_TRUE(has(other, "another program's database")) << other.output;
  EXPECT_EQ(rtsim::read_input_file(dir / "other.sqlite", 1 << 20), before) << "the database was modified";
  EXPECT_FALSE(fs::exists(dir / "r1"));
  EXPECT_FALSE(fs::exists(dir / "r2"));
  // A campaign writing into it is refused the same way.
  write_text(dir / "c.toml", "[campaign]\nname = \"c\"\n[sweep]\nscene = \"cornell\"\nbuilder = \"sah\"\n");
  const CliResult run = run_in(dir, "campaign run c.toml --db other.sqlite");
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_EQ(rtsim::read_input_file(dir / "other.sqlite", 1 << 20), before);
}

// Before: every tree built and traced, then exit 1 with the reason in runs/*.log and
// partial output left.
TEST(BadInputRoundTwo, Table1WithABadConfigExitsTwoBeforeBuildingAnything) {
  const fs::path dir = fresh_folder("table1");
  write_text(dir / "bad.toml", "clock_mhz = = 3\n");
  const CliResult r = run_in(dir, "table1 --scene cornell --res 16x16 --config bad.toml --out-dir t1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r, "--config: bad.toml")) << r.output;
  EXPECT_FALSE(fs::exists(dir / "t1")) << "partial output left";
}

// ---------------------------------------------------------------- campaigns

struct FakeCampaign {
  fs::path dir, fake;
  std::string rtsim(const std::string& args, const std::string& env = "") const {
    return "cd " + shell_quote(dir.string()) + " && " + env + " RTSIM_NO_PROGRESS=1 " + shell_quote(RTSIM_BINARY) +
           " " + args + " --rtsim " + shell_quote(fake.string()) + " 2>&1";
  }
};

FakeCampaign fake_campaign(const std::string& tag, const std::string& text) {
  FakeCampaign f;
  f.dir = fresh_folder(tag);
  f.fake = rtsim::test::write_fake_rtsim(f.dir);
  write_text(f.dir / "c.toml", text);
  return f;
}

// Before: exit 0 (the old ok rows were kept, so the store showed no failure).
TEST(CampaignsKeepTheirWord, ARunWhoseJobsFailExitsOneEvenWithForce) {
  const FakeCampaign f = fake_campaign("force", "[campaign]\nname = \"f\"\n[sweep]\nscene = \"cornell\"\nbuilder = \"sah\"\n");
  EXPECT_EQ(run_rtsim_command(f.rtsim("campaign run c.toml")).exit_code, 0);
  const CliResult forced = run_rtsim_command(f.rtsim("campaign run c.toml --force", "FAKE_FAIL_BUILDER=sah"));
  EXPECT_EQ(forced.exit_code, 1) << forced.output;
  // The reason is shown, not only "exit code 3".
  EXPECT_TRUE(has(forced, "builder sah refused on purpose")) << forced.output;
}

TEST(CampaignsKeepTheirWord, FailureReasonsAppearInRunAndStatus) {
  const FakeCampaign f = fake_campaign("reason", "[campaign]\nname = \"r\"\n[sweep]\nscene = \"cornell\"\nbuilder = \"sah\"\n");
  const CliResult run = run_rtsim_command(f.rtsim("campaign run c.toml", "FAKE_FAIL_BUILDER=sah"));
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_TRUE(has(run, "failed cornell/sah")) << run.output;
  EXPECT_TRUE(has(run, "exit code 3: fake: builder sah refused on purpose")) << run.output;
  const CliResult status = run_rtsim_command(f.rtsim("campaign status c.toml"));
  EXPECT_TRUE(has(status, "exit code 3: fake: builder sah refused on purpose")) << status.output;
  std::string command = f.rtsim("campaign status c.toml --json");
  command.replace(command.rfind(" 2>&1"), 5, " 2>/dev/null");
  const CliResult json = run_rtsim_command(command);
  ASSERT_EQ(json.exit_code, 0) << json.output;
  const auto j = nlohmann::json::parse(json.output);
  EXPECT_EQ(j["failed"], 1);
  EXPECT_NE(j["failures"][0]["reason"].get<std::string>().find("refused on purpose"), std::string::npos);
}

// Before: after editing the mesh, status still said "1 ok" (the key had only the
// descriptor's name).
TEST(CampaignsKeepTheirWord, AnEditedMeshMakesItsJobsMissingAgainAndStatusSaysWhy) {
  const FakeCampaign f = fake_campaign(
      "stale", "[campaign]\nname = \"s\"\n[sweep]\nscene = \"scene/scene.toml\"\nbuilder = [\"sah\", \"sbvh\"]\n");
  fs::create_directories(f.dir / "scene");
  write_text(f.dir / "scene" / "tri.obj", kTriangleObj);
  scene_with(f.dir / "scene", "tri.obj");
  ASSERT_EQ(run_rtsim_command(f.rtsim("campaign run c.toml")).exit_code, 0);
  EXPECT_TRUE(has(run_rtsim_command(f.rtsim("campaign status c.toml")), "2 ok, 0 failed, 0 missing"));
  write_text(f.dir / "scene" / "tri.obj", "v 0 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\n");  // the mesh changes
  const CliResult status = run_rtsim_command(f.rtsim("campaign status c.toml"));
  EXPECT_TRUE(has(status, "0 ok, 0 failed, 2 missing")) << status.output;
  EXPECT_TRUE(has(status, "the scene's files changed since its result")) << status.output;
  const CliResult rerun = run_rtsim_command(f.rtsim("campaign run c.toml"));
  EXPECT_EQ(rerun.exit_code, 0) << rerun.output;
  EXPECT_TRUE(has(rerun, "ran 2 (2 ok, 0 failed)")) << rerun.output;
}

// Before: status and export created an empty rtsim-campaigns/<name>/results.sqlite
// in whatever folder they ran from.
TEST(CampaignsKeepTheirWord, StatusAndExportReadOnlyAndFindTheFolderBesideTheFile) {
  const FakeCampaign f = fake_campaign("ro", "[campaign]\nname = \"ro\"\n[sweep]\nscene = \"cornell\"\nbuilder = \"sah\"\n");
  const fs::path elsewhere = f.dir / "elsewhere";
  fs::create_directories(elsewhere);
  auto in_elsewhere = [&](const std::string& args) {
    return run_rtsim_command("cd " + shell_quote(elsewhere.string()) + " && RTSIM_NO_PROGRESS=1 " +
                             shell_quote(RTSIM_BINARY) + " " + args + " --rtsim " + shell_quote(f.fake.string()) +
                             " 2>&1");
  };
  const std::string file = shell_quote((f.dir / "c.toml").string());
  EXPECT_EQ(in_elsewhere("campaign status " + file).exit_code, 0);
  EXPECT_EQ(in_elsewhere("campaign export " + file + " --csv").exit_code, 0);
  EXPECT_FALSE(fs::exists(elsewhere / "rtsim-campaigns")) << "a database appeared in the working folder";
  EXPECT_FALSE(fs::exists(f.dir / "rtsim-campaigns")) << "status or export created the campaign folder";
  // run, from anywhere, puts the campaign folder beside the campaign file.
  EXPECT_EQ(in_elsewhere("campaign run " + file).exit_code, 0);
  EXPECT_TRUE(fs::exists(f.dir / "rtsim-campaigns" / "ro" / "results.sqlite"));
  EXPECT_TRUE(has(in_elsewhere("campaign status " + file), "1 ok"));
}

// Unknown builders, scenes and cameras stop the campaign when it is read.
TEST(CampaignsKeepTheirWord, NamesAreCheckedBeforeAnyJob) {
  const fs::path dir = fresh_folder("names");
  const struct {
    const char* sweep;
    const char* message;
  } cases[] = {{"scene = \"cornel\"\nbuilder = \"sah\"\n", "key 'scene'"},
               {"scene = \"cornell\"\nbuilder = \"sahh\"\n", "unknown builder 'sahh'"},
               {"scene = \"cornell\"\nbuilder = \"sah\"\ncamera = \"view3\"\n", "has no camera 'view3'"}};
  for (const auto& c : cases) {
    write_text(dir / "c.toml", std::string("[sweep]\n") + c.sweep);
    const CliResult r = run_in(dir, "campaign run c.toml");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_TRUE(has(r, c.message)) << r.output;
    EXPECT_FALSE(fs::exists(dir / "rtsim-campaigns"));
  }
}

// Before: a damaged tree in the cache failed every job that replayed it, for ever.
TEST(CampaignsKeepTheirWord, ADamagedCachedTreeIsDetectedAndRebuilt) {
  const fs::path dir = fresh_folder("tree");
  write_text(dir / "c.toml", "[campaign]\nname = \"t\"\n[sweep]\nscene = \"cornell\"\nbuilder = \"sah\"\n"
                             "resolution = \"8x8\"\n");
  const std::string run = "campaign run c.toml --tree-cache trees";
  ASSERT_EQ(run_in(dir, run).exit_code, 0);
  fs::path tree;
  for (const auto& e : fs::directory_iterator(dir / "trees"))
    if (e.path().extension() == ".bvh") tree = e.path();
  ASSERT_FALSE(tree.empty());
  const auto size = fs::file_size(tree);
  fs::resize_file(tree, size / 2);  // an interrupted copy
  const CliResult again = run_in(dir, run + " --force");
  EXPECT_EQ(again.exit_code, 0) << again.output;
  EXPECT_TRUE(has(again, "is damaged")) << again.output;
  EXPECT_EQ(fs::file_size(tree), size);
}

// RTSIM_RESULTS_CACHE names the default results cache (the suite runs with "off"): a
// renamed campaign reuses the first one's run from the folder it names.
TEST(CampaignsKeepTheirWord, ResultsCacheFromTheEnvironmentIsUsedAndOffRunsTheJobs) {
  const fs::path dir = fresh_folder("results_env");
  const auto run = [&](const std::string& name, const std::string& env) {
    write_text(dir / (name + ".toml"), "[campaign]\nname = \"" + name +
                                           "\"\n[sweep]\nscene = \"cornell\"\nbuilder = \"sah\"\n"
                                           "resolution = \"8x8\"\n");
    return run_rtsim_command("cd " + shell_quote(dir.string()) + " && RTSIM_NO_PROGRESS=1 " + env + " " +
                             shell_quote(RTSIM_BINARY) + " campaign run " + name + ".toml --no-tree-cache 2>&1");
  };
  const std::string cache = "RTSIM_RESULTS_CACHE=" + shell_quote((dir / "results").string());
  const CliResult first = run("first", cache);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  EXPECT_FALSE(has(first, "reused")) << first.output;
  const CliResult renamed = run("renamed", cache);
  ASSERT_EQ(renamed.exit_code, 0) << renamed.output;
  EXPECT_TRUE(has(renamed, "1 reused from the results cache")) << renamed.output;
  const CliResult off = run("off", "RTSIM_RESULTS_CACHE=off");
  ASSERT_EQ(off.exit_code, 0) << off.output;
  EXPECT_FALSE(has(off, "reused")) << off.output;
}

// ---------------------------------------------------------------- validation

// Before: exit 1 on cornell at 64x64 (one ray Embree hits through a box corner it
// misses by 3e-8). Now the referee rules, and only a wrong core fails.
TEST(ValidationReferee, CornellAt64x64PassesWithTheRefereesCounts) {
  const fs::path dir = fresh_folder("validate");
  const CliResult r = run_in(dir, "trace --scene cornell --res 64x64 --validate --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_GE(j["validate"]["embree_wrong"].get<int>(), 1);
  EXPECT_EQ(j["validate"]["core_wrong"].get<int>(), 0);
  const CliResult text = run_in(dir, "trace --scene cornell --res 64x64 --validate");
  EXPECT_TRUE(has(text, "Embree wrong")) << text.output;
  EXPECT_TRUE(has(text, "referee: Embree wrong")) << text.output;
}

// ---------------------------------------------------------------- one command line

TEST(OneCommandLine, NoArgumentsListsTheSubcommands) {
  const CliResult r = run_rtsim("");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  for (const char* sub : {"scenes", "build", "trace", "simulate", "campaign", "table1", "accuracy", "report"})
    EXPECT_TRUE(has(r, std::string("\n  ") + sub)) << sub << ": " << r.output;
}

// Old spellings still work, with a warning naming the new one; errors name the
// spelling typed.
TEST(OneCommandLine, DeprecatedSpellingsWorkWithAWarning) {
  const fs::path dir = fresh_folder("alias");
  const CliResult sim = run_in(dir, "simulate --scene cornell --res 8x8 --out old --max-depth 1");
  EXPECT_EQ(sim.exit_code, 0) << sim.output;
  EXPECT_TRUE(has(sim, "--out is deprecated; use --out-dir")) << sim.output;
  EXPECT_TRUE(has(sim, "--max-depth (the bounce count in trace and simulate")) << sim.output;
  EXPECT_TRUE(fs::exists(dir / "old" / "stats.json"));
  const auto config = nlohmann::json::parse(rtsim::read_input_file(dir / "old" / "config.json", 1 << 20));
  EXPECT_EQ(config["inputs"]["bounces"], 1);
  // The error names --out, the spelling typed, not --out-dir.
  write_text(dir / "file", "x");
  const CliResult typed = run_in(dir, "simulate --scene cornell --res 8x8 --out file");
  EXPECT_EQ(typed.exit_code, 2);
  EXPECT_TRUE(has(typed, "--out file: exists and is not a folder")) << typed.output;
  const CliResult render = run_in(dir, "scenes render cornell --width 16 --height 8 -o p.png");
  EXPECT_EQ(render.exit_code, 0) << render.output;
  EXPECT_TRUE(has(render, "--width is deprecated; use --res")) << render.output;
  EXPECT_TRUE(has(render, "16x8")) << render.output;
  const CliResult layout = run_in(dir, "trace --scene cornell --res 8x8 --node-layout single --json");
  EXPECT_EQ(layout.exit_code, 0) << layout.output;
  EXPECT_TRUE(has(layout, "\"node_format\": \"bvh2-32\"")) << layout.output;
  EXPECT_TRUE(has(layout, "--node-layout single is deprecated; use --node-format bvh2-32")) << layout.output;
  // Ray files: --rays-in on both, simulate's --rays kept as an alias.
  ASSERT_EQ(run_in(dir, "trace --scene cornell --res 8x8 --ao 0 --rays-out r.rays").exit_code, 0);
  const CliResult rays = run_in(dir, "simulate --scene cornell --rays r.rays --out-dir replay");
  EXPECT_EQ(rays.exit_code, 0) << rays.output;
  EXPECT_TRUE(has(rays, "--rays is deprecated; use --rays-in")) << rays.output;
  // The campaign folder: --out-dir, with --dir kept.
  write_text(dir / "c.toml", "[campaign]\nname = \"a\"\n[sweep]\nscene = \"cornell\"\nbuilder = \"sah\"\n");
  const CliResult campaign = run_in(dir, "campaign status c.toml --dir somewhere");
  EXPECT_EQ(campaign.exit_code, 0) << campaign.output;
  EXPECT_TRUE(has(campaign, "--dir is deprecated; use --out-dir")) << campaign.output;
  // One default image size: 256x256 in simulate as in trace (simulate had 128x128).
  ASSERT_EQ(run_in(dir, "simulate --scene cornell --ao 0 --out-dir default").exit_code, 0);
  const auto defaults = nlohmann::json::parse(rtsim::read_input_file(dir / "default" / "config.json", 1 << 20));
  EXPECT_EQ(defaults["inputs"]["resolution"], nlohmann::json({256, 256}));
  // The new spellings take no warning.
  const CliResult fresh = run_in(dir, "simulate --scene cornell --res 8x8 --out-dir new --bounces 1");
  EXPECT_EQ(fresh.exit_code, 0);
  EXPECT_FALSE(has(fresh, "deprecated")) << fresh.output;
}

// Internal field names stay inside: the flag the user typed is named.
TEST(OneCommandLine, ErrorsNameTheFlagNotTheField) {
  const fs::path dir = fresh_folder("flags");
  const CliResult budget = run_in(dir, "build --scene cornell --builder sbvh --sbvh-budget 0.5");
  EXPECT_EQ(budget.exit_code, 2);
  EXPECT_TRUE(has(budget, "--sbvh-budget: must be >= 1")) << budget.output;
  EXPECT_FALSE(has(budget, "sbvh_reference_budget")) << budget.output;
  const CliResult stack = run_in(dir, "trace --scene cornell --res 8x8 --stack-limit 0");
  EXPECT_EQ(stack.exit_code, 2);
  EXPECT_TRUE(has(stack, "--stack-limit: must be at least 1")) << stack.output;
  EXPECT_FALSE(has(stack, "traversal.stack_limit")) << stack.output;
}

// --json on the subcommands that print results, scenes list and campaign status included.
TEST(OneCommandLine, JsonWhereResultsArePrinted) {
  const fs::path dir = fresh_folder("json");
  for (const char* args : {"scenes list --json", "scenes info cornell --json", "build --scene cornell --json",
                           "trace --scene cornell --res 8x8 --json",
                           "simulate --scene cornell --res 8x8 --out-dir s --json",
                           "scenes render cornell --res 8x8 --out p.png --json"}) {
    const CliResult r = run_in(dir, args, 300, true);
    ASSERT_EQ(r.exit_code, 0) << args << ": " << r.output;
    EXPECT_TRUE(nlohmann::json::accept(r.output)) << args << ": " << r.output;
  }
  write_text(dir / "c.toml", "[campaign]\nname = \"j\"\n[sweep]\nscene = \"cornell\"\nbuilder = \"sah\"\n");
  const CliResult status = run_in(dir, "campaign status c.toml --json", 60, true);
  ASSERT_EQ(status.exit_code, 0) << status.output;
  EXPECT_EQ(nlohmann::json::parse(status.output)["missing"], 1);
  const auto list = nlohmann::json::parse(run_in(dir, "scenes list --json", 60, true).output);
  bool cornell = false;
  for (const auto& s : list["scenes"]) cornell |= s["name"] == "cornell" && s["available"] == true;
  EXPECT_TRUE(cornell);
}

// Every text table fits 120 columns; table1 --wide has the full one.
TEST(OneCommandLine, TextTablesFitOneHundredTwentyColumns) {
  const fs::path dir = fresh_folder("width");
  auto widest = [](const std::string& text, std::string* line_out) {
    size_t widest_line = 0;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);)
      // Table rows: two spaces between columns (indentation before the first word does not count).
      if (line.find("  ", line.find_first_not_of(' ') == std::string::npos ? 0 : line.find_first_not_of(' ')) !=
              std::string::npos &&
          line.size() > widest_line) {
        widest_line = line.size();
        *line_out = line;
      }
    return widest_line;
  };
  for (const char* args : {"build --scene cornell --all --no-epo", "trace --scene cornell --res 8x8", "scenes list", "",
                           "--help", "trace --help", "build --help", "simulate --help", "campaign --help", "scenes --help",
                           "table1 --scene cornell --res 16x16 --no-cycle --out-dir t"}) {
    const CliResult r = run_in(dir, args, 300, true);
    ASSERT_EQ(r.exit_code, 0) << args << ": " << r.output;
    std::string line;
    EXPECT_LE(widest(r.output, &line), 120u) << args << ":\n" << line;
  }
  const CliResult wide = run_in(dir, "table1 --scene cornell --res 16x16 --no-cycle --out-dir t --wide", 300, true);
  ASSERT_EQ(wide.exit_code, 0);
  EXPECT_TRUE(has(wide, "fetch red. vs median")) << wide.output;
  std::string line;
  EXPECT_GT(widest(wide.output, &line), 120u);
}

// Before: table1 ignored --osah-resolution (OSAH always cast the frame's rays).
TEST(OneCommandLine, Table1HonoursOsahResolution) {
  const fs::path dir = fresh_folder("osah");
  ASSERT_EQ(run_in(dir, "table1 --scene cornell --res 16x16 --no-cycle --builders osah --osah-resolution 7 --out-dir t")
                .exit_code,
            0);
  const CliResult tree = run_in(dir, "build --scene cornell --load t/trees/osah-view1.bvh --json --no-epo", 60, true);
  ASSERT_EQ(tree.exit_code, 0) << tree.output;
  const auto j = nlohmann::json::parse(tree.output);
  EXPECT_EQ(j["trees"][0]["parameters"]["osah_width"], 7) << tree.output;
  // Without the flag OSAH samples its visibility as build and trace do (256x256),
  // not at the frame's resolution: one OSAH tree everywhere.
  ASSERT_EQ(run_in(dir, "table1 --scene cornell --res 16x16 --no-cycle --builders osah --build-seeds 1 --out-dir u")
                .exit_code,
            0);
  const CliResult plain = run_in(dir, "build --scene cornell --load u/trees/osah-view1.bvh --json --no-epo", 60, true);
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  const auto p = nlohmann::json::parse(plain.output)["trees"][0]["parameters"];
  EXPECT_EQ(p["osah_width"], rtsim::BuildParams{}.osah_width) << plain.output;
  EXPECT_EQ(p["osah_height"], rtsim::BuildParams{}.osah_height) << plain.output;
}

// A sampled builder's costs over several seeds; a builder that draws no random
// rays has no spread to report.
TEST(OneCommandLine, BuildReportsTheSeedSpreadOfSampledBuilders) {
  const fs::path dir = fresh_folder("spread");
  const CliResult ao = run_in(dir, "build --scene cornell --builder aobvh --seed-spread 3 --no-epo --json", 60, true);
  ASSERT_EQ(ao.exit_code, 0) << ao.output;
  const auto tree = nlohmann::json::parse(ao.output)["trees"][0];
  ASSERT_TRUE(tree["seed_spread"].is_object()) << ao.output;
  EXPECT_EQ(tree["seed_spread"]["seeds"], 3);
  const auto& sah = tree["seed_spread"]["sah_cost"];
  EXPECT_LE(sah["min"].get<double>(), tree["sah_cost"].get<double>());
  EXPECT_GE(sah["max"].get<double>(), tree["sah_cost"].get<double>());
  EXPECT_LE(sah["lo95"].get<double>(), sah["mean"].get<double>());
  EXPECT_LE(sah["mean"].get<double>(), sah["hi95"].get<double>());
  EXPECT_LT(sah["min"].get<double>(), sah["max"].get<double>()) << "three seeds gave one tree";
  const CliResult plain = run_in(dir, "build --scene cornell --builder sah --seed-spread 3 --no-epo --json", 60, true);
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  EXPECT_FALSE(nlohmann::json::parse(plain.output)["trees"][0].contains("seed_spread"));
}

// Before: the BSP loader's dropped sky and textures/common faces were counted
// nowhere; now `scenes info` reports both (the counting itself:
// tests/workloads/test_loaders.cpp, Q3Bsp.LeftOutSkyAndToolFacesAreCounted*).
TEST(OneCommandLine, ScenesInfoReportsTheFacesTheLoaderLeavesOut) {
  const fs::path dir = fresh_folder("bsp");
  const CliResult r = run_in(dir, "scenes info cornell --json", 60, true);
  ASSERT_EQ(r.exit_code, 0);
  const auto v = nlohmann::json::parse(r.output)["validation"];
  EXPECT_EQ(v["dropped_sky_faces"], 0);
  EXPECT_EQ(v["dropped_tool_faces"], 0);
}

// Before: trace --threads 1 built its tree on every core (2 threads on a 2-core
// machine); the build honours it now. Measured as the most threads the process
// ever had, sampled from /proc while it builds an SBVH of the interior scene.
TEST(OneCommandLine, TraceThreadsLimitsTheBuildToo) {
  if (std::thread::hardware_concurrency() < 2) GTEST_SKIP() << "one core: nothing to limit";
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::setenv("RTSIM_NO_PROGRESS", "1", 1);
    const int null_fd = ::open("/dev/null", O_WRONLY);
    ::dup2(null_fd, 1);
    ::dup2(null_fd, 2);
    ::execl(RTSIM_BINARY, RTSIM_BINARY, "trace", "--scene", "interior", "--builder", "sbvh", "--threads", "1",
            "--res", "8x8", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  int most = 0, status = 0;
  const std::string proc = "/proc/" + std::to_string(pid) + "/status";
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    std::ifstream in(proc);
    for (std::string line; std::getline(in, line);)
      if (line.rfind("Threads:", 0) == 0) most = std::max(most, std::stoi(line.substr(8)));
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  EXPECT_EQ(most, 1);
}

// aosbvh is a builder; --help and the builder list say so.
TEST(OneCommandLine, EveryBuilderIsListed) {
  const CliResult help = run_rtsim("build --help");
  const CliResult list = run_rtsim("build --list-builders");
  for (const char* b : {"sah", "median", "sbvh", "osah", "aobvh", "aosbvh", "embree", "embree-sbvh"}) {
    EXPECT_TRUE(has(help, b)) << b;
    EXPECT_TRUE(has(list, std::string(b) + "\n")) << b;
  }
  EXPECT_TRUE(has(run_rtsim("trace --help"), "aosbvh"));
}

}  // namespace

// table1 --node-formats: one Table 1 per format, side by side, with the finding.
TEST(NodeFormats, Table1ComparesFormatsAndStatesTheFinding) {
  const fs::path dir = fresh_folder("table1-formats");
  const CliResult r = run_in(dir, "table1 --scene cornell --res 16x16 --no-cycle --builders sah sbvh aobvh "
                                  "--node-formats bvh2-64 bvh8-80q --out-dir t");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* f : {"t/bvh2-64/table1.json", "t/bvh8-80q/table1.json", "t/formats.md", "t/formats.csv"})
    EXPECT_TRUE(fs::exists(dir / f)) << f;
  const std::string md = rtsim::read_input_file(dir / "t" / "formats.md", 1 << 20);
  EXPECT_NE(md.find("AO-BVH against SBVH"), std::string::npos) << md;
  EXPECT_NE(md.find("in bvh8-80q"), std::string::npos) << md;
  const auto wide = nlohmann::json::parse(rtsim::read_input_file(dir / "t" / "bvh8-80q" / "table1.json", 1 << 20));
  EXPECT_EQ(wide["node_format"], "bvh8-80q");
  EXPECT_NE(wide["counting_rule"].get<std::string>().find("up to 8 child boxes"), std::string::npos);
  // A wide node visit tests more boxes than a binary one.
  for (const auto& row : wide["rows"])
    EXPECT_GT(row["combined"]["box_tests_per_ray"].get<double>(), 2 * row["combined"]["trv_ops_per_ray"].get<double>());
  const CliResult bad = run_in(dir, "table1 --scene cornell --no-cycle --node-formats bvh2-64 bvh5 --out-dir u");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_TRUE(has(bad, "--node-formats")) << bad.output;
  EXPECT_TRUE(has(bad, "bvh8-80q")) << bad.output;
}
