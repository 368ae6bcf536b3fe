// simulate<Model>(): integrate M(θ) θ̈ + bias(θ, θ̇) = (u, 0, …, 0)ᵀ from t = 0 to t_end.
//
// The state is x = [θ; θ̇] (2·kDof), plus [W_in, E_diss] when the energy ledger is on. The run is
// cut at every output sample and every input switching time (schedule.hpp): every method arrives
// exactly there (CVODE and ARKODE through their stop time, RK4 by shortening its last step), so
// samples are integrator states (not interpolants) and no step ever straddles a jump of u; after
// a jump the integrator is restarted. The method (settings.hpp) picks the stepper:
//   bdf, adams, adams-fixed-point   CVODE (cvode_stepper.hpp)
//   erk-dp5, erk-fehlberg8          ARKODE ERKStep (erk_stepper.hpp)
//   rk4                             ipsim's fixed-step RK4 (rk4_stepper.hpp)
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Core>

#include "ipsim/cvode_stepper.hpp"
#include "ipsim/diagnostics.hpp"
#include "ipsim/erk_stepper.hpp"
#include "ipsim/errors.hpp"
#include "ipsim/guards.hpp"
#include "ipsim/input.hpp"
#include "ipsim/jacobian.hpp"
#include "ipsim/model.hpp"
#include "ipsim/result.hpp"
#include "ipsim/rhs.hpp"
#include "ipsim/rk4_stepper.hpp"
#include "ipsim/schedule.hpp"
#include "ipsim/settings.hpp"
#include "ipsim/sundials.hpp"

