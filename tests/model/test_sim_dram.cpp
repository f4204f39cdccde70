// DRAM microbenchmarks for every part: isolated accesses take exactly the configured
// latencies, a sequential stream reaches the peak bandwidth less refresh, activates
// respect tRRD and tFAW, writes cost their turnaround, a full queue refuses and the
// held time counts as latency, refresh runs every tREFI also across idle time, the
// page policies close rows as documented, and a protocol checker replays the command
// log of random mixed traffic of both the queued (cycle) and the FCFS (lt) path.
#include <rtsim/model/sim/dram.h>
#include <rtsim/workloads/error.h>

#include <gtest/gtest.h>

#include <map>
#include <tuple>

#include <algorithm>
#include <map>
#include <random>

using namespace rtsim;
using namespace rtsim::sim;

namespace {

constexpr uint32_t kLine = 64;

DramConfig part(const std::string& name, uint32_t channels = 2) {
  DramConfig c;
  apply_dram_part(c, name);
  c.channels = channels;
  return c;
}

// A config without refresh and with open pages: isolated timings are exact.
DramConfig quiet(const std::string& name, uint32_t channels = 1) {
  DramConfig c = part(name, channels);
  c.trefi = 0;
  c.page_policy = "open";
  return c;
}

uint64_t edge_after(uint64_t t, uint64_t tck) { return (t + tck - 1) / tck * tck; }
uint32_t bursts(const DramConfig& c) { return (kLine + c.burst_bytes - 1) / c.burst_bytes; }
uint64_t tburst(const DramConfig& c) { return uint64_t(bursts(c)) * c.burst_cycles * c.tck_ps; }

// An address under the default mapping row:rank:bank:column:bankgroup:channel;
// bank is the bank within its group.
struct Place {
  uint32_t channel = 0, rank = 0, group = 0, bank = 0, column = 0;
  uint64_t row = 0;
};
uint64_t address_of(const DramConfig& c, const Place& p) {
  const uint64_t columns = c.row_bytes / kLine;
  uint64_t a = p.row;
  a = a * c.ranks + p.rank;
  a = a * (c.banks / c.bank_groups) + p.bank;
  a = a * columns + p.column;
  a = a * c.bank_groups + p.group;
  a = a * c.channels + p.channel;
  return a * kLine;
}

// Runs until every queued request is issued; returns completions in issue order.
std::vector<DramCompletion> drain(DramModel& dram) {
  std::vector<DramCompletion> done;
  while (!dram.idle()) dram.advance(dram.next_decision_ps(), done);
  return done;
}

struct CommandLog {
  std::vector<DramCommand> commands;
  void attach(DramModel& dram) {
    dram.set_command_observer([this](const DramCommand& c) { commands.push_back(c); });
  }
  std::vector<DramCommand> of(DramCommandKind kind) const {
    std::vector<DramCommand> out;
    for (auto& c : commands)
      if (c.kind == kind) out.push_back(c);
    return out;
  }
};

// A requester that keeps every queue as full as it can: requests go in order, the
// first refused one waits (counted) until a queue entry frees.
struct Feed {
  uint64_t address;
  bool write;
  uint64_t earliest_ps;  // not sent before
};
std::vector<DramCompletion> run_cycle(DramModel& dram, const std::vector<Feed>& feed) {
  std::vector<DramCompletion> done;
  size_t next = 0;
  uint64_t now = 0;
  uint64_t first_try = UINT64_MAX;  // of the request held back
  while (next < feed.size() || !dram.idle()) {
    while (next < feed.size() && feed[next].earliest_ps <= now) {
      const Feed& f = feed[next];
      if (first_try == UINT64_MAX) first_try = std::max(now, f.earliest_ps);
      const DramRequest r{f.address, first_try, next, f.write};
      if (!dram.try_enqueue(r, now)) break;
      first_try = UINT64_MAX;
      ++next;
    }
    uint64_t t = dram.next_decision_ps();
    if (next < feed.size() && first_try == UINT64_MAX) t = std::min(t, feed[next].earliest_ps);
    if (t == UINT64_MAX) break;
    now = std::max(now, t);
    dram.advance(now, done);
  }
  return done;
}

// Every timing rule, replayed over a command log.
struct ProtocolChecker {
  DramConfig c;
  bool command_bus_precharges = true;  // false: closed page auto-precharges bypass it

  struct BankState {
    bool open = false;
    uint64_t row = 0;
    int64_t act = -1, pre = -1, last_read = -1, last_write = -1;
  };
  struct RankState {
    std::vector<uint64_t> acts;
    int64_t last_ref = -1, last_col = -1, last_write = -1;
    std::vector<int64_t> group_act, group_col, group_write;
    uint64_t refreshes = 0;
  };

