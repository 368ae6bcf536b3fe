// ipsim's own classic fourth-order Runge–Kutta with a fixed step (Settings::step): what many
// users and MuJoCo's RK4 mode reach for, kept for comparison. Each interval between two stops is
// covered by equal steps of Settings::step from its start, the last one shortened to end exactly
// on the stop.
#pragma once

#include <algorithm>
#include <cmath>
#include <exception>
#include <string>

#include <Eigen/Core>

#include "ipsim/diagnostics.hpp"
#include "ipsim/guards.hpp"
#include "ipsim/result.hpp"
#include "ipsim/rhs.hpp"
#include "ipsim/settings.hpp"
#include "ipsim/sundials.hpp"
#include "ipgen_model.h"

namespace ipsim::detail {

/// Flag names of RK4 failures, in IntegrationError::flag_name().
inline constexpr const char* kRk4TooMuchWork = "RK4_TOO_MUCH_WORK";
inline constexpr const char* kRk4RhsFail = "RK4_RHSFUNC_FAIL";

template <class Model>
class Rk4Stepper {
 public:
  /// `y`, `rhs_context` and `diagnostics` must outlive the stepper.
  Rk4Stepper(const Settings<Model>& settings, sundials::NVector& y, const sundials::Context& /*context*/,
             RhsContext<Model>& rhs_context, Diagnostics& /*diagnostics*/)
      : settings_(settings),
        rhs_context_(rhs_context),
        y_(y.data(), y.length()),
        work_(5 * y.length()),
        initial_(y_) {}

  /// Integrates from the current time to exactly t_stop in ceil((t_stop − t)/step) steps (a
  /// quotient within 1e-9 of an integer is taken as that integer). Throws IntegrationError when
  /// that exceeds max_steps (RK4_TOO_MUCH_WORK) or a derivative is not finite
  /// (RK4_RHSFUNC_FAIL), and the exception of a feedback callback unchanged.
  void advance(double t_stop) {
    const double start = t_;
    const double h = settings_.step;
    const double count = std::max(1.0, std::ceil((t_stop - start) / h - 1e-9));
    if (count > static_cast<double>(settings_.max_steps)) {
      throw integration_error("RK4", -1, kRk4TooMuchWork, start, settings_,
                              "reaching the next stop at t = " + format_number(t_stop) + " s takes " +
                                  format_number(count) + " steps, more than max_steps");
    }
    const long steps = static_cast<long>(count);
    for (long k = 0; k < steps; ++k) {
      // Step ends are start + k·h, not a running sum; the last one is the stop itself.
      const double t0 = start + static_cast<double>(k) * h;
      const double t1 = k + 1 == steps ? t_stop : start + static_cast<double>(k + 1) * h;
      step(t0, t1 - t0);
    }
    t_ = t_stop;
  }

  /// Nothing to forget (a one-step method); the time is already at t.
  void restart(double t, Statistics& /*stats*/) { t_ = t; }

  /// RK4 takes 4 RHS evaluations per step.
  void add_statistics(Statistics& stats) const {
    stats.steps += steps_;
    stats.rhs_evals += 4 * steps_;
  }

 private:
  /// f(t, x) for ipgen_rk4: evaluate_rhs, the failing time kept for the error.
  static int evaluate(void* self, double t, const double x[], double dx[]) {
    auto& stepper = *static_cast<Rk4Stepper*>(self);
    const int flag = evaluate_rhs<Model>(stepper.rhs_context_, t, x, dx, static_cast<long>(stepper.y_.size()));
    if (flag != 0) stepper.failed_at_ = t;
    return flag;
  }

  /// The likely cause of a non-finite derivative (guards.hpp), and whether the fixed step is
  /// beyond RK4's stability limit for the decaying modes at the initial state (then the
  /// solution blows up whatever the motion: stiff).
  std::string explain_failure() {
    std::string text = explain_nonfinite<Model>(*rhs_context_.params, rhs_context_.nonfinite);
    const double rho = stiffness<Model>(rhs_context_, 0.0, initial_);
    if (std::isfinite(rho) && settings_.step * rho > kRk4StabilityLimit) {
      text += "; stiff: use BDF (method bdf) or a step below " + format_number(kRk4StabilityLimit / rho) +
              " s: at t = 0 a decaying mode at rate " + format_number(rho) + " 1/s puts step * rate = " +
              format_number(settings_.step * rho) + " beyond RK4's stability limit " + format_number(kRk4StabilityLimit);
    }
    return text;
  }

  /// Whether the model library's rk4_step computes this run's steps: a model loaded at run time
  /// that has one, and a right-hand side that is the model's alone with the input held on the
  /// segment (no energy ledger, drive lag, Coulomb friction, acceleration-driven base, fixed
  /// chain's inputs or feedback input evaluated at each stage).
  bool library_steps() const {
    if constexpr (is_runtime<Model>) {
      const RhsContext<Model>& c = rhs_context_;
      return Model::has_rk4_step() && !c.energy_ledger && c.lag_index < 0 && c.coulomb_index < 0 &&
             !c.acceleration && c.input_matrix == nullptr && c.input->piecewise_constant() &&
             y_.size() == 2 * dof_of<Model>();
    } else {
      return false;
    }
  }

  void step(double t, double h) {
    if constexpr (is_runtime<Model>) {
      // The model library's own step: the same ipgen_rk4 with its sizes known to the
      // compiler (one call a step instead of four). A failing step is redone below, which
      // diagnoses it.
      if (library_steps_) {
        const double u = rhs_context_.segment_input + rhs_context_.segment_pulse;
        if (Model::rk4_step(y_.data(), &u, h, *rhs_context_.params) == 0) {
          ++steps_;
          return;
        }
      }
    }
    if (ipgen_rk4(static_cast<int>(y_.size()), y_.data(), t, h, &Rk4Stepper::evaluate, this, work_.data()) != 0) {
      throw integration_error("RK4", -1, kRk4RhsFail, failed_at_, settings_, explain_failure());
    }
    ++steps_;
  }

  const Settings<Model>& settings_;
  RhsContext<Model>& rhs_context_;
  Eigen::Map<Eigen::VectorXd> y_;  ///< the caller's N_Vector, updated in place
  Eigen::VectorXd work_;           ///< ipgen_rk4's k1..k4 and stage
  Eigen::VectorXd initial_;        ///< the state at t = 0, for the stability diagnosis
  bool library_steps_ = library_steps();
  double failed_at_ = 0.0;  ///< the time of the last evaluation that failed [s]
  double t_ = 0.0;
  long steps_ = 0;
};

}  // namespace ipsim::detail
