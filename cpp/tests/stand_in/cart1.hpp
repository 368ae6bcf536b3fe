// Hand-written stand-in for a generated ipgen model header: a single inverted pendulum on a cart.
// Same shape as the generator's output so ipsim and its tests can be developed before the
// generator exists. Derived by hand from the project's docs/model.md (classical, n = 1):
//   M(θ) θ̈ + bias(θ, θ̇) = (F, 0)ᵀ,  θ0 = cart position [m], θ1 = link angle from upright [rad].
#pragma once

#include <array>
#include <cmath>

#include <Eigen/Dense>

namespace ipgen::cart1 {

/// Number of pendulum links.
inline constexpr int kLinks = 1;
/// Degrees of freedom: cart position plus one angle per link.
inline constexpr int kDof = kLinks + 1;

/// Physical parameters; index 0 is the cart, 1..kLinks the links.
template <typename Scalar = double>
struct Params {
  std::array<Scalar, kDof> m;      ///< masses [kg]
  std::array<Scalar, kDof> l;      ///< lengths [m]; l[0] is unused for a cart
  std::array<Scalar, kDof> delta;  ///< viscous friction: δ0 [kg/s], δi [kg m²/s]
  Scalar g = Scalar(9.81);         ///< gravitational acceleration [m/s²]
};

/// Generalised coordinates or velocities (dim kDof).
template <typename Scalar>
using Vector = Eigen::Matrix<Scalar, kDof, 1>;
/// kDof × kDof matrix.
template <typename Scalar>
using Matrix = Eigen::Matrix<Scalar, kDof, kDof>;

/// Mass matrix M(θ) (symmetric positive definite).
template <typename Scalar>
Matrix<Scalar> mass_matrix(const Vector<Scalar>& q, const Params<Scalar>& p) {
  using std::cos;
  const Scalar coupling = p.m[1] * p.l[1] / Scalar(2) * cos(q(1));
  Matrix<Scalar> M;
  M(0, 0) = p.m[0] + p.m[1];
  M(0, 1) = coupling;
  M(1, 0) = coupling;
  M(1, 1) = p.m[1] * p.l[1] * p.l[1] / Scalar(3);
  return M;
}

/// Gravity vector P(θ).
template <typename Scalar>
Vector<Scalar> gravity(const Vector<Scalar>& q, const Params<Scalar>& p) {
  using std::sin;
  Vector<Scalar> P;
  P(0) = Scalar(0);
  P(1) = -p.m[1] * p.g * p.l[1] / Scalar(2) * sin(q(1));
  return P;
}

/// One (non-unique) factorisation N(θ, θ̇) of the velocity terms, N θ̇ = bias − P.
template <typename Scalar>
Matrix<Scalar> n_matrix(const Vector<Scalar>& q, const Vector<Scalar>& qd, const Params<Scalar>& p) {
  using std::sin;
  Matrix<Scalar> N;
  N(0, 0) = p.delta[0];
  N(0, 1) = -p.m[1] * p.l[1] / Scalar(2) * qd(1) * sin(q(1));
  N(1, 0) = Scalar(0);
  N(1, 1) = p.delta[1];
  return N;
}

/// Bias terms b(θ, θ̇) = N θ̇ + P, so that M θ̈ + b = (u, 0)ᵀ.
template <typename Scalar>
Vector<Scalar> bias(const Vector<Scalar>& q, const Vector<Scalar>& qd, const Params<Scalar>& p) {
  using std::sin;
  Vector<Scalar> b;
  b(0) = p.delta[0] * qd(0) - p.m[1] * p.l[1] / Scalar(2) * sin(q(1)) * qd(1) * qd(1);
  b(1) = p.delta[1] * qd(1) - p.m[1] * p.g * p.l[1] / Scalar(2) * sin(q(1));
  return b;
}

/// Accelerations θ̈ for input u (force on the cart [N]).
template <typename Scalar>
Vector<Scalar> forward_dynamics(const Vector<Scalar>& q, const Vector<Scalar>& qd, Scalar u,
                                const Params<Scalar>& p) {
  Vector<Scalar> rhs = -bias(q, qd, p);
  rhs(0) += u;
  return mass_matrix(q, p).ldlt().solve(rhs);
}

/// θ̈ and its partial derivatives, for exact integrator Jacobians.
template <typename Scalar>
struct Derivatives {
  Vector<Scalar> qdd;       ///< θ̈ = forward_dynamics(q, qd, u, p)
  Matrix<Scalar> dqdd_dq;   ///< ∂θ̈/∂θ (column i: derivative with respect to θ_i)
  Matrix<Scalar> dqdd_dqd;  ///< ∂θ̈/∂θ̇
  Vector<Scalar> dqdd_du;   ///< ∂θ̈/∂u
};

/// θ̈ and its derivatives by implicit differentiation of M θ̈ + b = (u, 0)ᵀ:
/// ∂θ̈/∂x = −M⁻¹ (∂M/∂x θ̈ + ∂b/∂x), ∂θ̈/∂u = M⁻¹ e₀ (one factorisation of M, no inverse).
template <typename Scalar>
Derivatives<Scalar> forward_dynamics_derivatives(const Vector<Scalar>& q, const Vector<Scalar>& qd, Scalar u,
                                                 const Params<Scalar>& p) {
  using std::cos;
  using std::sin;
  const Scalar a = p.m[1] * p.l[1] / Scalar(2);
  const Scalar s = sin(q(1)), c = cos(q(1));
  const auto factor = mass_matrix(q, p).ldlt();
  Vector<Scalar> rhs = -bias(q, qd, p);
  rhs(0) += u;
  Derivatives<Scalar> d;
  d.qdd = factor.solve(rhs);
  // Only θ1 enters M and b: ∂M/∂θ1 = [[0, −a s], [−a s, 0]], ∂b/∂θ1 = (−a c θ̇1², −a g c).
  Matrix<Scalar> forcing_q = Matrix<Scalar>::Zero();
  forcing_q(0, 1) = -a * s * d.qdd(1) - a * c * qd(1) * qd(1);
  forcing_q(1, 1) = -a * s * d.qdd(0) - a * p.g * c;
  d.dqdd_dq = -factor.solve(forcing_q);
  Matrix<Scalar> forcing_qd;  // ∂b/∂θ̇
  forcing_qd << p.delta[0], Scalar(-2) * a * s * qd(1), Scalar(0), p.delta[1];
  d.dqdd_dqd = -factor.solve(forcing_qd);
  d.dqdd_du = factor.solve(Vector<Scalar>::UnitX());
  return d;
}

/// Kinetic energy T = ½ θ̇ᵀ M θ̇ [J].
template <typename Scalar>
Scalar kinetic_energy(const Vector<Scalar>& q, const Vector<Scalar>& qd, const Params<Scalar>& p) {
  return Scalar(0.5) * qd.dot(mass_matrix(q, p) * qd);
}

/// Potential energy V [J], zero at the height of the pivot.
template <typename Scalar>
Scalar potential_energy(const Vector<Scalar>& q, const Params<Scalar>& p) {
  using std::cos;
  return p.m[1] * p.g * p.l[1] / Scalar(2) * cos(q(1));
}

/// Rayleigh dissipation function D [W/2]; the power lost to friction is 2D.
template <typename Scalar>
Scalar dissipation(const Vector<Scalar>& qd, const Params<Scalar>& p) {
  return Scalar(0.5) * p.delta[0] * qd(0) * qd(0) + Scalar(0.5) * p.delta[1] * qd(1) * qd(1);
}

/// Tag type bundling the model for generic code (ipsim::simulate<Model>, tests).
struct Model {
  static constexpr int kLinks = cart1::kLinks;
  static constexpr int kDof = cart1::kDof;
  static constexpr const char* kName = "cart1";
  static constexpr const char* kType = "classical";
  static constexpr const char* kInertia = "";  ///< only rotary models have an inertia variant
  template <typename Scalar = double>
  using Params = cart1::Params<Scalar>;
  template <typename Scalar>
  using Vector = cart1::Vector<Scalar>;
  template <typename Scalar>
  using Matrix = cart1::Matrix<Scalar>;

