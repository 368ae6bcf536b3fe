// Checks of ipsim that hold for every model, written against the model tag type so they run on
// the stand-in (its sizes fixed at compile time) and on each generated model loaded at run time
// (ipsim::RuntimeModel: sizes from dof_of, links_of; see test_model.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "check.hpp"
#include "ipsim/ipsim.hpp"
#include "paper_params.hpp"

namespace ipsim_test {

/// Tight tolerances and every link tilted (all below 90°, so V > 0 and relative errors are
/// meaningful).
template <class Model>
ipsim::Settings<Model> tilted_settings() {
  ipsim::Settings<Model> s;
  s.rtol = 1e-10;
  s.atol = 1e-12;
  s.t_end = 5.0;
  s.sample = 0.01;
  for (int i = 1; i < ipsim::dof_of<Model>(); ++i) s.theta(i) = 0.2 + 0.1 * i;
  s.dtheta(1) = 0.5;
  return s;
}

/// A run whose input is a pulse from t = 0 to its falling edge, and the same motion in two
/// constant-input pieces with the run's other settings: `on` (the pulse's amplitude up to the
/// edge), then `off` (no input, from the state `on` ends in, for the rest of the run; the model is
/// autonomous, so it may start at t = 0). at_edge is max |pulsed sample at the edge − end of
/// `on`|, at_end max |last pulsed sample − end of `off`| (infinite when the edge is not sampled).
struct PulseInPieces {
  ipsim::Result pulsed, on, off;
  double at_edge = INFINITY, at_end = INFINITY;
};

template <class Model>
PulseInPieces run_pulse_in_pieces(const ipsim::ParamsOf<Model>& p, const ipsim::Settings<Model>& s) {
  PulseInPieces runs;
  if (s.input.kind != ipsim::Input::Kind::pulse || s.input.start != 0.0) {
    fail(__FILE__, __LINE__, "run_pulse_in_pieces needs a pulse starting at t = 0");
    return runs;
  }
  const double edge = s.input.duration;
  runs.pulsed = ipsim::simulate<Model>(p, s);
  auto on = s;
  on.t_end = edge;
  on.input = ipsim::Input::constant(s.input.amplitude);
  runs.on = ipsim::simulate<Model>(p, on);
  auto off = on;
  off.t_end = s.t_end - edge;
  off.input = ipsim::Input::zero();
  const Eigen::VectorXd at_switch = runs.on.states.bottomRows(1).transpose();
  const int n = ipsim::dof_of<Model>();
  off.theta = at_switch.head(n);
  off.dtheta = at_switch.tail(n);
  runs.off = ipsim::simulate<Model>(p, off);
  const auto& times = runs.pulsed.times;
  const auto sample = std::find(times.begin(), times.end(), edge);
  if (sample != times.end()) {
    runs.at_edge = max_difference(runs.pulsed.states.row(sample - times.begin()), runs.on.states.bottomRows(1));
  }
  runs.at_end = max_difference(runs.pulsed.states.bottomRows(1), runs.off.states.bottomRows(1));
  return runs;
}

/// The model's functions agree with each other: M = ∂²T/∂θ̇², bias = N θ̇ + P, T = ½ θ̇ᵀMθ̇,
/// P = ∂V/∂θ, M θ̈ + bias = (u, 0, …), D = the Rayleigh function of docs/model.md.
template <class Model>
void check_model_consistency() {
  using Vector = ipsim::VectorOf<Model>;
  const int n = ipsim::dof_of<Model>();
  const auto p = paper_params<Model>(true);
  for (int trial = 0; trial < 5; ++trial) {
    const Vector q = Vector::LinSpaced(n, -0.7 + 0.3 * trial, 1.1 - 0.2 * trial);
    const Vector qd = Vector::LinSpaced(n, 0.4 * trial - 0.9, 0.5);
    const double u = 0.3 * trial - 0.5;
    const auto M = Model::template mass_matrix<double>(q, p);
    const Vector b = Model::template bias<double>(q, qd, p);
    const Vector P = Model::template gravity<double>(q, p);
    const auto N = Model::template n_matrix<double>(q, qd, p);
    // M is the Hessian of T in θ̇, entry by entry (hence symmetric). A generated header emits
    // kinetic_energy as its own polynomial, not from mass_matrix (which writes M(1, 0) = M(0, 1),
    // so M = Mᵀ alone could not fail), so a wrong entry of M in either triangle shows here. T is
    // exactly quadratic in θ̇: the central second difference
    //   [T(θ̇ + h eᵢ + h eⱼ) − T(θ̇ + h eᵢ − h eⱼ) − T(θ̇ − h eᵢ + h eⱼ) + T(θ̇ − h eᵢ − h eⱼ)] / 4h²
    // is ∂²T/∂θ̇ᵢ∂θ̇ⱼ for any h, up to rounding. h = 0.5 (like |θ̇| here) keeps the cancellation
    // mild: the rounding of T, a few ε·|θ̇ ± 2h|²·max|M|, divided by 4h², stays near 1e-14·max|M|
    // (worst measured 3.6e-15·max|M|, classical10); 1e-12·max|M| leaves room and still catches a
    // wrong term.
    const double h = 0.5;
    Eigen::MatrixXd hessian(n, n);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        auto kinetic = [&](double step_i, double step_j) {
          Vector shifted = qd;
          shifted(i) += step_i;
          shifted(j) += step_j;
          return Model::template kinetic_energy<double>(q, shifted, p);
        };
        hessian(i, j) = (kinetic(h, h) - kinetic(h, -h) - kinetic(-h, h) + kinetic(-h, -h)) / (4 * h * h);
      }
    }
    CHECK_NEAR(max_difference(M, hessian), 0.0, 1e-12 * max_abs(M));
    CHECK(max_difference(N * qd + P, b) <= 1e-12);
    CHECK_NEAR(Model::template kinetic_energy<double>(q, qd, p), 0.5 * qd.dot(M * qd), 1e-12);

