// A linear state feedback u = −K (x − x_eq), optionally saturated and sampled, as an ipsim Input,
// and the closed-loop poles of the model linearised at x_eq (the header's linearize).
//
// x = [θ; θ̇] (2·kDof): θ0 the cart position [m] or arm angle [rad], θ1..θn the absolute link
// angles [rad], then the rates; u the force [N] or torque [N m] on the base (or its acceleration).
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ipsim/eigenvalues.hpp"
#include "ipsim/ldlt.hpp"
#include "ipsim/errors.hpp"
#include "ipsim/input.hpp"
#include "ipsim/ldlt.hpp"
#include "ipsim/linkage.hpp"
#include "ipsim/model.hpp"
#include "ipgen_loop.h"

namespace ipsim {

/// u = clamp(−K (x − x_eq), −saturation, saturation), continuous (period = 0) or computed every
/// `period` seconds and held (sampled data).
struct LinearFeedback {
  Eigen::VectorXd gain;         ///< K (2·kDof), in the order of x = [θ0..θn, θ̇0..θ̇n]
  Eigen::VectorXd equilibrium;  ///< x_eq (2·kDof)
  double saturation = std::numeric_limits<double>::infinity();  ///< |u| ≤ saturation, > 0
  double period = 0.0;                                           ///< sampling period [s]; 0: continuous
  bool given = false;  ///< true: K was given (a scene's `gain`), false: ipgen's LQR gain (for the summary)

  /// The (saturated) input in state x (2·kDof entries). Throws InvalidInput when K or x_eq does
  /// not have x's size (a gain of another model).
  double operator()(const Eigen::VectorXd& x) const {
    if (gain.size() != x.size() || equilibrium.size() != x.size()) {
      throw InvalidInput({"invalid setting controller.gain: has " + std::to_string(gain.size()) +
                          " entries and controller.equilibrium " + std::to_string(equilibrium.size()) +
                          ", the state x has " + std::to_string(x.size()) + " (2·kDof)"});
    }
    const double u = -gain.dot(x - equilibrium);
    return ipgen_loop_saturate(u, saturation);
  }

  /// The ipsim input that applies this feedback: Input::from_feedback, or Input::sampled when
  /// period > 0. Throws InvalidInput for the problems() of K's own size (K and x_eq of different
  /// sizes, an entry not finite, saturation ≤ 0, a bad period); the first call checks x's size.
  Input input() const {
    if (gain.size() != equilibrium.size()) {
      throw InvalidInput({"invalid setting controller.gain: has " + std::to_string(gain.size()) +
                          " entries, controller.equilibrium " + std::to_string(equilibrium.size()) +
                          ": both need 2·kDof"});
    }
    const std::vector<std::string> found = problems(static_cast<int>(gain.size()));
    if (!found.empty()) throw InvalidInput(found);
    LinearFeedback copy = *this;
    auto law = [copy](double /*t*/, const Eigen::VectorXd& x) { return copy(x); };
    return period > 0.0 ? Input::sampled(period, std::move(law)) : Input::from_feedback(std::move(law));
  }

