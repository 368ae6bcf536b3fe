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
#include "ipsim/sink.hpp"
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
  const int n = dof_of<Model>();
  if (x.size() < 2 * n) {
    throw std::invalid_argument("mechanical_energy: state has " + std::to_string(x.size()) + " entries, model " +
                                name_of<Model>() + " needs 2·kDof = " + std::to_string(2 * n));
  }
  return mechanical_energy<Model>(params, VectorOf<Model>(x.head(n)), VectorOf<Model>(x.segment(n, n)));
}

namespace detail {

/// Runs `Stepper` over the stop schedule, handing each sample to `sink` as it is reached.
template <class Model, class Stepper>
void run_schedule(const Settings<Model>& settings, sundials::NVector& y, const sundials::Context& context,
                  RhsContext<Model>& rhs_context, Diagnostics& diagnostics, SampleSink& sink, Result& result) {
  const int n = dof_of<Model>();
  Eigen::Map<Eigen::VectorXd> y_values(y.data(), y.length());
  Stepper stepper(settings, y, context, rhs_context, diagnostics);

  const bool sampled = settings.input.kind == Input::Kind::sampled;
  // The stops are generated as the run reaches them: no list of every sample in memory.
  // Disturbance pulses (Settings::pulses) switch too: their edges are restarts as well.
  std::vector<double> switching = sampled ? std::vector<double>{} : settings.input.switching_times(settings.t_end);
  for (const Pulse& pulse : settings.pulses) {
    switching.push_back(pulse.start);
    switching.push_back(pulse.start + pulse.duration);
  }
  for (const Input& more : settings.more_inputs) {  // a fixed chain's other inputs switch too
    if (more.kind == Input::Kind::sampled) continue;  // sampled with input, at its instants
    const std::vector<double> times = more.switching_times(settings.t_end);
    switching.insert(switching.end(), times.begin(), times.end());
  }
  std::vector<double> more_values(settings.more_inputs.size(), 0.0);  // u_2..u_m of a sample
  StopSchedule schedule(settings.t_end, settings.sample, std::move(switching), sampled ? settings.input.period : 0.0);
  sink.begin(static_cast<std::size_t>(schedule.sample_count()), 2 * n, settings.energy_ledger);

  auto check_finite = [&](double t) {
    if (!y_values.allFinite()) {  // never hand out a non-finite sample (the integrators should not produce one)
      throw IntegrationError("the state is not finite at t = " + format_number(t) + " s (" + describe(settings) +
                                 "): " + format_values(y_values.data(), y_values.size()) + "; not recorded",
                             -1, "NONFINITE_STATE", t);
    }
  };
  // u is constant between switching times: take it from the middle of the segment that starts
  // at `start`, which is unambiguous even when the segment's ends are switching times. The
  // segment ends at the next restart or at t_end (found on a copy of the schedule, which is
  // small). A sampled controller instead computes u once from the state at the segment's first
  // stop (a sampling instant) and holds it.
  auto set_segment_input = [&](double start) {
    if (!settings.pulses.empty()) {  // the pulses' force on this segment, from its middle
      StopSchedule ahead = schedule;
      double end = settings.t_end;
      while (const auto stop = ahead.next()) {
        end = stop->t;
        if (stop->restart) break;
      }
      const double middle = 0.5 * (start + end);
      rhs_context.segment_pulse = 0.0;
      for (const Pulse& pulse : settings.pulses) {
        if (middle >= pulse.start && middle < pulse.start + pulse.duration) rhs_context.segment_pulse += pulse.amplitude;
      }
    }
    if (sampled) {
      // A restart at a pulse's edge between two sampling instants keeps the held u.
      const double k = std::round(start / settings.input.period);
      if (settings.pulses.empty() || std::abs(start - k * settings.input.period) <= 1e-9 * settings.input.period) {
        rhs_context.x = y_values.head(2 * n);
        rhs_context.segment_input = settings.input.value(start, rhs_context.x);
      }
    } else if (settings.input.piecewise_constant()) {
      StopSchedule ahead = schedule;
      double end = start;
      while (const auto stop = ahead.next()) {
        end = stop->t;
        if (stop->restart) break;
      }
      rhs_context.segment_input = settings.input.value(0.5 * (start + end), rhs_context.x);
    } else {
      rhs_context.segment_input = 0.0;
    }
    result.max_abs_input = std::max(result.max_abs_input, std::abs(rhs_context.segment_input));
    if (!settings.more_inputs.empty()) {  // a fixed chain's other inputs on this segment, from its middle
      StopSchedule ahead = schedule;
      double end = start;
      while (const auto stop = ahead.next()) {
        end = stop->t;
        if (stop->restart) break;
      }
      for (std::size_t k = 0; k < settings.more_inputs.size(); ++k) {
        const Input& more = settings.more_inputs[k];
        rhs_context.segment_more[k] = more.piecewise_constant() ? more.value(0.5 * (start + end), rhs_context.x) : 0.0;
        result.max_abs_input = std::max(result.max_abs_input, std::abs(rhs_context.segment_more[k]));
      }
    }
  };
  // The sample at t: the state, the ledger, and u (the segment's value, or the input evaluated
  // at the recorded state). False when the sink stops the run.
  auto record = [&](double t) {
    double u = rhs_context.segment_input;
    if (!settings.input.piecewise_constant()) {
      rhs_context.x = y_values.head(2 * n);
      u = settings.input.value(t, rhs_context.x);
    }
    result.max_abs_input = std::max(result.max_abs_input, std::abs(u));
    Sample sample;
    sample.t = t;
    sample.state = y_values.data();
    sample.state_size = 2 * n;
    if (settings.energy_ledger) {
      sample.input_work = y_values(2 * n);
      sample.dissipated_energy = y_values(2 * n + 1);
    }
    sample.input = u;
    for (std::size_t k = 0; k < settings.more_inputs.size(); ++k) {
      const Input& more = settings.more_inputs[k];
      more_values[k] = more.piecewise_constant() ? rhs_context.segment_more[k] : more.value(t, rhs_context.x);
      result.max_abs_input = std::max(result.max_abs_input, std::abs(more_values[k]));
    }
    sample.more_inputs = more_values.data();
    sample.more_count = static_cast<int>(more_values.size());
    if (rhs_context.coulomb_index >= 0) result.coulomb_dissipated = y_values(rhs_context.coulomb_index);
    ++result.samples;
    return sink.record(sample);
  };

  const Stop first = *schedule.next();  // t = 0, a sample
  check_finite(first.t);
  set_segment_input(first.t);
  bool go_on = record(first.t);
  while (go_on) {
    const auto stop = schedule.next();
    if (!stop) break;
    stepper.advance(stop->t);
    if (stop->sample) check_finite(stop->t);
    if (stop->restart) {
      stepper.restart(stop->t, result.stats);
      ++result.stats.restarts;
      set_segment_input(stop->t);
    }
    if (stop->sample) go_on = record(stop->t);
  }
  result.stopped_early = !go_on;
  stepper.add_statistics(result.stats);
}

/// Settings the model cannot honour: the exact Jacobian needs forward_dynamics_derivatives, an
/// energy ledger needs the energy functions (a specialised header may omit both).
template <class Model>
std::vector<std::string> model_setting_problems(const Settings<Model>& settings) {
  std::vector<std::string> problems;
  if (uses_jacobian(settings.method) && settings.jacobian == Jacobian::exact &&
      !(has_derivatives<Model> && provides<Model>(Feature::derivatives))) {
    problems.push_back(std::string("invalid setting jacobian = exact: model ") + name_of<Model>() +
                       " has no forward_dynamics_derivatives (regenerate its header, or use jacobian = dq)");
  }
  if (settings.acceleration && !provides<Model>(Feature::mass_and_bias)) {
    problems.push_back(std::string("invalid setting acceleration-driven base: model ") + name_of<Model>() +
                       " has no mass_matrix and bias (regenerate its header without specialising it)");
  }
  if constexpr (is_runtime<Model>) {
    const bool fixed = Model::fixed_pivot();
    if (static_cast<int>(settings.more_inputs.size()) != Model::inputs() - 1) {
      problems.push_back("invalid setting inputs: model " + std::string(name_of<Model>()) + " has " +
                         std::to_string(Model::inputs()) + " input(s), the settings give " +
                         std::to_string(settings.more_inputs.size() + 1));
    }
    if (fixed && (settings.acceleration || settings.lag > 0.0 || !settings.pulses.empty())) {
      problems.emplace_back("invalid setting actuator: a fixed chain takes no acceleration drive, lag or pulses "
                            "in the simulator yet");
    }
    if (!fixed && (settings.coulomb_atan || settings.input_sign != 1.0)) {
      problems.emplace_back("invalid setting coulomb_law/input_sign: a fixed chain's only");
    }
  } else if (!settings.more_inputs.empty()) {
    problems.emplace_back("invalid setting input2: only a fixed chain loaded at run time has more than one input");
  } else if (settings.coulomb_atan || settings.input_sign != 1.0) {
    problems.emplace_back("invalid setting coulomb_law/input_sign: a fixed chain's only");
  }
  if (settings.energy_ledger && !provides<Model>(Feature::energy)) {
    problems.push_back(std::string("invalid setting energy ledger: model ") + name_of<Model>() +
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
                       "specialised header of model " + name_of<Model>() + " (regenerate the header)");
  }
  for (const auto& list : {validate<Model>(settings), detail::model_setting_problems<Model>(settings)}) {
    problems.insert(problems.end(), list.begin(), list.end());
  }
  if (!problems.empty()) throw InvalidInput(std::move(problems));
}

/// Integrates `Model` from t = 0 to settings.t_end, handing every sample to `sink` as soon as
/// it is reached (nothing of the trajectory is kept: memory stays flat however long the run).
///
/// \param[in] given    Physical parameters (see validate(const ParamsOf<Model>&)); unset com/J: the rods.
/// \param[in] settings Method, Jacobian, tolerances or step, output interval, initial state and input.
/// \param[in] sink     Receives the samples at t = k·settings.sample and t_end; returning false
///                     from SampleSink::record stops the run there (Result::stopped_early).
/// \return The summary of the run: statistics, warnings, number of samples, largest |u|, wall
///         time (times, states, inputs and the ledger vectors stay empty).
/// \throws InvalidInput     before integrating, listing every invalid parameter and setting.
/// \throws IntegrationError when the integrator fails (flag name, time reached and settings in what()).
/// \throws whatever a feedback input callback or the sink throws, unchanged.
template <class Model>
Result simulate(const ParamsOf<Model>& given, const Settings<Model>& settings, SampleSink& sink) {
  static_assert(detail::check_model<Model>());
  const auto started = std::chrono::steady_clock::now();
  require_valid_run<Model>(given, settings);
  // The rods' com and J once, not in every right-hand-side call (same values: l/2, m l²/12).
  const ParamsOf<Model> params = with_rod_links<Model>(given);

  const int n = dof_of<Model>();
  const bool coulomb = (settings.coulomb.array() != 0.0).any();
  const bool lag = settings.lag > 0.0;
  const int size = 2 * n + (settings.energy_ledger ? 2 : 0) + (coulomb ? 1 : 0) + (lag ? 1 : 0);
  // Declared before the stepper (created in run_schedule), so destroyed after it.
  sundials::Context context;
  sundials::NVector y(size, context);
  Eigen::Map<Eigen::VectorXd> y_values(y.data(), size);
  y_values.setZero();
  y_values.head(n) = settings.theta;
  y_values.segment(n, n) = settings.dtheta;

  Result result;
  if constexpr (has_mass_matrix<Model>) {  // guards.hpp: warn when M makes θ̈ untrustworthy
    if (provides<Model>(Feature::mass_matrix)) {
      if (std::string warning = conditioning_warning<Model>(params, settings.theta); !warning.empty()) {
        result.warnings.push_back(std::move(warning));
      }
    }
  }
  detail::RhsContext<Model> rhs_context;
  rhs_context.params = &params;
  rhs_context.input = &settings.input;
  rhs_context.energy_ledger = settings.energy_ledger;
  rhs_context.acceleration = settings.acceleration;
  if (coulomb) {
    rhs_context.coulomb = settings.coulomb;
    rhs_context.coulomb_speed = settings.coulomb_speed;
    rhs_context.coulomb_index = size - 1 - (lag ? 1 : 0);
  }
  if (lag) {  // the drive's state u_a, last; u_a(0) = 0
    rhs_context.lag = settings.lag;
    rhs_context.lag_index = size - 1;
  }
  rhs_context.x = Eigen::VectorXd::Zero(2 * n);
  if constexpr (is_runtime<Model>) {
    if (Model::fixed_pivot()) {  // m inputs through B (rhs.hpp)
      rhs_context.input_matrix = Model::input_matrix();
      rhs_context.inputs = Model::inputs();
      rhs_context.more_inputs = &settings.more_inputs;
      rhs_context.segment_more.assign(settings.more_inputs.size(), 0.0);
      rhs_context.all_inputs.assign(static_cast<std::size_t>(rhs_context.inputs), 0.0);
      rhs_context.input_sign = settings.input_sign;
      rhs_context.coulomb_relative_from = 1;  // joint 1 against the ground, joint i against link i − 1
      rhs_context.coulomb_atan = settings.coulomb_atan;
      rhs_context.coulomb_gain = settings.coulomb_gain;
    }
  }
  detail::Diagnostics diagnostics{{}, &result.warnings};

  switch (family_of(settings.method)) {
    case Family::cvode:
      detail::run_schedule<Model, detail::CvodeStepper<Model>>(settings, y, context, rhs_context, diagnostics, sink,
                                                               result);
      break;
    case Family::erk:
      detail::run_schedule<Model, detail::ErkStepper<Model>>(settings, y, context, rhs_context, diagnostics, sink,
                                                             result);
      break;
    case Family::rk4:
      detail::run_schedule<Model, detail::Rk4Stepper<Model>>(settings, y, context, rhs_context, diagnostics, sink,
                                                             result);
      break;
  }

  result.wall_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return result;
}

/// Integrates `Model` from t = 0 to settings.t_end and keeps every sample (MemorySink).
///
/// \param[in] params   Physical parameters (see validate(const ParamsOf<Model>&)).
/// \param[in] settings Method, Jacobian, tolerances or step, output interval, initial state and input.
/// \return The trajectory sampled at t = k·settings.sample and t_end, with the integrator's statistics.
/// \throws InvalidInput     before integrating, listing every invalid parameter and setting.
/// \throws IntegrationError when the integrator fails (flag name, time reached and settings in what()).
/// \throws whatever a feedback input callback throws, unchanged.
template <class Model>
Result simulate(const ParamsOf<Model>& params, const Settings<Model>& settings) {
  Result kept;
  MemorySink sink(kept);
  Result summary = simulate<Model>(params, settings, sink);
  sink.finish();
  summary.times = std::move(kept.times);
  summary.states = std::move(kept.states);
  summary.inputs = std::move(kept.inputs);
  summary.input_work = std::move(kept.input_work);
  summary.dissipated_energy = std::move(kept.dissipated_energy);
  return summary;
}

}  // namespace ipsim
