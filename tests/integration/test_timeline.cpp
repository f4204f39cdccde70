// simulate --timeline (model/sim/timeline.h): the Chrome / Perfetto trace-event
// format a viewer opens (named tracks, complete events that never overlap on a
// row), every kind of span the machine has, unit spans that add up to the cycle
// accounting in stats.json, the window and the cap, and bad input refused up front
// with no file left behind.
#include "cli_runner.h"
#include "stats_support.h"

#include <rtsim/model/sim/accounting.h>

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <regex>
#include <set>

namespace {

using nlohmann::json;

const char* kMachine = "preset = \"mobile-gpu\"\ncores = 2\n";

struct TimelineRun {
  CliResult result;
  std::filesystem::path dir, timeline;
};

TimelineRun simulate(const std::string& name, const std::string& level, const std::string& extra) {
  TimelineRun r;
  r.dir = scratch_folder("timeline", name);
  std::ofstream(r.dir / "machine.toml") << kMachine;
  r.timeline = r.dir / "run.json";
  r.result = run_rtsim("simulate --scene cornell --res 24x24 --fidelity " + level + " --config " +
                       (r.dir / "machine.toml").string() + " --out-dir " + (r.dir / "out").string() +
                       " --timeline " + r.timeline.string() + " " + extra);
  return r;
}

json read_json(const std::filesystem::path& file) {
  std::ifstream in(file);
  return json::parse(in);
}

// Microseconds written to within half a picosecond, back to picoseconds.
uint64_t ps(double us) { return uint64_t(std::llround(us * 1e6)); }

struct Span {
  std::string name;
  uint64_t start, end;
  double start_us, end_us;  // as a viewer reads them: ts, and ts + dur added in doubles
  double dur_us;
};

// Rows (thread names) and their spans, checking the format on the way.
std::map<std::string, std::vector<Span>> rows_of(const json& trace) {
  EXPECT_TRUE(trace.at("traceEvents").is_array());
  EXPECT_EQ(trace.at("displayTimeUnit"), "ns");
  std::map<std::pair<int, int>, std::string> names;
  std::set<int> processes;
  std::map<std::pair<int, int>, std::vector<Span>> spans;
  for (const json& e : trace.at("traceEvents")) {
    const std::string ph = e.at("ph");
    const std::pair<int, int> row{e.at("pid").get<int>(), e.value("tid", 0)};
    if (ph == "M") {
      if (e.at("name") == "thread_name") names[row] = e.at("args").at("name");
      if (e.at("name") == "process_name") processes.insert(row.first);
      continue;
    }
    EXPECT_EQ(ph, "X") << e.dump();
    EXPECT_TRUE(e.at("name").is_string());
    EXPECT_GE(e.at("ts").get<double>(), 0.0);
    EXPECT_GT(e.at("dur").get<double>(), 0.0) << e.dump();
    const double ts = e.at("ts").get<double>(), dur = e.at("dur").get<double>();
    spans[row].push_back({e.at("name"), ps(ts), ps(ts + dur), ts, ts + dur, dur});
  }
  std::map<std::string, std::vector<Span>> out;
  for (auto& [row, list] : spans) {
    EXPECT_TRUE(names.count(row)) << "a row without a name: " << row.first << "/" << row.second;
    EXPECT_TRUE(processes.count(row.first)) << "a group without a name: " << row.first;
    // Viewers nest the spans of a row: they must not overlap.
    std::sort(list.begin(), list.end(), [](const Span& a, const Span& b) { return a.start < b.start; });
    for (size_t i = 1; i < list.size(); ++i) {
      EXPECT_LE(list[i - 1].end, list[i].start) << names[row] << " at " << list[i].start << " ps";
      // Nor as doubles: a span whose ts + dur rounds past the next one's ts makes
      // speedscope nest every later span of the row inside it.
      EXPECT_LE(list[i - 1].end_us, list[i].start_us) << names[row] << " at " << list[i].start << " ps";
      // Nor once speedscope has moved the row to start at 0 (it subtracts the row's
      // first ts from every ts, then adds dur): a windowed file starts late, and
      // decimal times rounded there.
      const double first = list.front().start_us;
      EXPECT_LE((list[i - 1].start_us - first) + list[i - 1].dur_us, list[i].start_us - first)
          << names[row] << " at " << list[i].start << " ps, rebased";
    }
    EXPECT_FALSE(out.count(names[row])) << "two rows named " << names[row];
    out[names[row]] = list;
  }
  return out;
}

class Timeline : public testing::TestWithParam<std::string> {};

}  // namespace

