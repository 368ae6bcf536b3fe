// Checks of the exact Jacobian and of every integration method, generic over the model (run on
// the stand-in and on each generated model loaded at run time, see test_model.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.hpp"
#include "ipsim/ipsim.hpp"
#include "model_checks.hpp"

namespace ipsim_test {

/// Every method with settings that make it accurate to about 1e-9 on the test motions.
template <class Model>
std::vector<ipsim::Settings<Model>> accurate_settings_of_every_method(const ipsim::Settings<Model>& base) {
  std::vector<ipsim::Settings<Model>> all;
  for (const auto method : {ipsim::Method::bdf, ipsim::Method::adams, ipsim::Method::adams_fixed_point,
                            ipsim::Method::erk_dp5, ipsim::Method::erk_fehlberg8,
                            ipsim::Method::rk4}) {
    auto s = base;
    s.method = method;
    s.rtol = 1e-11;
    s.atol = 1e-13;
    s.step = 2.5e-4;
    all.push_back(s);
  }
  return all;
}

/// forward_dynamics_derivatives against central differences of forward_dynamics at random
/// states, inputs and parameters: θ̈ to 1e-12, every derivative to 1e-6 relative (to the largest
/// entry of its matrix, or 1).
template <class Model>
void check_derivatives_against_differences() {
  using Vector = ipsim::VectorOf<Model>;
  const int n = ipsim::dof_of<Model>();
  std::mt19937 random(20240605u + static_cast<unsigned>(n));
  std::uniform_real_distribution<double> angle(-ipsim::kPi, ipsim::kPi), rate(-3.0, 3.0), force(-2.0, 2.0),
      scale(0.5, 2.0);
  double worst = 0.0;
  for (int trial = 0; trial < 20; ++trial) {
    auto p = paper_params<Model>(true);
    for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i) {
      p.m[i] *= scale(random);
      p.l[i] *= scale(random);
      p.delta[i] *= scale(random);
    }
    Vector q(n), qd(n);
    for (int i = 0; i < n; ++i) {
      q(i) = angle(random);
      qd(i) = rate(random);
    }
    const double u = force(random);
    const auto d = Model::template forward_dynamics_derivatives<double>(q, qd, u, p);
    const Vector qdd = Model::template forward_dynamics<double>(q, qd, u, p);
    CHECK(max_difference(d.qdd, qdd) <= 1e-12 * std::max(1.0, max_abs(qdd)));

    Eigen::MatrixXd exact(n, 2 * n + 1), differences(n, 2 * n + 1);
    exact << d.dqdd_dq, d.dqdd_dqd, d.dqdd_du;
    for (int j = 0; j < 2 * n + 1; ++j) {
      Vector q_up = q, q_down = q, qd_up = qd, qd_down = qd;
      double u_up = u, u_down = u;
      const double h = 1e-5;
      if (j < n) {
        q_up(j) += h;
        q_down(j) -= h;
      } else if (j < 2 * n) {
        qd_up(j - n) += h;
        qd_down(j - n) -= h;
      } else {
        u_up += h;
        u_down -= h;
      }
      differences.col(j) = (Model::template forward_dynamics<double>(q_up, qd_up, u_up, p) -
                            Model::template forward_dynamics<double>(q_down, qd_down, u_down, p)) / (2 * h);
    }
    for (const auto& [offset, width] : {std::pair{0, n}, std::pair{n, n}, std::pair{2 * n, 1}}) {
      const auto e = exact.middleCols(offset, width);
      const auto f = differences.middleCols(offset, width);
      raise_to(worst, max_difference(e, f) / std::max(1.0, max_abs(e)));
    }
  }
  if (!(worst <= 1e-6)) fail(__FILE__, __LINE__, "exact derivatives differ from central differences by " + number(worst));
}