  template <typename Scalar>
  static Matrix<Scalar> mass_matrix(const Vector<Scalar>& q, const Params<Scalar>& p) {
    return cart1::mass_matrix(q, p);
  }
  template <typename Scalar>
  static Vector<Scalar> bias(const Vector<Scalar>& q, const Vector<Scalar>& qd, const Params<Scalar>& p) {
    return cart1::bias(q, qd, p);
  }
  template <typename Scalar>
  static Vector<Scalar> gravity(const Vector<Scalar>& q, const Params<Scalar>& p) {
    return cart1::gravity(q, p);
  }
  template <typename Scalar>
  static Matrix<Scalar> n_matrix(const Vector<Scalar>& q, const Vector<Scalar>& qd,
                                        const Params<Scalar>& p) {
    return cart1::n_matrix(q, qd, p);
  }
  template <typename Scalar>
  static Vector<Scalar> forward_dynamics(const Vector<Scalar>& q, const Vector<Scalar>& qd, Scalar u,
                                         const Params<Scalar>& p) {
    return cart1::forward_dynamics(q, qd, u, p);
  }
  template <typename Scalar>
  using Derivatives = cart1::Derivatives<Scalar>;
  template <typename Scalar>
  static Derivatives<Scalar> forward_dynamics_derivatives(const Vector<Scalar>& q, const Vector<Scalar>& qd,
                                                          Scalar u, const Params<Scalar>& p) {
    return cart1::forward_dynamics_derivatives(q, qd, u, p);
  }
  template <typename Scalar>
  static Scalar kinetic_energy(const Vector<Scalar>& q, const Vector<Scalar>& qd, const Params<Scalar>& p) {
    return cart1::kinetic_energy(q, qd, p);
  }
  template <typename Scalar>
  static Scalar potential_energy(const Vector<Scalar>& q, const Params<Scalar>& p) {
    return cart1::potential_energy(q, p);
  }
  template <typename Scalar>
  static Scalar dissipation(const Vector<Scalar>& qd, const Params<Scalar>& p) {
    return cart1::dissipation(qd, p);
  }
};

}  // namespace ipgen::cart1