  /// Problems, one line each (empty when valid): sizes against 2·kDof, finiteness, saturation > 0,
  /// period ≥ 0. closed_loop_poles and input() throw them as InvalidInput.
  std::vector<std::string> problems(int state_size) const;
};

namespace detail {
template <class Model, class = void>
struct HasLinearize : std::false_type {};
template <class Model>
struct HasLinearize<Model, std::void_t<decltype(Model::template linearize<double>(
                               std::declval<const VectorOf<Model>&>(), std::declval<const VectorOf<Model>&>(), 0.0,
                               std::declval<const ParamsOf<Model>&>()))>> : std::true_type {};
}  // namespace detail

/// True when the model header defines linearize (it needs forward_dynamics_derivatives).
template <class Model>
inline constexpr bool has_linearize = detail::HasLinearize<Model>::value;

/// Eigenvalues of A − B K, the model linearised at the controller's equilibrium with u = 0 (the
/// saturation and the sampling are not part of this continuous linear model), sorted by real
/// part, then imaginary part [1/s]. `acceleration`: u is the base's acceleration
/// (Settings::acceleration); A and B are then those of the links' rows with θ̈0 = u, from the
/// header's linearisation at the base force τ that holds θ̈0 = 0 by the chain rule through τ:
/// A ← A − B A_θ̈0 / B_θ̈0, B ← B / B_θ̈0 (A_θ̈0, B_θ̈0 the θ̈0 row).
template <class Model>
Eigen::VectorXcd closed_loop_poles(const ParamsOf<Model>& params, const LinearFeedback& controller,
                                   bool acceleration = false) {
  static_assert(has_linearize<Model>, "closed_loop_poles needs the model's linearize (forward_dynamics_derivatives)");
  const int n = dof_of<Model>();
  const std::vector<std::string> found = controller.problems(2 * n);
  if (!found.empty()) throw InvalidInput(found);
  const VectorOf<Model> q = controller.equilibrium.head(n);
  const VectorOf<Model> qd = controller.equilibrium.segment(n, n);
  double force = 0.0;
  if (acceleration) {
    if constexpr (has_mass_and_bias<Model>) {  // τ = b_0 + M_0L θ̈_L at θ̈0 = 0 (0 at rest upright)
      if (provides<Model>(Feature::mass_and_bias)) {
        const int links = n - 1;
        const auto mass = Model::template mass_matrix<double>(q, params);
        const auto bias = Model::template bias<double>(q, qd, params);
        const LinksMatrixOf<Model> block = mass.bottomRightCorner(links, links);
        const LinksVectorOf<Model> rhs = -bias.tail(links);
        const LinksVectorOf<Model> qdd = detail::solve_spd(block, rhs);
        force = bias(0) + mass.row(0).segment(1, links).dot(qdd);
      }
    }
  }
  auto lin = Model::template linearize<double>(q, qd, force, params);
  if (acceleration) {
    const double b0 = lin.B(n);
    const StateRowOf<Model> row = lin.A.row(n);
    lin.A -= lin.B * row / b0;
    lin.B /= b0;
  }
  const Eigen::MatrixXd closed = lin.A - lin.B * controller.gain.transpose();
  Eigen::VectorXcd poles = detail::general_eigenvalues(closed);  // LAPACK: no Eigen solver to compile
  std::sort(poles.data(), poles.data() + poles.size(), [](const std::complex<double>& a, const std::complex<double>& b) {
    return a.real() != b.real() ? a.real() < b.real() : a.imag() < b.imag();
  });
  return poles;
}

}  // namespace ipsim

#if IPSIM_DEFINITIONS
namespace ipsim {

IPSIM_DECL std::vector<std::string> LinearFeedback::problems(int state_size) const {
  std::vector<std::string> found;
  for (const auto& [name, vector] : {std::pair<const char*, const Eigen::VectorXd*>{"gain", &gain},
                                     std::pair<const char*, const Eigen::VectorXd*>{"equilibrium", &equilibrium}}) {
    if (vector->size() != state_size) {
      found.push_back(std::string("invalid setting controller.") + name + ": has " + std::to_string(vector->size()) +
                      " entries, the model's state has 2·kDof = " + std::to_string(state_size));
    } else if (!vector->allFinite()) {
      found.push_back(std::string("invalid setting controller.") + name + ": must be finite");
    }
  }
  if (!(saturation > 0.0)) {
    found.push_back("invalid setting controller.saturation = " + detail::format_number(saturation) + ": must be > 0");
  }
  if (!(std::isfinite(period) && period >= 0.0)) {
    found.push_back("invalid setting controller.period = " + detail::format_number(period) +
                    ": must be finite and > 0 (or 0: continuous)");
  }
  return found;
}

}  // namespace ipsim
#endif  // IPSIM_DEFINITIONS