/// The whole integrator Jacobian (exact_jacobian: ledger rows, and ∂u/∂x of a feedback input)
/// against central differences of the right-hand side; also for an acceleration-driven base
/// (u = θ̈0: the chain rule through the base force, and the ledger's τ θ̇0).
template <class Model>
void check_system_jacobian() {
  const int n = ipsim::dof_of<Model>();
  const int size = 2 * n + 2;
  const auto p = paper_params<Model>(true);
  const ipsim::Input feedback = ipsim::Input::from_feedback(
      [n](double t, const Eigen::VectorXd& x) { return -3.0 * x(0) - 2.0 * x(n) + 0.5 * std::sin(x(1)) + t; });
  for (const bool acceleration : {false, true}) {
    if (acceleration && !ipsim::provides<Model>(ipsim::Feature::mass_and_bias)) continue;
    ipsim::detail::RhsContext<Model> context;
    context.params = &p;
    context.input = &feedback;
    context.acceleration = acceleration;
    context.energy_ledger = true;
    context.x = Eigen::VectorXd::Zero(2 * n);
    Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(size, -0.8, 1.3);
    const double t = 0.3;
    Eigen::MatrixXd exact(size, size), differences(size, size);
    ipsim::detail::exact_jacobian<Model>(context, t, x.data(), exact);
    Eigen::VectorXd up(size), down(size);
    for (int j = 0; j < size; ++j) {
      const double h = 1e-6;
      Eigen::VectorXd x_up = x, x_down = x;
      x_up(j) += h;
      x_down(j) -= h;
      CHECK(ipsim::detail::evaluate_rhs<Model>(context, t, x_up.data(), up.data(), size) == 0);
      CHECK(ipsim::detail::evaluate_rhs<Model>(context, t, x_down.data(), down.data(), size) == 0);
      differences.col(j) = (up - down) / (2 * h);
    }
    const double relative = max_difference(exact, differences) / std::max(1.0, max_abs(exact));
    if (!(relative <= 1e-6)) {
      fail(__FILE__, __LINE__, std::string(acceleration ? "acceleration-driven: " : "") +
                                   "system Jacobian differs from differences by " + number(relative));
    }
  }
}

/// bdf and adams with the exact Jacobian follow the same trajectory as with CVODE's difference
/// quotients (1e-8); bdf spends fewer RHS evaluations with it.
template <class Model>
void check_exact_jacobian_pays_off() {
  const auto p = paper_params<Model>(true);
  for (const auto method : {ipsim::Method::bdf, ipsim::Method::adams}) {
    // Swinging about the hanging position (regular motion: differences in the step sequence are
    // not amplified as they are near the upright equilibrium).
    auto s = tilted_settings<Model>();
    for (int i = 1; i < ipsim::dof_of<Model>(); ++i) s.theta(i) = ipsim::kPi - s.theta(i);
    s.rtol = 1e-12;
    s.atol = 1e-14;
    s.t_end = 3.0;
    s.method = method;
    s.input = ipsim::Input::pulse(0.4, 0.25, 1.0);
    s.jacobian = ipsim::Jacobian::exact;
    const ipsim::Result exact = ipsim::simulate<Model>(p, s);
    s.jacobian = ipsim::Jacobian::dq;
    const ipsim::Result dq = ipsim::simulate<Model>(p, s);
    const double difference = max_difference(exact, dq);
    std::printf("%s %s: RHS evaluations with the exact Jacobian %ld, with difference quotients %ld + %ld; "
                "trajectories differ by %.2g\n",
                ipsim::name_of<Model>(), ipsim::to_string(method), exact.stats.rhs_evals, dq.stats.rhs_evals,
                dq.stats.linear_solver_rhs_evals, difference);
    if (!(difference <= 1e-8)) {
      fail(__FILE__, __LINE__, std::string(ipsim::to_string(method)) + ": exact and dq Jacobians differ by " + number(difference));
    }
    CHECK(exact.stats.jacobian_evals > 0 && exact.stats.linear_solver_rhs_evals == 0);
    CHECK(dq.stats.jacobian_evals > 0 && dq.stats.linear_solver_rhs_evals > 0);
    // BDF re-evaluates its Jacobian often and saves the 2·kDof quotient evaluations each time. Adams
    // needs few Jacobians on these non-stiff motions; its step sequence changes with the Jacobian,
    // so only "no quotient evaluations and no more than 10% more work" is required of it.
    const long with_exact = exact.stats.total_rhs_evals(), with_dq = dq.stats.total_rhs_evals();
    const bool fewer = method == ipsim::Method::bdf ? with_exact < with_dq
                                                    : static_cast<double>(with_exact) <= 1.1 * static_cast<double>(with_dq);
    if (!fewer) {
      fail(__FILE__, __LINE__, std::string(ipsim::to_string(method)) + ": exact Jacobian used " +
                                   std::to_string(with_exact) + " RHS evaluations, dq " + std::to_string(with_dq));
    }
  }
}

