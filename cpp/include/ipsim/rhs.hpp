// The first-order system ẋ = f(t, x) that every integrator advances: x = [θ; θ̇] (2·kDof), plus
// [W_in, E_diss] when the energy ledger is on, with θ̈ from the model's forward dynamics (or, for
// an acceleration-driven base, from the links' rows with θ̈0 = u: acceleration_dynamics).
#pragma once

#include <cmath>
#include <exception>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <sundials/sundials_nvector.h>

#include "ipsim/input.hpp"
#include "ipsim/ldlt.hpp"
#include "ipsim/model.hpp"
#include "ipgen_loop.h"

namespace ipsim::detail {

/// The latest right-hand side evaluation whose derivative was not finite (for the failure
/// diagnosis of guards.hpp).
struct NonFiniteEvaluation {
  bool seen = false;
  double t = 0.0;     ///< [s]
  double u = 0.0;     ///< the input there
  Eigen::VectorXd x;  ///< the state there, [θ; θ̇] (2·kDof)
};

/// What the right-hand side (and the Jacobian) need; SUNDIALS passes it back as user data.
template <class Model>
struct RhsContext {
  const ParamsOf<Model>* params = nullptr;
  const Input* input = nullptr;
  bool energy_ledger = false;
  /// u on the current segment when the input is piecewise constant. Evaluating u(t) instead would
  /// be wrong at the segment's closing stop: the integrator's last evaluation there sees the new value.
  double segment_input = 0.0;
  Eigen::VectorXd x;         ///< preallocated copy of [θ; θ̇] for feedback inputs (dim 2·kDof)
  std::exception_ptr error;  ///< exception thrown by a feedback callback, rethrown after the step
  NonFiniteEvaluation nonfinite;  ///< set by evaluate_rhs when a derivative is not finite
  /// Coulomb friction (Settings::coulomb, coulomb_speed); `coulomb_index` ≥ 0: the state that
  /// integrates its dissipated power.
  VectorOf<Model> coulomb = zero_vector<Model>();
  double coulomb_speed = 1.0;
  int coulomb_index = -1;
  /// Settings::acceleration: u is the base's acceleration θ̈0, not its force.
  bool acceleration = false;
  /// Settings::pulses: the disturbance force on the base on the current segment [N or N m].
  double segment_pulse = 0.0;
  /// Settings::lag > 0: `lag_index` is the state u_a the model sees, u_a' = (u − u_a) / lag.
  double lag = 0.0;
  int lag_index = -1;
  /// Whether the model has a mass matrix (Coulomb friction acts through it).
  bool has_mass = provides<Model>(Feature::mass_matrix);
  /// A fixed chain loaded at run time (RuntimeModel::fixed_pivot): its m inputs u = [u, more…]
  /// through the model's B (input_matrix, dof × m row-major); the ledger's power is uᵀ Bᵀ θ̇.
  /// Null for every other model (its one input drives the base: power u θ̇0).
  const double* input_matrix = nullptr;
  int inputs = 1;
  const std::vector<Input>* more_inputs = nullptr;  ///< Settings::more_inputs (m − 1)
  std::vector<double> segment_more;  ///< their values on the current segment (piecewise-constant ones)
  std::vector<double> all_inputs;    ///< preallocated u (m) for the model's call
  /// A fixed chain: −1 when its inputs are counterclockwise torques (Settings::input_sign).
  double input_sign = 1.0;
  /// The first coordinate whose Coulomb friction acts on a relative rate θ̇i − θ̇(i−1): 2 (a cart
  /// or an arm: θ̇0, θ̇1 absolute) or 1 (a fixed chain: θ̇1 absolute).
  int coulomb_relative_from = 2;
  bool coulomb_atan = false;   ///< Settings::coulomb_atan: c atan(k w), k = coulomb_gain
  double coulomb_gain = 100.0;
};

/// u_2..u_m of a fixed chain at time t into context.all_inputs[1..m) (all_inputs[0] is the caller's).
template <class Model>
void more_inputs_at(RhsContext<Model>& context, double t) {
  for (int k = 1; k < context.inputs; ++k) {
    const Input& more = (*context.more_inputs)[static_cast<std::size_t>(k - 1)];
    context.all_inputs[static_cast<std::size_t>(k)] =
        more.piecewise_constant() ? context.segment_more[static_cast<std::size_t>(k - 1)] : more.value(t, context.x);
  }
}

/// The inputs' power uᵀ Bᵀ θ̇ of a fixed chain (context.all_inputs, B = context.input_matrix).
template <class Model>
double inputs_power(const RhsContext<Model>& context, const double* qd, int n) {
  double power = 0.0;
  for (int i = 0; i < n; ++i) {
    double force = 0.0;  // (B u)_i: the generalised force on coordinate i
    for (int k = 0; k < context.inputs; ++k) {
      force += context.input_matrix[i * context.inputs + k] * context.all_inputs[static_cast<std::size_t>(k)];
    }
    power += force * qd[i];
  }
  return power;
}

/// The input the model sees: u itself, or the lagged drive's state u_a (Settings::lag).
template <class Model>
double drive_input(const RhsContext<Model>& context, double u, const double* state) {
  return context.lag_index >= 0 ? state[context.lag_index] : u;
}

/// The Coulomb friction's generalised force Q (Settings::coulomb) at rates qd; with `slope`, also
/// ∂Q/∂θ̇ (kDof × kDof, symmetric negative semidefinite).
template <class Model>
VectorOf<Model> coulomb_force(const RhsContext<Model>& context, const VectorOf<Model>& qd,
                              DofMatrixOf<Model>* slope = nullptr) {
  const int n = dof_of<Model>();
  VectorOf<Model> force = VectorOf<Model>::Zero(n);
  if (slope) slope->setZero();
  for (int i = 0; i < n; ++i) {
    const double c = context.coulomb(i);
    if (c == 0.0) continue;
    const bool relative = i >= context.coulomb_relative_from;
    const double w = relative ? qd(i) - qd(i - 1) : qd(i);  // the joint's rate, as for delta[i]
    const double t = context.coulomb_atan ? std::atan(context.coulomb_gain * w) : std::tanh(w / context.coulomb_speed);
    force(i) -= c * t;
    if (relative) force(i - 1) += c * t;
    if (slope) {
      const double kw = context.coulomb_gain * w;
      const double s = context.coulomb_atan ? c * context.coulomb_gain / (1.0 + kw * kw)
                                            : c * (1.0 - t * t) / context.coulomb_speed;
      (*slope)(i, i) -= s;
      if (relative) {
        (*slope)(i - 1, i - 1) -= s;
        (*slope)(i, i - 1) += s;
        (*slope)(i - 1, i) += s;
      }
    }
  }
  return force;
}

/// θ̈ of a base that follows the acceleration θ̈0 = a, from M and residual = b − applied (the
/// generalised force `applied`, Coulomb friction, on the coordinates): the link rows of
/// M θ̈ + b = e0 τ + applied give θ̈_L = M_LL⁻¹ (applied_L − b_L − M_L0 a); `force` receives
/// τ = M_0· θ̈ + b_0 − applied_0, the force [N] or torque [N m] the base's drive applies.
/// Matrices of any sizes, fixed or run-time.
template <class Mass, class Vector>
Vector links_following(const Mass& mass, const Vector& residual, double a, double& force) {
  const Eigen::Index links = mass.rows() - 1;
  constexpr int L = Mass::RowsAtCompileTime == Eigen::Dynamic ? Eigen::Dynamic : Mass::RowsAtCompileTime - 1;
  constexpr int max = Mass::MaxRowsAtCompileTime - 1;
  Vector qdd(mass.rows());
  qdd(0) = a;
  const Eigen::Matrix<double, L, L, Eigen::ColMajor, max, max> links_mass = mass.bottomRightCorner(links, links);
  const Eigen::Matrix<double, L, 1, Eigen::ColMajor, max, 1> rhs =
      -(mass.block(1, 0, links, 1) * a + residual.tail(links));
  qdd.tail(links) = solve_spd(links_mass, rhs);
  force = mass.row(0).dot(qdd) + residual(0);
  return qdd;
}

/// links_following with the sizes fixed at N when the run-time size is N, for N up to
/// kCoreLdltSize + 1: the same Eigen expressions, and so the same bits, as a simulator compiled
/// for the model (a sum's order depends on whether its size is known at compile time).
template <int N = 2, class Mass, class Vector>
Vector links_following_as_compiled(const Mass& mass, const Vector& residual, double a, double& force) {
  if constexpr (N > kCoreLdltSize + 1) {
    return links_following(mass, residual, a, force);
  } else {
    if (mass.rows() != N) return links_following_as_compiled<N + 1>(mass, residual, a, force);
    return Vector(links_following(Eigen::Matrix<double, N, N>(mass), Eigen::Matrix<double, N, 1>(residual), a, force));
  }
}

/// links_following on the model's M and b − applied at (q, qd): θ̈ of an acceleration-driven base.
template <class Model>
VectorOf<Model> acceleration_dynamics(const VectorOf<Model>& q, const VectorOf<Model>& qd, double a,
                                      const VectorOf<Model>& applied, const ParamsOf<Model>& params, double& force) {
  if constexpr (has_mass_and_bias<Model>) {
    const auto mass = Model::template mass_matrix<double>(q, params);
    const VectorOf<Model> residual = Model::template bias<double>(q, qd, params) - applied;
    if constexpr (is_runtime<Model>) {
      return links_following_as_compiled(mass, residual, a, force);
    } else {
      return links_following(mass, residual, a, force);
    }
  } else {  // simulate() refuses Settings::acceleration for such a model before any run
    (void)q, (void)qd, (void)a, (void)applied, (void)params;
    force = 0.0;
    return VectorOf<Model>::Constant(dof_of<Model>(), std::numeric_limits<double>::quiet_NaN());
  }
}

/// u at time t [s] in state `state` = [θ; θ̇, …] (the first 2·kDof entries are read, and only by a
/// feedback input). Throws whatever a feedback callback throws.
template <class Model>
double input_at(RhsContext<Model>& context, double t, const double* state) {
  if (context.input->piecewise_constant()) return context.segment_input;
  if (context.input->kind == Input::Kind::feedback) {
    context.x = Eigen::Map<const Eigen::VectorXd>(state, 2 * dof_of<Model>());  // no allocation: same size
  }
  return context.input->value(t, context.x);
}

template <class Model, class = void>
struct HasDynamicsInto : std::false_type {};
template <class Model>
struct HasDynamicsInto<Model, std::void_t<decltype(Model::forward_dynamics_into(
                                  nullptr, nullptr, 0.0, std::declval<const ParamsOf<Model>&>(), nullptr, 0))>>
    : std::true_type {};

/// 0, or 1 (and the context told) when a derivative in out[0..size) is not finite.
template <class Model>
int check_finite(RhsContext<Model>& context, double t, double u, const double* in, const double* out, long size) {
  for (long i = 0; i < size; ++i) {
    if (!std::isfinite(out[i])) {
      context.nonfinite.seen = true;
      context.nonfinite.t = t;
      context.nonfinite.u = u;
      context.nonfinite.x = Eigen::Map<const Eigen::VectorXd>(in, 2 * dof_of<Model>());
      return 1;
    }
  }
  return 0;
}

/// Writes f(t, x) to `out` (same length as x: 2·kDof, or 2·kDof + 2 with the ledger). Returns 0 on
/// success and 1 when a derivative is not finite. Throws what a feedback callback throws.
template <class Model>
int evaluate_rhs(RhsContext<Model>& context, double t, const double* in, double* out, long size) {
  const int n = dof_of<Model>();
  if constexpr (HasDynamicsInto<Model>::value) {
    // A model loaded at run time, without friction or an acceleration-driven base: the same
    // numbers, computed on the state's own arrays (a small model's RHS is mostly copies otherwise).
    if constexpr (is_runtime<Model>) {
      if (context.input_matrix != nullptr) {  // a fixed chain: m inputs through B (no lag or pulses)
        const double u = input_at(context, t, in);
        context.all_inputs[0] = u;
        more_inputs_at(context, t);
        if (context.input_sign != 1.0) {  // the rig's counterclockwise torques -> ipgen's clockwise ones
          for (double& value : context.all_inputs) value *= context.input_sign;
        }
        for (int i = 0; i < n; ++i) out[i] = in[n + i];
        Model::forward_dynamics_inputs_into(in, in + n, context.all_inputs.data(), *context.params, out + n, n);
        double coulomb_power = 0.0;
        if (context.coulomb_index >= 0) {  // Coulomb friction on the joints' rates, through M
          const VectorOf<Model> q = Eigen::Map<const VectorOf<Model>>(in, n);
          const VectorOf<Model> qd = Eigen::Map<const VectorOf<Model>>(in + n, n);
          const VectorOf<Model> friction = coulomb_force<Model>(context, qd);
          Eigen::Map<VectorOf<Model>> acceleration_out(out + n, n);
          acceleration_out += solve_spd(Model::template mass_matrix<double>(q, *context.params), friction);
          coulomb_power = -friction.dot(qd);
          out[context.coulomb_index] = coulomb_power;
        }
        if (context.energy_ledger) {
          out[2 * n] = inputs_power(context, in + n, n);
          const VectorOf<Model> qd = Eigen::Map<const VectorOf<Model>>(in + n, n);
          out[2 * n + 1] = 2.0 * Model::template dissipation<double>(qd, *context.params) + coulomb_power;
        }
        return check_finite(context, t, u, in, out, size);
      }
    }
    if (!context.acceleration && !(context.has_mass && context.coulomb_index >= 0)) {
      const double command = input_at(context, t, in);
      const double u = drive_input(context, command, in) + context.segment_pulse;
      if (context.lag_index >= 0) out[context.lag_index] = ipgen_loop_lag_rate(command, in[context.lag_index], context.lag);
      for (int i = 0; i < n; ++i) out[i] = in[n + i];
      Model::forward_dynamics_into(in, in + n, u, *context.params, out + n, n);
      if constexpr (has_energy<Model>) {
        if (context.energy_ledger) {
          out[2 * n] = u * in[n];
          const VectorOf<Model> qd = Eigen::Map<const VectorOf<Model>>(in + n, n);
          out[2 * n + 1] = 2.0 * Model::template dissipation<double>(qd, *context.params) + 0.0;
        }
      }
      return check_finite(context, t, u, in, out, size);
    }
  }
  const VectorOf<Model> q = Eigen::Map<const VectorOf<Model>>(in, n);
  const VectorOf<Model> qd = Eigen::Map<const VectorOf<Model>>(in + n, n);
  const double command = input_at(context, t, in);
  const double u = drive_input(context, command, in) + context.segment_pulse;
  if (context.lag_index >= 0) out[context.lag_index] = ipgen_loop_lag_rate(command, in[context.lag_index], context.lag);
  double coulomb_power = 0.0;
  double force = u;  // the base's force or torque (u itself unless the base is acceleration-driven)
  VectorOf<Model> qdd;
  // Coulomb friction: a generalised force, applied through M (as before, not with a model without M).
  const bool friction_on = context.has_mass && context.coulomb_index >= 0;
  const VectorOf<Model> friction = friction_on ? coulomb_force<Model>(context, qd) : VectorOf<Model>::Zero(n).eval();
  if (context.acceleration) {
    qdd = acceleration_dynamics<Model>(q, qd, u, friction, *context.params, force);
  } else {
    qdd = Model::template forward_dynamics<double>(q, qd, u, *context.params);
    if constexpr (has_mass_matrix<Model>) {
      if (friction_on) qdd += solve_spd(Model::template mass_matrix<double>(q, *context.params), friction);
    }
  }
  if (friction_on) {
    coulomb_power = -friction.dot(qd);
    out[context.coulomb_index] = coulomb_power;
  }
  Eigen::Map<VectorOf<Model>> velocity_out(out, n), acceleration_out(out + n, n);
  velocity_out = qd;
  acceleration_out = qdd;
  if constexpr (has_energy<Model>) {
    if (context.energy_ledger) {
      out[2 * n] = force * qd(0);  // the base's power (τ θ̇0 for an acceleration-driven base)
      out[2 * n + 1] = 2.0 * Model::template dissipation<double>(qd, *context.params) + coulomb_power;
    }
  }
  return check_finite(context, t, u, in, out, size);
}

/// SUNDIALS right-hand side (CVRhsFn and ARKRhsFn have this signature): 0 on success, 1
/// (recoverable: CVODE retries with a smaller step) when a derivative is not finite, -1 (fatal)
/// when the input callback threw; the exception is kept in the context.
template <class Model>
int rhs(realtype t, N_Vector y, N_Vector ydot, void* user_data) {
  auto& context = *static_cast<RhsContext<Model>*>(user_data);
  try {
    return evaluate_rhs<Model>(context, t, N_VGetArrayPointer(y), N_VGetArrayPointer(ydot),
                               static_cast<long>(N_VGetLength(ydot)));
  } catch (...) {
    context.error = std::current_exception();
    return -1;
  }
}

}  // namespace ipsim::detail
