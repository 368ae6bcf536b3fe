// Where a run stops: output samples, input switching times and t_end, merged into one list.
#pragma once

#include <algorithm>
#include <limits>
#include <vector>

namespace ipsim::detail {

/// A point where the integrator is told to stop exactly.
struct Stop {
  double t;              ///< [s]
  bool sample = false;   ///< record the state here
  bool restart = false;  ///< the input jumps here: restart the integrator after arriving
};

/// Output samples k·sample (< t_end) and t_end, merged with the input's switching times inside
/// (0, t_end). Points closer than max(1e-9·min(sample, t_end), 64·ε·t_end) are one stop (an
/// integrator cannot take a step shorter than a few ulps of t); a sample merged with a switching
/// time takes the switching time exactly.
inline std::vector<Stop> make_schedule(double t_end, double sample, const std::vector<double>& switching_times) {
  const double tolerance =
      std::max(1e-9 * std::min(sample, t_end), 64.0 * std::numeric_limits<double>::epsilon() * t_end);
  std::vector<Stop> points;
  for (long k = 0;; ++k) {
    // k·sample, not a running sum, so sample times carry no accumulated round-off.
    const double t = static_cast<double>(k) * sample;
    if (t >= t_end - tolerance) break;
    points.push_back({t, true, false});
  }
  points.push_back({t_end, true, false});
  for (double s : switching_times) {
    if (s > tolerance && s < t_end - tolerance) points.push_back({s, false, true});
  }
  std::stable_sort(points.begin(), points.end(), [](const Stop& a, const Stop& b) { return a.t < b.t; });

  std::vector<Stop> stops;
  for (const Stop& p : points) {
    if (!stops.empty() && p.t - stops.back().t <= tolerance) {
      Stop& merged = stops.back();
      if (p.restart && !merged.restart) merged.t = p.t;
      merged.sample = merged.sample || p.sample;
      merged.restart = merged.restart || p.restart;
    } else {
      stops.push_back(p);
    }
  }
  return stops;
}

}  // namespace ipsim::detail
