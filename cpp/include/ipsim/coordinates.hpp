// Coordinates: the rig's own convention for the link angles, and its map to ipgen's.
//
// ipgen's (canonical) state is x = [θ0, θ1..θn, θ̇0..θ̇n]: θi the absolute angle of link i from
// the upright, clockwise positive (docs/model.md). A rig may measure instead, with s = +1
// (positive = clockwise) or −1 (counterclockwise) and z = 0 (zero = upright) or π (hanging):
//
//   angles = absolute:  αi = s (θi − z)                                (i = 1..n)
//   angles = relative:  α1 = s (θ1 − z),  αi = s (θi − θ(i−1))        (i = 2..n)
//
// and the rates likewise (without z); θ0 and θ̇0 are unchanged (a fixed chain has none: base = 0).
// The map is affine, x_user = P x + c,
// the same as the Python side's ipgen.control.coordinates. ipsim integrates in ipgen's coordinates;
// a scene in the rig's is mapped at the edges: its initial state and controller in (Scene), the
// CSV's rows and the summary out (CsvSink::set_coordinates).
#pragma once

#include "ipsim/linkage.hpp"

#include <string>

#include <Eigen/Core>
#include <Eigen/LU>

namespace ipsim {

/// A convention for the link angles; the default is ipgen's own (the map is then the identity).
struct Coordinates {
  bool relative = false;          ///< angles = relative: link i from link i − 1 (i ≥ 2)
  bool hanging = false;           ///< zero = hanging: link 1 (absolute: every link) at 0 when hanging
  bool counterclockwise = false;  ///< positive = counterclockwise
  /// The coordinates before link 1: 1 (a cart's or an arm's base θ0, unchanged by the map) or 0
  /// (a fixed chain: x = [θ1..θn, θ̇1..θ̇n], link 1 at entry 0).
  int base = 1;

  bool canonical() const noexcept { return !relative && !hanging && !counterclockwise; }

  /// "angles relative, zero hanging, positive counterclockwise".
  std::string describe() const;

  /// P of x_user = P x + c for 2·dof states.
  Eigen::MatrixXd matrix(int dof) const;

  /// c of x_user = P x + c for 2·dof states: −s z on link 1 (relative) or on every link (absolute).
  Eigen::VectorXd offset(int dof) const;

  /// The rig's state of ipgen's state x (2·dof entries).
  Eigen::VectorXd to_user(const Eigen::VectorXd& x) const;

  /// ipgen's state of the rig's state x_user (2·dof entries): θ1 = s α1 + z, then θi = s αi + z
  /// (absolute) or θ(i−1) + s αi (relative); the rates alike without z.
  Eigen::VectorXd to_canonical(const Eigen::VectorXd& x_user) const;

  /// The gain on ipgen's state of a gain on the rig's: u = −K_user (x_user − x_eq,user)
  /// = −(K_user P) (x − x_eq), so K = K_user P (a row, 2·dof entries).
  Eigen::VectorXd gain_to_canonical(const Eigen::VectorXd& gain_user) const;

  /// The inverse of gain_to_canonical: K_user = K P⁻¹.
  Eigen::VectorXd gain_to_user(const Eigen::VectorXd& gain) const;

 private:
  static constexpr double kPi = 3.141592653589793238462643383279502884;
};

}  // namespace ipsim

#if IPSIM_DEFINITIONS
namespace ipsim {

IPSIM_DECL std::string Coordinates::describe() const {
  return std::string("angles ") + (relative ? "relative" : "absolute") + ", zero " + (hanging ? "hanging" : "upright") +
         ", positive " + (counterclockwise ? "counterclockwise" : "clockwise");
}

IPSIM_DECL Eigen::MatrixXd Coordinates::matrix(int dof) const {
  const double s = counterclockwise ? -1.0 : 1.0;
  Eigen::MatrixXd angle = Eigen::MatrixXd::Identity(dof, dof);
  for (int i = base; i < dof; ++i) {
    angle(i, i) = s;
    if (relative && i >= base + 1) angle(i, i - 1) = -s;
  }
  Eigen::MatrixXd p = Eigen::MatrixXd::Zero(2 * dof, 2 * dof);
  p.topLeftCorner(dof, dof) = angle;
  p.bottomRightCorner(dof, dof) = angle;
  return p;
}

IPSIM_DECL Eigen::VectorXd Coordinates::offset(int dof) const {
  Eigen::VectorXd c = Eigen::VectorXd::Zero(2 * dof);
  if (!hanging) return c;
  const double s = counterclockwise ? -1.0 : 1.0;
  const int last = relative ? (dof < base + 1 ? dof : base + 1) : dof;
  for (int i = base; i < last; ++i) c(i) = -s * kPi;
  return c;
}

IPSIM_DECL Eigen::VectorXd Coordinates::to_user(const Eigen::VectorXd& x) const {
  if (canonical()) return x;
  const int dof = static_cast<int>(x.size() / 2);
  return matrix(dof) * x + offset(dof);
}

IPSIM_DECL Eigen::VectorXd Coordinates::to_canonical(const Eigen::VectorXd& x_user) const {
  if (canonical()) return x_user;
  const Eigen::Index dof = x_user.size() / 2;
  const double s = counterclockwise ? -1.0 : 1.0;
  const double z = hanging ? kPi : 0.0;
  Eigen::VectorXd x = x_user;
  for (Eigen::Index block = 0; block < 2; ++block) {
    const Eigen::Index at = block * dof;
    const double zero = block == 0 ? z : 0.0;
    for (Eigen::Index i = base; i < dof; ++i) {
      const double from = relative && i >= base + 1 ? x(at + i - 1) : zero;
      x(at + i) = from + s * x_user(at + i);
    }
  }
  return x;
}

IPSIM_DECL Eigen::VectorXd Coordinates::gain_to_canonical(const Eigen::VectorXd& gain_user) const {
  if (canonical()) return gain_user;
  const int dof = static_cast<int>(gain_user.size() / 2);
  return (gain_user.transpose() * matrix(dof)).transpose();
}

IPSIM_DECL Eigen::VectorXd Coordinates::gain_to_user(const Eigen::VectorXd& gain) const {
  if (canonical()) return gain;
  const int dof = static_cast<int>(gain.size() / 2);
  return matrix(dof).transpose().partialPivLu().solve(gain);
}

}  // namespace ipsim
#endif  // IPSIM_DEFINITIONS
