// The exact Jacobian ∂f/∂x of the first-order system of rhs.hpp, from the model's
// forward_dynamics_derivatives, for CVODE's Newton iteration (CVodeSetJacFn).
//
//   x = [θ; θ̇; W_in; E_diss]   (the last two only with the energy ledger)
//   J = [[0,        I,          0],
//        [∂θ̈/∂θ,    ∂θ̈/∂θ̇,      0],
//        [0,        u e₀ᵀ,      0],     W_in' = u θ̇0
//        [0,        2 ∂D/∂θ̇,    0]]     E_diss' = 2 D(θ̇)
//
// A feedback input u(t, x) adds ∂θ̈/∂u (∂u/∂x)ᵀ to the θ̈ rows (and θ̇0 (∂u/∂x)ᵀ to the W_in row);
// ∂u/∂x is not known analytically, so it is taken by forward differences of the callback
// (2·kDof extra callback calls per Jacobian, no extra model evaluations). An acceleration-driven
// base (Settings::acceleration) is the force-driven model at the force τ(x) that gives θ̈0 = u:
// the chain rule through τ (exact_jacobian).
#pragma once

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <type_traits>
#include <utility>

#include <Eigen/Core>
#include <sundials/sundials_matrix.h>
#include <sundials/sundials_nvector.h>
#include <sunmatrix/sunmatrix_dense.h>

#include "ipsim/ldlt.hpp"
#include "ipsim/model.hpp"
#include "ipsim/rhs.hpp"

