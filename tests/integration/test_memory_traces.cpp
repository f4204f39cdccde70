// Issue 37: the DRAM and cache request traces that reference models replay
// (`simulate --dram-trace-out / --cache-trace-out`), read back and held against
// the run's own counts, and the flags' bad values.
#include "integration/cli_runner.h"

#include <rtsim/model/sim/dram.h>
#include <rtsim/model/sim/dram_reference.h>
#include <rtsim/model/sim/memory_trace.h>
#include <rtsim/reports/child_process.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>

namespace {

namespace fs = std::filesystem;
using rtsim::shell_quote;

fs::path fresh(const std::string& name) { return fresh_test_folder("rtsim_memory_traces", name); }

CliResult run_in(const fs::path& cwd, const std::string& args) { return run_rtsim_in(cwd, args); }

uint64_t stat(const nlohmann::json& stats, const std::string& path) {
  const nlohmann::json* j = &stats;
  std::stringstream in(path);
  std::string key;
  while (std::getline(in, key, '.')) j = &j->at(key);
  return j->at("value").get<uint64_t>();
}

nlohmann::json read_stats(const fs::path& dir) {
  std::ifstream in(dir / "stats.json");
  return nlohmann::json::parse(in);
}

// Every request the DRAM counted is in the trace, each once, as the reader reads it;
// the encoded addresses decode to valid locations of the run's own mapping.
TEST(MemoryTraces, DramTraceHoldsEveryRequestOfTheRun) {
  const fs::path dir = fresh("dram");
  // lt: timed, with the write-backs of a small L2 (the preset's is too large to evict).
  const CliResult r = run_in(dir,
                             "simulate --fidelity lt --res 32x32 --config desktop --out-dir o "
                             "--dram-trace-out d.trace");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json stats = read_stats(dir / "o");
  const auto entries = rtsim::sim::read_dramsim3_trace((dir / "d.trace").string());
  uint64_t reads = 0, writes = 0;
  for (const auto& e : entries) (e.write ? writes : reads)++;
  EXPECT_EQ(reads, stat(stats, "dram.reads"));
  EXPECT_EQ(writes, stat(stats, "dram.writes"));
  ASSERT_GT(reads, 100u);
  // Cycles are the DRAM clock of the part: the last request comes within the run.
  const double sim_ps = stats.at("time").at("seconds").at("value").get<double>() * 1e12;
  uint64_t last = 0;
  for (const auto& e : entries) last = std::max(last, e.cycle);
  EXPECT_LE(double(last) * 833, sim_ps + 833);
  EXPECT_GT(double(last) * 833, 0.5 * sim_ps);
  // Streamed to a temporary name and renamed once whole: nothing else is left beside it.
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
}

TEST(MemoryTraces, Ramulator2TraceDecodesEveryField) {
  const fs::path dir = fresh("ramulator");
  const CliResult r = run_in(dir,
                             "simulate --res 16x16 --config desktop --out-dir o --dram-trace-out d.trace "
                             "--dram-trace-format ramulator2");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "d.trace");
  std::string line;
  uint64_t n = 0;
  while (std::getline(in, line)) {
    ++n;
    char op = 0;
    unsigned ch, rank, group, bank, column;
    unsigned long long row;
    ASSERT_EQ(std::sscanf(line.c_str(), "%c %u,%u,%u,%u,%llu,%u", &op, &ch, &rank, &group, &bank, &row, &column), 7)
        << line;
    EXPECT_TRUE(op == 'R' || op == 'W');
    // desktop: 2 channels, 1 rank, 4 groups of 4 banks, 8 KiB rows of 64-byte lines.
    EXPECT_LT(ch, 2u);
    EXPECT_EQ(rank, 0u);
    EXPECT_LT(group, 4u);
    EXPECT_LT(bank, 4u);
    EXPECT_LT(column, 128u);
  }
  EXPECT_EQ(n, stat(read_stats(dir / "o"), "dram.reads") + stat(read_stats(dir / "o"), "dram.writes"));
}

