/// @file threads.cpp
/// @brief The thread count of each step, chosen from the steps' own times.
#include "pfmpm/solver/threads.h"

#include <algorithm>
#include <numeric>

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

void ThreadGovernor::record(double seconds)
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
    if (_phase_step < _period)
      return;
    _probing = true; // the period's last `window` steps are n's times
    _phase_step = 0;
    _probe_sum = 0.0;
    _m = other();
    return;
  }
  _probe_sum += seconds;
  const double n_sum = std::accumulate(_last.begin(), _last.end(), 0.0);
  if (_phase_step < window && _probe_sum <= n_sum)
    return;
  // m's mean step against n's (a probe cut short is slower than n's window).
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

int ThreadGovernor::other()
{
  const bool down = _n > 1, up = _n < _most;
  // Both ways open (more than two threads): alternately down and up.
  const bool go_up = up && (!down || (_try_up = !_try_up));
  return go_up ? std::min(_most, 2 * _n) : std::max(1, _n / 2);
}

} // namespace pfmpm
