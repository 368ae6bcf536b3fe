// Where a run stops: output samples, input switching times and t_end, merged in time order.
//
// StopSchedule produces the stops one at a time (constant memory, however many samples);
// make_schedule() collects them into a list.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

namespace ipsim::detail {

/// A point where the integrator is told to stop exactly.
struct Stop {
  double t;              ///< [s]
  bool sample = false;   ///< record the state here
  bool restart = false;  ///< the input jumps here: restart the integrator after arriving
};

/// The stops of a run, in time order, one by one: output samples k·sample (< t_end) and t_end,
/// merged with the input's switching times inside (0, t_end). Points closer than
/// max(1e-9·min(sample, t_end), 64·ε·t_end) are one stop (an integrator cannot take a step
/// shorter than a few ulps of t); a sample merged with a switching time takes the switching
/// time exactly. The switching times are a (short) list, or every k·period below t_end for a
/// sampled input, generated as they are reached, like the samples.
class StopSchedule {
 public:
  /// `switching_times` in any order; `period` > 0 adds k·period, k = 1, 2, … below t_end.
  StopSchedule(double t_end, double sample, std::vector<double> switching_times, double period = 0.0)
      : t_end_(t_end),
        sample_(sample),
        period_(period > 0.0 && std::isfinite(period) ? period : 0.0),
        tolerance_(std::max(1e-9 * std::min(sample, t_end), 64.0 * std::numeric_limits<double>::epsilon() * t_end)),
        listed_(std::move(switching_times)) {
    std::stable_sort(listed_.begin(), listed_.end());
    pending_ = next_point();
  }

  /// The next stop, or nullopt after the last (t_end).
  std::optional<Stop> next() {
    if (!pending_) return std::nullopt;
    Stop merged = *pending_;
    for (pending_ = next_point(); pending_ && pending_->t - merged.t <= tolerance_; pending_ = next_point()) {
      if (pending_->restart && !merged.restart) merged.t = pending_->t;
      merged.sample = merged.sample || pending_->sample;
      merged.restart = merged.restart || pending_->restart;
    }
    return merged;
  }

  /// Number of samples a complete run records (k·sample below t_end, and t_end), before merging
  /// with switching times (merging never joins two samples: they are sample apart).
  long sample_count() const {
    long count = 0;
    while (static_cast<double>(count) * sample_ < t_end_ - tolerance_) ++count;
    return count + 1;
  }

 private:
  /// The next sample point (k·sample, then t_end), or nullopt after t_end.
  std::optional<Stop> peek_sample() const {
    if (samples_done_) return std::nullopt;
    // k·sample, not a running sum, so sample times carry no accumulated round-off.
    const double t = static_cast<double>(k_) * sample_;
    if (t >= t_end_ - tolerance_) return Stop{t_end_, true, false};
    return Stop{t, true, false};
  }
  void take_sample() {
    const double t = static_cast<double>(k_) * sample_;
    if (t >= t_end_ - tolerance_) samples_done_ = true;
    else ++k_;
  }

  /// The next switching time inside (tolerance, t_end − tolerance), or nullopt.
  std::optional<double> peek_switch() {
    for (;;) {
      double s;
      bool from_list;
      const bool list_left = next_listed_ < listed_.size();
      const double periodic = period_ > 0.0 ? static_cast<double>(j_) * period_ : 0.0;
      const bool periodic_left = period_ > 0.0 && periodic < t_end_;
      if (!list_left && !periodic_left) return std::nullopt;
      if (list_left && (!periodic_left || listed_[next_listed_] <= periodic)) {
        s = listed_[next_listed_], from_list = true;
      } else {
        s = periodic, from_list = false;
      }
      if (s > tolerance_ && s < t_end_ - tolerance_) return s;
      from_list ? ++next_listed_ : ++j_;  // outside the run: dropped
    }
  }
  void take_switch() {
    const bool list_left = next_listed_ < listed_.size();
    const double periodic = period_ > 0.0 ? static_cast<double>(j_) * period_ : 0.0;
    const bool periodic_left = period_ > 0.0 && periodic < t_end_;
    if (list_left && (!periodic_left || listed_[next_listed_] <= periodic)) ++next_listed_;
    else ++j_;
  }

  /// The next point in time order; a sample before a switching time at the same t.
  std::optional<Stop> next_point() {
    const std::optional<Stop> sample = peek_sample();
    const std::optional<double> s = peek_switch();
    if (sample && (!s || sample->t <= *s)) {
      take_sample();
      return sample;
    }
    if (s) {
      take_switch();
      return Stop{*s, false, true};
    }
    return std::nullopt;
  }

  double t_end_, sample_, period_, tolerance_;
  std::vector<double> listed_;
  std::size_t next_listed_ = 0;
  long k_ = 0;   ///< next sample index
  long j_ = 1;   ///< next sampling instant index (k·period, k ≥ 1)
  bool samples_done_ = false;
  std::optional<Stop> pending_;
};

/// Every stop of StopSchedule(t_end, sample, switching_times) as a list (memory grows with the
/// number of samples: simulate() walks the schedule instead).
inline std::vector<Stop> make_schedule(double t_end, double sample, const std::vector<double>& switching_times) {
  StopSchedule schedule(t_end, sample, switching_times);
  std::vector<Stop> stops;
  while (const auto stop = schedule.next()) stops.push_back(*stop);
  return stops;
}

}  // namespace ipsim::detail
