/// @file threads.cpp
/// @brief The thread count of each step, chosen from the steps' own times.
#include "pfmpm/solver/threads.h"

#include <algorithm>
#include <cstdlib>
#include <numeric>

#include <fcntl.h>
#include <unistd.h>

namespace pfmpm
{

int ThreadGovernor::next(int most)
{
  if (most != _most)
  {
    *this = ThreadGovernor{};
    _most = _n = most;
  }
  _running = _probing ? _m : _n;
  return _running;
}

void ThreadGovernor::record(double seconds, double waited)
{
  if (_running < _most)
    ++_reduced;
  if (_most <= 1)
    return;
  ++_phase_step;
  if (!_settled)
  {
    if (_phase_step == settle)
    {
      _settled = true;
      _phase_step = 0;
    }
    return;
  }
  if (!_probing)
  {
    _last[_phase_step % window] = seconds;
    _waited[_phase_step % window] = waited;
    if (_phase_step >= window) // a full window of this period's steps
    {
      const bool busy = std::accumulate(_waited.begin(), _waited.end(), 0.0) >
                        crowded * std::accumulate(_last.begin(), _last.end(), 0.0);
      _calm = _calm && !busy;
      _early = _early || !busy;
      if (busy && _n > 1 && _early)
      {
        _early = false; // the load came during the period: end it now
        start_probe(std::max(1, _n / 2));
        return;
      }
    }
    if (_phase_step < _period)
      return;
    const int m = other();
    if (m == _n)
    {
      _phase_step = 0; // crowded on one thread: the same period again
      _calm = true;
      return;
    }
    start_probe(m);
    return;
  }
  _probe_sum += seconds;
  const double n_sum = std::accumulate(_last.begin(), _last.end(), 0.0);
  if (_phase_step < window && _probe_sum <= n_sum &&
      _probe_sum * window <= slower * n_sum * _phase_step)
    return;
  // m's mean step against n's (a probe cut short is slower than n's).
  const bool keep_m = _probe_sum / _phase_step < margin * n_sum / window;
  _probing = false;
  _phase_step = 0;
  if (keep_m)
  {
    _n = _m;
    _period = shortest;
  }
  else
    _period = std::clamp(2 * _period, shortest, longest);
}

void ThreadGovernor::start_probe(int m)
{
  _m = m;
  _probing = true;
  _probe_sum = 0.0;
  _phase_step = 0; // the period's last `window` steps are n's times
  _calm = true;
}

int ThreadGovernor::other()
{
  // Up only after a period whose every window found a core to spare.
  const bool down = _n > 1, up = _n < _most && _calm;
  if (!down && !up)
    return _n;
  // Both ways open (more than two threads): alternately down and up.
  const bool go_up = up && (!down || (_try_up = !_try_up));
  return go_up ? std::min(_most, 2 * _n) : std::max(1, _n / 2);
}

RunQueueWait::RunQueueWait() : _fd(open("/proc/thread-self/schedstat", O_RDONLY | O_CLOEXEC)) {}

RunQueueWait::~RunQueueWait()
{
  if (_fd >= 0)
    close(_fd);
}

double RunQueueWait::seconds() const
{
  // "run-time wait-time timeslices", in ns; read again from the start.
  char text[96];
  const ssize_t n = _fd >= 0 ? pread(_fd, text, sizeof(text) - 1, 0) : -1;
  if (n <= 0)
    return 0.0;
  text[n] = '\0';
  char* end = nullptr;
  std::strtoull(text, &end, 10);
  return 1e-9 * static_cast<double>(std::strtoull(end, nullptr, 10));
}

} // namespace pfmpm