  // Returns the violations (empty when the log obeys every rule).
  std::vector<std::string> check(std::vector<DramCommand> log, uint64_t end_ps) const {
    std::vector<std::string> errors;
    auto fail = [&](const DramCommand& cmd, const std::string& what) {
      if (errors.size() < 20)
        errors.push_back(std::string(dram_command_name(cmd.kind)) + " at " +
                         std::to_string(cmd.time_ps) + " ps ch" + std::to_string(cmd.channel) +
                         " r" + std::to_string(cmd.rank) + " b" + std::to_string(cmd.bank) +
                         ": " + what);
    };
    std::stable_sort(log.begin(), log.end(), [](const DramCommand& a, const DramCommand& b) {
      return a.channel != b.channel ? a.channel < b.channel : a.time_ps < b.time_ps;
    });
    const uint64_t tck = c.tck_ps, tb = tburst(c), n = bursts(c);
    const uint64_t cl = c.tcl * tck, cwl = c.tcwl * tck;
    const uint64_t read_to_pre = ((n - 1) * c.tccd_l + c.trtp) * tck;
    const uint64_t write_to_pre = cwl + tb + c.twr * tck;
    const uint32_t bpg = c.banks / c.bank_groups;
    for (uint32_t ch = 0; ch < c.channels; ++ch) {
      std::vector<BankState> banks(size_t(c.ranks) * c.banks);
      std::vector<RankState> ranks(c.ranks);
      for (auto& r : ranks) {
        r.group_act.assign(c.bank_groups, -1);
        r.group_col.assign(c.bank_groups, -1);
        r.group_write.assign(c.bank_groups, -1);
      }
      struct Burst { uint64_t start, end; bool write; uint32_t rank; };
      std::vector<Burst> bus;
      int64_t last_bus_command = -1;
      for (const DramCommand& cmd : log) {
        if (cmd.channel != ch) continue;
        const int64_t t = int64_t(cmd.time_ps);
        if (cmd.time_ps % tck != 0) fail(cmd, "not on a DRAM clock edge");
        RankState& rank = ranks[cmd.rank];
        if (cmd.bank_group != cmd.bank / bpg) fail(cmd, "bank group does not match the bank");
        const bool on_command_bus =
            cmd.kind != DramCommandKind::Precharge || command_bus_precharges;
        if (on_command_bus) {
          if (last_bus_command >= 0 && t < last_bus_command + int64_t(tck))
            fail(cmd, "two commands in one tCK");
          last_bus_command = t;
        }
        auto since = [&](int64_t then) { return then < 0 ? INT64_MAX : t - then; };
        if (cmd.kind == DramCommandKind::Refresh) {
          for (uint32_t b = 0; b < c.banks; ++b) {
            const BankState& k = banks[size_t(cmd.rank) * c.banks + b];
            if (k.open) fail(cmd, "bank " + std::to_string(b) + " open at refresh");
            if (since(k.pre) < int64_t(c.trp * tck)) fail(cmd, "tRP before refresh");
          }
          if (since(rank.last_ref) < int64_t(c.trfc * tck)) fail(cmd, "tRFC between refreshes");
          // The k-th refresh of a rank is due at its staggered start + (k-1) tREFI.
          const uint64_t refi = uint64_t(c.trefi) * tck;
          const uint64_t first = (refi * (cmd.rank + 1) / c.ranks + tck - 1) / tck * tck;
          const uint64_t due = first + rank.refreshes * refi;
          if (cmd.time_ps < due) fail(cmd, "refresh before it is due");
          const uint64_t slack = (c.tras + c.trp + c.tcwl + c.twr + c.trfc) * tck + 4 * tb + 200000;
          if (cmd.time_ps > due + slack)
            fail(cmd, "refresh late by " + std::to_string(cmd.time_ps - due));
          rank.refreshes++;
          rank.last_ref = t;
          continue;
        }
        BankState& k = banks[size_t(cmd.rank) * c.banks + cmd.bank];
        const uint32_t g = cmd.bank_group;
        switch (cmd.kind) {
          case DramCommandKind::Activate: {
            if (k.open) fail(cmd, "activate of an open bank");
            if (since(k.pre) < int64_t(c.trp * tck)) fail(cmd, "tRP");
            if (since(rank.last_ref) < int64_t(c.trfc * tck)) fail(cmd, "tRFC");
            if (!rank.acts.empty() && since(int64_t(rank.acts.back())) < int64_t(c.trrd_s * tck))
              fail(cmd, "tRRD_S");
            if (since(rank.group_act[g]) < int64_t(c.trrd_l * tck)) fail(cmd, "tRRD_L");
            if (rank.acts.size() >= 4 &&
                since(int64_t(rank.acts[rank.acts.size() - 4])) < int64_t(c.tfaw * tck))
              fail(cmd, "tFAW: a fifth activate inside the window");
            rank.acts.push_back(cmd.time_ps);
            rank.group_act[g] = t;
            k = BankState{true, cmd.row, t, k.pre, -1, -1};
            break;
          }
          case DramCommandKind::Precharge:
            if (!k.open) {
              fail(cmd, "precharge of a closed bank");
              break;
            }
            if (since(k.act) < int64_t(c.tras * tck)) fail(cmd, "tRAS");
            if (since(k.last_read) < int64_t(read_to_pre)) fail(cmd, "tRTP");
            if (since(k.last_write) < int64_t(write_to_pre)) fail(cmd, "tWR");
            k.open = false;
            k.pre = t;
            break;
          case DramCommandKind::Read:
          case DramCommandKind::Write: {
            const bool write = cmd.kind == DramCommandKind::Write;
            if (!k.open || k.row != cmd.row) fail(cmd, "column command without its row open");
            if (since(k.act) < int64_t((write ? c.trcd_write : c.trcd) * tck)) fail(cmd, "tRCD");
            if (since(rank.last_col) < int64_t(n * c.tccd_s * tck)) fail(cmd, "tCCD_S");
            if (since(rank.group_col[g]) < int64_t(n * c.tccd_l * tck)) fail(cmd, "tCCD_L");
            if (!write) {
              if (since(rank.last_write) < int64_t(cwl + tb + c.twtr_s * tck)) fail(cmd, "tWTR_S");
              if (since(rank.group_write[g]) < int64_t(cwl + tb + c.twtr_l * tck))
                fail(cmd, "tWTR_L");
              k.last_read = t;
            } else {
              rank.last_write = t;
              rank.group_write[g] = t;
              k.last_write = t;
            }
            rank.last_col = t;
            rank.group_col[g] = t;
            const uint64_t start = cmd.time_ps + (write ? cwl : cl);
            bus.push_back({start, start + tb, write, cmd.rank});
            break;
          }
          default: break;
        }
      }
      // The data bus: bursts never overlap; direction or rank changes leave tRTRS.
      std::sort(bus.begin(), bus.end(),
                [](const Burst& a, const Burst& b) { return a.start < b.start; });
      for (size_t i = 1; i < bus.size(); ++i) {
        const bool turn = bus[i].write != bus[i - 1].write || bus[i].rank != bus[i - 1].rank;
        if (bus[i].start < bus[i - 1].end + (turn ? c.trtrs * tck : 0) && errors.size() < 20)
          errors.push_back("data bus overlap or missing tRTRS at " + std::to_string(bus[i].start));
      }
      // Refresh keeps up with tREFI over the whole run.
      if (c.trefi)
        for (uint32_t r = 0; r < c.ranks; ++r) {
          const uint64_t refi = uint64_t(c.trefi) * tck;
          const uint64_t expected = end_ps > 2 * refi ? end_ps / refi - 1 : 0;
          if (ranks[r].refreshes < expected && errors.size() < 20)
            errors.push_back("rank " + std::to_string(r) + " refreshed " +
                             std::to_string(ranks[r].refreshes) + " times, expected >= " +
                             std::to_string(expected));
        }
    }
    return errors;
  }
};

std::string joined(const std::vector<std::string>& lines) {
  std::string out;
  for (auto& l : lines) out += l + "\n";
  return out;
}

class DramParts : public ::testing::TestWithParam<std::string> {};

}  // namespace

