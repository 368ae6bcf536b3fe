// SUNDIALS ARKODE's explicit Runge–Kutta module (ERKStep) as an ipsim stepper: adaptive
// Dormand–Prince 5(4) or Fehlberg 8(7) with ARKODE's default error controller.
#pragma once

#include <string>
#include <utility>

#include <Eigen/Core>
#include <arkode/arkode_erkstep.h>

#include "ipsim/diagnostics.hpp"
#include "ipsim/guards.hpp"
#include "ipsim/result.hpp"
#include "ipsim/rhs.hpp"
#include "ipsim/settings.hpp"
#include "ipsim/sundials.hpp"

namespace ipsim::detail {

/// The built-in ARKODE Butcher table of an erk-* method.
inline ARKODE_ERKTableID erk_table(Method method) {
  switch (method) {
    case Method::erk_fehlberg8: return ARKODE_FEHLBERG_13_7_8;
    default: return ARKODE_DORMAND_PRINCE_7_4_5;
  }
}

/// Advances y (owned by the caller) from stop to stop with ERKStep; the stop time is set before
/// each call, so ARKODE shortens its last step to land exactly on every stop.
template <class Model>
class ErkStepper {
 public:
  /// Sets ERKStep up from (t = 0, y). `y`, `rhs_context` and `diagnostics` must outlive the
  /// stepper. Throws ipsim::Error when a set-up call fails.
  ErkStepper(const Settings<Model>& settings, sundials::NVector& y, const sundials::Context& context,
             RhsContext<Model>& rhs_context, Diagnostics& diagnostics)
      : settings_(settings),
        y_(y),
        rhs_context_(rhs_context),
        diagnostics_(diagnostics),
        erk_(&rhs<Model>, 0.0, y, context) {
    void* const mem = erk_.get();
    check(ERKStepSetTableNum(mem, erk_table(settings.method)), "ERKStepSetTableNum");
    check(ERKStepSStolerances(mem, settings.rtol, settings.atol), "ERKStepSStolerances");
    check(ERKStepSetUserData(mem, &rhs_context), "ERKStepSetUserData");
    check(ERKStepSetErrHandlerFn(mem, &collect_message, &diagnostics), "ERKStepSetErrHandlerFn");
    check(ERKStepSetMaxNumSteps(mem, settings.max_steps), "ERKStepSetMaxNumSteps");
  }

  /// Integrates to exactly t_stop. Throws IntegrationError (ARKODE's flag) or the exception of a
  /// feedback callback.
  void advance(double t_stop) {
    void* const mem = erk_.get();
    check(ERKStepSetStopTime(mem, t_stop), "ERKStepSetStopTime");
    realtype reached = 0.0;
    rhs_context_.nonfinite.seen = false;
    const int flag = ERKStepEvolve(mem, t_stop, y_.get(), &reached, ARK_NORMAL);
    if (rhs_context_.error) std::rethrow_exception(rhs_context_.error);
    if (flag < 0) {
      throw integration_error("ARKODE", flag, sundials::erk_return_flag_name(flag), reached, settings_,
                              explain(flag, reached));
    }
    realtype internal = 0.0;  // behind the output: a step that underflowed (cvode_stepper.hpp)
    check(ERKStepGetCurrentTime(mem, &internal), "ERKStepGetCurrentTime");
    if (internal < reached) throw integration_error("ARKODE", ARK_WARNING, "ARK_WARNING", internal, settings_, step_underflow());
    warn_if_stiff(reached);
  }

  /// Restarts at t from the current y (after an input jump): ERKStepReInit forgets the step
  /// history, like CVodeReInit, and zeroes the counters, so they are added to `stats` first.
  void restart(double t, Statistics& stats) {
    add_statistics(stats);
    check(ERKStepReInit(erk_.get(), &rhs<Model>, t, y_.get()), "ERKStepReInit");
    stiffness_watch_.restart();
  }

  /// Adds ERKStep's counters since the last (re)start to `stats`.
  void add_statistics(Statistics& stats) const {
    void* const mem = erk_.get();
    long value = 0;
    check(ERKStepGetNumSteps(mem, &value), "ERKStepGetNumSteps");
    stats.steps += value;
    check(ERKStepGetNumRhsEvals(mem, &value), "ERKStepGetNumRhsEvals");
    stats.rhs_evals += value;
    check(ERKStepGetNumErrTestFails(mem, &value), "ERKStepGetNumErrTestFails");
    stats.error_test_failures += value;
  }

 private:
  static void check(int flag, const char* call) { check_setup(flag, call, &sundials::erk_return_flag_name); }

  /// [x; ledger] after the last step, as a vector.
  Eigen::VectorXd state() const { return Eigen::Map<const Eigen::VectorXd>(y_.data(), y_.length()); }

  /// Once per run: warns when stability, not accuracy, held the steps of a method other than BDF.
  void warn_if_stiff(double reached) {
    long steps = 0;
    realtype h = 0.0;
    ERKStepGetNumSteps(erk_.get(), &steps);
    ERKStepGetLastStep(erk_.get(), &h);
    stiffness_watch_.at_stop(rhs_context_, settings_, diagnostics_, reached, steps, h, [this] { return state(); });
  }

  /// ARKODE's own message, preceded by the likely cause (guards.hpp).
  std::string explain(int flag, double reached) {
    const Failure failure{flag == ARK_RHSFUNC_FAIL || flag == ARK_FIRST_RHSFUNC_ERR || flag == ARK_REPTD_RHSFUNC_ERR ||
                              flag == ARK_UNREC_RHSFUNC_ERR,
                          flag == ARK_TOO_MUCH_WORK || flag == ARK_ERR_FAILURE || flag == ARK_TOO_CLOSE,
                          flag == ARK_TOO_MUCH_WORK};
    return explain_failure<Model>(rhs_context_, settings_, diagnostics_, failure, reached, [this] { return state(); },
                                  [this] {
                                    realtype h = 0.0, h_now = 0.0;
                                    ERKStepGetLastStep(erk_.get(), &h);
                                    ERKStepGetCurrentStep(erk_.get(), &h_now);
                                    return std::pair<double, double>(h, h_now);
                                  });
  }

  const Settings<Model>& settings_;
  sundials::NVector& y_;
  RhsContext<Model>& rhs_context_;
  Diagnostics& diagnostics_;
  StiffnessWatch stiffness_watch_;
  sundials::ErkMemory erk_;
};

}  // namespace ipsim::detail