// The cache trace holds each access entering the cache once, with the outcome the
// cache's own counters give.
TEST(MemoryTraces, CacheTraceMatchesTheCacheCounters) {
  const fs::path dir = fresh("cache");
  for (const std::string cache : {"l1_node", "l2"}) {
    const CliResult r = run_in(dir, "simulate --res 24x24 --out-dir o --cache-trace " + cache +
                                        " --cache-trace-out c.trace");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    std::ifstream in(dir / "c.trace");
    std::string line;
    std::map<std::string, std::string> header;
    uint64_t hits = 0, misses = 0, writes = 0, accesses = 0;
    while (std::getline(in, line)) {
      if (line.rfind("# ", 0) == 0) {
        const size_t space = line.find(' ', 2);
        if (space != std::string::npos) header[line.substr(2, space - 2)] = line.substr(space + 1);
        continue;
      }
      unsigned instance;
      char op;
      char address[32], outcome[16];
      ASSERT_EQ(std::sscanf(line.c_str(), "%u %c %31s %15s", &instance, &op, address, outcome), 4) << line;
      ++accesses;
      if (op == 'W') ++writes;
      if (std::string(outcome) == "hit") ++hits;
      else if (std::string(outcome) == "miss") ++misses;
      EXPECT_LT(instance, std::stoul(header.at("instances")));
    }
    EXPECT_EQ(header.at("cache"), cache);
    const nlohmann::json stats = read_stats(dir / "o");
    const std::string p = cache == "l2" ? "l2" : "l1_node.all";
    EXPECT_EQ(accesses, stat(stats, p + ".accesses")) << cache;
    EXPECT_EQ(hits, stat(stats, p + ".hits")) << cache;
    EXPECT_EQ(misses, stat(stats, p + ".misses")) << cache;
    EXPECT_EQ(writes, stat(stats, p + ".writes")) << cache;
    ASSERT_GT(accesses, 0u);
  }
}