TEST_P(DramParts, IsolatedAccessesTakeTheConfiguredLatency) {
  const DramConfig c = quiet(GetParam());
  DramModel dram(c, kLine);
  const uint64_t tck = c.tck_ps, tb = tburst(c);
  // Same bank: closed, hit, then another row (conflict). Each request arrives on a
  // clock edge long after the previous one finished, so nothing overlaps.
  struct Case {
    uint64_t address, expected;
    RowOutcome outcome;
  };
  const Case cases[] = {
      {address_of(c, {}), (c.trcd + c.tcl) * tck + tb, RowOutcome::Closed},
      {address_of(c, {0, 0, 0, 0, 1, 0}), c.tcl * tck + tb, RowOutcome::Hit},
      {address_of(c, {0, 0, 0, 0, 0, 1}), (c.trp + c.trcd + c.tcl) * tck + tb,
       RowOutcome::Conflict},
  };
  uint64_t now = 1000 * tck;
  for (const Case& k : cases) {
    ASSERT_TRUE(dram.can_accept(k.address));
    dram.enqueue({k.address, now, 7, false});
    const auto done = drain(dram);
    ASSERT_EQ(done.size(), 1u);
    EXPECT_EQ(done[0].outcome, k.outcome);
    EXPECT_EQ(done[0].done_ps - now, k.expected) << int(k.outcome);
    EXPECT_EQ(dram.latency_ps(k.outcome), k.expected);
    now += 10000 * tck;  // well past tRAS, tRTP and the data
  }
  EXPECT_EQ(dram.counters().row_hits, 1u);
  EXPECT_EQ(dram.counters().row_closed, 1u);
  EXPECT_EQ(dram.counters().row_conflicts, 1u);
  EXPECT_EQ(dram.counters().activates, 2u);
  EXPECT_EQ(dram.counters().precharges, 1u);
  // A write is done when its data is on the bus: tCWL + tBURST after its command.
  dram.enqueue({address_of(c, {0, 0, 0, 0, 2, 1}), now, 8, true});
  const auto write = drain(dram);
  ASSERT_EQ(write.size(), 1u);
  EXPECT_TRUE(write[0].write);
  EXPECT_EQ(write[0].done_ps - now, c.tcwl * tck + tb);
}

// Bytes whose whole burst lies in [from, to).
static uint64_t bytes_within(const std::vector<uint64_t>& done, uint64_t tb, uint64_t from,
                             uint64_t to) {
  uint64_t n = 0;
  for (uint64_t d : done)
    if (d - tb >= from && d <= to) ++n;
  return n * kLine;
}

TEST_P(DramParts, SequentialStreamReachesPeakLessRefresh) {
  const DramConfig c = part(GetParam());
  DramModel dram(c, kLine);
  const uint64_t refi = uint64_t(c.trefi) * c.tck_ps;
  const double bound = (1.0 - double(c.trfc) / double(c.trefi)) * dram.peak_bytes_per_second();
  // Long enough for 12 refresh intervals at the peak rate.
  const uint64_t lines =
      uint64_t(12.5 * double(refi) * 1e-12 * dram.peak_bytes_per_second() / kLine);
  std::vector<Feed> feed;
  for (uint64_t i = 0; i < lines; ++i) feed.push_back({i * kLine, false, 0});
  const auto done = run_cycle(dram, feed);
  ASSERT_EQ(done.size(), lines);
  std::vector<uint64_t> ends;
  for (auto& d : done) ends.push_back(d.done_ps);
  // Whole refresh intervals in the middle of the run: each holds one refresh.
  const uint64_t from = refi / 2, to = from + 10 * refi;
  ASSERT_LT(to, *std::max_element(ends.begin(), ends.end()));
  const double achieved =
      double(bytes_within(ends, tburst(c), from, to)) / (double(to - from) * 1e-12);
  EXPECT_GE(achieved, 0.90 * bound) << achieved / 1e9 << " GB/s of " << bound / 1e9;
  EXPECT_LE(achieved, bound) << achieved / 1e9 << " GB/s of " << bound / 1e9;
  EXPECT_GE(dram.counters().refreshes, 2u * 10);  // both channels
  EXPECT_GT(dram.counters().row_hits, lines * 9 / 10);
}

TEST_P(DramParts, LooselyTimedSequentialStreamReachesPeakLessRefresh) {
  const DramConfig c = part(GetParam());
  DramModel dram(c, kLine);
  const uint64_t refi = uint64_t(c.trefi) * c.tck_ps;
  const double bound = (1.0 - double(c.trfc) / double(c.trefi)) * dram.peak_bytes_per_second();
  const uint64_t lines =
      uint64_t(12.5 * double(refi) * 1e-12 * dram.peak_bytes_per_second() / kLine);
  // A requester with 32 lines outstanding: each request is sent when the one 32
  // before it is done.
  std::vector<uint64_t> ends;
  for (uint64_t i = 0; i < lines; ++i) {
    const uint64_t now = i >= 32 ? ends[i - 32] : 0;
    ends.push_back(dram.lt_access(i * kLine, false, now));
  }
  const uint64_t from = refi / 2, to = from + 10 * refi;
  ASSERT_LT(to, *std::max_element(ends.begin(), ends.end()));
  const double achieved =
      double(bytes_within(ends, tburst(c), from, to)) / (double(to - from) * 1e-12);
  EXPECT_GE(achieved, 0.90 * bound) << achieved / 1e9 << " GB/s of " << bound / 1e9;
  EXPECT_LE(achieved, bound) << achieved / 1e9 << " GB/s of " << bound / 1e9;
  EXPECT_GE(dram.counters().refreshes, 2u * 10);
}

