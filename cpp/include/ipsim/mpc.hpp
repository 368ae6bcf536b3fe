// ipsim::MpcController: a scene's [controller] kind = "mpc" in the simulator. The step is
// ipgen_mpc_step of cpp/include/ipgen_mpc.h (written once, in C99: the same code ipgen.mpc calls
// through ctypes and the C header prints); this file only holds its memory and gives it the model:
// the callback is the model's forward_dynamics_derivatives (a model library's for RuntimeModel),
// x = [θ; θ̇] in ipgen's coordinates, u in the scene's unit (volts with a dc motor: the force or
// torque on the base is input_gain · u, the back-EMF already folded into the parameters' damping),
// f = [θ̇; θ̈], A = [[0, I], [∂θ̈/∂θ, ∂θ̈/∂θ̇]], B = [0; input_gain ∂θ̈/∂u]: what
// cpp/src/ipgen_mpc_model.c gives ipgen.mpc, so that both compute the same numbers.
//
// The problem comes resolved from the .cfg (controller.*, written by ipgen from the scene's
// [controller]: every default filled in, the terminal weight computed): nothing is designed here.
#pragma once

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ipsim/jacobian.hpp"
#include "ipsim/model.hpp"
#include "ipgen_mpc.h"

namespace ipsim {

/// The problem and budget of ipgen_mpc_settings, as the .cfg's controller.* keys give them.
struct MpcProblem {
  int horizon = 30;
  int substeps = 1;
  double period = 0.0;
  std::vector<double> Q, R, P, reference;  ///< nx², 1, nx², nx (row-major)
  double u_min = 0.0, u_max = 0.0;
  std::vector<int> hard_index, soft_index;
  std::vector<double> hard_min, hard_max, soft_min, soft_max, soft_linear, soft_quadratic;
  bool converged = false;  ///< mode converged: the line search and (double) the exact Hessian, as ipgen.mpc
  int sqp_iterations = 1, cold_iterations = 10, qp_iterations = 20;
  double sqp_tolerance = 0.0, qp_tolerance = 1e-9;
  double barrier = 0.0;   ///< > 0: each QP Newton steps on its log-barrier problem at this weight
  bool frozen = false;    ///< the sensitivities from the Jacobians at each stage's start (ipgen_mpc_method)
  bool shifted = false;   ///< and most of them kept from the last sample (IPGEN_MPC_SHIFTED; implies frozen)
};

/// What the steps did over a run (the summary's MPC part).
struct MpcTally {
  long steps = 0;
  long not_ok = 0;           ///< steps whose status was not IPGEN_MPC_OK
  int last_bad_status = 0;   ///< the last such status
  int max_qp_iterations = 0; ///< the most interior-point iterations of one step
  long qp_iterations = 0;    ///< summed
};

/// ipgen_mpc_step with its settings, arrays and workspace: step(x) → u (the scene's unit).
/// Not copyable (the settings point into it); held by a shared pointer.
template <class Model>
class MpcController {
 public:
  MpcController(MpcProblem problem, const ParamsOf<Model>& params, double input_gain)
      : p_(std::move(problem)), params_(with_rod_links<Model>(params)), gain_(input_gain) {
    const int n = dof_of<Model>();
    u_ref_ = {0.0};
    ipgen_mpc_settings& s = settings_;
    s = ipgen_mpc_settings{};
    s.nx = 2 * n;
    s.nu = 1;
    s.N = p_.horizon;
    s.period = p_.period;
    s.substeps = p_.substeps;
    s.dynamics = &MpcController::dynamics;
    s.context = this;
    s.Q = p_.Q.data();
    s.R = p_.R.data();
    s.P = p_.P.data();
    s.x_ref = p_.reference.data();
    s.u_ref = u_ref_.data();
    s.u_min = &p_.u_min;
    s.u_max = &p_.u_max;
    s.hard_count = static_cast<int>(p_.hard_index.size());
    s.hard_index = p_.hard_index.data();
    s.hard_min = p_.hard_min.data();
    s.hard_max = p_.hard_max.data();
    s.soft_count = static_cast<int>(p_.soft_index.size());
    s.soft_index = p_.soft_index.data();
    s.soft_min = p_.soft_min.data();
    s.soft_max = p_.soft_max.data();
    s.soft_linear = p_.soft_linear.data();
    s.soft_quadratic = p_.soft_quadratic.data();
    s.sqp_iterations = p_.sqp_iterations;
    s.sqp_tolerance = p_.sqp_tolerance;
    s.qp_iterations = p_.qp_iterations;
    s.qp_tolerance = p_.qp_tolerance;
    s.shift = 1;
    s.line_search = p_.converged ? 1 : 0;
    s.cold_iterations = p_.cold_iterations;
    s.exact_hessian = p_.converged ? 1 : 0;
    method_.barrier = p_.barrier;
    method_.sensitivities = p_.shifted ? IPGEN_MPC_SHIFTED : p_.frozen ? IPGEN_MPC_FROZEN : IPGEN_MPC_EXACT;
    work_.assign(static_cast<std::size_t>(ipgen_mpc_work_size(&s)), 0.0);
  }
  MpcController(const MpcController&) = delete;
  MpcController& operator=(const MpcController&) = delete;

