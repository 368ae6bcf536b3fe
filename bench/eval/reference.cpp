// Pinocchio model of the n-link pendulum, see reference.hpp.
//
// World frame: z up, gravity -g z. Classical: the cart slides along x (prismatic joint PX) and
// every link turns about y (revolute RY), so that a link's axis is (sin a, 0, cos a) for its
// absolute angle a: the same clockwise-positive angle as ipgen's, but relative to the previous
// link. Rotary: the arm turns about z (RZ) and points along its frame's y axis; the links turn
// about that axis (RY) at the arm's tip. A link is a thin rod along its frame's z axis: centre
// of gravity at l/2, inertia m l^2/12 about x and y, none about z.
#include "reference.hpp"

#include <memory>

#include "pinocchio/algorithm/aba.hpp"
#include "pinocchio/algorithm/crba.hpp"
#include "pinocchio/algorithm/rnea.hpp"
#include "pinocchio/multibody.hpp"

namespace reference {
namespace {

std::unique_ptr<pinocchio::Model> model;
std::unique_ptr<pinocchio::Data> data;

pinocchio::Inertia rod(double mass, double length, const Eigen::Vector3d& axis) {
  const double across = mass * length * length / 12.0;
  const Eigen::Vector3d diagonal = Eigen::Vector3d::Constant(across) - across * axis.cwiseAbs();
  return pinocchio::Inertia(mass, 0.5 * length * axis, diagonal.asDiagonal());
}

}  // namespace

void build(const System& system) {
  model = std::make_unique<pinocchio::Model>();
  model->gravity.linear(Eigen::Vector3d(0.0, 0.0, -system.g));
  const Eigen::Vector3d y = Eigen::Vector3d::UnitY(), z = Eigen::Vector3d::UnitZ();
  pinocchio::JointIndex parent;
  pinocchio::SE3 placement = pinocchio::SE3::Identity();
  if (system.rotary) {
    parent = model->addJoint(0, pinocchio::JointModelRZ(), placement, "arm");
    model->appendBodyToJoint(parent, rod(system.m[0], system.l[0], y));  // m0 l0^2/3 about z
    placement.translation(system.l[0] * y);
  } else {
    parent = model->addJoint(0, pinocchio::JointModelPX(), placement, "cart");
    const Eigen::Matrix3d none = Eigen::Matrix3d::Zero();  // the cart never turns
    model->appendBodyToJoint(parent, pinocchio::Inertia(system.m[0], Eigen::Vector3d::Zero(), none));
  }
  for (std::size_t i = 1; i < system.m.size(); ++i) {
    parent = model->addJoint(parent, pinocchio::JointModelRY(), placement, "link" + std::to_string(i));
    model->appendBodyToJoint(parent, rod(system.m[i], system.l[i], z));
    placement = pinocchio::SE3::Identity();
    placement.translation(system.l[i] * z);
  }
  data = std::make_unique<pinocchio::Data>(*model);
}

namespace {
pinocchio::Convention convention(bool world) {
  return world ? pinocchio::Convention::WORLD : pinocchio::Convention::LOCAL;
}
}  // namespace

const Eigen::MatrixXd& crba(const Eigen::VectorXd& q, bool world) {
  return pinocchio::crba(*model, *data, q, convention(world));
}

const Eigen::VectorXd& nonlinear_effects(const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  return pinocchio::nonLinearEffects(*model, *data, q, v);
}

const Eigen::VectorXd& aba(const Eigen::VectorXd& q, const Eigen::VectorXd& v, const Eigen::VectorXd& tau,
                           bool world) {
  return pinocchio::aba(*model, *data, q, v, tau, convention(world));
}

}  // namespace reference