TEST_P(DramParts, RowPerAccessStreamRespectsTrrdAndTfaw) {
  DramConfig c = part(GetParam(), 1);
  c.page_policy = "open";
  DramModel dram(c, kLine);
  CommandLog log;
  log.attach(dram);
  // Every access another row: bank after bank (over all groups), the row growing
  // each time round, so every access needs an activate.
  const uint32_t bpg = c.banks / c.bank_groups;
  std::vector<Feed> feed;
  for (uint32_t i = 0; i < 4000; ++i) {
    const uint32_t bank = i % c.banks;
    feed.push_back({address_of(c, {0, 0, bank % c.bank_groups, bank / c.bank_groups % bpg, 0,
                                   uint64_t(i)}),
                    false, 0});
  }
  const auto done = run_cycle(dram, feed);
  ASSERT_EQ(done.size(), feed.size());
  EXPECT_EQ(dram.counters().row_hits, 0u);
  const auto acts = log.of(DramCommandKind::Activate);
  ASSERT_GE(acts.size(), feed.size());  // refreshes close rows opened ahead of their read
  uint64_t tightest_window = UINT64_MAX;
  for (size_t i = 1; i < acts.size(); ++i) {
    EXPECT_GE(acts[i].time_ps - acts[i - 1].time_ps, uint64_t(c.trrd_s) * c.tck_ps) << i;
    if (i >= 4) {
      const uint64_t window = acts[i].time_ps - acts[i - 4].time_ps;
      EXPECT_GE(window, uint64_t(c.tfaw) * c.tck_ps) << "five activates within tFAW at " << i;
      tightest_window = std::min(tightest_window, window);
    }
  }
  for (uint32_t g = 0; g < c.bank_groups; ++g) {
    int64_t last = -1;
    for (auto& a : acts) {
      if (a.bank_group != g) continue;
      if (last >= 0) EXPECT_GE(int64_t(a.time_ps) - last, int64_t(c.trrd_l) * c.tck_ps);
      last = int64_t(a.time_ps);
    }
  }
  // The stream is activate-bound: four activates fill a window close to tFAW.
  EXPECT_LE(tightest_window, uint64_t(std::max(c.tfaw, 4 * c.trrd_s) + 4 * c.trrd_l) * c.tck_ps);
  const auto errors = ProtocolChecker{c}.check(log.commands, done.back().done_ps);
  EXPECT_TRUE(errors.empty()) << joined(errors);
}

TEST_P(DramParts, ReadAfterWritePaysTheTurnaround) {
  const DramConfig c = quiet(GetParam());
  const uint64_t tck = c.tck_ps, tb = tburst(c), n = bursts(c);
  // Column command time of the second access after the first, both to open rows.
  auto gap = [&](bool first_write, uint32_t second_group) {
    DramModel dram(c, kLine);
    CommandLog log;
    log.attach(dram);
    const uint64_t a = address_of(c, {}), b = address_of(c, {0, 0, second_group, 0, 0, 0});
    dram.enqueue({a, 0, 0, false});
    dram.enqueue({b + 2 * kLine * c.bank_groups, 0, 1, false});  // opens b's row
    drain(dram);
    const uint64_t t = 1000 * tck;
    dram.enqueue({a + kLine * c.bank_groups, t, 2, first_write});  // the first: issued at t
    std::vector<DramCompletion> done;
    dram.advance(t, done);
    dram.enqueue({b + kLine * c.bank_groups, t, 3, false});
    drain(dram);
    const auto cols = log.commands;
    EXPECT_EQ(cols.back().kind, DramCommandKind::Read);
    EXPECT_EQ(cols[cols.size() - 2].time_ps, t);
    return cols.back().time_ps - cols[cols.size() - 2].time_ps;
  };
  const uint64_t read_read = gap(false, 0);
  const uint64_t write_read = gap(true, 0);
  EXPECT_EQ(read_read, std::max(n * c.tccd_l * tck, tb));
  EXPECT_EQ(write_read, c.tcwl * tck + tb + c.twtr_l * tck);  // same bank group: tWTR_L
  EXPECT_GT(write_read, read_read);
  if (c.bank_groups > 1) {
    EXPECT_EQ(gap(true, 1), c.tcwl * tck + tb + c.twtr_s * tck);  // other group: tWTR_S
    EXPECT_EQ(gap(false, 1), std::max(n * c.tccd_s * tck, tb));
  }
  // Read to write: the write's data follows the read's after tRTRS.
  DramModel dram(c, kLine);
  CommandLog log;
  log.attach(dram);
  dram.enqueue({0, 0, 0, false});
  drain(dram);
  const uint64_t t = 1000 * tck;
  dram.enqueue({kLine * c.bank_groups * c.channels, t, 1, false});
  std::vector<DramCompletion> done;
  dram.advance(t, done);
  dram.enqueue({2 * kLine * c.bank_groups * c.channels, t, 2, true});
  drain(dram);
  const uint64_t read_to_write = log.commands.back().time_ps - t;
  EXPECT_EQ(read_to_write, std::max<uint64_t>(n * c.tccd_l * tck,
                                              c.tcl * tck + tb + c.trtrs * tck - c.tcwl * tck));
  EXPECT_EQ(dram.counters().turnarounds, 1u);
}

