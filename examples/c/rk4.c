/* A software-in-the-loop style run of a generated C header: the paper's rotary single
 * inverted pendulum (rsip.h, from `ipgen --type rotary --links 1 --name rsip --emit c -o DIR`)
 * integrated with a fixed-step classical Runge-Kutta scheme, as an embedded observer or a
 * SIL test would, without damping and without input, so that the energy T + V must stay
 * constant. Prints "steps <n> energy_drift <|E(t_end) - E(0)| / E(0)>" and exits 1 if the
 * drift exceeds 1e-6 or the dynamics fail.
 *
 *   gcc -std=c99 -Wall -Wextra -Wpedantic -Werror -I DIR examples/c/rk4.c -o rk4 -lm
 */
#include <stdio.h>

#include "rsip.h"

#define N IPGEN_RSIP_DOF

/* x = [q; qd] -> dx/dt = [qd; qdd]; 0, or non-zero if the dynamics fail. */
static int rhs(const IPGEN_SCALAR x[], const ipgen_rsip_params *p, IPGEN_SCALAR dx[]) {
  int i;
  for (i = 0; i < N; ++i) dx[i] = x[N + i];
  return ipgen_rsip_forward_dynamics(x, x + N, (IPGEN_SCALAR)0, p, dx + N);
}

/* One step of the classical fourth-order Runge-Kutta scheme, in place. */
static int rk4_step(IPGEN_SCALAR x[], IPGEN_SCALAR h, const ipgen_rsip_params *p) {
  IPGEN_SCALAR k1[2 * N], k2[2 * N], k3[2 * N], k4[2 * N], y[2 * N];
  int i, status = rhs(x, p, k1);
  for (i = 0; i < 2 * N; ++i) y[i] = x[i] + h / 2 * k1[i];
  status |= rhs(y, p, k2);
  for (i = 0; i < 2 * N; ++i) y[i] = x[i] + h / 2 * k2[i];
  status |= rhs(y, p, k3);
  for (i = 0; i < 2 * N; ++i) y[i] = x[i] + h * k3[i];
  status |= rhs(y, p, k4);
  for (i = 0; i < 2 * N; ++i) x[i] += h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
  return status;
}

static IPGEN_SCALAR energy(const IPGEN_SCALAR x[], const ipgen_rsip_params *p) {
  return ipgen_rsip_kinetic_energy(x, x + N, p) + ipgen_rsip_potential_energy(x, p);
}

int main(void) {
  /* The paper's rotary pendulum (scenes/rsip_pulse.toml: arm 0.5 kg, 0.6 m; link 0.275 kg,
   * 0.5 m), here without damping. */
  const ipgen_rsip_params p = {{0.5, 0.275}, {0.6, 0.5}, {0.0, 0.0}, 9.81};
  IPGEN_SCALAR x[2 * N] = {0.0, 0.3, 1.0, -0.5}; /* arm angle, link angle, their rates */
  const IPGEN_SCALAR h = 1e-3;                    /* 1 kHz, a typical control loop */
  const int steps = 2000;                         /* 2 s */
  const IPGEN_SCALAR e0 = energy(x, &p);
  IPGEN_SCALAR drift;
  int k;
  for (k = 0; k < steps; ++k) {
    if (rk4_step(x, h, &p) != 0) {
      printf("the mass matrix is not positive definite at step %d\n", k);
      return 1;
    }
  }
  drift = fabs(energy(x, &p) - e0) / fabs(e0);
  printf("steps %d energy_drift %.3e\n", steps, drift);
  return drift < 1e-6 ? 0 : 1;
}
