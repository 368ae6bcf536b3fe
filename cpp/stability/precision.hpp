// The precision scenarios of docs/stability.md (mass and length ratios, float): forward_dynamics
// in double and float against the same header instantiated with long double. Kept apart from
// scenarios.hpp because instantiating a large header three more times is what makes a driver slow
// to compile: the quick drivers of the many-link models leave it out.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>

#include "ipsim/ipsim.hpp"
#include "scenarios.hpp"

namespace stability {

/// Model::Params<To> from parameters of another scalar type.
template <class To, class Model, class Source>
typename Model::template Params<To> cast_params(const Source& p) {
  typename Model::template Params<To> out{};
  for (std::size_t i = 0; i < static_cast<std::size_t>(Model::kDof); ++i) {
    out.m[i] = static_cast<To>(p.m[i]);
    out.l[i] = static_cast<To>(p.l[i]);
    out.delta[i] = static_cast<To>(p.delta[i]);
  }
  out.g = static_cast<To>(p.g);
  return out;
}

/// What forward_dynamics loses at one parameter set, over random states.
struct Precision {
  double double_error = 0.0;  ///< max ‖θ̈_double − θ̈_long‖ / ‖θ̈_long‖
  double float_error = 0.0;   ///< the same for float, inputs and parameters rounded to float for both
  double residual = 0.0;      ///< max ‖M θ̈_double + bias − B u‖ / (‖|M| |θ̈|‖ + ‖bias‖ + |u|), in long double
  double cond = 0.0;          ///< max cond(M) (long double eigenvalues)
  double scaled_cond = 0.0;   ///< max cond(S M S), S = diag(M)^-1/2
};

template <class Model>
Precision measure_precision(const ipsim::ParamsOf<Model>& p, int states, unsigned seed) {
  constexpr int n = Model::kDof;
  using Long = long double;
  using VL = typename Model::template Vector<Long>;
  using ML = typename Model::template Matrix<Long>;
  const auto pl = cast_params<Long, Model>(p);
  const auto pf = cast_params<float, Model>(p);
  const auto pfl = cast_params<Long, Model>(pf);  // the float parameters, exactly
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> angle(-ipsim::kPi, ipsim::kPi), rate(-3.0, 3.0), force(-1.0, 1.0);
  auto eigen_ratio = [](const ML& m) {
    const Eigen::SelfAdjointEigenSolver<ML> solver(m, Eigen::EigenvaluesOnly);
    const Long low = solver.eigenvalues().minCoeff();
    if (!(low > 0)) return std::numeric_limits<double>::infinity();
    return static_cast<double>(solver.eigenvalues().maxCoeff() / low);
  };
  // u scaled to the system's weight, so that it matters but does not dominate.
  double weight = 0.0;
  for (int i = 0; i < n; ++i) weight += p.m[static_cast<std::size_t>(i)];
  Precision out;
  for (int k = 0; k < states; ++k) {
    ipsim::VectorOf<Model> q, qd;
    for (int i = 0; i < n; ++i) {
      q(i) = angle(random);
      qd(i) = rate(random);
    }
    // The first states have the links aligned (upright, hanging), where a heavy link on light
    // ones makes M nearly singular; random angles almost never come close.
    if (k < 4) {
      for (int i = 1; i < n; ++i) q(i) = k % 2 == 0 ? 0.0 : ipsim::kPi;
    }
    const double u = force(random) * weight * p.g;
    const VL ql = q.template cast<Long>(), qdl = qd.template cast<Long>();
    const VL exact = Model::template forward_dynamics<Long>(ql, qdl, static_cast<Long>(u), pl);
    const VL in_double = Model::template forward_dynamics<double>(q, qd, u, p).template cast<Long>();
    // float: the arithmetic's loss alone, against long double at the same (float) inputs.
    const auto qf = q.template cast<float>(), qdf = qd.template cast<float>();
    const auto uf = static_cast<float>(u);
    const VL in_float = Model::template forward_dynamics<float>(qf, qdf, uf, pf).template cast<Long>();
    const VL exact_float = Model::template forward_dynamics<Long>(qf.template cast<Long>(), qdf.template cast<Long>(),
                                                                  static_cast<Long>(uf), pfl);
    out.double_error = std::max(out.double_error, static_cast<double>((in_double - exact).norm() / exact.norm()));
    out.float_error =
        std::max(out.float_error, static_cast<double>((in_float - exact_float).norm() / exact_float.norm()));
    const ML M = Model::template mass_matrix<Long>(ql, pl);
    const VL b = Model::template bias<Long>(ql, qdl, pl);
    VL generalized_force = VL::Zero();
    generalized_force(0) = static_cast<Long>(u);
    const VL r = M * in_double + b - generalized_force;
    const Long scale = (M.cwiseAbs() * in_double.cwiseAbs()).norm() + b.norm() + std::abs(static_cast<Long>(u));
    out.residual = std::max(out.residual, static_cast<double>(r.norm() / scale));
    out.cond = std::max(out.cond, eigen_ratio(M));
    const VL s = M.diagonal().cwiseSqrt().cwiseInverse();
    out.scaled_cond = std::max(out.scaled_cond, eigen_ratio(ML(s.asDiagonal() * M * s.asDiagonal())));
  }
  return out;
}

/// A named parameter set of the ratio scenarios.
template <class Model>
struct ParameterCase {
  std::string name;
  ipsim::ParamsOf<Model> params;
  bool in_range;  ///< masses within 1e-3..1e3 × the base's, lengths within 1e-3..100 m
};

/// The parameter sets: link masses 1e-3 and 1e3 times the base's (uniform, alternating, a heavy
/// tip on light links), lengths 1e-3 m and 100 m (uniform, alternating), random sets across both
/// ranges, and a heavy tip beyond the range (1e12, 1e14 times every other mass, the base's too),
/// where M becomes untrustworthy once there are two links or more.
template <class Model>
std::vector<ParameterCase<Model>> parameter_cases() {
  constexpr int n = Model::kDof;
  const auto base = paper_params<Model>(true);
  const double m0 = base.m[0];
  auto with = [&](auto&& change) {
    auto p = base;
    for (int i = 1; i < n; ++i) change(p, static_cast<std::size_t>(i));
    return p;
  };
  std::vector<ParameterCase<Model>> cases{
      {"nominal", base, true},
      {"link masses 1e-3 x base", with([&](auto& p, std::size_t i) { p.m[i] = 1e-3 * m0; }), true},
      {"link masses 1e3 x base", with([&](auto& p, std::size_t i) { p.m[i] = 1e3 * m0; }), true},
      {"link masses alternate 1e-3/1e3 x base",
       with([&](auto& p, std::size_t i) { p.m[i] = (i % 2 ? 1e-3 : 1e3) * m0; }), true},
      {"heavy tip: last link 1e3, others 1e-3 x base",
       with([&](auto& p, std::size_t i) { p.m[i] = (i + 1 == n ? 1e3 : 1e-3) * m0; }), true},
      {"lengths 1e-3 m", with([&](auto& p, std::size_t i) { p.l[i] = 1e-3; }), true},
      {"lengths 100 m", with([&](auto& p, std::size_t i) { p.l[i] = 100.0; }), true},
      {"lengths alternate 1e-3/100 m", with([&](auto& p, std::size_t i) { p.l[i] = i % 2 ? 1e-3 : 100.0; }), true},
  };
  std::mt19937 random(7u);
  std::uniform_real_distribution<double> exponent(-1.0, 1.0);
  for (int k = 0; k < 3; ++k) {
    auto p = base;
    for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i) {
      if (i > 0) p.m[i] = m0 * std::pow(10.0, 3.0 * exponent(random));               // 1e-3..1e3 x base
      if (i > 0 || !ipsim::is_classical<Model>()) {
        p.l[i] = std::pow(10.0, -0.5 + 2.5 * exponent(random));  // 1e-3..100 m
      }
    }
    cases.push_back({"random masses 1e-3..1e3 x base, lengths 1e-3..100 m #" + std::to_string(k + 1), p, true});
  }
  for (const double ratio : {1e12, 1e14}) {
    auto p = with([&](auto& q, std::size_t i) { q.m[i] = (i + 1 == n ? ratio : 1.0) * 1e-3 * m0; });
    p.m[0] = 1e-3 * m0;
    cases.push_back({"beyond the range: last link " + g3(ratio) + " x every other mass (base too)", p, false});
  }
  return cases;
}

