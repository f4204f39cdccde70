// fork_without_workers: a process that has run parallel work forks with no worker
// thread alive (so the child inherits no lock a worker held), the child can run
// parallel work of its own, and the parent's parallel work goes on afterwards.
#include <rtsim/workloads/fork.h>

#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <thread>

namespace {

uint64_t parallel_sum(uint64_t n) {
  std::atomic<uint64_t> sum{0};
  tbb::parallel_for(uint64_t(0), n, [&](uint64_t i) { sum += i; });
  return sum;
}

}  // namespace

TEST(ForkWithoutWorkers, NoWorkerIsAliveAtTheForkAndBothSidesGoOn) {
  if (std::thread::hardware_concurrency() < 2) GTEST_SKIP() << "one core: TBB starts no workers";
  ASSERT_EQ(parallel_sum(100000), uint64_t(100000) * 99999 / 2);
  ASSERT_GT(rtsim::thread_count(), 1u);  // the workers of the loop above
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  const pid_t pid = rtsim::fork_without_workers();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const uint64_t sum = parallel_sum(1000);
    (void)!write(fds[1], &sum, sizeof sum);
    _exit(0);
  }
  close(fds[1]);
  EXPECT_EQ(rtsim::thread_count(), 1u);  // the workers were stopped before the fork
  uint64_t child_sum = 0;
  ASSERT_EQ(read(fds[0], &child_sum, sizeof child_sum), ssize_t(sizeof child_sum));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  EXPECT_EQ(child_sum, uint64_t(1000) * 999 / 2);
  EXPECT_EQ(parallel_sum(100000), uint64_t(100000) * 99999 / 2);
  EXPECT_GT(rtsim::thread_count(), 1u);  // and start again when needed
}