  /// ipgen_mpc_check: 0 when the settings describe a problem.
  int check() const { return ipgen_mpc_check(&settings_); }

  /// u for the state estimate x (2·kDof, ipgen's coordinates), in the scene's unit (volts with a
  /// dc motor): one step of ipgen_mpc.h (its warm start kept in the workspace).
  double operator()(const Eigen::VectorXd& x) { return track(x, nullptr, nullptr); }

  /// The same about a reference per stage (ipgen_mpc_track: x_refs (horizon + 1) × 2·kDof and
  /// u_refs horizon entries in the scene's unit, row-major; null: the constant reference).
  double track(const Eigen::VectorXd& x, const double* x_refs, const double* u_refs) {
    double u = 0.0;
    ipgen_mpc_info info{};
    ipgen_mpc_track_method(&settings_, &method_, x_refs, u_refs, x.data(), &u, work_.data(), &info);
    ++tally_.steps;
    tally_.qp_iterations += info.qp_iterations;
    if (info.qp_iterations > tally_.max_qp_iterations) tally_.max_qp_iterations = info.qp_iterations;
    if (info.status != IPGEN_MPC_OK) {
      ++tally_.not_ok;
      tally_.last_bad_status = info.status;
    }
    return u;
  }

  /// Forgets the warm start: the next step is cold (ipgen_mpc_reset).
  void reset() { ipgen_mpc_reset(work_.data()); }

  const MpcProblem& problem() const noexcept { return p_; }
  const MpcTally& tally() const noexcept { return tally_; }
  std::size_t work_entries() const noexcept { return work_.size(); }

 private:
  /// ipgen_mpc_dynamics on the model (see the file's comment). 1 where the model fails.
  static int dynamics(void* context, const double x[], const double u[], double f[], double A[], double B[]) {
    const auto& self = *static_cast<const MpcController*>(context);
    const int n = dof_of<Model>(), nx = 2 * n;
    const VectorOf<Model> q = Eigen::Map<const Eigen::VectorXd>(x, n);
    const VectorOf<Model> qd = Eigen::Map<const Eigen::VectorXd>(x + n, n);
    const double force = self.gain_ * u[0];
    VectorOf<Model> qdd;
    if (A != nullptr && B != nullptr) {
      if constexpr (has_derivatives<Model>) {
        const auto d = Model::template forward_dynamics_derivatives<double>(q, qd, force, self.params_);
        if (!d.qdd.allFinite()) return 1;
        qdd = d.qdd;
        for (int i = 0; i < nx * nx; ++i) A[i] = 0.0;
        for (int i = 0; i < n; ++i) {
          A[i * nx + n + i] = 1.0;
          for (int j = 0; j < n; ++j) {
            A[(n + i) * nx + j] = d.dqdd_dq(i, j);
            A[(n + i) * nx + n + j] = d.dqdd_dqd(i, j);
          }
          B[i] = 0.0;
          B[n + i] = self.gain_ * d.dqdd_du(i);
        }
      } else {
        return 1;  // refused when the scene is loaded (scene.hpp)
      }
    } else {
      qdd = Model::template forward_dynamics<double>(q, qd, force, self.params_);
      if (!qdd.allFinite()) return 1;
    }
    for (int i = 0; i < n; ++i) {
      f[i] = x[n + i];
      f[n + i] = qdd(i);
    }
    return 0;
  }

  MpcProblem p_;
  ParamsOf<Model> params_;
  double gain_;
  std::vector<double> u_ref_;
  ipgen_mpc_settings settings_{};
  ipgen_mpc_method method_{};
  std::vector<double> work_;
  MpcTally tally_;
};

}  // namespace ipsim
