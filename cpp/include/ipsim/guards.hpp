// Numerical guards: how well conditioned the mass matrix is before a run, and why a run failed.
//
// Conditioning. The accelerations come from an L D Lᵀ solve with M(θ). Its relative error is
// bounded by about ε·cond(S M S), S = diag(M)^-1/2 (van der Sluis: a symmetric diagonal scaling
// does not change what the factorisation computes, only the units). cond(M) itself mixes kg, kg m
// and kg m²: lengths from 1e-3 m to 100 m drive it to 1e13 while θ̈ stays accurate to 1e-13
// (docs/stability.md), so a warning on cond(M) alone would be a false alarm. What does make M
// nearly singular is a heavy link carried by light ones (the base and the light links can then
// cancel each other's motion of the heavy link's pivot): the scaled condition number grows with
// that mass ratio. simulate() warns when it exceeds kConditionWarning (about 6 digits of θ̈ left).
//
// Failures. The right-hand side reports a non-finite derivative to the integrator as recoverable
// (rhs.hpp) and records the evaluation; when the integrator gives up, explain_nonfinite() names
// the time, the state and the likely cause. When a method other than BDF runs out of steps or
// its step size collapses, explain_slow_progress() estimates the stiffness (the eigenvalues of
// ∂f/∂x by difference quotients) and says "stiff: use BDF" when stability, not accuracy, holds
// the step down.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <limits>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ipsim/diagnostics.hpp"
#include "ipsim/eigenvalues.hpp"
#include "ipsim/errors.hpp"
#include "ipsim/input.hpp"
#include "ipsim/linkage.hpp"
#include "ipsim/model.hpp"
#include "ipsim/rhs.hpp"
#include "ipsim/settings.hpp"

