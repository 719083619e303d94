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
/// threads can be much slower than one (docs/performance/threads.md).
/// Since every kernel gives the same bits on any number of
/// threads, the count may change from step to step without changing the
/// result; this class changes it by measurement:
/// - the first `settle` steps (allocations, the first sort, a cold
///   phase-field solve) run on `most` threads, the user's count;
/// - each period ends with `window` steps on the count kept, n, timed;
/// - a probe then runs `window` steps on the other candidate m (n / 2, or
///   2 n when n < most; with both open, down and up in turn), and m is kept
///   if its steps took less than `margin` times n's on average. Single
///   steps are too noisy to decide for m on a busy machine (a step of a few
///   milliseconds takes one or two of the scheduler's time slices), but not
///   to decide against it: the probe stops, keeping n, as soon as its mean
///   step is above `slower` times n's, or its steps took longer than n's
///   window;
/// - the first period is `window` steps; the next is `shortest` steps after
///   a change, and twice the last (at least `shortest`, at most `longest`)
///   after a probe that kept the count.
///
/// The time the calling thread spent ready to run but waiting for a core
/// (the scheduler's run-queue wait, RunQueueWait), over the wall time of n's
/// window, tells whether the machine has a core to spare: above `crowded`,
/// the thread itself waits for a core, so more threads would find none
/// free. Unlike CPU time, it does not count the time a thread sleeps at a
/// barrier. Then
/// - a probe goes up only at the end of a period none of whose windows was
///   crowded; otherwise the period ends with a probe down if there is one
///   to make, or else starts again, which costs nothing;
/// - on n > 1 threads, a crowded window ends the period at once with a
///   probe down (the load came during the period). After it, the next such
///   early probe waits for an uncrowded window first.
/// A probe that keeps n costs the difference between its steps on m and
/// as many on n: on a quiet machine with two threads twice as fast as one,
/// one step's worth per period; on a crowded one nothing once the count is
/// down.
class ThreadGovernor
{
public:
  static constexpr int settle = 2;       ///< steps on all threads first
  static constexpr int window = 8;       ///< steps timed on each count
  static constexpr int shortest = 50;    ///< steps of a period after a change
  static constexpr int longest = 800;    ///< and of the longest
  static constexpr double margin = 0.95; ///< m kept if its mean step < margin x n's
  static constexpr double slower = 1.25; ///< a probe stops when its mean step > slower x n's
  static constexpr double crowded = 0.1; ///< run-queue wait over wall time above it: no core to spare

  /// @brief Threads for the next step, `most` the user's count (a change of
  /// it starts the schedule again).
  int next(int most);
  /// @brief The wall time of the step just run on next()'s count, and the
  /// time the calling thread waited for a core in it.
  void record(double seconds, double waited);
  /// Steps run on fewer threads than `most` so far.
  std::int64_t reduced_steps() const { return _reduced; }
  /// Steps to the end of the first probe: a warm-up after which steps run
  /// as a long run's do.
  static constexpr int warmup() { return settle + 2 * window; }

private:
  int other();
  void start_probe(int m);

  int _most = 0;          // the user's count the schedule is for
  int _n = 0;             // the count kept
  int _m = 0;             // the candidate of the probe under way
  int _running = 0;       // the count of the step under way
  int _phase_step = 0;    // steps into settling, the period or the probe
  bool _settled = false;  // the first settle steps are done
  bool _probing = false;
  bool _try_up = false;   // with both ways open, the last probe went up
  bool _calm = true;      // no window of this period was crowded
  bool _early = true;     // a crowded window may end a period early
  int _period = window;
  std::array<double, window> _last{}; // the period's last step times, a ring
  std::array<double, window> _waited{}; // and the calling thread's waits for a core
  double _probe_sum = 0.0;
  std::int64_t _reduced = 0;
};

/// @brief The time the calling thread has spent ready to run but waiting
/// for a core, from the scheduler's statistics (/proc/thread-self/schedstat,
/// its second field), or zero where the kernel does not keep them.
class RunQueueWait
{
public:
  RunQueueWait();
  ~RunQueueWait();
  RunQueueWait(const RunQueueWait&) = delete;
  RunQueueWait& operator=(const RunQueueWait&) = delete;
  /// Seconds waited so far by the thread that constructed this object.
  double seconds() const;

private:
  int _fd; // the statistics file, open while this object lives; -1 if none
};

} // namespace pfmpm
