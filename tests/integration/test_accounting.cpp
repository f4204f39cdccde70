// Cycle accounting that adds up (model/sim/accounting.h): every unit's cycles split
// exclusively into busy, waiting on L1 / crossbar / L2 / DRAM, blocked, waiting on
// IST, latency and idle, at every level and on machines with and without a real
// crossbar; the machine roll-ups are those of the units; cycles per ray type add up
// to the units' busy cycles; a write-back is charged to the ray type that wrote it.
#include "cli_runner.h"
#include "stats_support.h"

#include <rtsim/model/core/ray_file.h>
#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/ray_reorder.h>

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <regex>
#include <set>

namespace {

using Stats = std::map<std::string, nlohmann::json>;
using rtsim::sim::CycleBucket;
using rtsim::sim::UnitKind;

struct Machine {
  const char* name;
  const char* toml;
};
// A one-core accelerator with an ideal crossbar, and two mobile-GPU cores with a
// timed crossbar, sliced L2 and LPDDR5 (every waiting bucket can fill).
const Machine kMachines[] = {{"mobile", "preset = \"mobile\"\n"},
                             {"gpu", "preset = \"mobile-gpu\"\ncores = 2\n"}};

// cornell has a light: shadow rays, so shading is elaborated too.
Stats run(const std::string& level, const Machine& machine, const std::filesystem::path& dir,
          const std::string& extra = "", const std::string& scene = "cornell") {
  const std::string config = (dir / "machine.toml").string();
  std::ofstream(config) << machine.toml;
  const CliResult r = run_rtsim("simulate --scene " + scene + " --res 24x24 --fidelity " + level + " --config " + config +
                                " --out-dir " + (dir / "out").string() + " " + extra);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return read_stats(dir / "out");
}

UnitKind kind_of(const std::string& unit) {
  if (unit.find(".trv") != std::string::npos) return UnitKind::Trv;
  if (unit.find(".ist") != std::string::npos) return UnitKind::Ist;
  return UnitKind::Shading;
}

// Every unit instance that reports a cycle split: core0.trv1, core1.shading, ...
std::vector<std::string> units(const Stats& s) {
  std::vector<std::string> out;
  const std::regex unit(R"((core\d+\.(trv\d+|ist\d+|shading))\.busy_cycles)");
  std::smatch m;
  for (const auto& [key, value] : s)
    if (std::regex_match(key, m, unit)) out.push_back(m[1]);
  return out;
}

class Accounting : public testing::TestWithParam<std::tuple<std::string, int>> {};

}  // namespace

