// The reference: Pinocchio's rigid-body algorithms on the same pendulum, in Pinocchio's own
// (relative) joint coordinates. Compiled in its own translation unit (reference.cpp), once,
// with the same compiler and flags as the benchmark; nothing here depends on n at compile time.
#pragma once

#include <vector>

#include <Eigen/Core>

namespace reference {

struct System {
  bool rotary;            // false: cart on a rail (classical); true: arm about the vertical
  std::vector<double> m;  // masses, index 0 = base
  std::vector<double> l;  // lengths, index 0 = arm (rotary) or unused (classical)
  double g;
};

// Builds the pinocchio::Model of the system (joint 1 = base, joints 2..n+1 = links).
void build(const System& system);

// Each call runs one algorithm and returns Pinocchio's own result buffer. CRBA and ABA come in
// Pinocchio's two conventions (local: the default; world): the benchmark keeps the faster one.
const Eigen::MatrixXd& crba(const Eigen::VectorXd& q, bool world = false);  // upper triangle only
const Eigen::VectorXd& nonlinear_effects(const Eigen::VectorXd& q, const Eigen::VectorXd& v);
const Eigen::VectorXd& aba(const Eigen::VectorXd& q, const Eigen::VectorXd& v, const Eigen::VectorXd& tau,
                           bool world = false);

}  // namespace reference