namespace ipsim {

namespace detail {
template <class Model, class = void>
struct HasBias : std::false_type {};
template <class Model>
struct HasBias<Model, std::void_t<decltype(Model::template bias<double>(std::declval<const VectorOf<Model>&>(),
                                                                        std::declval<const VectorOf<Model>&>(),
                                                                        std::declval<const ParamsOf<Model>&>()))>>
    : std::true_type {};
}  // namespace detail


/// True when the model defines bias.
template <class Model>
inline constexpr bool has_bias = detail::HasBias<Model>::value;

/// simulate() warns when the scaled condition number of M exceeds this: θ̈ may then keep fewer
/// than about 6 of double's 16 digits.
inline constexpr double kConditionWarning = 1e10;

/// Condition numbers of a symmetric mass matrix, from its eigenvalues (2-norm).
struct Conditioning {
  double cond = 1.0;         ///< cond(M) = λmax/λmin; infinity when M is not positive definite
  double scaled_cond = 1.0;  ///< cond(S M S), S = diag(M)^-1/2: what bounds the L D Lᵀ solve's error
  double smallest_eigenvalue = 1.0;  ///< λmin(M)
};

namespace detail {

/// The condition numbers of a symmetric matrix (only meaningful for a mass matrix); not a
/// template, so it is compiled once per program whatever the models (eigenvalues.hpp).
Conditioning conditioning_of_matrix(const Eigen::MatrixXd& matrix);

}  // namespace detail

/// The condition numbers of a symmetric matrix `M` (only meaningful for a mass matrix).
template <class Derived>
Conditioning conditioning_of(const Eigen::MatrixBase<Derived>& M) {
  return detail::conditioning_of_matrix(M.template cast<double>());
}

/// The worst conditioning of M over a few configurations, and where it occurs.
template <class Model>
struct ConditioningReport {
  Conditioning worst;     ///< the configuration with the largest scaled condition number
  std::string where;      ///< "the initial state", "upright", "hanging", …
  VectorOf<Model> theta;  ///< that configuration
};

/// cond(M) at the initial configuration `theta0` and at the upright, hanging, horizontal and
/// zig-zag configurations (base coordinate as in theta0): a heavy link on light ones is worst
/// when the links are aligned, which the initial state need not show.
template <class Model>
ConditioningReport<Model> assess_conditioning(const ParamsOf<Model>& params, const VectorOf<Model>& theta0) {
  static_assert(has_mass_matrix<Model>, "assess_conditioning needs the model's mass_matrix");
  const int n = dof_of<Model>();
  std::vector<std::pair<const char*, VectorOf<Model>>> configurations{{"the initial state", theta0}};
  const double half_pi = 0.5 * kPi;
  for (const auto& [name, angle, alternate] : {std::tuple{"upright", 0.0, false}, std::tuple{"hanging", kPi, false},
                                               std::tuple{"horizontal", half_pi, false},
                                               std::tuple{"zig-zag", half_pi, true}}) {
    VectorOf<Model> q = theta0;
    for (int i = 1; i < n; ++i) q(i) = alternate && i % 2 == 0 ? -angle : angle;
    configurations.emplace_back(name, q);
  }
  ConditioningReport<Model> report{{}, "", theta0};
  bool first = true;
  for (const auto& [name, q] : configurations) {
    const Conditioning c = conditioning_of(Model::template mass_matrix<double>(q, params));
    if (first || c.scaled_cond > report.worst.scaled_cond || std::isnan(c.scaled_cond)) {
      report = {c, name, q};
      first = false;
    }
  }
  return report;
}

namespace detail {

/// "[0.1, -2, 3e+05]" (6 significant digits).
std::string format_values(const double* values, Eigen::Index count);

/// "m[2]/m[1] = 1e+06" for the largest over the smallest of values[first..count).
template <class Array>
std::string extreme_ratio(const char* name, const Array& values, int first, int count) {
  int low = first, high = first;
  for (int i = first; i < count; ++i) {
    if (values[static_cast<std::size_t>(i)] < values[static_cast<std::size_t>(low)]) low = i;
    if (values[static_cast<std::size_t>(i)] > values[static_cast<std::size_t>(high)]) high = i;
  }
  return std::string(name) + "[" + std::to_string(high) + "]/" + name + "[" + std::to_string(low) + "] = " +
         format_number(values[static_cast<std::size_t>(high)] / values[static_cast<std::size_t>(low)]);
}

/// "name[i] = value" of the largest of values[0..count).
template <class Array>
std::string largest(const char* name, const Array& values, int count) {
  int high = 0;
  for (int i = 1; i < count; ++i)
    if (values[static_cast<std::size_t>(i)] > values[static_cast<std::size_t>(high)]) high = i;
  return std::string(name) + "[" + std::to_string(high) + "] = " + format_number(values[static_cast<std::size_t>(high)]);
}

}  // namespace detail

/// A warning when M is ill-conditioned enough to make θ̈ untrustworthy (scaled cond(M) above
/// `threshold`) anywhere assess_conditioning() looks, naming the parameter ratio that causes it;
/// empty otherwise. The cause is found by making the masses (or the lengths) all equal and
/// seeing which removes more of the ill-conditioning.
template <class Model>
std::string conditioning_warning(const ParamsOf<Model>& params, const VectorOf<Model>& theta0,
                                 double threshold = kConditionWarning) {
  const auto report = assess_conditioning<Model>(params, theta0);
  const double kappa = report.worst.scaled_cond;
  if (!(kappa > threshold)) return {};
  auto equalised = [&](bool masses) {
    ParamsOf<Model> p = params;
    for (int i = 0; i < dof_of<Model>(); ++i) {
      auto& value = masses ? p.m[static_cast<std::size_t>(i)] : p.l[static_cast<std::size_t>(i)];
      if (masses || i > 0 || !is_classical<Model>()) value = 1.0;
    }
    return conditioning_of(Model::template mass_matrix<double>(report.theta, p)).scaled_cond;
  };
  const bool masses_cause = equalised(true) <= equalised(false);
  const double lost = kappa * std::numeric_limits<double>::epsilon();
  const int digits = std::max(0, static_cast<int>(std::floor(-std::log10(lost))));
  std::string cause =
      masses_cause
          ? "the mass ratio " + detail::extreme_ratio("m", params.m, 0, dof_of<Model>()) +
                " (largest/smallest mass: a heavy link carried by light links or a light base nearly cancels a "
                "degree of freedom)"
          : "the length ratio " + detail::extreme_ratio("l", params.l, is_classical<Model>() ? 1 : 0, dof_of<Model>()) +
                " (largest/smallest length)";
  return "ill-conditioned mass matrix: cond(M) = " + detail::format_number(kappa) + " after diagonal scaling (" +
         detail::format_number(report.worst.cond) + " unscaled) at " + report.where +
         ", so accelerations keep only about " + std::to_string(digits) +
         " significant digits and the results are untrustworthy at that level; caused by " + cause;
}

namespace detail {

/// The likely cause of the non-finite derivative recorded in `e`, with its time and state.
template <class Model>
std::string explain_nonfinite(const ParamsOf<Model>& params, const NonFiniteEvaluation& e) {
  const int n = dof_of<Model>();
  std::string text = "non-finite derivative at t = " + format_number(e.t) + " s, state theta = " +
                     format_values(e.x.data(), n) + ", dtheta = " + format_values(e.x.data() + n, n) +
                     ", u = " + format_number(e.u) + "; likely cause: ";
  if (!std::isfinite(e.u)) {
    return text + "the input u is not finite (a feedback callback returned " + format_number(e.u) + ")";
  }
  if (!e.x.allFinite()) return text + "the state grew without bound (it is no longer finite)";
  const VectorOf<Model> q = e.x.head(n);
  const VectorOf<Model> qd = e.x.segment(n, n);
  const double rate = qd.cwiseAbs().maxCoeff();
  if constexpr (has_mass_matrix<Model>) {
    if (!provides<Model>(Feature::mass_matrix)) return text + "the accelerations overflow";
    const auto M = Model::template mass_matrix<double>(q, params);
    if (!M.allFinite()) return text + "M(theta) is not finite (masses or lengths overflow)";
    const Conditioning c = conditioning_of(M);
    if (!(c.scaled_cond < 1e15)) {
      return text + "accelerations overflow: M is near singular (cond(M) = " + format_number(c.cond) + ", " +
             format_number(c.scaled_cond) + " after diagonal scaling; " + extreme_ratio("m", params.m, 0, n) + ")";
    }
    if constexpr (has_bias<Model>) {
      if (!provides<Model>(Feature::mass_and_bias)) return text + "the accelerations overflow";
      const auto b = Model::template bias<double>(q, qd, params);
      if (!b.allFinite()) {
        if (!(rate < 1e100)) {
          return text + "the state grew without bound: rates of " + format_number(rate) +
                 " overflow the centrifugal and Coriolis forces";
        }  // modest rates: the parameters' products overflow (a mass of 1e307 kg)
        return text + "the forces overflow at rates up to " + format_number(rate) +
               ": the masses, lengths or g are too large for a double (" + largest("m", params.m, n) + ", " +
               largest("l", params.l, n) + ", g = " + format_number(params.g) + ")";
      }
      VectorOf<Model> force = -b;
      force(0) += e.u;
      return text + "accelerations overflow: M is near singular for these forces (smallest eigenvalue of M " +
             format_number(c.smallest_eigenvalue) + ", |B u - bias| = " + format_number(force.norm()) + ")";
    }
  }
  if (rate > 1e100) return text + "the state grew without bound: rates of " + format_number(rate);
  return text + "the accelerations overflow";
}

/// Stiffness at state x: the largest −Re λ over the eigenvalues λ of ∂f/∂x (mechanical part,
/// forward differences of the RHS), 0 if none has a negative real part, NaN if the RHS fails.
template <class Model>
double stiffness(RhsContext<Model>& context, double t, const Eigen::VectorXd& x) {
  const int m = 2 * dof_of<Model>();
  const NonFiniteEvaluation kept = context.nonfinite;  // diagnosing must not overwrite the record
  const long size = static_cast<long>(x.size());
  Eigen::VectorXd f0(x.size()), f1(x.size()), shifted = x;
  Eigen::MatrixXd jacobian(m, m);
  double result = std::numeric_limits<double>::quiet_NaN();
  try {
    if (evaluate_rhs<Model>(context, t, x.data(), f0.data(), size) == 0) {
      bool ok = true;
      for (int j = 0; j < m && ok; ++j) {
        const double h = std::sqrt(std::numeric_limits<double>::epsilon()) * std::max(1.0, std::abs(x(j)));
        shifted(j) = x(j) + h;
        ok = evaluate_rhs<Model>(context, t, shifted.data(), f1.data(), size) == 0;
        jacobian.col(j) = (f1.head(m) - f0.head(m)) / (shifted(j) - x(j));
        shifted(j) = x(j);
      }
      if (ok) {
        const Eigen::VectorXd real = eigenvalue_real_parts(jacobian);
        if (real.allFinite()) result = std::max(0.0, -real.minCoeff());
      }
    }
  } catch (...) {
    // A feedback callback that throws while we diagnose: no estimate.
  }
  context.nonfinite = kept;
  return result;
}

/// A step h with h·|Re λ| at least this is taken as limited by stability (explicit methods
/// have stability regions reaching |z| ≈ 2.5–5 on the negative real axis; their error estimators often
/// hold h·|Re λ| well below that, e.g. Fehlberg 8(7) near 0.4).
inline constexpr double kStiffStep = 0.1;

/// Why a method made no progress (ran out of steps, or too many error test or convergence
/// failures: `out_of_steps` false) at time t, state x, after the last successful step h and with
/// the step it was attempting, h_now: "stiff: use BDF" when h·|Re λ| shows that stability, not
/// accuracy, limits the step of a method other than BDF; a near-singular M or a collapsed step
/// size otherwise. (Running out of steps says nothing about a collapse: the first steps of a run
/// are tiny.)
template <class Model>
std::string explain_slow_progress(RhsContext<Model>& context, const Settings<Model>& settings, double t,
                                  const Eigen::VectorXd& x, double h, double h_now, bool out_of_steps) {
  const double rho = stiffness<Model>(context, t, x);
  std::string text = "last step h = " + format_number(h) + " s";
  if (std::isfinite(rho)) {
    text += ", stiffness max(-Re lambda(df/dx)) = " + format_number(rho) + " 1/s (h*|Re lambda| = " +
            format_number(h * rho) + ")";
  }
  const bool collapsed = !out_of_steps && std::abs(h_now) <= 1e-12 * std::max(1.0, std::abs(t));
  if (collapsed) text += "; the step size collapsed to " + format_number(h_now) + " s";
  if (settings.method != Method::bdf && std::isfinite(rho) && (h * rho >= kStiffStep || (collapsed && rho > 1e6))) {
    return text + "; stiff: use BDF (method bdf): a decaying mode at rate " + format_number(rho) + " 1/s holds " +
           to_string(settings.method) + "'s step near its stability limit";
  }
  if constexpr (has_mass_matrix<Model>) {
    const VectorOf<Model> q = x.head(dof_of<Model>());
    const Conditioning c = !provides<Model>(Feature::mass_matrix) ? Conditioning{} : conditioning_of(Model::template mass_matrix<double>(q, *context.params));
    if (!(c.scaled_cond <= kConditionWarning)) {
      return text + "; M is near singular at this state (cond(M) = " + format_number(c.scaled_cond) +
             " after diagonal scaling; " + extreme_ratio("m", context.params->m, 0, dof_of<Model>()) +
             "): the accelerations are not accurate enough for the error test";
    }
  }
  if (collapsed) return text + "; the solution may be singular or not finite nearby";
  if (!out_of_steps) {
    const double rate = x.segment(dof_of<Model>(), dof_of<Model>()).cwiseAbs().maxCoeff();
    return text + "; not stiff at this state: the error test failed repeatedly, the motion (rates up to " +
           format_number(rate) + ") is too fast for " + to_string(settings.method) +
           " at this tolerance (loosen rtol and atol, or try another method)";
  }
  if (settings.method == Method::bdf) {
    return text + "; the motion needs small steps (raise max_steps, loosen rtol, or sample more often: max_steps "
                  "counts steps between two samples)";
  }
  return text + "; not stiff at this state: the motion itself needs small steps (raise max_steps, loosen rtol, or "
                "sample more often: max_steps counts steps between two samples)";
}

/// Steps between two stops from which a method other than BDF is checked for stiffness.
inline constexpr long kStiffnessCheckSteps = 1000;

/// A warning for a method other than BDF that needed `steps` ≥ kStiffnessCheckSteps steps over the
/// last interval between stops because stability, not accuracy, held its step h at state x (empty
/// otherwise): it still succeeds, but BDF would be far cheaper.
template <class Model>
std::string stiffness_warning(RhsContext<Model>& context, const Settings<Model>& settings, double t,
                              const Eigen::VectorXd& x, double h, long steps) {
  if (settings.method == Method::bdf || steps < kStiffnessCheckSteps) return {};
  const double rho = stiffness<Model>(context, t, x);
  if (!(std::isfinite(rho) && h * rho >= kStiffStep)) return {};
  return std::string("stiff: use BDF (method bdf): ") + to_string(settings.method) + " needed " +
         std::to_string(steps) + " steps to reach t = " + format_number(t) + " s, its step h = " + format_number(h) +
         " s held near its stability limit by a decaying mode at rate " + format_number(rho) +
         " 1/s (h*|Re lambda| = " + format_number(h * rho) + ")";
}

/// How a SUNDIALS integrator gave up, classified by the stepper from its own flags.
/// Outputs further apart than this (11.6 days) are named in a failure's cause: the integrators
/// choose their first steps from the output interval, and none resolves a pendulum's motion
/// (t_end = 1e200 s sampled every 1e199 s let CVODE try a step of 5.9e80 s; the causes named
/// were the state, a motion "too fast for bdf" or the rates).
inline constexpr double kLongOutputInterval = 1e6;

struct Failure {
  bool rhs_failed;    ///< the right-hand side kept failing
  bool no_progress;   ///< out of steps, or too many error-test or convergence failures
  bool out_of_steps;  ///< no progress because max_steps ran out
};

/// The integrator's own message (diagnostics.last_error) preceded by the likely cause: non-finite
/// derivatives that persisted, or a method that cannot make progress (explain_slow_progress).
/// `state()` gives x at time t, `steps()` the last and the attempted step sizes; both are only
/// asked for when needed.
template <class Model, class State, class Steps>
std::string explain_failure(RhsContext<Model>& context, const Settings<Model>& settings,
                            const Diagnostics& diagnostics, const Failure& failure, double t, State state,
                            Steps steps) {
  std::string cause;
  // Outputs days apart: the integrators chose their trial steps from them, which explains a
  // failure better than the state or the step size found there (a run out of steps is told to
  // sample more often already).
  const bool long_outputs = settings.sample > kLongOutputInterval;
  const std::string outputs = "outputs " + detail::format_number(settings.sample) +
                              " s apart let the integrator try steps far beyond a pendulum's time scale: sample "
                              "more often (simulation.sample)";
  if (context.nonfinite.seen && (failure.rhs_failed || failure.no_progress)) {
    cause = explain_nonfinite<Model>(*context.params, context.nonfinite);
    if (long_outputs) cause += "; " + outputs;
  } else if (failure.no_progress && long_outputs && !failure.out_of_steps) {
    cause = outputs;
  } else if (failure.no_progress) {
    const auto [h, h_now] = steps();
    cause = explain_slow_progress<Model>(context, settings, t, state(), h, h_now, failure.out_of_steps);
  }
  if (diagnostics.last_error.empty()) return cause;
  return cause.empty() ? diagnostics.last_error : cause + " [" + diagnostics.last_error + "]";
}

/// Warns once per run when a method other than BDF took ≥ kStiffnessCheckSteps steps between two
/// stops because stability held its step down (stiffness_warning).
class StiffnessWatch {
 public:
  /// At a stop at time t after `steps` steps in all, the last of size h; `state()` gives x.
  template <class Model, class State>
  void at_stop(RhsContext<Model>& context, const Settings<Model>& settings, Diagnostics& diagnostics, double t,
               long steps, double h, State state) {
    const long interval = steps - steps_at_last_stop_;
    steps_at_last_stop_ = steps;
    if (warned_ || interval < kStiffnessCheckSteps || settings.method == Method::bdf) return;  // skip state()
    std::string warning = stiffness_warning<Model>(context, settings, t, state(), h, interval);
    if (!warning.empty()) {
      diagnostics.warnings->push_back(std::move(warning));
      warned_ = true;
    }
  }