    const Vector qdd = Model::template forward_dynamics<double>(q, qd, u, p);
    Vector generalized_force = Vector::Zero(n);
    generalized_force(0) = u;
    CHECK(max_difference(M * qdd + b, generalized_force) <= 1e-10);

    for (int i = 0; i < n; ++i) {
      const double h = 1e-6;
      Vector up = q, down = q;
      up(i) += h;
      down(i) -= h;
      const double dV = (Model::template potential_energy<double>(up, p) -
                         Model::template potential_energy<double>(down, p)) / (2 * h);
      CHECK_NEAR(dV, P(i), 1e-7);
    }

    double rayleigh = 0.5 * p.delta[0] * qd(0) * qd(0) + 0.5 * p.delta[1] * qd(1) * qd(1);
    for (int i = 2; i < n; ++i) {
      const double relative = qd(i) - qd(i - 1);
      rayleigh += 0.5 * p.delta[static_cast<std::size_t>(i)] * relative * relative;
    }
    CHECK_NEAR(Model::template dissipation<double>(qd, p), rayleigh, 1e-14);
  }
}

/// Every invalid parameter is reported with the field's name; l[0] only matters for a rotary base.
template <class Model>
void check_parameter_validation() {
  using ipsim::validate;
  const int last = ipsim::links_of<Model>();
  const auto good = paper_params<Model>(true);
  CHECK(validate<Model>(good).empty());

  auto expect_one = [&](auto mutate, const std::string& message) {
    auto p = good;
    mutate(p);
    const auto problems = validate<Model>(p);
    CHECK(problems.size() == 1);
    if (problems.size() == 1 && problems[0] != message) fail(__FILE__, __LINE__, "got \"" + problems[0] + "\", want \"" + message + "\"");
    CHECK_THROWS(ipsim::simulate<Model>(p, tilted_settings<Model>()), ipsim::InvalidInput, message);
  };
  const auto k = static_cast<std::size_t>(last);
  expect_one([&](auto& p) { p.m[k] = -1; },
             "invalid parameter m[" + std::to_string(last) + "] = -1: masses must be > 0");
  expect_one([](auto& p) { p.m[0] = 0; }, "invalid parameter m[0] = 0: masses must be > 0");
  expect_one([](auto& p) { p.m[0] = std::numeric_limits<double>::quiet_NaN(); },
             "invalid parameter m[0] = nan: must be finite");
  expect_one([](auto& p) { p.l[1] = 0; }, "invalid parameter l[1] = 0: lengths must be > 0");
  expect_one([&](auto& p) { p.l[k] = std::numeric_limits<double>::infinity(); },
             "invalid parameter l[" + std::to_string(last) + "] = inf: must be finite");
  expect_one([](auto& p) { p.delta[0] = -0.5; }, "invalid parameter delta[0] = -0.5: damping must be >= 0");
  expect_one([](auto& p) { p.g = std::numeric_limits<double>::infinity(); },
             "invalid parameter g = inf: must be finite");

  auto base_length_zero = good;
  base_length_zero.l[0] = 0;
  if (ipsim::is_classical<Model>()) {
    CHECK(validate<Model>(base_length_zero).empty());  // a cart has no length
  } else {
    CHECK(validate<Model>(base_length_zero).size() == 1);
  }

  auto two_wrong = good;
  two_wrong.m[1] = -2;
  two_wrong.delta[1] = -3;
  CHECK(validate<Model>(two_wrong).size() == 2);
  CHECK_THROWS(ipsim::require_valid<Model>(two_wrong), ipsim::InvalidInput,
               "invalid parameter m[1] = -2: masses must be > 0; invalid parameter delta[1] = -3");
}