namespace ipsim {

static_assert(std::is_same_v<realtype, double>, "ipsim needs SUNDIALS built with double precision");

/// Mechanical energy T(θ, θ̇) + V(θ) [J].
template <class Model>
double mechanical_energy(const ParamsOf<Model>& params, const VectorOf<Model>& theta, const VectorOf<Model>& dtheta) {
  static_assert(has_energy<Model>, "this model header has no energy functions (a specialised header omits them)");
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

/// Runs `Stepper` over the stop schedule, recording samples into `result`.
template <class Model, class Stepper>
void run_schedule(const Settings<Model>& settings, sundials::NVector& y, const sundials::Context& context,
                  RhsContext<Model>& rhs_context, Diagnostics& diagnostics, Result& result) {
  constexpr int n = Model::kDof;
  Eigen::Map<Eigen::VectorXd> y_values(y.data(), y.length());
  Stepper stepper(settings, y, context, rhs_context, diagnostics);

  const std::vector<Stop> stops =
      make_schedule(settings.t_end, settings.sample, settings.input.switching_times(settings.t_end));
  const auto sample_count = std::count_if(stops.begin(), stops.end(), [](const Stop& s) { return s.sample; });
  result.times.reserve(static_cast<std::size_t>(sample_count));
  result.states.resize(sample_count, 2 * n);
  result.inputs.reserve(static_cast<std::size_t>(sample_count));
  if (settings.energy_ledger) {
    result.input_work.reserve(static_cast<std::size_t>(sample_count));
    result.dissipated_energy.reserve(static_cast<std::size_t>(sample_count));
  }
  auto record = [&](double t) {
    if (!y_values.allFinite()) {  // never hand out a non-finite sample (the integrators should not produce one)
      throw IntegrationError("the state is not finite at t = " + format_number(t) + " s (" + describe(settings) +
                                 "): " + format_values(y_values.data(), y_values.size()) + "; not recorded",
                             -1, "NONFINITE_STATE", t);
    }
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
  // A sampled controller instead computes u once from the state at the segment's first stop (a
  // sampling instant) and holds it.
  auto set_segment_input = [&](std::size_t first) {
    if (settings.input.kind == Input::Kind::sampled) {
      rhs_context.x = y_values.head(2 * n);
      rhs_context.segment_input = settings.input.value(stops[first].t, rhs_context.x);
    } else {
      std::size_t last = first + 1;
      while (last + 1 < stops.size() && !stops[last].restart) ++last;
      const double middle = 0.5 * (stops[first].t + stops[last].t);
      rhs_context.segment_input =
          settings.input.piecewise_constant() ? settings.input.value(middle, rhs_context.x) : 0.0;
    }
    result.max_abs_input = std::max(result.max_abs_input, std::abs(rhs_context.segment_input));
  };
  // u at a sample: the segment's value, or the input evaluated at the recorded state.
  auto record_input = [&](double t) {
    double u = rhs_context.segment_input;
    if (!settings.input.piecewise_constant()) {
      rhs_context.x = y_values.head(2 * n);
      u = settings.input.value(t, rhs_context.x);
    }
    result.inputs.push_back(u);
    result.max_abs_input = std::max(result.max_abs_input, std::abs(u));
  };

  record(0.0);
  set_segment_input(0);
  record_input(0.0);
  for (std::size_t i = 1; i < stops.size(); ++i) {
    const Stop& stop = stops[i];
    stepper.advance(stop.t);
    if (stop.sample) record(stop.t);
    if (stop.restart) {
      stepper.restart(stop.t, result.stats);
      ++result.stats.restarts;
      set_segment_input(i);
    }
    if (stop.sample) record_input(stop.t);
  }
  stepper.add_statistics(result.stats);
}

/// Settings the model cannot honour: the exact Jacobian needs forward_dynamics_derivatives, an
/// energy ledger needs the energy functions (a specialised header may omit both).
template <class Model>
std::vector<std::string> model_setting_problems(const Settings<Model>& settings) {
  std::vector<std::string> problems;
  if (uses_jacobian(settings.method) && settings.jacobian == Jacobian::exact && !has_derivatives<Model>) {
    problems.push_back(std::string("invalid setting jacobian = exact: model ") + Model::kName +
                       " has no forward_dynamics_derivatives (regenerate its header, or use jacobian = dq)");
  }
  if (settings.energy_ledger && !has_energy<Model>) {
    problems.push_back(std::string("invalid setting energy ledger: model ") + Model::kName +
                       " has no energy functions (specialised without [outputs] energy = true; regenerate it)");
  }
  return problems;
}

}  // namespace detail

/// Throws InvalidInput listing every problem simulate() would refuse before integrating: invalid
/// parameters (or ones that differ from a specialised header's folded values) and settings.
template <class Model>
void require_valid_run(const ParamsOf<Model>& params, const Settings<Model>& settings) {
  auto problems = validate<Model>(params);
  if (const char* name = folded_mismatch<Model>(params)) {
    problems.push_back(std::string("invalid parameter ") + name + ": differs from the value folded into the " +
                       "specialised header of model " + Model::kName + " (regenerate the header)");
  }
  for (const auto& list : {validate<Model>(settings), detail::model_setting_problems<Model>(settings)}) {
    problems.insert(problems.end(), list.begin(), list.end());
  }
  if (!problems.empty()) throw InvalidInput(std::move(problems));
}

/// Integrates `Model` from t = 0 to settings.t_end.
///
/// \param[in] params   Physical parameters (see validate(const ParamsOf<Model>&)).
/// \param[in] settings Method, Jacobian, tolerances or step, output interval, initial state and input.
/// \return The trajectory sampled at t = k·settings.sample and t_end, with the integrator's statistics.
/// \throws InvalidInput     before integrating, listing every invalid parameter and setting.
/// \throws IntegrationError when the integrator fails (flag name, time reached and settings in what()).
/// \throws whatever a feedback input callback throws, unchanged.
template <class Model>
Result simulate(const ParamsOf<Model>& params, const Settings<Model>& settings) {
  static_assert(detail::check_model<Model>());
  const auto started = std::chrono::steady_clock::now();
  require_valid_run<Model>(params, settings);

  constexpr int n = Model::kDof;
  const int size = 2 * n + (settings.energy_ledger ? 2 : 0);
  // Declared before the stepper (created in run_schedule), so destroyed after it.
  sundials::Context context;
  sundials::NVector y(size, context);
  Eigen::Map<Eigen::VectorXd> y_values(y.data(), size);
  y_values.setZero();
  y_values.head<n>() = settings.theta;
  y_values.segment<n>(n) = settings.dtheta;

  Result result;
  if constexpr (has_mass_matrix<Model>) {  // guards.hpp: warn when M makes θ̈ untrustworthy
    if (std::string warning = conditioning_warning<Model>(params, settings.theta); !warning.empty()) {
      result.warnings.push_back(std::move(warning));
    }
  }
  detail::RhsContext<Model> rhs_context;
  rhs_context.params = &params;
  rhs_context.input = &settings.input;
  rhs_context.energy_ledger = settings.energy_ledger;
  rhs_context.x = Eigen::VectorXd::Zero(2 * n);
  detail::Diagnostics diagnostics{{}, &result.warnings};

  switch (family_of(settings.method)) {
    case Family::cvode:
      detail::run_schedule<Model, detail::CvodeStepper<Model>>(settings, y, context, rhs_context, diagnostics, result);
      break;
    case Family::erk:
      detail::run_schedule<Model, detail::ErkStepper<Model>>(settings, y, context, rhs_context, diagnostics, result);
      break;
    case Family::rk4:
      detail::run_schedule<Model, detail::Rk4Stepper<Model>>(settings, y, context, rhs_context, diagnostics, result);
      break;
  }

  result.wall_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return result;
}

}  // namespace ipsim
