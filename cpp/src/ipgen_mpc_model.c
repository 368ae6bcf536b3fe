/* ipgen_mpc_model.c: ipgen_mpc.h for Python (ipgen.control.mpc), compiled with it into one shared
 * library with -DIPGEN_MPC_EXPORT (the header's functions exported), plus what ctypes needs:
 * - ipgen_mpc_model_dynamics: the MPC's model callback (ipgen_mpc_dynamics) on a compiled model
 *   library (ipgen_model.h): x = [q; qd] in ipgen's coordinates, u the drive's input, the force
 *   or torque on the base gain * u (gain: a DC motor's force or torque per volt, its back-EMF
 *   folded into the model's damping; 1 without a motor); f = [qd; qdd], A = [[0, I], [dqdd/dq,
 *   dqdd/dqd]], B = [0; gain dqdd/du] from forward_dynamics_derivatives (exact). The model
 *   computes in double; with IPGEN_MPC_REAL = float the values are converted at the boundary.
 * - ipgen_mpc_model_layout: the sizes and offsets of the header's structs and of the context,
 *   which the Python side checks against its ctypes mirrors when it loads the library.
 * Nothing here is an algorithm of its own.
 */
#include <stddef.h>

#include "ipgen_model.h"
#include "ipgen_mpc.h"

/* The context of ipgen_mpc_model_dynamics: a model library's description and parameters. */
typedef struct {
  const ipgen_model *model;
  const ipgen_parameters *parameters;
  double gain; /* force or torque on the base per unit of u */
} ipgen_mpc_model_context;

/* Entries ipgen_mpc_model_layout writes. */
#define IPGEN_MPC_MODEL_LAYOUT 42

int ipgen_mpc_model_dynamics(void *context, const ipgen_mpc_real x[], const ipgen_mpc_real u[], ipgen_mpc_real f[],
                             ipgen_mpc_real A[], ipgen_mpc_real B[]) {
  const ipgen_mpc_model_context *c = (const ipgen_mpc_model_context *)context;
  const ipgen_model *m = c->model;
  const int dof = m->dof, nx = 2 * dof, inputs = m->inputs;
  double q[IPGEN_MAX_DOF], qd[IPGEN_MAX_DOF], qdd[IPGEN_MAX_DOF], force[IPGEN_MAX_DOF];
  double dq[IPGEN_MAX_DOF * IPGEN_MAX_DOF], dqd[IPGEN_MAX_DOF * IPGEN_MAX_DOF], du[IPGEN_MAX_DOF * IPGEN_MAX_DOF];
  int i, j;
  for (i = 0; i < dof; ++i) {
    q[i] = (double)x[i];
    qd[i] = (double)x[dof + i];
  }
  for (j = 0; j < inputs; ++j) force[j] = c->gain * (double)u[j];
  if (A != 0 && B != 0) {
    if (m->forward_dynamics_derivatives(q, qd, force, c->parameters, qdd, dq, dqd, du) != 0) return 1;
    for (i = 0; i < nx * nx; ++i) A[i] = (ipgen_mpc_real)0;
    for (i = 0; i < dof; ++i) {
      A[i * nx + dof + i] = (ipgen_mpc_real)1;
      for (j = 0; j < dof; ++j) {
        A[(dof + i) * nx + j] = (ipgen_mpc_real)dq[i * dof + j];
        A[(dof + i) * nx + dof + j] = (ipgen_mpc_real)dqd[i * dof + j];
      }
    }
    for (i = 0; i < dof; ++i)
      for (j = 0; j < inputs; ++j) {
        B[i * inputs + j] = (ipgen_mpc_real)0;
        B[(dof + i) * inputs + j] = (ipgen_mpc_real)(c->gain * du[i * inputs + j]);
      }
  } else if (m->forward_dynamics(q, qd, force, c->parameters, qdd) != 0) {
    return 1;
  }
  for (i = 0; i < dof; ++i) {
    f[i] = x[dof + i];
    f[dof + i] = (ipgen_mpc_real)qdd[i];
  }
  return 0;
}

/* out[0..IPGEN_MPC_MODEL_LAYOUT): sizeof(ipgen_mpc_real), then per struct its size and the
 * offsets of its fields in declaration order. Returns IPGEN_MPC_MODEL_LAYOUT. */
long ipgen_mpc_model_layout(long out[]) {
  long i = 0;
  out[i++] = (long)sizeof(ipgen_mpc_real);
  out[i++] = (long)sizeof(ipgen_mpc_settings);
  out[i++] = (long)offsetof(ipgen_mpc_settings, period);
  out[i++] = (long)offsetof(ipgen_mpc_settings, substeps);
  out[i++] = (long)offsetof(ipgen_mpc_settings, dynamics);
  out[i++] = (long)offsetof(ipgen_mpc_settings, context);
  out[i++] = (long)offsetof(ipgen_mpc_settings, Q);
  out[i++] = (long)offsetof(ipgen_mpc_settings, u_ref);
  out[i++] = (long)offsetof(ipgen_mpc_settings, u_max);
  out[i++] = (long)offsetof(ipgen_mpc_settings, hard_count);
  out[i++] = (long)offsetof(ipgen_mpc_settings, hard_index);
  out[i++] = (long)offsetof(ipgen_mpc_settings, hard_max);
  out[i++] = (long)offsetof(ipgen_mpc_settings, soft_count);
  out[i++] = (long)offsetof(ipgen_mpc_settings, soft_index);
  out[i++] = (long)offsetof(ipgen_mpc_settings, soft_quadratic);
  out[i++] = (long)offsetof(ipgen_mpc_settings, sqp_iterations);
  out[i++] = (long)offsetof(ipgen_mpc_settings, sqp_tolerance);
  out[i++] = (long)offsetof(ipgen_mpc_settings, qp_iterations);
  out[i++] = (long)offsetof(ipgen_mpc_settings, qp_tolerance);
  out[i++] = (long)offsetof(ipgen_mpc_settings, shift);
  out[i++] = (long)offsetof(ipgen_mpc_settings, line_search);
  out[i++] = (long)offsetof(ipgen_mpc_settings, cold_iterations);
  out[i++] = (long)offsetof(ipgen_mpc_settings, exact_hessian);
  out[i++] = (long)sizeof(ipgen_mpc_method);
  out[i++] = (long)offsetof(ipgen_mpc_method, sensitivities);
  out[i++] = (long)sizeof(ipgen_mpc_info);
  out[i++] = (long)offsetof(ipgen_mpc_info, sqp_iterations);
  out[i++] = (long)offsetof(ipgen_mpc_info, qp_iterations);
  out[i++] = (long)offsetof(ipgen_mpc_info, step);
  out[i++] = (long)offsetof(ipgen_mpc_info, defect);
  out[i++] = (long)offsetof(ipgen_mpc_info, qp_residual);
  out[i++] = (long)sizeof(ipgen_mpc_model_context);
  out[i++] = (long)offsetof(ipgen_mpc_model_context, parameters);
  out[i++] = (long)offsetof(ipgen_mpc_model_context, gain);
  out[i++] = (long)sizeof(ipgen_parameters);
  out[i++] = (long)offsetof(ipgen_parameters, g);
  out[i++] = (long)offsetof(ipgen_parameters, tip);
  out[i++] = (long)offsetof(ipgen_model, dof);
  out[i++] = (long)offsetof(ipgen_model, inputs);
  out[i++] = (long)offsetof(ipgen_model, forward_dynamics);
  out[i++] = (long)sizeof(ipgen_mpc_layout);
  out[i++] = (long)IPGEN_MPC_MODEL_LAYOUT;
  return i;
}
