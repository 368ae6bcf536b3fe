// The limits on input that the simulator shares with ipgen (generator/limits.py has the same
// numbers and says why; tests/test_bad_input_properties.py parses this file and fails when the
// two differ), so a scene ipgen accepts is never refused here for a limit.
#pragma once

#include <cstddef>

namespace ipsim {

/// Largest number of output samples, t_end / sample: every sample is a CSV row (1e7 samples of a
/// double pendulum: about 1.4 GB of CSV; simulate_<model> streams them, simulate() without a sink
/// keeps them in a Result: 0.5 GB).
inline constexpr double kMaxSamples = 1e7;
/// Shortest run t_end [s]: CVODE refuses a stop time of 1e-200 s ("behind current t = 0").
inline constexpr double kMinTEnd = 1e-9;
/// Smallest relative tolerance: below it double precision cannot meet the request (rtol < 1 too).
inline constexpr double kRtolMin = 1e-15;
/// sensors.delay is k whole sampling periods, k = round(delay / period) <= kMaxDelayPeriods, to
/// a relative kDelayTolerance: |delay − k · period| <= kDelayTolerance · max(delay, period).
inline constexpr double kMaxDelayPeriods = 1e6;
inline constexpr double kDelayTolerance = 1e-9;
/// Longest user-supplied value quoted in a message (longer ones are cut in the middle).
inline constexpr std::size_t kMessageValueChars = 60;
/// Longest path quoted in a message.
inline constexpr std::size_t kMessagePathChars = 240;

}  // namespace ipsim
