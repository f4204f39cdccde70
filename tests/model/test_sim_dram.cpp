// DRAM microbenchmarks: isolated accesses take exactly the configured latencies,
// a sequential stream reaches the configured peak bandwidth within 5%, and the
// FR-FCFS queue serves row hits before older row misses.
#include <rtsim/model/sim/dram.h>

#include <gtest/gtest.h>

using namespace rtsim::sim;

namespace {

// Runs until every request is issued; returns completions in issue order.
std::vector<DramCompletion> drain(DramModel& dram) {
  std::vector<DramCompletion> done;
  while (!dram.idle()) dram.advance(dram.next_decision_ps(), done);
  return done;
}

DramConfig part(const std::string& name) {
  DramConfig c;
  apply_dram_part(c, name);
  c.channels = 2;
  return c;
}

class DramParts : public ::testing::TestWithParam<std::string> {};

}  // namespace

TEST_P(DramParts, IsolatedAccessesTakeTheConfiguredLatency) {
  const DramConfig c = part(GetParam());
  DramModel dram(c, 64);
  const uint64_t tck = c.tck_ps;
  const uint64_t bursts = (64 + c.burst_bytes - 1) / c.burst_bytes;
  const uint64_t tburst = bursts * c.burst_cycles * tck;
  // Same bank, same row, then another row: closed, hit, conflict. Each request
  // arrives long after the previous one finished, so nothing overlaps.
  const uint64_t row_stride = uint64_t(c.row_bytes) * c.channels * c.banks * c.ranks;
  const uint64_t a = 0;  // row 0 of bank 0, rank 0, channel 0
  struct Case { uint64_t address; uint64_t expected; RowOutcome outcome; };
  const Case cases[] = {
      {a, (c.trcd + c.tcl) * tck + tburst, RowOutcome::Closed},
      {a + 64 * c.channels, c.tcl * tck + tburst, RowOutcome::Hit},
      {a + row_stride, (c.trp + c.trcd + c.tcl) * tck + tburst, RowOutcome::Conflict},
  };
  uint64_t now = 1'000'000;
  for (const Case& k : cases) {
    ASSERT_TRUE(dram.can_accept(k.address));
    dram.enqueue({k.address, now, 7});
    const auto done = drain(dram);
    ASSERT_EQ(done.size(), 1u);
    EXPECT_EQ(done[0].outcome, k.outcome);
    EXPECT_EQ(done[0].done_ps - now, k.expected) << int(k.outcome);
    EXPECT_EQ(dram.latency_ps(k.outcome), k.expected);
    now = done[0].done_ps + 10'000'000;  // well past tRAS
  }
  EXPECT_EQ(dram.counters().row_hits, 1u);
  EXPECT_EQ(dram.counters().row_closed, 1u);
  EXPECT_EQ(dram.counters().row_conflicts, 1u);
}

TEST_P(DramParts, SequentialStreamReachesPeakBandwidth) {
  const DramConfig c = part(GetParam());
  DramModel dram(c, 64);
  const uint64_t lines = 20000;
  uint64_t next = 0, now = 0, last_done = 0;
  std::vector<DramCompletion> done;
  // Keep every queue as full as it can be: the requester is never the bottleneck.
  while (next < lines || !dram.idle()) {
    while (next < lines && dram.can_accept(next * 64)) dram.enqueue({next * 64, now, next}), ++next;
    const uint64_t t = dram.next_decision_ps();
    if (t == UINT64_MAX) continue;
    now = std::max(now, t);
    dram.advance(now, done);
  }
  ASSERT_EQ(done.size(), lines);
  for (auto& d : done) last_done = std::max(last_done, d.done_ps);
  const double achieved = double(lines * 64) / (double(last_done) * 1e-12);
  EXPECT_GE(achieved, 0.95 * dram.peak_bytes_per_second())
      << achieved / 1e9 << " GB/s of " << dram.peak_bytes_per_second() / 1e9;
  EXPECT_LE(achieved, dram.peak_bytes_per_second() * 1.0000001);
}

TEST_P(DramParts, LooselyTimedStreamIsCappedAtPeakBandwidth) {
  const DramConfig c = part(GetParam());
  DramModel dram(c, 64);
  uint64_t last = 0;
  for (uint64_t i = 0; i < 10000; ++i) last = std::max(last, dram.lt_access(i * 64, false, 0));
  const double achieved = 10000.0 * 64 / (double(last) * 1e-12);
  EXPECT_LE(achieved, dram.peak_bytes_per_second() * 1.0000001);
  EXPECT_GE(achieved, 0.95 * dram.peak_bytes_per_second());
  // One isolated access costs the closed-row latency.
  DramModel fresh(c, 64);
  EXPECT_EQ(fresh.lt_access(0, false, 5000) - 5000, fresh.latency_ps(RowOutcome::Closed));
}

INSTANTIATE_TEST_SUITE_P(Parts, DramParts,
                         ::testing::Values("lpddr4-3200", "ddr4-2400", "gddr6"),
                         [](const auto& info) {
                           std::string n = info.param;
                           for (char& ch : n)
                             if (ch == '-') ch = '_';
                           return n;
                         });

TEST(Dram, RowHitsAreServedBeforeOlderMisses) {
  DramConfig c = part("ddr4-2400");
  c.channels = 1;
  DramModel dram(c, 64);
  const uint64_t row_stride = uint64_t(c.row_bytes) * c.banks * c.ranks;
  dram.enqueue({0, 0, 0});  // opens row 0 of bank 0
  const auto first = drain(dram);
  ASSERT_EQ(first.size(), 1u);
  // An older conflict to bank 0 and a younger hit to the open row: the hit goes first.
  const uint64_t t = first[0].done_ps + 1'000'000;
  dram.enqueue({row_stride, t, 1});
  dram.enqueue({64, t + 1, 2});
  const auto rest = drain(dram);
  ASSERT_EQ(rest.size(), 2u);
  EXPECT_EQ(rest[0].tag, 2u);
  EXPECT_EQ(rest[0].outcome, RowOutcome::Hit);
  EXPECT_EQ(rest[1].outcome, RowOutcome::Conflict);
}

TEST(Dram, BoundedQueueRefusesWhenFull) {
  DramConfig c = part("lpddr4-3200");
  c.channels = 1;
  c.queue_entries = 4;
  DramModel dram(c, 64);
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(dram.can_accept(uint64_t(i) * 64));
    dram.enqueue({uint64_t(i) * 64, 0, uint64_t(i)});
  }
  EXPECT_FALSE(dram.can_accept(4 * 64));
}

TEST(Dram, AddressMappingPutsConfiguredFieldLowest) {
  DramConfig c = part("ddr4-2400");
  c.channels = 4;
  c.address_mapping = "row:rank:bank:column:channel";
  DramAddressMap map(c, 64);
  EXPECT_EQ(map.decode(64).channel, 1u);
  EXPECT_EQ(map.decode(64 * 4).column, 1u);
  c.address_mapping = "row:channel:rank:column:bank";
  DramAddressMap other(c, 64);
  EXPECT_EQ(other.decode(64).bank, 1u);
  EXPECT_EQ(other.decode(64).channel, 0u);
}
