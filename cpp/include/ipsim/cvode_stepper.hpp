// CVODE as an ipsim stepper: bdf and adams (Newton iteration, dense direct solver, exact or
// difference-quotient Jacobian) and adams-fixed-point (functional iteration, no Jacobian).
#pragma once

#include <memory>
#include <string>
#include <utility>

#include <Eigen/Core>

#include <cvode/cvode.h>
#include <cvode/cvode_ls.h>

#include "ipsim/diagnostics.hpp"
#include "ipsim/guards.hpp"
#include "ipsim/jacobian.hpp"
#include "ipsim/result.hpp"
#include "ipsim/rhs.hpp"
#include "ipsim/settings.hpp"
#include "ipsim/sundials.hpp"

namespace ipsim::detail {

/// Advances y (owned by the caller) from stop to stop with CVODE. The stop time is set before each
/// call, so CVODE arrives exactly at every stop; restart() re-initialises it after an input jump.
template <class Model>
class CvodeStepper {
 public:
  /// Sets CVODE up from (t = 0, y). `y`, `context`, `rhs_context` and `diagnostics` must outlive
  /// the stepper. Throws ipsim::Error when a set-up call fails.
  CvodeStepper(const Settings<Model>& settings, sundials::NVector& y, const sundials::Context& context,
               RhsContext<Model>& rhs_context, Diagnostics& diagnostics)
      : settings_(settings),
        y_(y),
        rhs_context_(rhs_context),
        diagnostics_(diagnostics),
        cvode_(settings.method == Method::bdf ? CV_BDF : CV_ADAMS, context) {
    void* const mem = cvode_.get();
    check(CVodeInit(mem, &rhs<Model>, 0.0, y.get()), "CVodeInit");
    check(CVodeSStolerances(mem, settings.rtol, settings.atol), "CVodeSStolerances");
    check(CVodeSetUserData(mem, &rhs_context), "CVodeSetUserData");
    check(CVodeSetErrHandlerFn(mem, &collect_message, &diagnostics), "CVodeSetErrHandlerFn");
    check(CVodeSetMaxNumSteps(mem, settings.max_steps), "CVodeSetMaxNumSteps");
    if (settings.method == Method::adams_fixed_point) {
      fixed_point_ = std::make_unique<sundials::FixedPointSolver>(y, context);
      check(CVodeSetNonlinearSolver(mem, fixed_point_->get()), "CVodeSetNonlinearSolver");
    } else {
      const sunindextype size = y.length();
      matrix_ = std::make_unique<sundials::DenseMatrix>(size, size, context);
      linear_solver_ = std::make_unique<sundials::DenseLinearSolver>(y, *matrix_, context);
      check(CVodeSetLinearSolver(mem, linear_solver_->get(), matrix_->get()), "CVodeSetLinearSolver");
      if (settings.jacobian == Jacobian::exact) {
        if constexpr (has_derivatives<Model>) {
          if (provides<Model>(Feature::derivatives)) check(CVodeSetJacFn(mem, &jacobian_callback<Model>), "CVodeSetJacFn");
        }
      }
    }
  }

  /// Integrates to exactly t_stop. Throws IntegrationError (CVODE's flag) or the exception of a
  /// feedback callback.
  void advance(double t_stop) {
    void* const mem = cvode_.get();
    check(CVodeSetStopTime(mem, t_stop), "CVodeSetStopTime");
    realtype reached = 0.0;
    rhs_context_.nonfinite.seen = false;
    const int flag = CVode(mem, t_stop, y_.get(), &reached, CV_NORMAL);
    if (rhs_context_.error) std::rethrow_exception(rhs_context_.error);
    if (flag < 0) {
      throw integration_error("CVODE", flag, sundials::return_flag_name(flag), reached, settings_, explain(flag, reached));
    }
    // A step that underflowed (t + h = t: CVODE warns and "continues anyway") leaves CVODE's own time
    // behind the output it returns, which it then extrapolated: not a solution.
    realtype internal = 0.0;
    check(CVodeGetCurrentTime(mem, &internal), "CVodeGetCurrentTime");
    if (internal < reached) throw integration_error("CVODE", CV_WARNING, "CV_WARNING", internal, settings_, step_underflow());
    warn_if_stiff(reached);
  }