/// forward_dynamics against long double for every parameter case: the double error must stay
/// below cond(M)·ε (the classical bound) and the backward residual at rounding level; the
/// simulator must warn exactly where cond(S M S) makes θ̈ untrustworthy, naming the mass ratio:
/// beyond the range with two links or more, never within it (a single link on its base cannot be
/// made ill-conditioned by positive masses: cond(S M S) stays below about 30). Two float rows
/// follow: the largest float error over the in-range cases (measured), and over those with scaled
/// cond(M) < 1e3, held to 1e-3.
template <class Model>
std::vector<Row> ratios_and_float(const Options& options) {
  std::vector<Row> rows;
  const int states = options.quick ? 40 : 400;
  unsigned seed = 11u;
  double float_all = 0.0, float_mild = 0.0, double_all = 0.0;
  for (const auto& c : parameter_cases<Model>()) {
    const Precision m = measure_precision<Model>(c.params, states, seed++);
    if (c.in_range) {
      float_all = std::max(float_all, m.float_error);
      double_all = std::max(double_all, m.double_error);
      if (m.scaled_cond < 1e3) float_mild = std::max(float_mild, m.float_error);
    }
    Row row{"mass/length ratios", model_label<Model>(), c.name, "rel. error of qdd (double vs long double)"};
    row.value = m.double_error;
    row.bound = std::max(10.0 * m.cond * kEps, 1e-14);
    row.note = "cond(M) " + g3(m.cond) + ", scaled " + g3(m.scaled_cond) + "; error/(scaled cond eps) " +
               g3(m.double_error / (m.scaled_cond * kEps)) + "; residual " + g3(m.residual) + "; float error " +
               g3(m.float_error);
    row.outcome = "ok";
    apply_bound(row);
    if (row.passed && !(m.residual <= 64.0 * Model::kDof * kEps)) {
      row.passed = false;
      row.outcome = "FAILED: backward residual " + g3(m.residual) + " above 64 n eps";
    }
    // The warning: on (and naming the mass ratio) beyond the range, off within it.
    auto settings = tight_settings<Model>(0.01, 0.01);
    const std::string warning = ipsim::conditioning_warning<Model>(c.params, settings.theta);
    const bool expected = !c.in_range && Model::kLinks >= 2;
    if (row.passed && expected == warning.empty()) {
      row.passed = false;
      row.outcome = expected ? "FAILED: no warning" : "FAILED: warned: " + warning;
    }
    if (row.passed && expected) {
      const Run r = run<Model>(c.params, settings);  // the simulator reports it in Result::warnings
      const bool reported = r.ok && !r.result.warnings.empty() &&
                            r.result.warnings.front().find("caused by the mass ratio") != std::string::npos;
      row.outcome = reported ? "warned (mass ratio)" : "FAILED: simulate() did not warn";
      row.passed = reported;
    }
    rows.push_back(row);
  }
  Row all{"float", model_label<Model>(), "all in-range parameter cases", "rel. error of qdd (float vs long double)"};
  all.value = float_all;
  all.outcome = "measured";
  all.note = "double: " + g3(double_all);
  Row mild{"float", model_label<Model>(), "in-range cases with scaled cond(M) < 1e3",
           "rel. error of qdd (float vs long double)"};
  mild.value = float_mild;
  mild.bound = 1e-3;  // the claim of docs/stability.md: float keeps about 3 digits there
  mild.outcome = "ok";
  apply_bound(mild);
  rows.push_back(all);
  rows.push_back(mild);
  return rows;
}

}  // namespace stability