/// Every invalid setting is rejected before integrating, naming the field.
template <class Model>
void check_settings_validation() {
  const auto p = paper_params<Model>(true);
  CHECK(ipsim::validate<Model>(tilted_settings<Model>()).empty());
  auto expect = [&](auto mutate, const std::string& message) {
    auto s = tilted_settings<Model>();
    mutate(s);
    CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::InvalidInput, message);
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  expect([](auto& s) { s.rtol = 0; }, "invalid setting rtol = 0: must be finite and > 0");
  expect([](auto& s) { s.rtol = -1e-6; }, "invalid setting rtol = -1e-06");
  expect([](auto& s) { s.atol = -1; }, "invalid setting atol = -1: must be finite and > 0");
  expect([](auto& s) { s.atol = 0; }, "invalid setting atol = 0: must be finite and > 0");  // CVODE: ewt infinite
  expect([](auto& s) { s.t_end = 0; }, "invalid setting t_end = 0: must be finite and >= 1e-9 s (kMinTEnd)");
  // CVODE refused a stop time this short at t = 0 (CV_ILL_INPUT): now an InvalidInput before it runs
  expect([](auto& s) { s.t_end = 1e-300; }, "invalid setting t_end = 1e-300: must be finite and >= 1e-9 s");
  expect([](auto& s) { s.sample = 0; }, "invalid setting sample = 0: must be finite and > 0");
  expect([](auto& s) { s.sample = 1e-12; }, "exceeds 10000000 output samples");
  expect([](auto& s) { s.max_steps = 0; }, "invalid setting max_steps = 0: must be > 0");
  expect([&](auto& s) { s.theta(1) = nan; }, "invalid setting theta[1] = nan: initial state must be finite");
  expect([&](auto& s) { s.dtheta(0) = inf; }, "invalid setting dtheta[0] = inf: initial state must be finite");
  expect([](auto& s) { s.input = ipsim::Input::pulse(1.0, 0.0, -1.0); },
         "invalid setting input.duration = -1: must be >= 0");
  expect([&](auto& s) { s.input = ipsim::Input::sine(1.0, nan, 0.0); }, "invalid setting input.frequency = nan");
  expect([](auto& s) { s.input = ipsim::Input::from_feedback(nullptr); }, "feedback input without a callback");
  // Parameter and setting problems are reported together.
  auto s = tilted_settings<Model>();
  s.rtol = 0;
  auto bad = p;
  bad.m[1] = -1;
  CHECK_THROWS(ipsim::simulate<Model>(bad, s), ipsim::InvalidInput, "masses must be > 0; invalid setting rtol = 0");
}

/// CVODE failures surface as IntegrationError naming the flag, the time and the settings; a
/// throwing controller's exception reaches the caller unchanged.
template <class Model>
void check_integration_errors() {
  const auto p = paper_params<Model>(true);
  auto s = tilted_settings<Model>();
  s.max_steps = 1;
  CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::IntegrationError, "CV_TOO_MUCH_WORK");
  CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::IntegrationError, "at t = ");
  CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::IntegrationError,
               "(method bdf, jacobian exact, rtol 1e-10, atol 1e-12, max_steps 1)");
  try {
    ipsim::simulate<Model>(p, s);
    fail(__FILE__, __LINE__, "expected an IntegrationError (max_steps 1)");
  } catch (const ipsim::IntegrationError& e) {
    CHECK(e.flag_name() == "CV_TOO_MUCH_WORK");
    CHECK(e.flag() == CV_TOO_MUCH_WORK);
    CHECK(e.time() >= 0.0 && e.time() < s.sample);
    CHECK(std::string(e.what()).find('\n') == std::string::npos);
  }

  // A non-finite input is a recoverable RHS failure; CVODE cannot recover on its first call.
  s = tilted_settings<Model>();
  s.input = ipsim::Input::from_feedback([](double, const Eigen::VectorXd&) { return std::nan(""); });
  CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::IntegrationError, "CV_FIRST_RHSFUNC_ERR");

  // Failing later, after successful steps: CVODE retries with smaller steps, then gives up.
  s.input = ipsim::Input::from_feedback([](double t, const Eigen::VectorXd&) { return t > 0.5 ? std::nan("") : 0.0; });
  CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::IntegrationError, "at t = 0.5");

  s.input = ipsim::Input::from_feedback([n = ipsim::dof_of<Model>()](double t, const Eigen::VectorXd& x) -> double {
    if (x.size() != 2 * n) throw std::logic_error("feedback got a state of the wrong size");
    if (t > 0.1) throw std::domain_error("controller exploded");
    return 0.0;
  });
  CHECK_THROWS(ipsim::simulate<Model>(p, s), std::domain_error, "controller exploded");
}