/// Every method, at tight settings, reproduces bdf's trajectory through a pulse whose edges are
/// off the sample grid, lands exactly on the edges (one sample is taken on the falling edge) and
/// reports its work.
template <class Model>
void check_every_method_agrees() {
  const auto p = paper_params<Model>(true);
  auto base = tilted_settings<Model>();
  base.t_end = 2.0;
  base.sample = 0.1;
  base.input = ipsim::Input::pulse(0.4, 0.25, 0.5);  // edges at 0.25 and 0.75
  auto reference_settings = base;
  reference_settings.rtol = 1e-12;
  reference_settings.atol = 1e-14;
  const ipsim::Result reference = ipsim::simulate<Model>(p, reference_settings);
  for (const auto& s : accurate_settings_of_every_method<Model>(base)) {
    const std::string name = ipsim::to_string(s.method);
    const ipsim::Result r = ipsim::simulate<Model>(p, s);
    const double difference = max_difference(r, reference);
    if (!(difference <= 1e-7)) fail(__FILE__, __LINE__, name + " differs from bdf by " + number(difference));
    CHECK(r.times.size() == 21 && r.times[10] == 1.0);
    CHECK(r.stats.restarts == 2 && r.stats.steps > 0 && r.stats.rhs_evals >= r.stats.steps);
    if (s.method == ipsim::Method::rk4) CHECK(r.stats.rhs_evals == 4 * r.stats.steps);
    if (!ipsim::uses_jacobian(s.method)) CHECK(r.stats.jacobian_evals == 0 && r.stats.linear_solver_rhs_evals == 0);
    if (s.method == ipsim::Method::adams_fixed_point) CHECK(r.stats.nonlinear_iterations > 0);
  }
}

/// Stopping exactly at an input jump, for every method: the pulsed run equals a run with the
/// input on up to the edge followed by a run with it off from the state reached there.
template <class Model>
void check_every_method_stops_at_the_edge() {
  const auto p = paper_params<Model>(true);
  auto base = tilted_settings<Model>();
  base.t_end = 1.3;
  base.sample = 0.1;
  base.input = ipsim::Input::pulse(0.4, 0.0, 0.65);  // falling edge between two samples
  for (auto s : accurate_settings_of_every_method<Model>(base)) {
    const std::string name = ipsim::to_string(s.method);
    s.sample = 0.65;  // samples at 0, 0.65 (the edge) and 1.3
    const PulseInPieces runs = run_pulse_in_pieces<Model>(p, s);
    const ipsim::Result& pulsed = runs.pulsed;
    CHECK(pulsed.times.size() == 3 && pulsed.times[1] == 0.65 && pulsed.stats.restarts == 1);
    const double at_edge = runs.at_edge, at_end = runs.at_end;
    // RK4 takes the very same steps in both. The adaptive methods restart at the edge in both, but
    // their step sequences differ by round-off in t, so the two runs differ by their global error
    // (up to 2e-8 measured); stepping across the edge would cost about 1e-3.
    const double limit = s.method == ipsim::Method::rk4 ? 1e-12 : 1e-7;
    if (!(at_edge <= limit && at_end <= limit)) {
      fail(__FILE__, __LINE__, name + ": pulsed run differs from the two pieces by " + number(at_edge) + " at the edge, " +
                                   number(at_end) + " at the end");
    }
  }
}