TEST_P(DramParts, FullQueueRefusesAndLatencyCountsTheHeldTime) {
  DramConfig c = quiet(GetParam());
  c.queue_entries = 4;
  DramModel dram(c, kLine);
  const uint64_t row = address_of(c, {0, 0, 0, 0, 0, 1}) - address_of(c, {});
  for (uint64_t i = 0; i < 4; ++i) {
    ASSERT_TRUE(dram.can_accept(i * row));
    dram.enqueue({i * row, 0, i, false}, 0);  // four conflicts in one bank
  }
  const uint64_t held = 4 * row;
  EXPECT_FALSE(dram.can_accept(held));
  EXPECT_FALSE(dram.try_enqueue({held, 0, 4, false}, 0));
  EXPECT_EQ(dram.counters().queue_full_refusals, 1u);
  // The caller holds it until an entry frees, then sends it with its first-try time.
  std::vector<DramCompletion> done;
  while (done.empty()) dram.advance(dram.next_decision_ps(), done);
  const uint64_t entered = dram.next_decision_ps();
  ASSERT_GT(entered, 0u);
  ASSERT_TRUE(dram.try_enqueue({held, 0, 4, false}, entered));
  while (!dram.idle()) dram.advance(dram.next_decision_ps(), done);
  ASSERT_EQ(done.size(), 5u);
  EXPECT_EQ(done.back().tag, 4u);
  EXPECT_EQ(dram.counters().read_latency_max_ps, done.back().done_ps);  // from time 0
  EXPECT_GT(dram.counters().read_latency_max_ps, entered + dram.latency_ps(RowOutcome::Closed));
  StatsRegistry s;
  dram.report(s, "dram", true, true, done.back().done_ps);
  EXPECT_EQ(s.number("dram.queue_full_stalls"), 1.0);
  EXPECT_DOUBLE_EQ(s.number("dram.latency_max"), double(done.back().done_ps) / 1000.0);
}

TEST_P(DramParts, RefreshEveryTrefiAcrossIdleTimeBlocksTheRank) {
  DramConfig c = part(GetParam(), 1);
  c.page_policy = "open";
  const uint64_t tck = c.tck_ps, refi = uint64_t(c.trefi) * tck, rfc = uint64_t(c.trfc) * tck;
  for (bool lt : {false, true}) {
    SCOPED_TRACE(lt ? "lt" : "cycle");
    DramModel dram(c, kLine);
    CommandLog log;
    log.attach(dram);
    auto access = [&](uint64_t address, uint64_t now) {
      if (lt) return dram.lt_access(address, false, now);
      dram.enqueue({address, now, 0, false});
      return drain(dram).at(0).done_ps;
    };
    access(0, 0);  // leaves a row open: the first refresh precharges it
    // Idle for ten and a half intervals, then a request just after the 11th refresh
    // started: it waits for the rank until tRFC has passed.
    const auto before = log.of(DramCommandKind::Refresh).size();
    EXPECT_EQ(before, 0u);
    const uint64_t arrival = edge_after(11 * refi, tck) + 2 * tck;
    const uint64_t done = access(address_of(c, {0, 0, 0, 0, 0, 5}), arrival);
    const auto refs = log.of(DramCommandKind::Refresh);
    ASSERT_EQ(refs.size(), 11u);
    EXPECT_EQ(dram.counters().refreshes, 11u);
    EXPECT_EQ(refs[0].time_ps, refi + c.trp * tck);  // the open row is closed first
    for (size_t k = 1; k < refs.size(); ++k) EXPECT_EQ(refs[k].time_ps, (k + 1) * refi) << k;
    EXPECT_EQ(done, refs.back().time_ps + rfc + (c.trcd + c.tcl) * tck + tburst(c));
    const auto errors = ProtocolChecker{c}.check(log.commands, done);
    EXPECT_TRUE(errors.empty()) << joined(errors);
  }
}

INSTANTIATE_TEST_SUITE_P(Parts, DramParts,
                         ::testing::Values("lpddr4-3200", "ddr4-2400", "gddr6", "lpddr5"),
                         [](const auto& info) {
                           std::string n = info.param;
                           for (char& ch : n)
                             if (ch == '-') ch = '_';
                           return n;
                         });

namespace {

// Random mixed traffic over a small footprint (hits, misses and conflicts), with
// bursts of arrivals and idle gaps.
std::vector<Feed> random_traffic(const DramConfig& c, uint64_t seed, size_t count,
                                 double write_share, uint64_t mean_gap_ps) {
  std::mt19937_64 rng(seed);
  const uint32_t bpg = c.banks / c.bank_groups;
  std::uniform_int_distribution<uint32_t> channel(0, c.channels - 1), rank(0, c.ranks - 1),
      group(0, c.bank_groups - 1), bank(0, bpg - 1), column(0, c.row_bytes / kLine - 1), row(0, 3);
  std::bernoulli_distribution write(write_share), pause(0.02);
  std::exponential_distribution<double> gap(1.0 / double(mean_gap_ps));
  std::vector<Feed> feed;
  uint64_t t = 0;
  for (size_t i = 0; i < count; ++i) {
    t += uint64_t(gap(rng));
    if (pause(rng)) t += uint64_t(c.trefi) * c.tck_ps / 2;  // idle: refreshes and timeouts
    const Place p{channel(rng), rank(rng), group(rng), bank(rng), column(rng), row(rng)};
    feed.push_back({address_of(c, p), write(rng), t});
  }
  return feed;
}

}  // namespace

TEST(Dram, ProtocolCheckerAcceptsRandomMixedTrafficOfEveryPartAndPolicy) {
  for (const std::string name : {"lpddr4-3200", "ddr4-2400", "gddr6", "lpddr5"})
    for (const std::string policy : {"open", "closed", "timeout"})
      for (bool lt : {false, true}) {
        SCOPED_TRACE(name + " " + policy + (lt ? " lt" : " cycle"));
        DramConfig c = part(name);
        c.ranks = 2;
        c.page_policy = policy;
        c.queue_entries = 16;
        DramModel dram(c, kLine);
        CommandLog log;
        log.attach(dram);
        // Cycle: arrivals faster than the DRAM serves them, so queues fill; lt: a load
        // it keeps up with (it answers at once and cannot push back).
        const uint64_t gap = lt ? 3 * dram.transfer_ps() : dram.transfer_ps() / 4;
        const auto feed = random_traffic(c, 1234 + name.size() + policy.size(), 6000, 0.3, gap);
        uint64_t end = 0;
        size_t completed = 0, writes = 0;
        if (lt) {
          for (const Feed& f : feed)
            end = std::max(end, dram.lt_access(f.address, f.write, f.earliest_ps));
          completed = feed.size();
        } else {
          const auto done = run_cycle(dram, feed);
          completed = done.size();
          for (auto& d : done) {
            end = std::max(end, d.done_ps);
            writes += d.write;
          }
          EXPECT_EQ(writes, dram.counters().writes);
        }
        EXPECT_EQ(completed, feed.size());
        const auto& n = dram.counters();
        EXPECT_EQ(n.reads + n.writes, feed.size());
        EXPECT_EQ(n.row_hits + n.row_closed + n.row_conflicts, feed.size());
        EXPECT_GT(n.row_hits, 0u);
        EXPECT_GT(n.row_conflicts + n.row_closed, 0u);
        EXPECT_GT(n.turnarounds, 0u);
        EXPECT_EQ(n.activates, log.of(DramCommandKind::Activate).size());
        EXPECT_EQ(n.refreshes, log.of(DramCommandKind::Refresh).size());
        if (!lt) EXPECT_GT(n.queue_full_refusals, 0u);
        ProtocolChecker checker{c};
        checker.command_bus_precharges = policy != "closed";
        const auto errors = checker.check(log.commands, end);
        EXPECT_TRUE(errors.empty()) << joined(errors);
      }
}

