/* mpc_qube_loop.c: the MPC step (ipgen_mpc.h) on a generated C header (`--emit c`, model qube:
 * rotary1, general in its parameters), as a firmware runs it: the model callback on the header's
 * *_built functions, static memory, IPGEN_SCALAR = IPGEN_MPC_REAL (double, or float with
 * -DIPGEN_SCALAR=float -DIPGEN_MPC_REAL=float). Reads the design from stdin (numbers, in the
 * order of main's scanf calls), runs STEPS samples of the real-time iteration in closed loop on
 * the same model (the plant: ipgen_mpc_rk4 with 10 RK4 steps per sample) and prints per sample
 * the state x_k [rad, rad/s] and u_k [V], then the mean time of a step [ns] (tests/test_mpc.py,
 * bench/mpc.py). */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#include <stdio.h>
#include <time.h>

#include "qube.h"
#include "ipgen_mpc.h"

#define HORIZON 30
#define STEPS 150

typedef struct {
  ipgen_qube_params p;
  ipgen_qube_links links;
  ipgen_mpc_real gain; /* torque per volt [N m / V] */
} model;

/* x' = f(x, u) and its Jacobians from the header (ipgen_mpc_dynamics). */
static int dynamics(void *context, const ipgen_mpc_real x[], const ipgen_mpc_real u[], ipgen_mpc_real f[],
                    ipgen_mpc_real A[], ipgen_mpc_real B[]) {
  const model *m = (const model *)context;
  const ipgen_mpc_real torque = m->gain * u[0];
  ipgen_mpc_real qdd[2], dq[4], dqd[4], du[2];
  int i, j;
  if (A != 0 && B != 0) {
    if (ipgen_qube_forward_dynamics_derivatives_built(x, x + 2, torque, &m->p, &m->links, qdd, dq, dqd, du) != 0) return 1;
    for (i = 0; i < 16; ++i) A[i] = (ipgen_mpc_real)0;
    for (i = 0; i < 2; ++i) {
      A[i * 4 + 2 + i] = (ipgen_mpc_real)1;
      for (j = 0; j < 2; ++j) {
        A[(2 + i) * 4 + j] = dq[i * 2 + j];
        A[(2 + i) * 4 + 2 + j] = dqd[i * 2 + j];
      }
      B[i] = (ipgen_mpc_real)0;
      B[2 + i] = m->gain * du[i];
    }
  } else if (ipgen_qube_forward_dynamics_built(x, x + 2, torque, &m->p, &m->links, qdd) != 0) {
    return 1;
  }
  f[0] = x[2];
  f[1] = x[3];
  f[2] = qdd[0];
  f[3] = qdd[1];
  return 0;
}

static ipgen_mpc_real work[IPGEN_MPC_WORK(4, 1, HORIZON, 1, 0)];
static ipgen_mpc_real scratch[IPGEN_MPC_WORK(4, 1, HORIZON, 1, 0)];

static int read_numbers(ipgen_mpc_real v[], int n) {
  int i;
  for (i = 0; i < n; ++i) {
    double d;
    if (scanf("%lf", &d) != 1) return 1;
    v[i] = (ipgen_mpc_real)d;
  }
  return 0;
}

int main(void) {
  model m;
  ipgen_mpc_real Q[16], R[1], P[16], x_ref[4] = {0, 0, 0, 0}, u_ref[1] = {0}, u_min[1], u_max[1];
  ipgen_mpc_real travel_min[1], travel_max[1], x[4], u[1], period[1], numbers[8];
  const int arm[1] = {0};
  ipgen_mpc_settings s, plant;
  ipgen_mpc_info info;
  struct timespec start, end;
  double nanoseconds = 0;
  int k, i;
  if (read_numbers(m.p.m, 2) || read_numbers(m.p.l, 2) || read_numbers(m.p.delta, 2) || read_numbers(&m.p.g, 1) ||
      read_numbers(m.links.com, 2) || read_numbers(m.links.J, 2) || read_numbers(m.links.J_axial, 2) ||
      read_numbers(m.links.tip, 2) || read_numbers(&m.gain, 1) || read_numbers(Q, 16) || read_numbers(R, 1) ||
      read_numbers(P, 16) || read_numbers(numbers, 2) || read_numbers(period, 1) || read_numbers(x, 4))
    return 2;
  u_max[0] = numbers[0];
  u_min[0] = -numbers[0];
  travel_max[0] = numbers[1];
  travel_min[0] = -numbers[1];
  s.nx = 4; s.nu = 1; s.N = HORIZON; s.period = period[0]; s.substeps = 1;
  s.dynamics = dynamics; s.context = &m;
  s.Q = Q; s.R = R; s.P = P; s.x_ref = x_ref; s.u_ref = u_ref; s.u_min = u_min; s.u_max = u_max;
  s.hard_count = 1; s.hard_index = arm; s.hard_min = travel_min; s.hard_max = travel_max;
  s.soft_count = 0; s.soft_index = 0; s.soft_min = s.soft_max = s.soft_linear = s.soft_quadratic = 0;
  s.sqp_iterations = 1; s.sqp_tolerance = 0; s.cold_iterations = 10;
  s.qp_iterations = 20; s.qp_tolerance = sizeof(ipgen_mpc_real) == sizeof(float) ? (ipgen_mpc_real)1e-4 : (ipgen_mpc_real)1e-9;
  s.shift = 1; s.line_search = 0; s.exact_hessian = 0;
  plant = s;
  plant.substeps = 10;
  ipgen_mpc_reset(work);
  for (k = 0; k < STEPS; ++k) {
    clock_gettime(CLOCK_MONOTONIC, &start);
    ipgen_mpc_step(&s, x, u, work, &info);
    clock_gettime(CLOCK_MONOTONIC, &end);
    if (k > 0) nanoseconds += (double)(end.tv_sec - start.tv_sec) * 1e9 + (double)(end.tv_nsec - start.tv_nsec);
    for (i = 0; i < 4; ++i) printf("%.17g ", (double)x[i]);
    printf("%.17g %d\n", (double)u[0], info.status);
    if (ipgen_mpc_rk4(&plant, x, u, x, 0, 0, scratch) != 0) return 3;
  }
  printf("%.1f\n", nanoseconds / (STEPS - 1));
  return 0;
}
