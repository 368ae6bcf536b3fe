// What a simulation returns: the sampled trajectory, CVODE's work counters and the wall time.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace ipsim {

/// CVODE counters summed over every integration segment (CVODE resets them on each restart).
struct Statistics {
  long steps = 0;                           ///< internal steps (CVodeGetNumSteps)
  long rhs_evals = 0;                       ///< right-hand side evaluations (CVodeGetNumRhsEvals)
  long jacobian_evals = 0;                  ///< Jacobian evaluations (CVodeGetNumJacEvals)
  long linear_solver_rhs_evals = 0;         ///< RHS evaluations spent on difference-quotient Jacobians (CVodeGetNumLinRhsEvals)
  long error_test_failures = 0;             ///< local error test failures (CVodeGetNumErrTestFails)
  long nonlinear_convergence_failures = 0;  ///< Newton convergence failures (CVodeGetNumNonlinSolvConvFails)
  long restarts = 0;                        ///< CVodeReInit calls at input discontinuities
};

/// A sampled trajectory.
struct Result {
  /// Sample times [s]: k·sample for k = 0, 1, … below t_end, then t_end. A sample within
  /// about 1e-9·sample of an input switching time is taken exactly at the switching time.
  std::vector<double> times;
  /// Row k is the state x(times[k]) = [θ; θ̇] (2·kDof columns).
  Eigen::MatrixXd states;
  /// Input work W_in(times[k]) = ∫₀ᵗ u θ̇0 dt [J]; empty unless Settings::energy_ledger.
  std::vector<double> input_work;
  /// Dissipated energy E_diss(times[k]) = ∫₀ᵗ 2D dt [J]; empty unless Settings::energy_ledger.
  std::vector<double> dissipated_energy;
  /// CVODE statistics for the whole run.
  Statistics stats;
  /// CVODE warnings (e.g. "t + h = t on the next step"), in order of occurrence.
  std::vector<std::string> warnings;
  /// Wall-clock time spent in simulate() [s].
  double wall_time = 0.0;
};

}  // namespace ipsim