TEST(Dram, LooselyTimedPathKeepsEachBanksOrderAndDependsOnlyOnRequestTimes) {
  DramConfig c = part("ddr4-2400");
  const auto feed = random_traffic(c, 99, 3000, 0.3, 4000);
  auto run = [&](const std::vector<Feed>& requests, std::vector<DramCommand>* log) {
    DramModel dram(c, kLine);
    if (log) dram.set_command_observer([log](const DramCommand& cmd) { log->push_back(cmd); });
    std::vector<uint64_t> done;
    for (const Feed& f : requests)
      done.push_back(dram.lt_access(f.address, f.write, f.earliest_ps));
    return done;
  };
  std::vector<DramCommand> log;
  const auto first = run(feed, &log);
  EXPECT_EQ(run(feed, nullptr), first);  // deterministic
  // Each bank changes rows in the order of the calls (a request for another row
  // completes after the bank's previous request); hits on the open row and other
  // banks may go first (bank parallelism, as a reordering controller allows), and do.
  DramAddressMap map(c, kLine);
  std::map<std::tuple<uint32_t, uint32_t, uint32_t, uint32_t>, std::pair<uint64_t, uint64_t>> last_of_bank;
  std::vector<std::vector<uint64_t>> done_per_channel(c.channels);
  size_t row_changes = 0;
  for (size_t i = 0; i < feed.size(); ++i) {
    const DramAddress a = map.decode(feed[i].address);
    const auto key = std::make_tuple(a.channel, a.rank, a.bank_group, a.bank);
    auto it = last_of_bank.find(key);
    if (it != last_of_bank.end() && it->second.first != a.row) {
      EXPECT_GT(first[i], it->second.second) << "request " << i;
      ++row_changes;
    }
    last_of_bank[key] = {a.row, first[i]};
    done_per_channel[a.channel].push_back(first[i]);
  }
  EXPECT_GT(row_changes, 100u);
  size_t overtaken = 0;
  for (auto& d : done_per_channel) overtaken += !std::is_sorted(d.begin(), d.end());
  EXPECT_GT(overtaken, 0u) << "no request was ever served before an earlier one";
  // A channel's answers depend on its own requests' times only, not on the other
  // channel's traffic.
  std::vector<Feed> only_channel0;
  std::vector<uint64_t> expected;
  for (size_t i = 0; i < feed.size(); ++i)
    if (map.decode(feed[i].address).channel == 0) {
      only_channel0.push_back(feed[i]);
      expected.push_back(first[i]);
    }
  EXPECT_EQ(run(only_channel0, nullptr), expected);
  // The same rules as the queued path.
  const auto errors = ProtocolChecker{c}.check(log, *std::max_element(first.begin(), first.end()));
  EXPECT_TRUE(errors.empty()) << joined(errors);
}

TEST(Dram, LooselyTimedIsolatedAccessesTakeTheConfiguredLatency) {
  const DramConfig c = quiet("lpddr4-3200");
  DramModel dram(c, kLine);
  const uint64_t tck = c.tck_ps;
  uint64_t now = 1000 * tck;
  EXPECT_EQ(dram.lt_access(0, false, now) - now, dram.latency_ps(RowOutcome::Closed));
  now += 10000 * tck;
  EXPECT_EQ(dram.lt_access(kLine, false, now) - now, dram.latency_ps(RowOutcome::Hit));
  now += 10000 * tck;
  const uint64_t other_row = address_of(c, {0, 0, 0, 0, 0, 1});
  EXPECT_EQ(dram.lt_access(other_row, false, now) - now, dram.latency_ps(RowOutcome::Conflict));
  // Off the DRAM clock the request waits for the next edge.
  now += 10000 * tck + 1;
  EXPECT_EQ(dram.lt_access(other_row + kLine, false, now) - now,
            dram.latency_ps(RowOutcome::Hit) + tck - 1);
}

