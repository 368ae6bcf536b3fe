// simulate<Model>(): integrate M(θ) θ̈ + bias(θ, θ̇) = (u, 0, …, 0)ᵀ with CVODE.
//
// The state is x = [θ; θ̇] (2·kDof), plus [W_in, E_diss] when the energy ledger is on. CVODE
// uses a dense direct linear solver with its own difference-quotient Jacobian. The run is cut at
// every output sample and every input switching time with CVodeSetStopTime, so samples are
// integrator states (not interpolants) and no step ever straddles a jump of u; after a jump the
// integrator is restarted with CVodeReInit.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <exception>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Core>
#include <cvode/cvode.h>
#include <cvode/cvode_ls.h>

#include "ipsim/errors.hpp"
#include "ipsim/input.hpp"
#include "ipsim/model.hpp"
#include "ipsim/result.hpp"
#include "ipsim/settings.hpp"
#include "ipsim/sundials.hpp"

namespace ipsim {

static_assert(std::is_same_v<realtype, double>, "ipsim needs SUNDIALS built with double precision");

/// Mechanical energy T(θ, θ̇) + V(θ) [J].
template <class Model>
double mechanical_energy(const ParamsOf<Model>& params, const VectorOf<Model>& theta, const VectorOf<Model>& dtheta) {
  return Model::template kinetic_energy<double>(theta, dtheta, params) +
         Model::template potential_energy<double>(theta, params);
}

/// Mechanical energy T + V [J] of a state x = [θ; θ̇] (dim ≥ 2·kDof; entries after 2·kDof, such
/// as ledger states, are ignored). Throws std::invalid_argument if x is shorter.
template <class Model>
double mechanical_energy(const ParamsOf<Model>& params, const Eigen::VectorXd& x) {
  constexpr int n = Model::kDof;
  if (x.size() < 2 * n) {
    throw std::invalid_argument("mechanical_energy: state has " + std::to_string(x.size()) + " entries, model " +
                                Model::kName + " needs 2·kDof = " + std::to_string(2 * n));
  }
  return mechanical_energy<Model>(params, VectorOf<Model>(x.head<n>()), VectorOf<Model>(x.segment<n>(n)));
}

namespace detail {

/// What the RHS callback needs; CVODE passes it back as user data.
template <class Model>
struct RhsContext {
  const ParamsOf<Model>* params = nullptr;
  const Input* input = nullptr;
  bool energy_ledger = false;
  /// u on the current segment when the input is piecewise constant. Evaluating u(t) instead would
  /// be wrong at the segment's closing stop: CVODE's last evaluation there sees the new value.
  double segment_input = 0.0;
  Eigen::VectorXd x;         ///< preallocated copy of [θ; θ̇] for feedback inputs
  std::exception_ptr error;  ///< exception thrown by a feedback callback, rethrown after CVode
};

/// CVODE right-hand side: 0 on success, 1 (recoverable: CVODE retries with a smaller step) when a
/// derivative is not finite, -1 (fatal) when the input callback threw.
template <class Model>
int rhs(realtype t, N_Vector y, N_Vector ydot, void* user_data) {
  auto& context = *static_cast<RhsContext<Model>*>(user_data);
  constexpr int n = Model::kDof;
  try {
    const realtype* in = N_VGetArrayPointer(y);
    realtype* out = N_VGetArrayPointer(ydot);
    const VectorOf<Model> q = Eigen::Map<const VectorOf<Model>>(in);
    const VectorOf<Model> qd = Eigen::Map<const VectorOf<Model>>(in + n);
    double u = context.segment_input;
    if (context.input->kind == Input::Kind::feedback) {
      context.x = Eigen::Map<const Eigen::VectorXd>(in, 2 * n);  // no allocation: same size
      u = context.input->feedback(t, context.x);
    } else if (!context.input->piecewise_constant()) {
      u = context.input->value(t, context.x);
    }
    const VectorOf<Model> qdd = Model::template forward_dynamics<double>(q, qd, u, *context.params);
    Eigen::Map<VectorOf<Model>> velocity_out(out), acceleration_out(out + n);
    velocity_out = qd;
    acceleration_out = qdd;
    if (context.energy_ledger) {
      out[2 * n] = u * qd(0);
      out[2 * n + 1] = 2.0 * Model::template dissipation<double>(qd, *context.params);
    }
    const sunindextype size = N_VGetLength(ydot);
    for (sunindextype i = 0; i < size; ++i) {
      if (!std::isfinite(out[i])) return 1;
    }
    return 0;
  } catch (...) {
    context.error = std::current_exception();
    return -1;
  }
}

/// Collects CVODE's messages instead of letting it print to stderr.
struct Diagnostics {
  std::string last_error;             ///< most recent error message, for the exception text
  std::vector<std::string>* warnings;  ///< destination of warnings (Result::warnings)
};

inline void collect_message(int code, const char* /*module*/, const char* function, char* message, void* data) {
  try {
    auto& diagnostics = *static_cast<Diagnostics*>(data);
    std::string text = std::string(function ? function : "CVODE") + ": " + (message ? message : "");
    std::replace(text.begin(), text.end(), '\n', ' ');  // exception messages stay on one line
    if (code < 0) diagnostics.last_error = std::move(text);
    else diagnostics.warnings->push_back(std::move(text));
  } catch (...) {
    // Running out of memory while recording a message must not unwind through C code.
  }
}

/// A point where CVODE is told to stop.
struct Stop {
  double t;              ///< [s]
  bool sample = false;   ///< record the state here
  bool restart = false;  ///< the input jumps here: CVodeReInit after arriving
};

/// Output samples k·sample (< t_end) and t_end, merged with the input's switching times inside
/// (0, t_end). Points closer than max(1e-9·min(sample, t_end), 64·ε·t_end) are one stop (CVODE
/// cannot take a step shorter than a few ulps of t); a sample merged with a switching time
/// takes the switching time exactly.
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

/// Throws ipsim::Error naming a failed CVODE set-up call.
inline void check_setup(int flag, const char* call) {
  if (flag != CV_SUCCESS) {
    throw Error(std::string(call) + " failed with " + sundials::return_flag_name(flag));
  }
}

template <class Model>
IntegrationError integration_error(int flag, double t, const Settings<Model>& settings, const std::string& explanation) {
  const std::string name = sundials::return_flag_name(flag);
  std::string message = "CVODE failed with " + name + " at t = " + format_number(t) + " s (method " +
                        to_string(settings.method) + ", rtol " + format_number(settings.rtol) + ", atol " +
                        format_number(settings.atol) + ", max_steps " + std::to_string(settings.max_steps) + ")";
  if (!explanation.empty()) message += ": " + explanation;
  return IntegrationError(message, flag, name, t);
}

}  // namespace detail

/// Integrates `Model` from t = 0 to settings.t_end.
///
/// \param[in] params   Physical parameters (see validate(const ParamsOf<Model>&)).
/// \param[in] settings Method, tolerances, output interval, initial state and input.
/// \return The trajectory sampled at t = k·settings.sample and t_end, with CVODE statistics.
/// \throws InvalidInput     before integrating, listing every invalid parameter and setting.
/// \throws IntegrationError when CVODE fails (flag name, time reached and settings in what()).
/// \throws whatever a feedback input callback throws, unchanged.
template <class Model>
Result simulate(const ParamsOf<Model>& params, const Settings<Model>& settings) {
  static_assert(detail::check_model<Model>());
  const auto started = std::chrono::steady_clock::now();

  auto problems = validate<Model>(params);
  const auto setting_problems = validate<Model>(settings);
  problems.insert(problems.end(), setting_problems.begin(), setting_problems.end());
  if (!problems.empty()) throw InvalidInput(std::move(problems));

  constexpr int n = Model::kDof;
  const int size = 2 * n + (settings.energy_ledger ? 2 : 0);

  // Declaration order is destruction order reversed: CVODE goes first, the context last.
  sundials::Context context;
  sundials::NVector y(size, context);
  sundials::DenseMatrix jacobian(size, size, context);
  sundials::DenseLinearSolver linear_solver(y, jacobian, context);
  sundials::CvodeMemory cvode(settings.method == Method::bdf ? CV_BDF : CV_ADAMS, context);
  void* const mem = cvode.get();

  Eigen::Map<Eigen::VectorXd> y_values(y.data(), size);
  y_values.setZero();
  y_values.head<n>() = settings.theta;
  y_values.segment<n>(n) = settings.dtheta;

  Result result;
  detail::RhsContext<Model> rhs_context;
  rhs_context.params = &params;
  rhs_context.input = &settings.input;
  rhs_context.energy_ledger = settings.energy_ledger;
  rhs_context.x = Eigen::VectorXd::Zero(2 * n);
  detail::Diagnostics diagnostics{{}, &result.warnings};

  detail::check_setup(CVodeInit(mem, &detail::rhs<Model>, 0.0, y.get()), "CVodeInit");
  detail::check_setup(CVodeSStolerances(mem, settings.rtol, settings.atol), "CVodeSStolerances");
  detail::check_setup(CVodeSetUserData(mem, &rhs_context), "CVodeSetUserData");
  detail::check_setup(CVodeSetErrHandlerFn(mem, &detail::collect_message, &diagnostics), "CVodeSetErrHandlerFn");
  detail::check_setup(CVodeSetMaxNumSteps(mem, settings.max_steps), "CVodeSetMaxNumSteps");
  detail::check_setup(CVodeSetLinearSolver(mem, linear_solver.get(), jacobian.get()), "CVodeSetLinearSolver");

  const std::vector<detail::Stop> stops =
      detail::make_schedule(settings.t_end, settings.sample, settings.input.switching_times());
  const auto sample_count = std::count_if(stops.begin(), stops.end(), [](const detail::Stop& s) { return s.sample; });
  result.times.reserve(static_cast<std::size_t>(sample_count));
  result.states.resize(sample_count, 2 * n);
  if (settings.energy_ledger) {
    result.input_work.reserve(static_cast<std::size_t>(sample_count));
    result.dissipated_energy.reserve(static_cast<std::size_t>(sample_count));
  }

  auto record = [&](double t) {
    const auto row = static_cast<Eigen::Index>(result.times.size());
    result.times.push_back(t);
    result.states.row(row) = y_values.head(2 * n).transpose();
    if (settings.energy_ledger) {
      result.input_work.push_back(y_values(2 * n));
      result.dissipated_energy.push_back(y_values(2 * n + 1));
    }
  };
  // u is constant between switching times: take it from the middle of the segment that starts
  // at stops[first], which is unambiguous even when the segment's ends are switching times.
  auto set_segment_input = [&](std::size_t first) {
    std::size_t last = first + 1;
    while (last + 1 < stops.size() && !stops[last].restart) ++last;
    const double middle = 0.5 * (stops[first].t + stops[last].t);
    rhs_context.segment_input = settings.input.piecewise_constant() ? settings.input.value(middle, rhs_context.x) : 0.0;
  };
  // CVODE zeroes its counters on CVodeReInit, so they are added up segment by segment.
  auto add_statistics = [&] {
    long value = 0;
    detail::check_setup(CVodeGetNumSteps(mem, &value), "CVodeGetNumSteps");
    result.stats.steps += value;
    detail::check_setup(CVodeGetNumRhsEvals(mem, &value), "CVodeGetNumRhsEvals");
    result.stats.rhs_evals += value;
    detail::check_setup(CVodeGetNumJacEvals(mem, &value), "CVodeGetNumJacEvals");
    result.stats.jacobian_evals += value;
    detail::check_setup(CVodeGetNumLinRhsEvals(mem, &value), "CVodeGetNumLinRhsEvals");
    result.stats.linear_solver_rhs_evals += value;
    detail::check_setup(CVodeGetNumErrTestFails(mem, &value), "CVodeGetNumErrTestFails");
    result.stats.error_test_failures += value;
    detail::check_setup(CVodeGetNumNonlinSolvConvFails(mem, &value), "CVodeGetNumNonlinSolvConvFails");
    result.stats.nonlinear_convergence_failures += value;
  };

  record(0.0);
  set_segment_input(0);
  for (std::size_t i = 1; i < stops.size(); ++i) {
    const detail::Stop& stop = stops[i];
    detail::check_setup(CVodeSetStopTime(mem, stop.t), "CVodeSetStopTime");
    realtype reached = 0.0;
    const int flag = CVode(mem, stop.t, y.get(), &reached, CV_NORMAL);
    if (rhs_context.error) std::rethrow_exception(rhs_context.error);
    if (flag < 0) throw detail::integration_error(flag, reached, settings, diagnostics.last_error);
    if (stop.sample) record(stop.t);
    if (stop.restart) {
      add_statistics();
      detail::check_setup(CVodeReInit(mem, stop.t, y.get()), "CVodeReInit");
      ++result.stats.restarts;
      set_segment_input(i);
    }
  }
  add_statistics();

  result.wall_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return result;
}

}  // namespace ipsim