  /// The integrator was re-initialised: its step counter starts again from zero.
  void restart() { steps_at_last_stop_ = 0; }

 private:
  long steps_at_last_stop_ = 0;  ///< the integrator's step count at the previous stop
  bool warned_ = false;
};

/// RK4's stability limit on the negative real axis (|1 + z + z²/2 + z³/6 + z⁴/24| ≤ 1 for z ≥ −2.785).
inline constexpr double kRk4StabilityLimit = 2.785;

}  // namespace detail
}  // namespace ipsim

#if IPSIM_DEFINITIONS
namespace ipsim::detail {

IPSIM_DECL Conditioning conditioning_of_matrix(const Eigen::MatrixXd& matrix) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  Conditioning c;
  if (!matrix.allFinite()) return {inf, inf, std::numeric_limits<double>::quiet_NaN()};
  auto ratio = [](const Eigen::VectorXd& eigenvalues) {  // ascending
    const double low = eigenvalues(0), high = eigenvalues(eigenvalues.size() - 1);
    return low > 0.0 ? high / low : inf;
  };
  const Eigen::VectorXd raw = symmetric_eigenvalues(matrix);
  c.smallest_eigenvalue = raw(0);
  c.cond = ratio(raw);
  if ((matrix.diagonal().array() <= 0.0).any()) {
    c.scaled_cond = inf;
    return c;
  }
  const Eigen::VectorXd s = matrix.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd scaled = s.asDiagonal() * matrix * s.asDiagonal();
  c.scaled_cond = ratio(symmetric_eigenvalues(scaled));
  return c;
}

IPSIM_DECL std::string format_values(const double* values, Eigen::Index count) {
  std::string text = "[";
  for (Eigen::Index i = 0; i < count; ++i) {
    char number[32];
    std::snprintf(number, sizeof number, "%.6g", values[i]);
    text += (i > 0 ? ", " : "") + std::string(number);
  }
  return text + "]";
}

}  // namespace ipsim::detail
#endif  // IPSIM_DEFINITIONS