TEST(Dram, PagePoliciesCloseRowsAsDocumented) {
  const DramConfig base = quiet("ddr4-2400");
  const uint64_t tck = base.tck_ps;
  const uint64_t a = address_of(base, {}), same_row = address_of(base, {0, 0, 0, 0, 3, 0});
  auto outcomes = [&](const std::string& policy, const std::vector<uint64_t>& times,
                      bool lt) {
    DramConfig c = base;
    c.page_policy = policy;
    c.page_timeout = 100;
    DramModel dram(c, kLine);
    std::vector<RowOutcome> out;
    for (size_t i = 0; i < times.size(); ++i) {
      const uint64_t address = i % 2 ? same_row : a;
      if (lt) {
        const auto before = dram.counters();
        dram.lt_access(address, false, times[i]);
        out.push_back(dram.counters().row_hits > before.row_hits ? RowOutcome::Hit
                      : dram.counters().row_closed > before.row_closed ? RowOutcome::Closed
                                                                       : RowOutcome::Conflict);
      } else {
        dram.enqueue({address, times[i], i, false});
        out.push_back(drain(dram).at(0).outcome);
      }
    }
    return out;
  };
  const uint64_t t0 = 1000 * tck;
  // The timeout (100 tCK) counts from the row's last column command, t0 + tRCD for the
  // first access: the second arrives 90 or 101 tCK after it.
  const uint64_t first_col = t0 + base.trcd * tck;
  const std::vector<uint64_t> within = {t0, first_col + 90 * tck};
  const std::vector<uint64_t> after = {t0, first_col + 101 * tck};
  for (bool lt : {false, true}) {
    SCOPED_TRACE(lt ? "lt" : "cycle");
    using R = RowOutcome;
    EXPECT_EQ(outcomes("open", after, lt), (std::vector<R>{R::Closed, R::Hit}));
    EXPECT_EQ(outcomes("timeout", within, lt), (std::vector<R>{R::Closed, R::Hit}));
    EXPECT_EQ(outcomes("timeout", after, lt), (std::vector<R>{R::Closed, R::Closed}));
    EXPECT_EQ(outcomes("closed", within, lt), (std::vector<R>{R::Closed, R::Closed}));
  }
  // Closed: queued hits to the row are served before the auto-precharge.
  DramConfig c = base;
  c.page_policy = "closed";
  DramModel dram(c, kLine);
  CommandLog log;
  log.attach(dram);
  dram.enqueue({a, t0, 0, false});
  dram.enqueue({same_row, t0, 1, false});
  const auto done = drain(dram);
  ASSERT_EQ(done.size(), 2u);
  EXPECT_EQ(done[1].outcome, RowOutcome::Hit);
  const auto pres = log.of(DramCommandKind::Precharge);
  ASSERT_EQ(pres.size(), 1u);
  EXPECT_GT(pres[0].time_ps, log.of(DramCommandKind::Read).back().time_ps);
  // Timeout: the precharge comes page_timeout after the last column command.
  c.page_policy = "timeout";
  c.page_timeout = 100;
  DramModel timed(c, kLine);
  CommandLog timed_log;
  timed_log.attach(timed);
  timed.enqueue({a, t0, 0, false});
  drain(timed);
  timed.settle(t0 + 1000 * tck);
  const auto timeout_pres = timed_log.of(DramCommandKind::Precharge);
  ASSERT_EQ(timeout_pres.size(), 1u);
  EXPECT_EQ(timeout_pres[0].time_ps, first_col + 100 * tck);
}

TEST(Dram, RowHitsAreServedBeforeOlderMisses) {
  DramConfig c = quiet("ddr4-2400");
  DramModel dram(c, kLine);
  const uint64_t conflict = address_of(c, {0, 0, 0, 0, 0, 1});
  dram.enqueue({0, 0, 0, false});  // opens row 0 of bank 0
  const auto first = drain(dram);
  ASSERT_EQ(first.size(), 1u);
  // An older conflict to bank 0 and a younger hit to the open row: the hit goes first.
  const uint64_t t = first[0].done_ps + 1'000'000;
  dram.enqueue({conflict, t, 1, false});
  dram.enqueue({address_of(c, {0, 0, 0, 0, 1, 0}), t + 1, 2, false});
  const auto rest = drain(dram);
  ASSERT_EQ(rest.size(), 2u);
  EXPECT_EQ(rest[0].tag, 2u);
  EXPECT_EQ(rest[0].outcome, RowOutcome::Hit);
  EXPECT_EQ(rest[1].outcome, RowOutcome::Conflict);
}

TEST(Dram, ReadsGoFirstAndWritesDrainBetweenTheWatermarks) {
  DramConfig c = quiet("ddr4-2400", 1);
  c.queue_entries = 8;  // drain from 4 writes down to 2
  c.write_drain_high = 0.5, c.write_drain_low = 0.25;
  auto order = [&](uint32_t writes, uint32_t reads) {
    DramModel dram(c, kLine);
    uint64_t tag = 0;
    for (uint32_t i = 0; i < writes; ++i) dram.enqueue({(tag++) * kLine * 8, 0, tag, true}, 0);
    for (uint32_t i = 0; i < reads; ++i) dram.enqueue({(tag++) * kLine * 8, 0, tag, false}, 0);
    std::string kinds;
    for (auto& d : drain(dram)) kinds += d.write ? 'W' : 'R';
    return kinds;
  };
  EXPECT_EQ(order(3, 3), "RRRWWW");  // below the high watermark: reads first
  EXPECT_EQ(order(4, 3), "WWRRRWW");  // at it: drain to the low watermark, then reads
  EXPECT_EQ(order(2, 0), "WW");       // no read waits: writes go
}

// Issue 37 (DRAMsim3 beside ours on 30% writes): a row activated for a request is
// used by it before it closes, whatever direction the channel turned to meanwhile.
// Before, a write drain precharged rows opened for waiting reads, and the reads
// activated them again: 5-7% more activates than requests on random traffic.
TEST(Dram, EveryActivateIsUsedBeforeItsRowCloses) {
  for (const std::string name : dram_part_names()) {
    DramConfig c = quiet(name, 1);  // no refresh, open pages: nothing else closes a row
    c.queue_entries = 16;
    DramModel dram(c, kLine);
    std::map<std::pair<uint32_t, uint32_t>, bool> used;  // (rank, bank) -> its ACT met a column
    uint64_t wasted = 0, activates = 0;
    dram.set_command_observer([&](const DramCommand& k) {
      const auto key = std::make_pair(k.rank, k.bank);
      if (k.kind == DramCommandKind::Activate) {
        ++activates;
        used[key] = false;
      } else if (k.kind == DramCommandKind::Read || k.kind == DramCommandKind::Write) {
        used[key] = true;
      } else if (k.kind == DramCommandKind::Precharge) {
        if (used.count(key) && !used[key]) ++wasted;
        used.erase(key);
      }
    });
    run_cycle(dram, random_traffic(c, 37, 4000, 0.3, 2 * tburst(c)));
    EXPECT_GT(activates, 1000u) << name;
    EXPECT_EQ(wasted, 0u) << name << ": activates closed unused";
  }
}