TEST(MemoryTraces, BadTraceFlagsExitTwoNamingTheFlag) {
  const fs::path dir = fresh("bad");
  const struct {
    std::string args, flag;
  } cases[] = {
      {"--dram-trace-out missing/d.trace", "--dram-trace-out"},
      {"--dram-trace-out d.trace --dram-trace-format dramsim", "--dram-trace-format"},
      {"--cache-trace-out missing/c.trace", "--cache-trace-out"},
      {"--cache-trace-out c.trace --cache-trace l3", "--cache-trace"},
      {"--cache-trace l1_node", "--cache-trace"},
  };
  for (const auto& c : cases) {
    const CliResult r = run_in(dir, "simulate --res 8x8 --out-dir o " + c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << ": " << r.output;
    EXPECT_NE(r.output.find(c.flag + ":"), std::string::npos) << c.args << ": " << r.output;
  }
}

// The reader is strict: a line it cannot take names its file and line.
TEST(MemoryTraces, TraceReaderRefusesMalformedLines) {
  const fs::path dir = fresh("reader");
  for (const std::string bad : {"0x40 READ\n", "40 READ 3\n", "0x40 LOAD 3\n", "0x40 READ -3\n",
                                "0x40 READ 3 4\n", "0xzz WRITE 1\n", "0x40 READ 010\n"}) {
    {
      std::ofstream out(dir / "t.trace");
      out << "0x0 READ 0\n" << bad;
    }
    try {
      rtsim::sim::read_dramsim3_trace((dir / "t.trace").string());
      ADD_FAILURE() << "accepted " << bad;
    } catch (const rtsim::InputError& e) {
      EXPECT_NE(std::string(e.what()).find("t.trace:2"), std::string::npos) << e.what();
    }
  }
}

// The dramsim3 format's address: a bit-field re-encoding that a power-of-two map
// decodes to the same location, also for a channel count that is no power of two.
TEST(MemoryTraces, BitFieldEncodingKeepsEveryField) {
  rtsim::sim::DramConfig c;
  rtsim::sim::apply_dram_part(c, "gddr6");
  c.channels = 12;
  rtsim::sim::DramConfig pow2 = c;
  pow2.channels = 16;
  const rtsim::sim::DramAddressMap ours(c, 64), theirs(pow2, 64);
  const rtsim::sim::DramBitFieldEncoder encoder(c, 64);
  EXPECT_EQ(encoder.dramsim3_mapping(), "rorabacobgch");
  std::mt19937_64 rng(7);
  for (int i = 0; i < 10000; ++i) {
    const uint64_t address = (rng() % (uint64_t(1) << 34)) & ~uint64_t(63);
    const rtsim::sim::DramAddress a = ours.decode(address);
    const rtsim::sim::DramAddress b = theirs.decode(encoder.encode(a));
    ASSERT_EQ(a.channel, b.channel);
    ASSERT_EQ(a.rank, b.rank);
    ASSERT_EQ(a.bank, b.bank);
    ASSERT_EQ(a.bank_group, b.bank_group);
    ASSERT_EQ(a.row, b.row);
    ASSERT_EQ(a.column, b.column);
  }
  // Power-of-two channels: the address itself.
  const rtsim::sim::DramBitFieldEncoder same(pow2, 64);
  for (int i = 0; i < 1000; ++i) {
    const uint64_t address = (rng() % (uint64_t(1) << 34)) & ~uint64_t(63);
    ASSERT_EQ(same.encode(theirs.decode(address)), address);
  }
}

// dram-replay with our model gives back what the run's DRAM measured: the same
// requests, and the latency to the rounding of each arrival to its DRAM clock edge.
TEST(MemoryTraces, ReplayingARunsTraceGivesItsDramFigures) {
  const fs::path dir = fresh("replay");
  ASSERT_EQ(run_in(dir, "simulate --fidelity cycle --res 32x32 --config desktop --out-dir o "
                        "--dram-trace-out d.trace")
                .exit_code,
            0);
  const CliResult r = run_in(dir, "dram-replay --trace d.trace --config desktop");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json replay = nlohmann::json::parse(r.output);
  const nlohmann::json stats = read_stats(dir / "o");
  EXPECT_EQ(replay.at("reads").get<uint64_t>(), stat(stats, "dram.reads"));
  const double in_run = stats.at("dram").at("latency_avg").at("value").get<double>();
  EXPECT_NEAR(replay.at("read_latency_mean_ns").get<double>(), in_run, 0.02 * in_run);
  EXPECT_EQ(replay.at("activates").get<uint64_t>() > 0, true);
  EXPECT_EQ(run_in(dir, "dram-replay --trace d.trace --model dramsim").exit_code, 2);
  EXPECT_EQ(run_in(dir, "dram-replay --trace missing.trace").exit_code, 2);
}

// DRAMsim3's configuration is written from our keys: the part's timings, the same
// field order, channels rounded up to a power of two; a part it has no protocol for
// is refused by key.
TEST(MemoryTraces, Dramsim3ConfigurationFollowsOurDramKeys) {
  rtsim::sim::DramConfig c;
  rtsim::sim::apply_dram_part(c, "ddr4-2400");
  const std::string ini = rtsim::sim::dramsim3_ini(c, 64);
  for (const char* line : {"protocol = DDR4", "CL = 17", "tRCD = 17", "tFAW = 26", "tREFI = 9360",
                           "BL = 8", "bus_width = 64", "address_mapping = rorabacobgch",
                           "row_buf_policy = OPEN_PAGE", "trans_queue_size = 32"})
    EXPECT_NE(ini.find(std::string("\n") + line + "\n"), std::string::npos) << line << "\n" << ini;
  rtsim::sim::apply_dram_part(c, "gddr6");
  c.channels = 12;
  const std::string gddr6 = rtsim::sim::dramsim3_ini(c, 64);
  EXPECT_NE(gddr6.find("\nchannels = 16\n"), std::string::npos) << gddr6;
  EXPECT_NE(gddr6.find("\ntRCDWR = 16\n"), std::string::npos) << gddr6;
  rtsim::sim::apply_dram_part(c, "lpddr5");
  try {
    rtsim::sim::dramsim3_ini(c, 64);
    ADD_FAILURE() << "lpddr5 accepted";
  } catch (const rtsim::InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("dram.model:", 0), 0u) << e.what();
  }
}

// The default build has no DRAMsim3: asking for it is a bad input naming the key.
TEST(MemoryTraces, DramModelDramsim3NeedsTheOptionalBuild) {
  if (rtsim::sim::dramsim3_linked()) GTEST_SKIP() << "this build links DRAMsim3";
  const fs::path dir = fresh("nodramsim3");
  {
    std::ofstream(dir / "d.toml") << "preset = \"desktop\"\n[dram]\nmodel = \"dramsim3\"\n";
  }
  const CliResult r = run_in(dir, "simulate --fidelity cycle --res 8x8 --config d.toml --out-dir o");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("dram.model:"), std::string::npos) << r.output;
}

}  // namespace
