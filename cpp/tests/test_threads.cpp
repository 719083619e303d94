/// @file test_threads.cpp
/// @brief ThreadGovernor: the thread count it keeps for given step times, and
/// what its probes cost.
#include "pfmpm/solver/threads.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <functional>
#include <map>
#include <thread>

#include <sched.h>

using namespace pfmpm;

namespace
{
/// Steps on the counts the governor chooses, step k taking time(n, k) on n
/// threads, of which the calling thread waited for a core a fraction
/// wait(n, k); the steps run on each count from step `from` on.
using Of = std::function<double(int, int)>;
std::map<int, int> run(ThreadGovernor& g, int most, int steps, const Of& time, int from = 0,
                       const Of& wait = [](int, int) { return 0.0; })
{
  std::map<int, int> on;
  for (int k = 0; k < steps; ++k)
  {
    const int n = g.next(most);
    g.record(time(n, k), wait(n, k) * time(n, k));
    if (k >= from)
      ++on[n];
  }
  return on;
}
} // namespace

TEST(ThreadGovernor, QuietMachineKeepsEveryThreadAndProbesRarely)
{
  // Two threads 1.5 times faster than one. Each probe stops after its first
  // step on one thread, slower than `slower` times the window's mean on two;
  // the probes come at steps 10, 61, 162, 363, 764 and 1565 (periods of 8,
  // 50, 100, 200, 400 and 800 steps, each ending with the window).
  ThreadGovernor g;
  const auto on = run(g, 2, 2000, [](int n, int) { return n == 2 ? 1.0 : 1.5; });
  EXPECT_EQ(on.at(1), 6);
  EXPECT_EQ(g.reduced_steps(), 6);
  EXPECT_EQ(g.next(2), 2);
}

TEST(ThreadGovernor, BusyMachineDropsToOneThread)
{
  // Two threads twice as slow as one: the first probe (steps 10-17) keeps one
  // thread; from step 18 each probe stops after its first step on two, at
  // steps 68, 169, 370, 771 and 1572.
  ThreadGovernor g;
  const auto on = run(g, 2, 2000, [](int n, int) { return n == 2 ? 2.0 : 1.0; }, 18);
  EXPECT_EQ(on.at(2), 5);
  EXPECT_EQ(on.at(1), 1982 - 5);
}

TEST(ThreadGovernor, CloseTimesKeepTheCount)
{
  // One thread 3 % faster, less than the margin: a whole window on it (steps
  // 10-17), and two threads kept.
  ThreadGovernor g;
  const auto on = run(g, 2, 60, [](int n, int) { return n == 2 ? 1.0 : 0.97; });
  EXPECT_EQ(on.at(1), 8);
  EXPECT_EQ(g.next(2), 2);
}

TEST(ThreadGovernor, FindsTheFastestCountAmongMany)
{
  // 16 threads: time 1/n + 0.1 n is least at n = 4 (0.65; 2: 0.7, 8: 0.925),
  // found by halving twice; later probes go up to 8 and down to 2 in turn.
  ThreadGovernor g;
  const auto on = run(g, 16, 4000, [](int n, int) { return 1.0 / n + 0.1 * n; }, 2000);
  EXPECT_GE(on.at(4), 1980);
  EXPECT_EQ(on.count(16) + on.count(1), 0u);
}

TEST(ThreadGovernor, OneThreadIsNeverProbedAndANewCountStartsAgain)
{
  ThreadGovernor g;
  const auto on = run(g, 1, 500, [](int, int) { return 1.0; });
  EXPECT_EQ(on.size(), 1u);
  EXPECT_EQ(g.reduced_steps(), 0);
  // The user's count changes: two settling steps on it first.
  EXPECT_EQ(g.next(2), 2);
  g.record(1.0, 0.0);
  EXPECT_EQ(g.next(2), 2);
}

TEST(ThreadGovernor, CrowdedMachineNeverProbesUp)
{
  // Two threads three times as slow as one, and the calling thread waiting
  // for a core 40 % of the time: two settling steps and the first window
  // (steps 2-9) on two threads, the probe down keeps one, and no step on two
  // threads after it (without the wait, one at each period's end: 5 more).
  ThreadGovernor g;
  const Of time = [](int n, int) { return n == 2 ? 3.0 : 1.0; };
  const Of wait = [](int, int) { return 0.4; };
  const auto on = run(g, 2, 2000, time, 0, wait);
  EXPECT_EQ(on.at(2), 10);
  EXPECT_EQ(on.at(1), 1990);
}

TEST(ThreadGovernor, LoadArrivingDuringAPeriodEndsIt)
{
  // Quiet (two threads 1.5 times as fast as one) but from step 500 to 1500,
  // where two threads become three times as slow as one and the calling
  // thread waits for a core 40 % of the time. The period under way (200
  // steps by then) ends at once with a probe down, which keeps one thread;
  // no step runs on two threads while the load lasts, and two threads come
  // back at the end of the first period of `shortest` steps with no crowded
  // window: at most two periods and a window after the load.
  ThreadGovernor g;
  const auto loaded = [](int k) { return k >= 500 && k < 1500; };
  int on_two_loaded = 0, back = -1;
  for (int k = 0; k < 2000; ++k)
  {
    const int n = g.next(2);
    const double time = loaded(k) ? (n == 2 ? 3.0 : 1.0) : (n == 2 ? 1.0 : 1.5);
    g.record(time, (loaded(k) ? 0.4 : 0.0) * time);
    if (loaded(k) && k > 500 && n == 2)
      ++on_two_loaded;
    if (k >= 1500 && n == 2 && back < 0)
      back = k;
  }
  EXPECT_EQ(on_two_loaded, 0);
  EXPECT_GE(back, 1500);
  EXPECT_LE(back, 1500 + 2 * ThreadGovernor::shortest + ThreadGovernor::window);
}

TEST(RunQueueWait, CountsTheTimeAThreadWaitsForItsCore)
{
  // This thread and a second one, both on one core and both busy for 0.2 s
  // of wall time: the scheduler lets each run about half of it, so this
  // thread waits about 0.1 s; alone, it waits about nothing.
  if (std::FILE* f = std::fopen("/proc/thread-self/schedstat", "r"))
    std::fclose(f);
  else
    GTEST_SKIP() << "this kernel keeps no scheduler statistics";
  const int core = sched_getcpu();
  cpu_set_t one, before;
  CPU_ZERO(&one);
  if (core >= 0)
    CPU_SET(core, &one);
  if (core < 0 || sched_getaffinity(0, sizeof(before), &before) != 0 ||
      sched_setaffinity(0, sizeof(one), &one) != 0)
    GTEST_SKIP() << "this thread cannot be pinned to one core here";
  const auto busy = [](double seconds)
  {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end)
    {
    }
  };
  const RunQueueWait waits;
  const double alone = waits.seconds();
  busy(0.1);
  const double shared = waits.seconds();
  std::thread other([&] { busy(0.2); }); // inherits the one core
  busy(0.2);
  other.join();
  const double after = waits.seconds();
  ASSERT_EQ(sched_setaffinity(0, sizeof(before), &before), 0);
  EXPECT_LT(shared - alone, 0.01);
  EXPECT_GT(after - shared, 0.05);
  EXPECT_LT(after - shared, 0.2);
}