TEST(Dram, ResetCountersKeepsRowAndTimingState) {
  const DramConfig c = quiet("lpddr4-3200");
  DramModel dram(c, kLine);
  dram.enqueue({0, 0, 0, false});
  drain(dram);
  dram.reset_counters();
  EXPECT_EQ(dram.counters().reads, 0u);
  EXPECT_EQ(dram.counters().activates, 0u);
  EXPECT_EQ(dram.latency_percentile_ns(0.99), 0.0);
  dram.enqueue({kLine, 1'000'000, 1, false});
  const auto done = drain(dram);
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0].outcome, RowOutcome::Hit);  // the row stayed open
  EXPECT_EQ(dram.counters().reads, 1u);
  EXPECT_EQ(dram.counters().row_hits, 1u);
}

TEST(Dram, ReportNamesEveryFigureWithUnits) {
  DramConfig c = part("lpddr5");
  DramModel dram(c, kLine);
  dram.lt_access(0, false, 0);
  dram.lt_access(kLine, true, 100000);
  dram.count_access(0, true);
  StatsRegistry s;
  dram.report(s, "dram", true, true, 1'000'000);
  for (const char* key : {"reads", "bytes", "writes", "bytes_written", "row_hits", "row_misses",
                          "row_conflicts", "activates", "precharges", "refreshes", "turnarounds",
                          "queue_full_stalls", "latency_avg", "latency_p99", "latency_max",
                          "write_latency_avg", "write_latency_p99", "write_latency_max",
                          "bandwidth", "write_bandwidth", "bus_utilisation", "peak_bandwidth"}) {
    const std::string path = std::string("dram.") + key;
    ASSERT_TRUE(s.contains(path)) << path;
    EXPECT_FALSE(s.at(path).unit.empty()) << path;
    EXPECT_FALSE(s.at(path).description.empty()) << path;
  }
  EXPECT_EQ(s.number("dram.bytes"), 64.0);  // bytes read
  EXPECT_EQ(s.number("dram.bytes_written"), 128.0);
  EXPECT_EQ(s.at("dram.bytes").description, "bytes read from DRAM");
}

TEST(Dram, AddressMappingPutsConfiguredFieldLowest) {
  DramConfig c = part("ddr4-2400");
  c.channels = 4;
  c.address_mapping = "row:rank:bank:column:channel";
  DramAddressMap map(c, 64);
  EXPECT_EQ(map.decode(64).channel, 1u);
  EXPECT_EQ(map.decode(64 * 4).column, 1u);
  EXPECT_EQ(map.decode(64 * 4 * 128).bank, 1u);  // without a bankgroup field: the bank number
  EXPECT_EQ(map.decode(64 * 4 * 128 * 4).bank_group, 1u);  // whose top bits are the group
  c.address_mapping = "row:channel:rank:column:bank";
  DramAddressMap other(c, 64);
  EXPECT_EQ(other.decode(64).bank, 1u);
  EXPECT_EQ(other.decode(64).channel, 0u);
  // The default mapping interleaves bank groups right above the channel.
  c = part("ddr4-2400");
  DramAddressMap standard(c, 64);
  EXPECT_EQ(standard.decode(64 * 2).bank_group, 1u);
  EXPECT_EQ(standard.decode(64 * 2).bank, 4u);  // group 1, its bank 0
  EXPECT_EQ(standard.decode(64 * 2 * 4).column, 1u);
  const Place p{1, 0, 3, 2, 17, 12345};
  const DramAddress d = standard.decode(address_of(c, p));
  EXPECT_EQ(d.channel, 1u);
  EXPECT_EQ(d.bank_group, 3u);
  EXPECT_EQ(d.bank, 3u * 4 + 2);
  EXPECT_EQ(d.column, 17u);
  EXPECT_EQ(d.row, 12345u);
}

TEST(Dram, ValidateChecksDramRulesByKey) {
  auto error_of = [](const std::function<void(DramConfig&)>& change) {
    HardwareConfig c = preset("desktop");
    change(c.dram);
    try {
      validate(c);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error_of([](DramConfig&) {}), "");
  EXPECT_NE(error_of([](DramConfig& d) { d.bank_groups = 3; }).find("dram.bank_groups"),
            std::string::npos);
  EXPECT_NE(error_of([](DramConfig& d) { d.bank_groups = 32; }).find("dram.bank_groups"),
            std::string::npos);
  EXPECT_NE(error_of([](DramConfig& d) { d.tccd_s = 9; }).find("dram.tccd_s"), std::string::npos);
  EXPECT_NE(error_of([](DramConfig& d) { d.trrd_s = 9; }).find("dram.trrd_s"), std::string::npos);
  EXPECT_NE(error_of([](DramConfig& d) { d.twtr_s = 10; }).find("dram.twtr_s"), std::string::npos);
  EXPECT_NE(error_of([](DramConfig& d) { d.trfc = d.trefi; }).find("dram.trfc"), std::string::npos);
  EXPECT_EQ(error_of([](DramConfig& d) { d.trefi = 0; }), "");  // no refresh
  EXPECT_NE(error_of([](DramConfig& d) { d.write_drain_low = 0.6; }).find("dram.write_drain_low"),
            std::string::npos);
  EXPECT_NE(error_of([](DramConfig& d) { d.address_mapping = "row:rank:bank:column:bankgroup:"
                                                             "channel:bankgroup"; })
                .find("dram.address_mapping"),
            std::string::npos);
  EXPECT_EQ(error_of([](DramConfig& d) { d.address_mapping = "row:rank:bank:column:channel"; }),
            "");
}

TEST(Dram, EveryPartValidatesAndRefreshCostsLessThanATenth) {
  for (const std::string& name : dram_part_names()) {
    HardwareConfig c = preset("mobile");
    apply_dram_part(c.dram, name);
    EXPECT_NO_THROW(validate(c)) << name;
    EXPECT_EQ(c.dram.part, name);
    EXPECT_LT(double(c.dram.trfc) / c.dram.trefi, 0.1) << name;
    EXPECT_EQ(c.dram.banks % c.dram.bank_groups, 0u) << name;
  }
  // The LPDDR4 channel is two x16 dies in lockstep: 64 bytes per BL16, two 2 KiB pages.
  DramConfig lpddr4 = part("lpddr4-3200");
  EXPECT_EQ(lpddr4.burst_bytes, 64u);
  EXPECT_EQ(lpddr4.row_bytes, 4096u);
  EXPECT_THROW(apply_dram_part(lpddr4, "sdram"), InputError);
}