/// Method-specific errors: rk4 without a step, ARKODE and RK4 running out of steps, and a
/// throwing feedback callback under every method.
template <class Model>
void check_method_errors() {
  const auto p = paper_params<Model>(true);
  auto s = tilted_settings<Model>();
  s.method = ipsim::Method::rk4;
  CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::InvalidInput,
               "invalid setting step = 0: method rk4 needs a fixed step: must be finite and > 0");
  s.step = -1e-3;
  CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::InvalidInput, "invalid setting step = -0.001");
  s.step = 1e-4;
  s.max_steps = 50;  // 100 steps to the first sample
  CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::IntegrationError,
               "RK4 failed with RK4_TOO_MUCH_WORK at t = 0 s (method rk4, step 0.0001, max_steps 50)");

  s = tilted_settings<Model>();
  s.max_steps = 1;
  for (const auto method : {ipsim::Method::erk_dp5, ipsim::Method::erk_fehlberg8}) {
    s.method = method;
    try {
      ipsim::simulate<Model>(p, s);
      fail(__FILE__, __LINE__, "expected an IntegrationError");
    } catch (const ipsim::IntegrationError& e) {
      CHECK(e.flag_name() == "ARK_TOO_MUCH_WORK" && e.flag() == ARK_TOO_MUCH_WORK);
      const std::string expected = std::string("ARKODE failed with ARK_TOO_MUCH_WORK at t = ");
      CHECK(std::string(e.what()).rfind(expected, 0) == 0);
      CHECK(std::string(e.what()).find(std::string("(method ") + ipsim::to_string(method) +
                                       ", rtol 1e-10, atol 1e-12, max_steps 1)") != std::string::npos);
    }
  }
  s.method = ipsim::Method::adams_fixed_point;
  CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::IntegrationError,
               "CVODE failed with CV_TOO_MUCH_WORK at t = ");

  for (auto with_method : accurate_settings_of_every_method<Model>(tilted_settings<Model>())) {
    with_method.input = ipsim::Input::from_feedback([](double t, const Eigen::VectorXd&) -> double {
      if (t > 0.1) throw std::domain_error("controller exploded");
      return 0.0;
    });
    CHECK_THROWS(ipsim::simulate<Model>(p, with_method), std::domain_error, "controller exploded");
    with_method.input = ipsim::Input::from_feedback([](double t, const Eigen::VectorXd&) {
      return t > 0.1 ? std::nan("") : 0.0;
    });
    CHECK_THROWS(ipsim::simulate<Model>(p, with_method), ipsim::IntegrationError, "at t = ");
  }
}

/// A stabilising state feedback with a stiff gain: the exact Jacobian includes ∂u/∂x, so bdf with
/// it matches bdf with difference quotients.
template <class Model>
void check_feedback_jacobian() {
  const auto p = paper_params<Model>(true);
  auto s = tilted_settings<Model>();
  s.t_end = 2.0;
  s.input = ipsim::Input::from_feedback(
      [n = ipsim::dof_of<Model>()](double, const Eigen::VectorXd& x) { return -50.0 * x(n); });
  const ipsim::Result exact = ipsim::simulate<Model>(p, s);
  s.jacobian = ipsim::Jacobian::dq;
  const ipsim::Result dq = ipsim::simulate<Model>(p, s);
  const double difference = max_difference(exact, dq);
  if (!(difference <= 1e-7)) fail(__FILE__, __LINE__, "feedback: exact and dq differ by " + number(difference));
}

/// Runs every method check on `Model`.
template <class Model>
void run_method_checks() {
  check_derivatives_against_differences<Model>();
  check_system_jacobian<Model>();
  check_exact_jacobian_pays_off<Model>();
  check_every_method_agrees<Model>();
  check_every_method_stops_at_the_edge<Model>();
  check_method_errors<Model>();
  check_feedback_jacobian<Model>();
}

}  // namespace ipsim_test
