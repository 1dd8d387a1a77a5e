#pragma once

#include <chrono>

namespace muscle
{

/// Wall-clock time of a run's phases (summary.json, progress lines).
using Clock = std::chrono::steady_clock;

inline double seconds_since(Clock::time_point start)
{
  return std::chrono::duration<double>(Clock::now() - start).count();
}

} // namespace muscle
