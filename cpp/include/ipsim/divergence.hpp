// DivergenceMonitor: stops a closed-loop run once the state has left the region where a linear
// controller (LinearFeedback) can hold it.
//
// The criterion: a link angle θi (every link, not the cart or arm θ0) more than `angle` (default
// π/2) from the controller's equilibrium x_eq, i.e. for the upright equilibrium a link below the
// horizontal. There the linearisation the gain was computed from has lost its meaning (cos θi
// changed sign), and a link that gets there under LQR falls: the cart or arm then runs away
// without bound (the 0.1 rad CDIP LQR scene ends 41 km away with |u| = 1.1e5 N). Angles are not
// wrapped: the controller uses θ − x_eq as it is, so a link one turn away is 2π away for it too.
// The check arms once every link is inside the region (at the first sample, for a start near
// x_eq); a run that starts outside (a swing-down to a hanging equilibrium) is not stopped until
// it has come inside and left again. Checked at every sample (every `sample` seconds).
#pragma once

#include <cmath>
#include <cstddef>
#include <optional>
#include <utility>

#include <Eigen/Core>

#include "ipsim/sink.hpp"

namespace ipsim {

/// Where and when a closed loop left the controller's region.
struct Divergence {
  double t = 0.0;          ///< time of the first sample outside [s]
  int link = 0;            ///< the link i (1..n) farthest from x_eq there
  double deviation = 0.0;  ///< |θi − x_eq,i| [rad]
};

/// The link angle farthest from `equilibrium` in state x (size 2·dof; the links are coordinates
/// first..dof−1: first = 1 behind a cart or arm, 0 on a fixed pivot), as (its link number 1..n,
/// its distance |θi − x_eq,i| [rad]); {0, 0} without a link.
inline std::pair<int, double> farthest_link(const Eigen::Ref<const Eigen::VectorXd>& x,
                                            const Eigen::VectorXd& equilibrium, int dof, int first = 1) {
  std::pair<int, double> worst{0, 0.0};
  for (int i = first; i < dof; ++i) {
    const double deviation = std::abs(x(i) - equilibrium(i));
    if (deviation > worst.second) worst = {i - first + 1, deviation};
  }
  return worst;
}

/// Passes every sample on to `inner`, and stops the run (record returns false) at the first
/// sample with a link more than `angle` from the equilibrium after every link has been within
/// it (see the file's comment). The sample that shows the divergence is passed on too.
class DivergenceMonitor : public SampleSink {
 public:
  /// \param inner       receives every sample
  /// \param equilibrium x_eq of the controller (2·dof entries)
  /// \param dof         kDof of the model (links + 1)
  /// \param angle       the region's half-width [rad], > 0; infinity: never stop
  /// \param first       the first link's coordinate (1 behind a cart or arm, 0 on a fixed pivot)
  DivergenceMonitor(SampleSink& inner, Eigen::VectorXd equilibrium, int dof, double angle = kHalfPi, int first = 1)
      : inner_(inner), equilibrium_(std::move(equilibrium)), dof_(dof), angle_(angle), first_(first) {}

  static constexpr double kHalfPi = 1.57079632679489661923;

  void begin(std::size_t samples, int state_size, bool energy_ledger) override {
    inner_.begin(samples, state_size, energy_ledger);
  }

  bool record(const Sample& sample) override {
    const bool more = inner_.record(sample);
    const auto [link, deviation] = farthest_link(sample.x(), equilibrium_, dof_, first_);
    if (deviation <= angle_) {
      armed_ = true;
    } else if (armed_) {
      divergence_ = Divergence{sample.t, link, deviation};
      return false;
    }
    return more;
  }

  /// Set when the run was stopped.
  const std::optional<Divergence>& divergence() const noexcept { return divergence_; }
  /// The region's half-width [rad].
  double angle() const noexcept { return angle_; }

 private:
  SampleSink& inner_;
  Eigen::VectorXd equilibrium_;
  int dof_;
  double angle_;
  int first_;
  bool armed_ = false;
  std::optional<Divergence> divergence_;
};

}  // namespace ipsim
