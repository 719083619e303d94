/// @file threads.h
/// @brief The thread count of each step, chosen from the steps' own times.
#pragma once

#include <array>
#include <cstdint>

namespace pfmpm
{

/// @brief Chooses how many OpenMP threads each step runs on, so that threads
/// do not make a run slower than fewer would.
///
/// On a machine whose cores are busy with other work, every barrier of a step
/// may wait for a thread that the operating system has set aside, and two
/// threads can be slower than one (docs/performance.md, "Threads on a busy
/// machine"). Since every kernel gives the same bits on any number of
/// threads, the count may change from step to step without changing the
/// result; this class changes it by measurement:
/// - the first `settle` steps (allocations, the first sort, a cold
///   phase-field solve) run on `most` threads, the user's count;
/// - each period ends with `window` steps on the count kept, n, timed;
/// - a probe then runs `window` steps on the other candidate m (n / 2, or
///   2 n when n < most; with both open, down and up in turn), or fewer if
///   they already took longer than n's window, and m is kept if its steps
///   took less than `margin` times n's on average. Single steps are too
///   noisy to decide on a busy machine: a step of a few milliseconds takes
///   one or two of the scheduler's time slices;
/// - the first period is `window` steps; the next is `shortest` steps after
///   a change, and twice the last (at least `shortest`, at most `longest`)
///   after a probe that kept the count.
/// A probe costs the difference between `window` steps on m and on n: on a
/// quiet machine with two threads twice as fast as one, about half a
/// percent of the steps once the period is `longest`.
class ThreadGovernor
{
public:
  static constexpr int settle = 2;       ///< steps on all threads first
  static constexpr int window = 8;       ///< steps timed on each count
  static constexpr int shortest = 50;    ///< steps of a period after a change
  static constexpr int longest = 800;    ///< and of the longest
  static constexpr double margin = 0.95; ///< m kept if its mean step < margin x n's

  /// @brief Threads for the next step, `most` the user's count (a change of
  /// it starts the schedule again).
  int next(int most);
  /// @brief The wall time of the step just run on next()'s count.
  void record(double seconds);
  /// Steps run on fewer threads than `most` so far.
  std::int64_t reduced_steps() const { return _reduced; }
  /// Steps to the end of the first probe: a warm-up after which steps run
  /// as a long run's do.
  static constexpr int warmup() { return settle + 2 * window; }

private:
  int other();

  int _most = 0;          // the user's count the schedule is for
  int _n = 0;             // the count kept
  int _m = 0;             // the candidate of the probe under way
  int _running = 0;       // the count of the step under way
  int _phase_step = 0;    // steps into settling, the period or the probe
  bool _settled = false;  // the first settle steps are done
  bool _probing = false;
  bool _try_up = false;   // with both ways open, the last probe went up
  int _period = window;
  std::array<double, window> _last{}; // the period's last step times, a ring
  double _probe_sum = 0.0;
  std::int64_t _reduced = 0;
};

} // namespace pfmpm
