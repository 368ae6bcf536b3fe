// TravelMonitor: stops a run once the base leaves the rig's travel, |θ0| > travel (the cart's
// position [m] or the arm's angle [rad]), as a real rig's end stops or limit switches would.
//
// Checked at every sample (every `sample` seconds), like DivergenceMonitor: a base that crosses
// the limit and comes back between two samples is not seen, so choose `sample` small against the
// base's fastest motion. The sample beyond the limit is passed on (it is the CSV's last row).
#pragma once

#include <cmath>
#include <cstddef>
#include <optional>

#include "ipsim/sink.hpp"

namespace ipsim {

/// Where and when the base left its travel.
struct TravelExceeded {
  double t = 0.0;         ///< time of the first sample beyond the limit [s]
  double position = 0.0;  ///< θ0 there [m or rad]
};

/// Passes every sample on to `inner`, and stops the run (record returns false) at the first
/// sample with |θ0| > travel.
class TravelMonitor : public SampleSink {
 public:
  /// \param inner   receives every sample
  /// \param travel  the limit on |θ0| [m or rad], > 0; infinity: never stop
  TravelMonitor(SampleSink& inner, double travel) : inner_(inner), travel_(travel) {}

  void begin(std::size_t samples, int state_size, bool energy_ledger) override {
    inner_.begin(samples, state_size, energy_ledger);
  }

  bool record(const Sample& sample) override {
    const bool more = inner_.record(sample);
    const double position = sample.state[0];
    if (!(std::abs(position) <= travel_)) {  // NaN counts as beyond
      exceeded_ = TravelExceeded{sample.t, position};
      return false;
    }
    return more;
  }

  /// Set when the run was stopped.
  const std::optional<TravelExceeded>& exceeded() const noexcept { return exceeded_; }
  /// The limit [m or rad].
  double travel() const noexcept { return travel_; }

 private:
  SampleSink& inner_;
  double travel_;
  std::optional<TravelExceeded> exceeded_;
};

}  // namespace ipsim