/// Without damping or input, T + V is conserved. Two motions:
///  - swinging about the hanging position (regular): relative drift < 1e-8 over 20 s at rtol 1e-10;
///  - falling from near upright and swinging over the top (chaotic, passes the unstable
///    equilibrium again and again, which amplifies the integrator's local errors): < 1e-6.
/// In both the drift is CVODE's global error; it shrinks in proportion to rtol.
template <class Model>
void check_energy_conservation(ipsim::Method method) {
  const auto p = paper_params<Model>(false);
  for (const bool hanging : {true, false}) {
    auto s = tilted_settings<Model>();
    s.method = method;
    s.t_end = 20.0;
    if (hanging) {
      for (int i = 1; i < ipsim::dof_of<Model>(); ++i) s.theta(i) = ipsim::kPi - s.theta(i);
    }
    const ipsim::Result r = ipsim::simulate<Model>(p, s);
    CHECK(r.times.size() == 2001);
    const double e0 = ipsim::mechanical_energy<Model>(p, s.theta, s.dtheta);
    double drift = 0.0;
    for (Eigen::Index k = 0; k < r.states.rows(); ++k) {
      const double e = ipsim::mechanical_energy<Model>(p, r.states.row(k).transpose());
      raise_to(drift, std::abs(e - e0) / std::abs(e0));
    }
    const double limit = hanging ? 1e-8 : 1e-6;
    if (!(drift < limit)) {
      fail(__FILE__, __LINE__, std::string("relative energy drift ") + number(drift) + " >= " + number(limit) + " (" +
                                   ipsim::to_string(method) + (hanging ? ", hanging" : ", falling from upright") + ")");
    }
  }
}

/// With damping and a pulse, T + V(t) = T + V(0) + W_in(t) − E_diss(t) at every sample.
template <class Model>
void check_work_energy_balance() {
  const auto p = paper_params<Model>(true);
  auto s = tilted_settings<Model>();
  s.t_end = 10.0;
  s.input = ipsim::Input::pulse(0.4, 0.5, 1.0);
  s.energy_ledger = true;
  const ipsim::Result r = ipsim::simulate<Model>(p, s);
  CHECK(r.input_work.size() == r.times.size() && r.dissipated_energy.size() == r.times.size());
  CHECK(r.input_work.front() == 0.0 && r.dissipated_energy.front() == 0.0);
  CHECK(r.dissipated_energy.back() > 0.0);
  CHECK(std::abs(r.input_work.back()) > 0.0);
  CHECK_NEAR(work_energy_error<Model>(p, r), 0.0, 1e-6);
}

/// Upright, at rest, no input: the (unstable) equilibrium is kept to 1e-12.
template <class Model>
void check_upright_equilibrium() {
  ipsim::Settings<Model> s;
  s.rtol = 1e-10;
  s.atol = 1e-12;
  s.t_end = 10.0;
  const ipsim::Result r = ipsim::simulate<Model>(paper_params<Model>(true), s);
  CHECK(max_abs(r.states) <= 1e-12);
}