  /// Restarts at t from the current y (after an input jump). CVODE zeroes its counters here, so
  /// they are added to `stats` first.
  void restart(double t, Statistics& stats) {
    add_statistics(stats);
    check(CVodeReInit(cvode_.get(), t, y_.get()), "CVodeReInit");
    stiffness_watch_.restart();
  }

  /// Adds CVODE's counters since the last (re)start to `stats`.
  void add_statistics(Statistics& stats) const {
    void* const mem = cvode_.get();
    long value = 0;
    check(CVodeGetNumSteps(mem, &value), "CVodeGetNumSteps");
    stats.steps += value;
    check(CVodeGetNumRhsEvals(mem, &value), "CVodeGetNumRhsEvals");
    stats.rhs_evals += value;
    check(CVodeGetNumErrTestFails(mem, &value), "CVodeGetNumErrTestFails");
    stats.error_test_failures += value;
    check(CVodeGetNumNonlinSolvIters(mem, &value), "CVodeGetNumNonlinSolvIters");
    stats.nonlinear_iterations += value;
    check(CVodeGetNumNonlinSolvConvFails(mem, &value), "CVodeGetNumNonlinSolvConvFails");
    stats.nonlinear_convergence_failures += value;
    if (linear_solver_) {
      check(CVodeGetNumJacEvals(mem, &value), "CVodeGetNumJacEvals");
      stats.jacobian_evals += value;
      check(CVodeGetNumLinRhsEvals(mem, &value), "CVodeGetNumLinRhsEvals");
      stats.linear_solver_rhs_evals += value;
    }
  }

 private:
  static void check(int flag, const char* call) { check_setup(flag, call, &sundials::return_flag_name); }

  /// [x; ledger] after the last step, as a vector.
  Eigen::VectorXd state() const { return Eigen::Map<const Eigen::VectorXd>(y_.data(), y_.length()); }

  /// Once per run: warns when stability, not accuracy, held the steps of a method other than BDF.
  void warn_if_stiff(double reached) {
    long steps = 0;
    realtype h = 0.0;
    CVodeGetNumSteps(cvode_.get(), &steps);
    CVodeGetLastStep(cvode_.get(), &h);
    stiffness_watch_.at_stop(rhs_context_, settings_, diagnostics_, reached, steps, h, [this] { return state(); });
  }

  /// CVODE's own message, preceded by the likely cause (guards.hpp).
  std::string explain(int flag, double reached) {
    const Failure failure{flag == CV_RHSFUNC_FAIL || flag == CV_FIRST_RHSFUNC_ERR || flag == CV_REPTD_RHSFUNC_ERR ||
                              flag == CV_UNREC_RHSFUNC_ERR,
                          flag == CV_TOO_MUCH_WORK || flag == CV_ERR_FAILURE || flag == CV_CONV_FAILURE,
                          flag == CV_TOO_MUCH_WORK};
    return explain_failure<Model>(rhs_context_, settings_, diagnostics_, failure, reached, [this] { return state(); },
                                  [this] {
                                    realtype h = 0.0, h_now = 0.0;
                                    CVodeGetLastStep(cvode_.get(), &h);
                                    CVodeGetCurrentStep(cvode_.get(), &h_now);
                                    return std::pair<double, double>(h, h_now);
                                  });
  }

  const Settings<Model>& settings_;
  sundials::NVector& y_;
  RhsContext<Model>& rhs_context_;
  Diagnostics& diagnostics_;
  StiffnessWatch stiffness_watch_;
  // Destroyed in reverse order: CVODE first, then the solvers and the matrix it refers to.
  // (Heap-held rather than std::optional: GCC 12 warns falsely about optional<unique_ptr>.)
  std::unique_ptr<sundials::DenseMatrix> matrix_;
  std::unique_ptr<sundials::DenseLinearSolver> linear_solver_;
  std::unique_ptr<sundials::FixedPointSolver> fixed_point_;
  sundials::CvodeMemory cvode_;
};

}  // namespace ipsim::detail
