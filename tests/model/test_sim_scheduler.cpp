// The cycle level's UnitScheduler: which unit runs when, in which order. Each
// case elaborates its own units (one process per case, as SystemC needs).
#include <rtsim/model/sim/cycle/unit_scheduler.h>

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

using namespace rtsim::sim;

namespace {

// A unit that logs "<time>:<name><item>" for every item it handles and, for an
// item in `then`, pushes the follow-ups named there.
struct Follow {
  int item;
  struct Push {
    size_t unit;
    uint64_t delay_ps;
    int item;
  };
  std::vector<Push> pushes;
};

struct Units {
  UnitScheduler scheduler{"scheduler"};
  std::vector<std::unique_ptr<TimedQueue<int>>> queues;
  std::vector<Follow> then;
  std::vector<std::string> log;
  uint32_t runs = 0;  // wakes delivered, empty drains included

  explicit Units(size_t n) {
    for (size_t u = 0; u < n; ++u)
      queues.push_back(std::make_unique<TimedQueue<int>>(scheduler, [this, u] {
        ++runs;
        queues[u]->drain([&](int item) {
          log.push_back(std::to_string(now_ps()) + ":" + char('A' + u) + std::to_string(item));
          for (const Follow& f : then)
            if (f.item == item)
              for (const Follow::Push& p : f.pushes) queues[p.unit]->push(now_ps() + p.delay_ps, p.item);
        });
      }));
  }
};

std::string joined(const std::vector<std::string>& log) {
  std::string s;
  for (const std::string& e : log) s += (s.empty() ? "" : " ") + e;
  return s;
}

}  // namespace

TEST(UnitScheduler, UnitsDueTogetherRunInBuildOrderAndAWakeForNowRunsInTheNextRound) {
  Units u(3);
  // At 10 ps: C asks first, then A; A's item 1 wakes B and C for now, B's item 2
  // wakes A for now.
  u.then = {{1, {{1, 0, 2}, {2, 0, 3}}}, {2, {{0, 0, 4}}}};
  u.queues[2]->push(10, 0);
  u.queues[0]->push(10, 1);
  sc_core::sc_start();
  // Round 1: A then C (build order, not asking order); C, running after A,
  // already finds A's item. Round 2: B (and C again, with nothing left), woken
  // by A. Round 3: A, woken by B.
  EXPECT_EQ(joined(u.log), "10:A1 10:C0 10:C3 10:B2 10:A4");
  EXPECT_EQ(u.runs, 5u);
  EXPECT_EQ(sc_core::sc_time_stamp().value(), 10u);
}

TEST(UnitScheduler, ItemsDueLaterWaitForTheirTimeAndAnEarlierOneComesFirst) {
  Units u(2);
  u.queues[0]->push(300, 7);
  u.queues[0]->push(100, 5);  // supersedes the wake at 300
  u.queues[1]->push(200, 6);
  u.queues[0]->push(300, 8);  // equal times keep insertion order
  sc_core::sc_start();
  EXPECT_EQ(joined(u.log), "100:A5 200:B6 300:A7 300:A8");
  // One wake per time the unit has work: the superseded one is not delivered.
  EXPECT_EQ(u.runs, 3u);
}

TEST(UnitScheduler, AnItemPushedForThePastIsHandledNowAndTimeNeverGoesBack) {
  Units u(2);
  // At 50 ps A's item 1 gives B an item due 40 ps ago (a late answer): B takes
  // it at 50, not earlier.
  u.then = {{1, {{1, uint64_t(-40), 2}}}};
  u.queues[0]->push(50, 1);
  sc_core::sc_start();
  ASSERT_EQ(u.log.size(), 2u);
  EXPECT_EQ(u.log[1], "50:B2");
}

TEST(UnitScheduler, ItemsAUnitPushesForNowWhileDrainingAreHandledInTheSameDrain) {
  Units u(1);
  u.then = {{1, {{0, 0, 2}}}, {2, {{0, 5, 3}}}};
  u.queues[0]->push(20, 1);
  sc_core::sc_start();
  EXPECT_EQ(joined(u.log), "20:A1 20:A2 25:A3");
  EXPECT_EQ(u.runs, 2u);  // 20 (items 1 and 2 in one drain) and 25
}