namespace ipsim {

namespace detail {
template <class Model, class = void>
struct HasDerivatives : std::false_type {};
template <class Model>
struct HasDerivatives<Model, std::void_t<decltype(Model::template forward_dynamics_derivatives<double>(
                                 std::declval<const VectorOf<Model>&>(), std::declval<const VectorOf<Model>&>(),
                                 0.0, std::declval<const ParamsOf<Model>&>()))>> : std::true_type {};
}  // namespace detail

/// True when the model tag provides forward_dynamics_derivatives (every header the generator
/// writes does); without it only difference-quotient Jacobians are available.
template <class Model>
inline constexpr bool has_derivatives = detail::HasDerivatives<Model>::value;

namespace detail {

/// ∂u/∂x of a feedback input at (t, x) by forward differences, written to `gradient` (2·kDof);
/// zero for every other input (their u does not depend on the state).
template <class Model>
void input_gradient(RhsContext<Model>& context, double t, const double* x, double u,
                    Eigen::Ref<Eigen::VectorXd> gradient) {
  gradient.setZero();
  if (context.input->kind != Input::Kind::feedback) return;
  const int size = 2 * dof_of<Model>();
  const double root_epsilon = std::sqrt(std::numeric_limits<double>::epsilon());
  Eigen::VectorXd& shifted = context.x;  // preallocated (2·kDof): no allocation per Jacobian
  shifted = Eigen::Map<const Eigen::VectorXd>(x, size);
  for (int j = 0; j < size; ++j) {
    const double h = root_epsilon * std::max(1.0, std::abs(x[j]));
    shifted(j) = x[j] + h;
    gradient(j) = (context.input->feedback(t, shifted) - u) / ((x[j] + h) - x[j]);
    shifted(j) = x[j];
  }
}

/// Rows of the Jacobian for the energy ledger states (input work and dissipated energy).
template <class Model, class Gradient, class Jacobian>
void ledger_jacobian(const RhsContext<Model>& context, double u, const VectorOf<Model>& qd, const Gradient& gradient,
                     Jacobian& jacobian) {
  const int n = dof_of<Model>();
  // W_in' = u θ̇0.
  jacobian.block(2 * n, 0, 1, 2 * n) = qd(0) * gradient.transpose();
  jacobian(2 * n, n) += u;
  // E_diss' = 2 D(θ̇), D a quadratic form: D(θ̇ + h eᵢ) − D(θ̇ − h eᵢ) = 2h ∂D/∂θ̇ᵢ exactly.
  for (int i = 0; i < n; ++i) {
    const double h = 1.0 + std::abs(qd(i));
    VectorOf<Model> up = qd, down = qd;
    up(i) += h;
    down(i) -= h;
    jacobian(2 * n + 1, n + i) = (Model::template dissipation<double>(up, *context.params) -
                                  Model::template dissipation<double>(down, *context.params)) / h;
  }
}

/// Writes ∂f/∂x at (t, x) into `jacobian` (size × size, size = 2·kDof or 2·kDof + 2 with the
/// ledger). Throws what a feedback callback throws.
template <class Model>
void exact_jacobian(RhsContext<Model>& context, double t, const double* x, Eigen::Ref<Eigen::MatrixXd> jacobian) {
  static_assert(has_derivatives<Model>, "the model has no forward_dynamics_derivatives");
  const int n = dof_of<Model>();
  const VectorOf<Model> q = Eigen::Map<const VectorOf<Model>>(x, n);
  const VectorOf<Model> qd = Eigen::Map<const VectorOf<Model>>(x + n, n);
  if constexpr (is_runtime<Model>) {
    if (context.input_matrix != nullptr) {  // a fixed chain: m open-loop inputs through B
      context.all_inputs[0] = input_at(context, t, x);
      more_inputs_at(context, t);
      if (context.input_sign != 1.0) {
        for (double& value : context.all_inputs) value *= context.input_sign;
      }
      const auto d = Model::template forward_dynamics_derivatives_inputs<double>(q, qd, context.all_inputs.data(),
                                                                                 *context.params);
      jacobian.setZero();
      jacobian.block(0, n, n, n).setIdentity();
      jacobian.block(n, 0, n, n) = d.dqdd_dq;
      jacobian.block(n, n, n, n) = d.dqdd_dqd;
      if (context.coulomb_index >= 0) {  // M⁻¹ ∂Q/∂θ̇ (as for a cart; the ∂M⁻¹/∂θ Q term left to Newton)
        DofMatrixOf<Model> slope(n, n);
        coulomb_force<Model>(context, qd, &slope);
        jacobian.block(n, n, n, n) += solve_spd(Model::template mass_matrix<double>(q, *context.params), slope);
      }
      if constexpr (has_energy<Model>) {
        if (context.energy_ledger) {
          // W_in' = uᵀ Bᵀ θ̇: ∂/∂θ̇ = (B u)ᵀ; E_diss' = 2 D(θ̇) as ledger_jacobian has it.
          ledger_jacobian<Model>(context, 0.0, qd, StateVectorOf<Model>::Zero(2 * n).eval(), jacobian);
          for (int i = 0; i < n; ++i) {
            double force = 0.0;
            for (int k = 0; k < context.inputs; ++k) {
              force += context.input_matrix[i * context.inputs + k] * context.all_inputs[static_cast<std::size_t>(k)];
            }
            jacobian(2 * n, n + i) = force;
          }
        }
      }
      return;
    }
  }
  const double command = input_at(context, t, x);
  const double u = drive_input(context, command, x) + context.segment_pulse;
  double force = u;  // the base's force or torque: u, or what an acceleration-driven base needs
  if (context.acceleration) {
    const VectorOf<Model> friction =
        context.coulomb_index >= 0 ? coulomb_force<Model>(context, qd) : VectorOf<Model>::Zero(n).eval();
    acceleration_dynamics<Model>(q, qd, u, friction, *context.params, force);
  }
  const auto d = Model::template forward_dynamics_derivatives<double>(q, qd, force, *context.params);

  jacobian.setZero();
  jacobian.block(0, n, n, n).setIdentity();
  DofStateMatrixOf<Model> rows(n, 2 * n);  // ∂θ̈/∂x of the force-driven model at `force`
  rows << d.dqdd_dq, d.dqdd_dqd;
  if constexpr (has_mass_matrix<Model>) {
    // Coulomb friction: M⁻¹ ∂Q/∂θ̇ (the smaller ∂M⁻¹/∂θ Q term and the ledger rows are left to
    // the Newton iteration: an approximate Jacobian costs iterations, not accuracy).
    if (context.coulomb_index >= 0 && context.has_mass) {
      DofMatrixOf<Model> slope(n, n);
      coulomb_force<Model>(context, qd, &slope);
      rows.rightCols(n) += solve_spd(Model::template mass_matrix<double>(q, *context.params), slope);
    }
  }
  StateVectorOf<Model> gradient(2 * n);
  input_gradient(context, t, x, command, gradient);
  if (context.lag_index >= 0) {
    // A lagged drive (Settings::lag): θ̈ depends on the state u_a, u_a' = (u − u_a) / lag on u(x).
    const int a = context.lag_index;
    jacobian.block(n, 0, n, 2 * n) = rows;
    jacobian.block(n, a, n, 1) = d.dqdd_du;
    jacobian.block(a, 0, 1, 2 * n) = gradient.transpose() / context.lag;
    jacobian(a, a) = -1.0 / context.lag;
    if constexpr (has_energy<Model>) {
      if (context.energy_ledger) {
        ledger_jacobian<Model>(context, u, qd, StateVectorOf<Model>::Zero(2 * n).eval(), jacobian);
        jacobian(2 * n, a) = qd(0);
      }
    }
    return;
  }
  if (context.acceleration) {
    // θ̈ = f(x, τ(x)) with τ chosen so that θ̈0 = u(x): τ_x = (∂u/∂x − ∂f0/∂x) / (∂f0/∂τ), and
    // ∂θ̈/∂x = ∂f/∂x + ∂f/∂τ τ_xᵀ (row 0 becomes ∂u/∂x). The ledger's W_in' = τ θ̇0.
    const StateVectorOf<Model> force_gradient = (gradient - rows.row(0).transpose()) / d.dqdd_du(0);
    jacobian.block(n, 0, n, 2 * n) = rows + d.dqdd_du * force_gradient.transpose();
    if constexpr (has_energy<Model>) {
      if (context.energy_ledger) ledger_jacobian<Model>(context, force, qd, force_gradient, jacobian);
    }
    return;
  }
  if (context.input->kind == Input::Kind::feedback) rows.noalias() += d.dqdd_du * gradient.transpose();
  jacobian.block(n, 0, n, 2 * n) = rows;
  if constexpr (has_energy<Model>) {
    if (context.energy_ledger) {
      ledger_jacobian<Model>(context, u, qd, gradient, jacobian);
    }
  }
}

/// CVODE Jacobian callback (CVLsJacFn) for a dense SUNMatrix: 0 on success, -1 (fatal) when the
/// input callback threw; the exception is kept in the context.
template <class Model>
int jacobian_callback(realtype t, N_Vector y, N_Vector /*fy*/, SUNMatrix matrix, void* user_data,
                      N_Vector /*tmp1*/, N_Vector /*tmp2*/, N_Vector /*tmp3*/) {
  auto& context = *static_cast<RhsContext<Model>*>(user_data);
  try {
    const auto size = static_cast<Eigen::Index>(SUNDenseMatrix_Rows(matrix));
    // SUNDIALS' dense matrices are column-major with leading dimension = rows, like Eigen's.
    Eigen::Map<Eigen::MatrixXd> jacobian(SUNDenseMatrix_Data(matrix), size, size);
    exact_jacobian<Model>(context, t, N_VGetArrayPointer(y), jacobian);
    return 0;
  } catch (...) {
    context.error = std::current_exception();
    return -1;
  }
}

}  // namespace detail
}  // namespace ipsim