TEST_P(Accounting, EveryUnitsCyclesAddUpToTheRunsCycles) {
  const auto& [level, machine_index] = GetParam();
  const Machine& machine = kMachines[machine_index];
  const auto dir = scratch_folder("accounting", level + "_" + machine.name);
  const Stats s = run(level, machine, dir);
  const uint64_t total = s.at("time.cycles").get<uint64_t>();
  ASSERT_GT(total, 0u);
  const std::vector<std::string> all = units(s);
  std::set<UnitKind> kinds;
  for (const std::string& unit : all) {
    const UnitKind kind = kind_of(unit);
    kinds.insert(kind);
    uint64_t sum = 0;
    for (CycleBucket b : rtsim::sim::kAllCycleBuckets) {
      const std::string key = unit + "." + rtsim::sim::cycle_bucket_name(b) + "_cycles";
      // A unit reports exactly the buckets its kind can be in.
      ASSERT_EQ(s.count(key) == 1, rtsim::sim::unit_traits(kind).has(b)) << key;
      if (s.count(key)) sum += s.at(key).get<uint64_t>();
    }
    EXPECT_EQ(sum, total) << unit;
    EXPECT_DOUBLE_EQ(stat_number(s, unit + ".utilisation"), stat_number(s, unit + ".busy_cycles") / double(total))
        << unit;
    if (kind == UnitKind::Trv) {
      // One pass a cycle (both machines), a pipeline interval of whole picoseconds: busy
      // is the passes' time and nothing else.
      const double cycle_ps = 1e6 / stat_number(s, "time.clock_mhz");
      const double pass_ps = level == "functional" ? cycle_ps : std::round(cycle_ps);  // untimed: exact
      const auto busy = uint64_t(std::llround(stat_number(s, unit + ".passes") * pass_ps / cycle_ps));
      EXPECT_EQ(s.at(unit + ".busy_cycles").get<uint64_t>(), std::min(total, busy)) << unit;
    }
  }
  EXPECT_EQ(kinds.size(), 3u) << "TRV, IST and shading units";
  // The roll-ups are the units' mean, least and most.
  for (UnitKind kind : kinds)
    for (CycleBucket b : rtsim::sim::kAllCycleBuckets) {
      if (!rtsim::sim::unit_traits(kind).has(b)) continue;
      const std::string name = std::string(rtsim::sim::cycle_bucket_name(b)) + "_cycles";
      double sum = 0, lo = INFINITY, hi = -INFINITY;
      int n = 0;
      for (const std::string& unit : all)
        if (kind_of(unit) == kind) {
          const double v = stat_number(s, unit + "." + name);
          sum += v, lo = std::min(lo, v), hi = std::max(hi, v), ++n;
        }
      const std::string p = std::string("machine.") + rtsim::sim::unit_traits(kind).name + "." + name;
      EXPECT_DOUBLE_EQ(stat_number(s, p + ".mean"), sum / n) << p;
      EXPECT_EQ(stat_number(s, p + ".min"), lo) << p;
      EXPECT_EQ(stat_number(s, p + ".max"), hi) << p;
    }
  if (level == "functional") {
    // No time modelled: a unit is busy or idle.
    for (const std::string& unit : all)
      EXPECT_EQ(s.at(unit + ".busy_cycles").get<uint64_t>() + s.at(unit + ".idle_cycles").get<uint64_t>(), total);
  } else if (std::string(machine.name) == "gpu") {
    // Two cores on LPDDR5 behind a real crossbar wait on all of it.
    for (const char* bucket : {"waiting_l1", "waiting_noc", "waiting_l2", "waiting_dram"})
      EXPECT_GT(stat_number(s, std::string("machine.trv.") + bucket + "_cycles.max"), 0) << bucket;
  }
  std::filesystem::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(
    Levels, Accounting,
    testing::Combine(testing::Values("functional", "lt", "cycle"), testing::Values(0, 1)),
    [](const testing::TestParamInfo<std::tuple<std::string, int>>& info) {
      return std::get<0>(info.param) + "_" + kMachines[std::get<1>(info.param)].name;
    });

// Cycles per ray type are the units' busy cycles, split by whose work they were.
TEST(Accounting, BusyCyclesByRayTypeAddUpToTheUnits) {
  const auto dir = scratch_folder("accounting", "by_type");
  const Stats s = run("cycle", kMachines[1], dir);
  for (const char* unit : {"trv", "ist"}) {
    double by_type = 0, by_unit = 0;
    int units_seen = 0;
    for (rtsim::RayType t : rtsim::kAllRayTypes) {
      const std::string key = std::string("per_type.") + rtsim::ray_type_name(t) + "." + unit + "_busy_cycles";
      if (s.count(key)) by_type += stat_number(s, key);
    }
    const std::regex busy(std::string(R"(core\d+\.)") + unit + R"(\d+\.busy_cycles)");
    for (const auto& [key, value] : s)
      if (std::regex_match(key, busy)) by_unit += value.get<double>(), ++units_seen;
    ASSERT_GT(units_seen, 0) << unit;
    // Each unit's busy cycles are its busy time rounded once.
    EXPECT_NEAR(by_type, by_unit, 0.5 * units_seen) << unit;
  }
  for (const char* type : {"primary", "shadow"})
    EXPECT_GT(stat_number(s, std::string("per_type.") + type + ".cycles_per_ray"), 0) << type;
  std::filesystem::remove_all(dir);
}

// Stack spills of AO rays only: every stack line the L1s write back to the L2 is
// AO traffic, whichever ray's miss pushed it out (the cycle level's fills charged
// them to primary rays before issue 35).
TEST(Accounting, WriteBacksAreChargedToTheRaysThatWroteThem) {
  const auto dir = scratch_folder("accounting", "writeback");
  const CliResult made = run_rtsim("trace --scene interior --res 24x24 --rays-out " + (dir / "all.rays").string());
  ASSERT_EQ(made.exit_code, 0) << made.output;
  rtsim::RaySet set = rtsim::read_ray_file((dir / "all.rays").string());
  std::vector<rtsim::Ray> ao;
  for (const rtsim::Ray& r : set.rays)
    if (r.type == rtsim::RayType::Ao) {
      ao.push_back(r);
      ao.back().parent = rtsim::kNoParent;  // replayed alone
    }
  ASSERT_GT(ao.size(), 100u);
  set.rays = ao;
  rtsim::write_ray_file((dir / "ao.rays").string(), set);
  // Two on-chip stack entries spill nearly every push; a 1 KiB L1 evicts the spills.
  const Machine tiny{"tiny", "preset = \"mobile\"\ntrv.stack_entries = 2\nl1_node.size_bytes = 1024\n"};
  for (const std::string level : {"lt", "cycle"}) {
    const Stats s = run(level, tiny, dir, "--rays-in " + (dir / "ao.rays").string(), "interior");
    EXPECT_GT(stat_number(s, "l1_node.all.writebacks"), 0) << level;
    EXPECT_GT(stat_number(s, "l2.bytes_requested.ao.stack"), 0) << level;
    for (const auto& [key, value] : s)
      if (key.rfind("l2.bytes_requested.", 0) == 0 && key != "l2.bytes_requested.total")
        EXPECT_EQ(key.find(".ao."), std::string("l2.bytes_requested").size()) << level << " " << key;
  }
  std::filesystem::remove_all(dir);
}

// The ray-reordering unit's own accounting (timed levels): its cycles add up, busy is
// the sort latency of each batch it formed, and the machine roll-up covers it.
TEST(Accounting, TheReorderingUnitsCyclesAddUpAndBusyIsItsSorts) {
  const Machine gpu{"gpu_reorder", "preset = \"mobile-gpu\"\ncores = 2\nreorder.batch_rays = 16\n"};
  rtsim::sim::HardwareConfig c;
  c.reorder_stage_cycles = 1;
  const uint64_t sort_cycles = rtsim::sim::reorder_sort_cycles(c, 16);  // mobile-gpu: one cycle a stage
  for (const std::string level : {"lt", "cycle"}) {
    const auto dir = scratch_folder("accounting", "reorder_" + level);
    const Stats s = run(level, gpu, dir);
    const uint64_t total = s.at("time.cycles").get<uint64_t>();
    double busy = 0;
    for (const std::string unit : {"core0.reorder", "core1.reorder"}) {
      uint64_t sum = 0;
      for (CycleBucket b : rtsim::sim::kAllCycleBuckets) {
        const std::string key = unit + "." + rtsim::sim::cycle_bucket_name(b) + "_cycles";
        ASSERT_EQ(s.count(key) == 1, rtsim::sim::RayReorderUnit::description().traits->has(b)) << level << " " << key;
        if (s.count(key)) sum += s.at(key).get<uint64_t>();
      }
      EXPECT_EQ(sum, total) << level << " " << unit;
      EXPECT_GT(stat_number(s, unit + ".blocked_cycles"), 0) << level << " " << unit;
      busy += stat_number(s, unit + ".busy_cycles");
    }
    // Each core's busy time is its batches' sorts, rounded once per core.
    EXPECT_NEAR(busy, stat_number(s, "reorder.batches") * double(sort_cycles), 1.0) << level;
    EXPECT_DOUBLE_EQ(stat_number(s, "machine.reorder.busy_cycles.mean"), busy / 2) << level;
    std::filesystem::remove_all(dir);
  }
}

// stats.accounting = "off" only stops the accounting: every stat but the split, the
// utilisation and the roll-ups is the same as with it on (so no unit's behaviour
// leans on it), at lt and cycle, on two cores with shading, reordering and the
// any-hit stage. The timeline, which draws the accounting, is refused by name.
TEST(Accounting, OffDropsItsOwnStatsAndChangesNoOther) {
  const std::string machine = "preset = \"mobile-gpu\"\ncores = 2\nreorder.batch_rays = 16\n";
  const Machine on{"gpu_on", machine.c_str()};
  const std::string off_text = machine + "[stats]\naccounting = \"off\"\n";
  const Machine off{"gpu_off", off_text.c_str()};
  // The accounting's own stats: each unit's buckets and utilisation, and the machine roll-ups.
  std::string buckets;
  for (CycleBucket k : rtsim::sim::kAllCycleBuckets) buckets += (buckets.empty() ? "" : "|") + std::string(rtsim::sim::cycle_bucket_name(k));
  const std::regex accounting_stat(R"(core\d+\.(trv\d+|ist\d+|shading|reorder)\.()" + buckets +
                                   R"()_cycles|core\d+\.(trv\d+|ist\d+|shading|reorder)\.utilisation|)"
                                   R"(machine\.(trv|ist|shading|reorder)\..*)");
  for (const std::string scene : {"cornell", "foliage_alpha"})
    for (const std::string level : {"lt", "cycle"}) {
      const auto dir_on = scratch_folder("accounting", "on_" + level + scene);
      const auto dir_off = scratch_folder("accounting", "off_" + level + scene);
      const Stats a = run(level, on, dir_on, "", scene), b = run(level, off, dir_off, "", scene);
      size_t dropped = 0;
      for (const auto& [key, value] : a) {
        if (std::regex_match(key, accounting_stat)) {
          EXPECT_EQ(b.count(key), 0u) << level << " " << scene << " " << key;
          ++dropped;
        } else {
          ASSERT_EQ(b.count(key), 1u) << level << " " << scene << " " << key;
          EXPECT_EQ(b.at(key), value) << level << " " << scene << " " << key;
        }
      }
      EXPECT_EQ(a.size(), b.size() + dropped) << level << " " << scene;  // nothing new either
      EXPECT_GT(dropped, 0u);
      std::filesystem::remove_all(dir_on);
      std::filesystem::remove_all(dir_off);
    }
  const auto dir = scratch_folder("accounting", "off_timeline");
  std::ofstream(dir / "machine.toml") << off_text;
  const CliResult r = run_rtsim("simulate --scene cornell --res 8x8 --fidelity lt --config " +
                                (dir / "machine.toml").string() + " --timeline " + (dir / "t.json").string() +
                                " --out-dir " + (dir / "out").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--timeline"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("stats.accounting"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "t.json"));
  std::filesystem::remove_all(dir);
}