TEST_P(Timeline, IsTraceEventJsonWhoseUnitSpansAddUpToTheAccounting) {
  const std::string level = GetParam();
  const TimelineRun r = simulate("whole_" + level, level, "");
  ASSERT_EQ(r.result.exit_code, 0) << r.result.output;
  const json trace = read_json(r.timeline);
  const json& about = trace.at("otherData").at("rtsim");
  EXPECT_EQ(about.at("level"), level);
  EXPECT_TRUE(about.at("capped_at_cycle").is_null());
  const auto rows = rows_of(trace);
  const auto stats = read_stats(r.dir / "out");
  const double cycle_ps = about.at("cycle_ps").get<double>();
  EXPECT_DOUBLE_EQ(cycle_ps, 1e6 / stat_number(stats, "time.clock_mhz"));

  // Every unit's drawn states, added up as the accounting rounds them, are its stats.
  const std::regex unit(R"(core\d+\.(trv\d+|ist\d+|shading))");
  int units = 0;
  for (const auto& [name, spans] : rows) {
    if (!std::regex_match(name, unit)) continue;
    ++units;
    rtsim::sim::CycleSplit split{};
    for (const Span& s : spans) {
      bool known = false;
      for (rtsim::sim::CycleBucket b : rtsim::sim::kAllCycleBuckets)
        if (s.name == rtsim::sim::cycle_bucket_name(b)) split[size_t(b)] += s.end - s.start, known = true;
      EXPECT_TRUE(known) << name << ": a span named " << s.name;
    }
    // Idle is not drawn: the rest of the run.
    uint64_t drawn = 0;
    for (uint64_t v : split) drawn += v;
    const uint64_t total_ps = uint64_t(std::llround(stat_number(stats, "time.seconds") * 1e12));
    ASSERT_LE(drawn, total_ps + 1) << name;
    split[size_t(rtsim::sim::CycleBucket::Idle)] = total_ps - std::min(total_ps, drawn);
    const rtsim::sim::CycleSplit cycles = rtsim::sim::bucket_cycles(split, cycle_ps);
    for (rtsim::sim::CycleBucket b : rtsim::sim::kAllCycleBuckets) {
      const std::string key = name + "." + rtsim::sim::cycle_bucket_name(b) + "_cycles";
      if (stats.count(key)) EXPECT_EQ(cycles[size_t(b)], stats.at(key).get<uint64_t>()) << key;
      else EXPECT_EQ(cycles[size_t(b)], 0u) << key;
    }
  }
  EXPECT_EQ(units, 2 * 3) << "2 cores x (TRV, IST, shading)";
  // The memory side: misses at every cache, crossbar messages both ways, DRAM commands.
  std::set<std::string> kinds;
  for (const auto& [name, spans] : rows)
    for (const Span& s : spans) kinds.insert(s.name);
  for (const char* k : {"busy", "waiting_dram", "node", "triangle", "request", "answer", "ACT", "RD", "PRE"})
    EXPECT_TRUE(kinds.count(k)) << k;
  for (const char* track : {"core1.l1_node0 misses", "l2.slice0 misses", "noc to l2.slice1", "noc to core1",
                            "dram channel 0"})
    EXPECT_TRUE(rows.count(track)) << track;
  std::filesystem::remove_all(r.dir);
}

INSTANTIATE_TEST_SUITE_P(Levels, Timeline, testing::Values("lt", "cycle"));

TEST(Timeline, AWindowKeepsItsSpansAndACapStopsWithAMessage) {
  const TimelineRun w = simulate("window", "cycle", "--timeline-window 200..600");
  ASSERT_EQ(w.result.exit_code, 0) << w.result.output;
  const json trace = read_json(w.timeline);
  const double cycle_ps = trace.at("otherData").at("rtsim").at("cycle_ps").get<double>();
  const auto rows = rows_of(trace);
  size_t spans = 0;
  for (const auto& [name, list] : rows)
    for (const Span& s : list) {
      ++spans;
      EXPECT_GE(double(s.start), 200 * cycle_ps - 1) << name;
      EXPECT_LE(double(s.end), 600 * cycle_ps + 1) << name;
    }
  EXPECT_GT(spans, 10u);
  EXPECT_EQ(trace.at("otherData").at("rtsim").at("from_cycle"), 200);

  const TimelineRun c = simulate("cap", "lt", "--timeline-max-events 50");
  ASSERT_EQ(c.result.exit_code, 0) << c.result.output;
  EXPECT_NE(c.result.output.find("--timeline: the cap of 50 spans was reached at cycle"), std::string::npos)
      << c.result.output;
  const json capped = read_json(c.timeline);
  size_t events = 0;
  for (const json& e : capped.at("traceEvents")) events += e.at("ph") == "X";
  EXPECT_EQ(events, 50u);
  EXPECT_FALSE(capped.at("otherData").at("rtsim").at("capped_at_cycle").is_null());
  std::filesystem::remove_all(w.dir);
  std::filesystem::remove_all(c.dir);
}

TEST(Timeline, BadInputIsRefusedNamingTheFlagAndLeavesNoFile) {
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {"functional", "", "--timeline: the functional level has no time"},
      {"lt", "--timeline-window 5..3", "--timeline-window: TO must be after FROM"},
      {"lt", "--timeline-window 5", "--timeline-window: expected FROM..TO"},
      {"lt", "--timeline-window 010..20", "--timeline-window FROM"},
      {"lt", "--timeline-window 1..x", "--timeline-window TO"},
      {"lt", "--timeline-max-events 0", "--timeline-max-events: must be at least 1"},
      // Found only once the pixel is traced (the timeline file is already open).
      {"cycle", "--trace-ray 0,0,refraction", "--trace-ray: the frame has no refraction ray 0"},
  };
  for (const auto& [level, flags, message] : cases) {
    const TimelineRun r = simulate("bad", level, flags);
    EXPECT_EQ(r.result.exit_code, 2) << flags << "\n" << r.result.output;
    EXPECT_NE(r.result.output.find(message), std::string::npos) << flags << "\n" << r.result.output;
    for (const auto& e : std::filesystem::directory_iterator(r.dir))
      EXPECT_EQ(e.path().filename().string().find("run.json"), std::string::npos) << flags << ": " << e.path();
    std::filesystem::remove_all(r.dir);
  }
  const auto dir = scratch_folder("timeline", "folder");
  const CliResult folder =
      run_rtsim("simulate --scene cornell --res 8x8 --fidelity lt --out-dir " + (dir / "out").string() +
                " --timeline " + dir.string());
  EXPECT_EQ(folder.exit_code, 2) << folder.output;
  EXPECT_NE(folder.output.find("--timeline"), std::string::npos) << folder.output;
  std::filesystem::remove_all(dir);
}
