// What a simulation returns: the sampled trajectory, the integrator's work counters and the wall time.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace ipsim {

/// Work counters of the integrator, summed over every integration segment (CVODE and ARKODE
/// reset theirs on each restart). A counter a method does not have stays 0.
struct Statistics {
  long steps = 0;                           ///< accepted steps (CVodeGetNumSteps, ERKStepGetNumSteps, RK4 steps)
  long rhs_evals = 0;                       ///< RHS evaluations by the method itself (RK4: 4 per step)
  long jacobian_evals = 0;                  ///< Jacobian evaluations, exact or by difference quotients (bdf, adams)
  long linear_solver_rhs_evals = 0;         ///< extra RHS evaluations spent on difference-quotient Jacobians
  long error_test_failures = 0;             ///< rejected steps: local error test failures (adaptive methods)
  long nonlinear_iterations = 0;            ///< Newton or fixed-point iterations (CVODE methods)
  long nonlinear_convergence_failures = 0;  ///< nonlinear solver convergence failures (CVODE methods)
  long restarts = 0;                        ///< integrator restarts at input discontinuities

  /// Every evaluation of the right-hand side, the Jacobian's difference quotients included.
  long total_rhs_evals() const noexcept { return rhs_evals + linear_solver_rhs_evals; }
};

/// A sampled trajectory. simulate(params, settings) fills every field; simulate(params,
/// settings, sink) hands the samples to the sink instead and leaves times, states, inputs,
/// input_work and dissipated_energy empty (the summary fields below are filled either way).
struct Result {
  /// Sample times [s]: k·sample for k = 0, 1, … below t_end, then t_end. A sample within
  /// about 1e-9·sample of an input switching time is taken exactly at the switching time.
  std::vector<double> times;
  /// Row k is the state x(times[k]) = [θ; θ̇] (2·kDof columns).
  Eigen::MatrixXd states;
  /// Input work W_in(times[k]) = ∫₀ᵗ u θ̇0 dt [J] (τ θ̇0, the base's force, for an acceleration-driven
  /// base); empty unless Settings::energy_ledger.
  std::vector<double> input_work;
  /// Dissipated energy E_diss(times[k]) = ∫₀ᵗ 2D dt [J]; empty unless Settings::energy_ledger.
  std::vector<double> dissipated_energy;
  /// The input u [N or N m] at times[k], one per sample: the value applied from times[k] on
  /// (right-continuous: a sampled controller's new value at a sampling instant), and at t_end the
  /// value applied just before it.
  std::vector<double> inputs;
  /// Largest |u| over the samples and, for piecewise-constant inputs (a sampled controller
  /// included), over every value held between two stops.
  double max_abs_input = 0.0;
  /// Energy Coulomb friction dissipated from t = 0 to the last sample [J] (0 without Settings::coulomb).
  double coulomb_dissipated = 0.0;
  /// Number of samples recorded (times.size() when kept in memory).
  std::size_t samples = 0;
  /// True when a SampleSink stopped the run before t_end (SampleSink::record returned false);
  /// the last sample recorded is the one it stopped at.
  bool stopped_early = false;
  /// Integrator statistics for the whole run.
  Statistics stats;
  /// Integrator warnings (e.g. CVODE's "t + h = t on the next step"), in order of occurrence.
  std::vector<std::string> warnings;
  /// Wall-clock time spent in simulate() [s].
  double wall_time = 0.0;
};

}  // namespace ipsim
