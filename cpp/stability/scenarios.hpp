// The stability scenarios of docs/stability.md, generic over a generated model: each measures
// one extreme (many links, mass and length ratios, no or enormous damping, fast motion, rotary
// geometry, float, long horizons) and asserts its outcome. driver.hpp runs them for one model
// and prints one JSON object per row; tools/stability.py tabulates them.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "ipsim/ipsim.hpp"
#include "check.hpp"         // cpp/tests: NaN-propagating error measures
#include "paper_params.hpp"  // cpp/tests: the paper's parameters, the work–energy balance

namespace stability {

inline constexpr double kEps = std::numeric_limits<double>::epsilon();
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// One row of the table: what was run, what was measured, the bound it is held to, the outcome.
struct Row {
  Row(std::string scenario_, std::string model_, std::string what_, std::string measure_)
      : scenario(std::move(scenario_)),
        model(std::move(model_)),
        what(std::move(what_)),
        measure(std::move(measure_)) {}

  std::string scenario;  ///< e.g. "undamped 10 s"
  std::string model;     ///< e.g. "cdip (classical, 2 links)"
  std::string what;      ///< the case: parameters, start, method
  std::string measure;   ///< the measured quantity, e.g. "rel. energy drift"
  double value = kNaN;   ///< its value
  double bound = kNaN;   ///< value must stay at or below this (NaN: measured only)
  long steps = -1;       ///< integrator steps (-1: not a simulation)
  double wall = kNaN;    ///< wall time [s]
  std::string outcome;   ///< "ok", "warned", "stiff: use BDF", "FAILED: …"
  bool passed = true;
  std::string note;      ///< anything else worth a column: cond(M), the float error, peak RSS
};

/// What to run: everything (make stability) or a quick subset (ctest).
struct Options {
  bool quick = false;
};

/// "%.3g" of a number, for notes.
inline std::string g3(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", value);
  return text;
}

/// The paper's parameters for any n, damped as in the paper or not at all (cpp/tests/paper_params.hpp).
using ipsim_test::paper_params;

template <class Model>
std::string model_label() {
  const int links = ipsim::links_of<Model>();
  return std::string(ipsim::name_of<Model>()) + " (" + ipsim::type_of<Model>() + ", " + std::to_string(links) +
         " link" + (links == 1 ? "" : "s") + ")";
}

/// Tight settings (the scenes' defaults): BDF, rtol 1e-10, atol 1e-12.
template <class Model>
ipsim::Settings<Model> tight_settings(double t_end, double sample) {
  ipsim::Settings<Model> s;
  s.rtol = 1e-10;
  s.atol = 1e-12;
  s.t_end = t_end;
  s.sample = sample;
  return s;
}

/// A simulation's result or its error message, with the wall time.
struct Run {
  bool ok = false;
  bool integration_error = false;  ///< failed with an ipsim::IntegrationError (a diagnosed stop)
  ipsim::Result result;
  std::string error;
  double wall = 0.0;
};

template <class Model>
Run run(const ipsim::ParamsOf<Model>& p, const ipsim::Settings<Model>& s) {
  Run r;
  const auto started = std::chrono::steady_clock::now();
  try {
    r.result = ipsim::simulate<Model>(p, s);
    r.ok = true;
  } catch (const ipsim::IntegrationError& e) {
    r.error = e.what();
    r.integration_error = true;
  } catch (const std::exception& e) {
    r.error = e.what();
  }
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return r;
}

/// max_k |E_k − E_0| / max_k (T_k + |V_k|): the drift of T + V relative to the energy in play
/// (|E_0| alone can be near zero, e.g. links horizontal and at rest).
template <class Model>
double energy_drift(const ipsim::ParamsOf<Model>& p, const ipsim::Result& r) {
  const int n = ipsim::dof_of<Model>();
  double e0 = 0.0, drift = 0.0, scale = 0.0;
  for (Eigen::Index k = 0; k < r.states.rows(); ++k) {
    const ipsim::VectorOf<Model> q = r.states.row(k).head(n).transpose();
    const ipsim::VectorOf<Model> qd = r.states.row(k).segment(n, n).transpose();
    const double t = Model::template kinetic_energy<double>(q, qd, p);
    const double v = Model::template potential_energy<double>(q, p);
    if (k == 0) e0 = t + v;
    ipsim_test::raise_to(drift, std::abs(t + v - e0));  // a NaN energy makes the row fail
    ipsim_test::raise_to(scale, t + std::abs(v));
  }
  return drift / scale;
}

/// Fills a row from a run: steps, wall time, and "ok" or the error.
inline void record_run(Row& row, const Run& r) {
  row.wall = r.wall;
  if (r.ok) {
    row.steps = r.result.stats.steps;
    row.outcome = "ok";
  } else {
    row.outcome = "FAILED: " + r.error;
    row.passed = false;
  }
}

/// Holds `row.value <= row.bound` (when a bound is given and the run succeeded).
inline void apply_bound(Row& row) {
  if (!row.passed || std::isnan(row.bound)) return;
  if (!(row.value <= row.bound)) {
    row.passed = false;
    row.outcome = "FAILED: " + g3(row.value) + " > bound " + g3(row.bound);
  }
}

// ---------------------------------------------------------------------------------------------
// Zero damping: T + V conserved (10 s: the many-links rows; 1000 s: the long-horizon one).

/// Undamped, no input, every link tilted 0.3 rad from upright: the chain falls and swings
/// chaotically, the hardest motion for energy conservation. The drift is the integrator's global
/// error, which for BDF (not symplectic) grows about linearly in time: bound rtol·(1e4 + 100·t/s),
/// i.e. 1.1e-6 over 10 s and 1.1e-5 over 1000 s at rtol 1e-10.
template <class Model>
Row undamped(double t_end, double sample) {
  const auto p = paper_params<Model>(false);
  auto s = tight_settings<Model>(t_end, sample);
  s.max_steps = 1000000;
  for (int i = 1; i < ipsim::dof_of<Model>(); ++i) s.theta(i) = 0.3;
  Row row{"undamped " + g3(t_end) + " s", model_label<Model>(), "links tilted 0.3 rad, no input, bdf rtol 1e-10",
          "rel. energy drift"};
  row.bound = s.rtol * (1e4 + 100.0 * t_end);
  const Run r = run<Model>(p, s);
  record_run(row, r);
  if (r.ok) row.value = energy_drift<Model>(p, r.result);
  apply_bound(row);
  return row;
}

// ---------------------------------------------------------------------------------------------
// Damping: a light tip link with enormous joint damping (stiff).

/// The chain hanging, its last link light (1e-3 kg), tilted 0.2 rad and damped by δ_n on its
/// joint, a pulse on the base; every method for t_end at rtol 1e-8 against BDF at 1e-12. BDF must
/// succeed in at most `bdf_steps` steps, within 1e3·rtol of the reference; every other method
/// must succeed just as accurately or stop with "stiff: use BDF", within `wall_limit` seconds.
template <class Model>
std::vector<Row> stiff_damping(const Options& options) {
  std::vector<Row> rows;
  const double t_end = 1.0, bdf_steps = 5000, wall_limit = 60.0;
  std::vector<double> dampings{1e4};
  if (!options.quick) dampings = {1e2, 1e4};
  std::vector<ipsim::Method> methods{ipsim::Method::bdf, ipsim::Method::erk_dp5, ipsim::Method::rk4};
  if (!options.quick) {
    methods = {ipsim::Method::bdf, ipsim::Method::adams, ipsim::Method::adams_fixed_point, ipsim::Method::erk_dp5,
               ipsim::Method::erk_fehlberg8, ipsim::Method::rk4};
  }
  for (const double delta : dampings) {
    auto p = paper_params<Model>(true);
    const auto last = static_cast<std::size_t>(ipsim::links_of<Model>());
    p.m[last] = 1e-3;
    p.delta[last] = delta;
    auto reference_settings = tight_settings<Model>(t_end, 0.01);
    for (int i = 1; i < ipsim::dof_of<Model>(); ++i) reference_settings.theta(i) = ipsim::kPi;  // hanging
    reference_settings.theta(ipsim::links_of<Model>()) += 0.2;
    reference_settings.input = ipsim::Input::pulse(0.4, 0.0, 0.5);
    reference_settings.rtol = 1e-12;
    reference_settings.atol = 1e-14;
    const Run reference = run<Model>(p, reference_settings);
    for (const auto method : methods) {
      auto s = reference_settings;
      s.rtol = 1e-8;
      s.atol = 1e-10;
      s.method = method;
      s.step = 1e-3;
      Row row{"stiff damping", model_label<Model>(),
              "hanging, tip link 1e-3 kg, delta_n = " + g3(delta) + ", 1 s, " + ipsim::to_string(method) +
                  (method == ipsim::Method::rk4 ? " step 1e-3" : " rtol 1e-8"),
              "max |x - x_ref| / max |x_ref| (ref: bdf rtol 1e-12)"};
      const Run r = run<Model>(p, s);
      record_run(row, r);
      if (r.ok && reference.ok) {
        row.value = ipsim_test::max_abs(r.result.states - reference.result.states) /
                    ipsim_test::max_abs(reference.result.states);
        if (!r.result.warnings.empty()) row.note = r.result.warnings.front().substr(0, 160);
      }
      if (method == ipsim::Method::bdf) {
        row.bound = 1e3 * s.rtol;
        apply_bound(row);
        if (row.passed && row.steps > bdf_steps) {
          row.passed = false;
          row.outcome = "FAILED: " + std::to_string(row.steps) + " steps > " + g3(bdf_steps);
        }
      } else if (!r.ok) {
        const bool diagnosed = r.error.find("stiff: use BDF") != std::string::npos;
        row.passed = diagnosed;
        row.outcome = diagnosed ? "stopped: stiff: use BDF" : "FAILED: " + r.error;
        row.note = r.error.substr(0, r.error.find(';'));
      } else {
        row.bound = 1e3 * s.rtol;
        apply_bound(row);
      }
      if (row.wall > wall_limit) {
        row.passed = false;
        row.outcome = "FAILED: ran " + g3(row.wall) + " s > " + g3(wall_limit) + " s";
      }
      if (!reference.ok) {
        row.passed = false;
        row.outcome = "FAILED: reference: " + reference.error;
      }
      rows.push_back(row);
    }
  }
  return rows;
}

// ---------------------------------------------------------------------------------------------
// Fast motion: rates of 1e3 rad/s, and a large input.

/// Fast motion, undamped, 0.05 s: (a) the links straight and spinning together at 1e3 rad/s
/// about the base, which starts at rest (8 turns); (b) for a rotary base, the arm spinning at
/// 1e3 rad/s with the links tilted 0.3 rad from hanging, flung outwards. Each method at rtol 1e-10
/// must conserve T + V to 1e4·rtol, or stop with a diagnosis (an IntegrationError naming the
/// cause: the whip of a long chain reaches rates of 4e4 rad/s, more than erk-fehlberg8's error
/// estimate handles at that tolerance). The difference from erk-fehlberg8 at rtol 1e-12 is recorded:
/// with several links these motions are chaotic within hundredths of a second (nearby
/// trajectories part at a rate of the order of the rates themselves), so it is held to a bound
/// only where the motion is regular, case (a) with one or two links: 1e-6 for the explicit
/// methods, 1e-3 for BDF, whose low order needs ~1000 steps per turn.
template <class Model>
std::vector<Row> fast_motion(const Options& /*options*/) {
  std::vector<Row> rows;
  const auto p = paper_params<Model>(false);
  std::vector<std::pair<std::string, ipsim::Settings<Model>>> cases;
  auto s = tight_settings<Model>(0.05, 0.001);
  s.max_steps = 1000000;
  for (int i = 1; i < ipsim::dof_of<Model>(); ++i) {
    s.theta(i) = 0.1;
    s.dtheta(i) = 1e3;
  }
  cases.emplace_back("links straight, spinning at 1e3 rad/s", s);
  if (!ipsim::is_classical<Model>()) {
    s.theta.setConstant(ipsim::kPi - 0.3);
    s.theta(0) = 0.0;
    s.dtheta.setZero();
    s.dtheta(0) = 1e3;
    cases.emplace_back("arm spinning at 1e3 rad/s, links 0.3 rad from hanging", s);
  }
  bool regular = ipsim::links_of<Model>() <= 2;  // only the first case
  for (const auto& [name, settings] : cases) {
    auto reference_settings = settings;
    reference_settings.method = ipsim::Method::erk_fehlberg8;
    reference_settings.rtol = 1e-12;
    reference_settings.atol = 1e-14;
    const Run reference = run<Model>(p, reference_settings);
    for (const auto method : {ipsim::Method::bdf, ipsim::Method::erk_dp5, ipsim::Method::erk_fehlberg8}) {
      auto with_method = settings;
      with_method.method = method;
      Row row{"fast motion", model_label<Model>(),
              name + ", undamped, 0.05 s, " + ipsim::to_string(method) + " rtol 1e-10", "rel. energy drift"};
      const Run r = run<Model>(p, with_method);
      record_run(row, r);
      row.bound = 1e4 * with_method.rtol;
      if (r.integration_error) {  // loud and explained is an acceptable outcome at these rates
        row.passed = true;
        row.outcome = "stopped (diagnosed)";
        row.note = r.error.substr(0, 400);
      }
      if (r.ok) {
        row.value = energy_drift<Model>(p, r.result);
        apply_bound(row);
        const double max_rate = r.result.states.rightCols(ipsim::dof_of<Model>()).cwiseAbs().maxCoeff();
        row.note = "max rate " + g3(max_rate);
        if (reference.ok) {
          const double difference = ipsim_test::max_abs(r.result.states - reference.result.states) /
                                    ipsim_test::max_abs(reference.result.states);
          const double limit = method == ipsim::Method::bdf ? 1e-3 : 1e-6;
          row.note += "; differs from erk-fehlberg8 rtol 1e-12 by " + g3(difference) + " of max |x|" +
                      (regular ? " (bound " + g3(limit) + ")" : " (not held to a bound)");
          if (row.passed && regular && !(difference <= limit)) {
            row.passed = false;
            row.outcome = "FAILED: differs from the reference by " + g3(difference) + " > " + g3(limit);
          }
        }
      }
      rows.push_back(row);
    }
    regular = false;
  }

  // A large input: 1e4 N (N m) for 0.1 s on the damped system, with the energy ledger.
  auto big = tight_settings<Model>(0.2, 0.001);
  big.input = ipsim::Input::pulse(1e4, 0.0, 0.1);
  big.energy_ledger = true;
  big.max_steps = 1000000;
  const auto pd = paper_params<Model>(true);
  Row row{"fast motion", model_label<Model>(), "input 1e4 N (N m) for 0.1 s, damped, bdf rtol 1e-10",
          "work-energy balance error / input work"};
  const Run r = run<Model>(pd, big);
  record_run(row, r);
  if (r.ok) {
    const auto& res = r.result;
    row.value = ipsim_test::work_energy_error<Model>(pd, res) / std::abs(res.input_work.back());
    row.note = "max rate " + g3(res.states.rightCols(ipsim::dof_of<Model>()).cwiseAbs().maxCoeff()) + " rad/s";
  }
  row.bound = 1e4 * big.rtol;
  apply_bound(row);
  rows.push_back(row);
  return rows;
}

// ---------------------------------------------------------------------------------------------
// Rotary geometry: links through horizontal, the base far from its origin (many turns).

/// Links starting horizontal (θ = π/2) at 10 rad/s: they swing over the top and pass ±π/2 again
/// and again; T + V must be conserved to the bound of undamped().
template <class Model>
Row through_horizontal(const Options& options) {
  const double t_end = options.quick ? 2.0 : 10.0;
  const auto p = paper_params<Model>(false);
  auto s = tight_settings<Model>(t_end, 0.001);
  s.max_steps = 1000000;
  for (int i = 1; i < ipsim::dof_of<Model>(); ++i) {
    s.theta(i) = 0.5 * ipsim::kPi;
    s.dtheta(i) = 10.0;
  }
  Row row{"links through horizontal", model_label<Model>(),
          "links start at pi/2 with 10 rad/s, undamped, " + g3(t_end) + " s, bdf rtol 1e-10", "rel. energy drift"};
  row.bound = s.rtol * (1e4 + 100.0 * t_end);  // as undamped()
  const Run r = run<Model>(p, s);
  record_run(row, r);
  if (r.ok) {
    row.value = energy_drift<Model>(p, r.result);
    long crossings = 0;  // passages of any link through ±π/2 (mod 2π)
    for (Eigen::Index k = 1; k < r.result.states.rows(); ++k) {
      for (int i = 1; i < ipsim::dof_of<Model>(); ++i) {
        const double a = std::cos(r.result.states(k - 1, i)), b = std::cos(r.result.states(k, i));
        if ((a > 0) != (b > 0)) ++crossings;
      }
    }
    row.note = std::to_string(crossings) + " passages through horizontal";
  }
  apply_bound(row);
  return row;
}

/// The same run started with the base shifted by `shift` (2πk rad for the arm: k turns; metres
/// for a cart), and with every link shifted by 2πk: the dynamics do not depend on either, so the
/// trajectories must agree up to the shift. The chain starts hanging, tilted, and is pushed: a
/// regular motion (a falling chain is chaotic, and any change of step sequence would show). The
/// bound is 1e4·rtol (the runs' global error) plus: for the base, which does not feed back into
/// the dynamics, its own rounding (64 ε·|shift|); for the links, rtol·|shift|, because the
/// integrator's error weight of a state is rtol·|θ| + atol, so a link at 2πk rad is integrated to
/// an absolute error of about rtol·2πk (and sin θ itself carries ε·|θ|).
template <class Model>
std::vector<Row> many_turns(const Options& options) {
  std::vector<Row> rows;
  const auto p = paper_params<Model>(true);
  auto s = tight_settings<Model>(options.quick ? 2.0 : 10.0, 0.01);
  s.input = ipsim::Input::pulse(0.4, 0.0, 1.0);
  for (int i = 1; i < ipsim::dof_of<Model>(); ++i) s.theta(i) = ipsim::kPi + 0.1 * i;  // hanging, tilted: regular
  const Run reference = run<Model>(p, s);
  const double base_unit = ipsim::is_classical<Model>() ? 1.0 : 2.0 * ipsim::kPi;
  std::vector<double> turns{1e6};
  if (!options.quick) turns = {1e2, 1e4, 1e6};
  for (const bool links : {false, true}) {
    for (const double k : turns) {
      auto shifted = s;
      const double shift = k * (links ? 2.0 * ipsim::kPi : base_unit);
      if (links) {
        for (int i = 1; i < ipsim::dof_of<Model>(); ++i) shifted.theta(i) += shift;
      } else {
        shifted.theta(0) += shift;
      }
      Row row{links ? "links spinning many turns" : (ipsim::is_classical<Model>() ? "cart far from origin"
                                                                                  : "arm spinning many turns"),
              model_label<Model>(),
              (links ? "links" : "base") + std::string(" shifted by ") + g3(shift) +
                  (links || !ipsim::is_classical<Model>() ? " rad (" + g3(k) + " turns)" : " m") + ", " +
                  g3(s.t_end) + " s pulse from hanging",
              "max |x - x_unshifted - shift|"};
      const Run r = run<Model>(p, shifted);
      record_run(row, r);
      if (r.ok && reference.ok) {
        Eigen::MatrixXd difference = r.result.states - reference.result.states;
        if (links) {
          difference.middleCols(1, ipsim::links_of<Model>()).array() -= shift;
        } else {
          difference.col(0).array() -= shift;
        }
        row.value = ipsim_test::max_abs(difference);
        row.bound = 1e4 * s.rtol + (links ? s.rtol : 64.0 * kEps) * shift;
        row.note = "steps " + std::to_string(r.result.stats.steps) + " vs " +
                   std::to_string(reference.result.stats.steps) + " unshifted";
      }
      apply_bound(row);
      rows.push_back(row);
    }
  }
  return rows;
}

// ---------------------------------------------------------------------------------------------
// Long horizon.

/// The paper's experiment (damped, 0.4 pulse for 1 s) for t_end with samples every `sample`:
/// success, a finite final state at rest, and the samples kept (the memory the caller measures).
template <class Model>
Row long_horizon(double t_end, double sample) {
  const auto p = paper_params<Model>(true);
  auto s = tight_settings<Model>(t_end, sample);
  s.input = ipsim::Input::pulse(0.4, 0.0, 1.0);
  s.max_steps = 10000000;
  Row row{"long horizon", model_label<Model>(),
          "paper pulse, damped, " + g3(t_end) + " s, sample " + g3(sample) + " s, bdf rtol 1e-10",
          "max |dtheta| at t_end"};
  const Run r = run<Model>(p, s);
  record_run(row, r);
  if (r.ok) {
    row.value = r.result.states.bottomRows(1).rightCols(ipsim::dof_of<Model>()).cwiseAbs().maxCoeff();
    row.bound = 1e-6;  // at rest long before t_end
    row.note = std::to_string(r.result.times.size()) + " samples kept";
  }
  apply_bound(row);
  return row;
}

/// Undamped for t_end with a coarse sample (1 s): no failure over the whole horizon, the drift
/// held to the same linear-in-time bound as the shorter runs.
template <class Model>
Row long_undamped(double t_end) {
  Row row = undamped<Model>(t_end, 1.0);
  row.scenario = "undamped " + g3(t_end) + " s";
  return row;
}

}  // namespace stability