/// Input jumps are integrator stops: samples land on them, CVODE restarts there, and the result
/// equals integrating each constant-input piece separately.
template <class Model>
void check_pulse_discontinuity() {
  const auto p = paper_params<Model>(true);

  // Pulse end on the sample grid: a sample exactly at t = 1, one restart (the start at t = 0
  // is not inside the run).
  // Piece 1 (`on`): constant input up to t = 1. Piece 2 (`off`): no input from that state.
  auto s = tilted_settings<Model>();
  s.t_end = 2.0;
  s.input = ipsim::Input::pulse(0.4, 0.0, 1.0);
  const PulseInPieces runs = run_pulse_in_pieces<Model>(p, s);
  const ipsim::Result& pulsed = runs.pulsed;
  CHECK(pulsed.times.size() == 201);
  CHECK(pulsed.times.size() > 100 && pulsed.times[100] == 1.0);
  CHECK(pulsed.stats.restarts == 1);
  CHECK(runs.on.stats.restarts == 0);
  CHECK_NEAR(runs.at_edge, 0.0, 1e-8);
  CHECK_NEAR(runs.at_end, 0.0, 1e-7);

  // Edges off the grid: no extra samples, two restarts, samples still exactly k·sample.
  s.t_end = 1.0;
  s.sample = 0.1;
  s.input = ipsim::Input::pulse(0.4, 0.25, 0.5);
  const ipsim::Result off_grid = ipsim::simulate<Model>(p, s);
  CHECK(off_grid.times.size() == 11);
  CHECK(off_grid.stats.restarts == 2);
  for (std::size_t k = 0; k < off_grid.times.size(); ++k) CHECK(off_grid.times[k] == static_cast<double>(k) * 0.1);

  // A switch a rounding error away from a sample (7·0.1 = 0.7000000000000001) is one stop,
  // taken at the switching time itself.
  s.input = ipsim::Input::step(0.4, 0.7);
  const ipsim::Result snapped = ipsim::simulate<Model>(p, s);
  CHECK(snapped.times.size() == 11);
  CHECK(snapped.times[7] == 0.7);
  CHECK(snapped.stats.restarts == 1);

  // t_end off the grid is still the last sample.
  s.input = ipsim::Input::zero();
  s.t_end = 1.05;
  const ipsim::Result tail = ipsim::simulate<Model>(p, s);
  CHECK(tail.times.size() == 12);
  CHECK(tail.times.back() == 1.05);
}

/// BDF and Adams agree, and the statistics are filled in (BDF with the default exact Jacobian).
template <class Model>
void check_methods_agree() {
  const auto p = paper_params<Model>(true);
  auto s = tilted_settings<Model>();
  s.input = ipsim::Input::sine(0.3, 0.5, 0.1);
  const ipsim::Result bdf = ipsim::simulate<Model>(p, s);
  s.method = ipsim::Method::adams;
  const ipsim::Result adams = ipsim::simulate<Model>(p, s);
  // Falling from near upright is chaotic: the two methods' global errors at rtol 1e-10 are
  // amplified to about 1e-6 on the triple pendulum (1.1e-6 measured with the exact Jacobian).
  CHECK(max_difference(bdf, adams) <= 3e-6);
  CHECK(bdf.stats.steps > 0 && bdf.stats.rhs_evals > bdf.stats.steps && bdf.stats.jacobian_evals > 0);
  CHECK(bdf.stats.linear_solver_rhs_evals == 0 && bdf.stats.restarts == 0);  // exact Jacobian: no quotients
  CHECK(bdf.wall_time > 0.0);
}

/// "cdip (classical, 2 links)": the model's checks as their verdict names them.
template <class Model>
std::string suite_name() {
  return std::string(ipsim::name_of<Model>()) + " (" + ipsim::type_of<Model>() + ", " +
         std::to_string(ipsim::links_of<Model>()) + " links)";
}

/// The physics identities alone (for large models, where every generic check would take minutes):
/// the functions agree with each other, T + V is conserved without damping and balances input
/// work and dissipation with it.
template <class Model>
int run_identity_checks() {
  check_model_consistency<Model>();
  check_energy_conservation<Model>(ipsim::Method::bdf);
  check_work_energy_balance<Model>();
  return finish(suite_name<Model>(), "identities hold");
}

/// Runs every generic check on `Model`.
template <class Model>
int run_model_checks() {
  check_model_consistency<Model>();
  check_parameter_validation<Model>();
  check_settings_validation<Model>();
  check_integration_errors<Model>();
  check_energy_conservation<Model>(ipsim::Method::bdf);
  check_energy_conservation<Model>(ipsim::Method::adams);
  check_work_energy_balance<Model>();
  check_upright_equilibrium<Model>();
  check_pulse_discontinuity<Model>();
  check_methods_agree<Model>();
  return finish(suite_name<Model>(), "all checks passed");
}

}  // namespace ipsim_test
