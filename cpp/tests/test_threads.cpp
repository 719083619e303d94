/// @file test_threads.cpp
/// @brief ThreadGovernor: the thread count it keeps for given step times, and
/// what its probes cost.
#include "pfmpm/solver/threads.h"

#include <gtest/gtest.h>

#include <functional>
#include <map>

using namespace pfmpm;

namespace
{
/// Steps on the counts the governor chooses, each taking time(n) on n
/// threads; the steps run on each count from step `from` on.
std::map<int, int> run(ThreadGovernor& g, int most, int steps, const std::function<double(int)>& time,
                       int from = 0)
{
  std::map<int, int> on;
  for (int k = 0; k < steps; ++k)
  {
    const int n = g.next(most);
    g.record(time(n));
    if (k >= from)
      ++on[n];
  }
  return on;
}
} // namespace

TEST(ThreadGovernor, QuietMachineKeepsEveryThreadAndProbesRarely)
{
  // Two threads 1.5 times faster than one. Each probe stops after 6 steps on
  // one thread, whose 9 time units exceed the 8 of the window on two; the
  // probes start at steps 10, 66, 172, 378, 784 and 1590 (periods of 8, 50,
  // 100, 200, 400 and 800 steps, each ending with the window).
  ThreadGovernor g;
  const auto on = run(g, 2, 2000, [](int n) { return n == 2 ? 1.0 : 1.5; });
  EXPECT_EQ(on.at(1), 6 * 6);
  EXPECT_EQ(g.reduced_steps(), 36);
  EXPECT_EQ(g.next(2), 2);
}

TEST(ThreadGovernor, BusyMachineDropsToOneThread)
{
  // Two threads twice as slow as one: the first probe (steps 10-17) keeps one
  // thread; from step 18 each probe stops after 5 steps on two (10 time units
  // against the window's 8), at steps 68, 173, 378, 783 and 1588.
  ThreadGovernor g;
  const auto on = run(g, 2, 2000, [](int n) { return n == 2 ? 2.0 : 1.0; }, 18);
  EXPECT_EQ(on.at(2), 5 * 5);
  EXPECT_EQ(on.at(1), 1982 - 25);
}

TEST(ThreadGovernor, CloseTimesKeepTheCount)
{
  // One thread 3 % faster, less than the margin: a whole window on it (steps
  // 10-17), and two threads kept.
  ThreadGovernor g;
  const auto on = run(g, 2, 60, [](int n) { return n == 2 ? 1.0 : 0.97; });
  EXPECT_EQ(on.at(1), 8);
  EXPECT_EQ(g.next(2), 2);
}

TEST(ThreadGovernor, FindsTheFastestCountAmongMany)
{
  // 16 threads: time 1/n + 0.1 n is least at n = 4 (0.65; 2: 0.7, 8: 0.925),
  // found by halving twice; later probes go up to 8 and down to 2 in turn.
  ThreadGovernor g;
  const auto on = run(g, 16, 4000, [](int n) { return 1.0 / n + 0.1 * n; }, 2000);
  EXPECT_GE(on.at(4), 1980);
  EXPECT_EQ(on.count(16) + on.count(1), 0u);
}

TEST(ThreadGovernor, OneThreadIsNeverProbedAndANewCountStartsAgain)
{
  ThreadGovernor g;
  const auto on = run(g, 1, 500, [](int) { return 1.0; });
  EXPECT_EQ(on.size(), 1u);
  EXPECT_EQ(g.reduced_steps(), 0);
  // The user's count changes: two settling steps on it first.
  EXPECT_EQ(g.next(2), 2);
  g.record(1.0);
  EXPECT_EQ(g.next(2), 2);
}
