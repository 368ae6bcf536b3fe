/* ipgen_loop_batch.c: ipgen_loop.h for Python (ipgen.common.loop_runtime), compiled with it into one
 * shared library with -DIPGEN_LOOP_EXPORT (the header's functions exported), plus what ctypes
 * needs beside them:
 * - ipgen_loop_batch_layout: the sizes and offsets of the header's structs, which the Python
 *   side checks against its ctypes.Structure mirrors once, when it loads the library;
 * - ipgen_loop_batch_ekf_work: IPGEN_LOOP_EKF_WORK, the EKF's scratch size, checked the same way
 *   (Python allocates the scratch C writes);
 * - ipgen_loop_batch_observe and ipgen_loop_batch_delay: ipgen.gym's measured observation and
 *   delayed action over a batch of environments (rows of a state array) in one call each, every
 *   row through the header's own ipgen_loop_quantise, _filter or _difference, and _delay.
 * Nothing here is an algorithm of its own: each loops over rows and calls ipgen_loop_*.
 */
#include <math.h>
#include <stddef.h>

#include "ipgen_loop.h"

/* Entries ipgen_loop_batch_layout writes. */
#define IPGEN_LOOP_BATCH_LAYOUT 54

/* out[0..IPGEN_LOOP_BATCH_LAYOUT): sizeof(ipgen_real) and, per struct, its size and the offsets
 * of its fields in declaration order. Returns IPGEN_LOOP_BATCH_LAYOUT. */
long ipgen_loop_batch_layout(long out[]) {
  long i = 0;
  out[i++] = (long)sizeof(ipgen_real);
  out[i++] = (long)sizeof(ipgen_loop_measurement);
  out[i++] = (long)offsetof(ipgen_loop_measurement, measured);
  out[i++] = (long)offsetof(ipgen_loop_measurement, x_eq);
  out[i++] = (long)sizeof(ipgen_loop_kalman);
  out[i++] = (long)offsetof(ipgen_loop_kalman, A);
  out[i++] = (long)offsetof(ipgen_loop_kalman, M);
  out[i++] = (long)offsetof(ipgen_loop_kalman, u_eq);
  out[i++] = (long)sizeof(ipgen_loop_ekf);
  out[i++] = (long)offsetof(ipgen_loop_ekf, period);
  out[i++] = (long)offsetof(ipgen_loop_ekf, gain);
  out[i++] = (long)offsetof(ipgen_loop_ekf, Qn);
  out[i++] = (long)offsetof(ipgen_loop_ekf, Rn);
  out[i++] = (long)offsetof(ipgen_loop_ekf, field);
  out[i++] = (long)offsetof(ipgen_loop_ekf, context);
  out[i++] = (long)offsetof(ipgen_loop_ekf, gain_spread);
  out[i++] = (long)offsetof(ipgen_loop_ekf, gain_drift);
  out[i++] = (long)offsetof(ipgen_loop_ekf, noise_weight);
  out[i++] = (long)offsetof(ipgen_loop_ekf, noise_margin);
  out[i++] = (long)offsetof(ipgen_loop_ekf, noise_floor);
  out[i++] = (long)offsetof(ipgen_loop_ekf, noise_ceiling);
  out[i++] = (long)offsetof(ipgen_loop_ekf, noise);
  out[i++] = (long)sizeof(ipgen_loop_energy_law);
  out[i++] = (long)offsetof(ipgen_loop_energy_law, energy_weight);
  out[i++] = (long)offsetof(ipgen_loop_energy_law, acceleration);
  out[i++] = (long)offsetof(ipgen_loop_energy_law, input_gain);
  out[i++] = (long)offsetof(ipgen_loop_energy_law, energy_step);
  out[i++] = (long)offsetof(ipgen_loop_energy_law, catch_deficit);
  out[i++] = (long)offsetof(ipgen_loop_energy_law, catch_base);
  out[i++] = (long)sizeof(ipgen_loop_swingup);
  out[i++] = (long)offsetof(ipgen_loop_swingup, u_max);
  out[i++] = (long)offsetof(ipgen_loop_swingup, target);
  out[i++] = (long)offsetof(ipgen_loop_swingup, energy);
  out[i++] = (long)offsetof(ipgen_loop_swingup, steps);
  out[i++] = (long)offsetof(ipgen_loop_swingup, gains);
  out[i++] = (long)offsetof(ipgen_loop_swingup, mass_bias);
  out[i++] = (long)offsetof(ipgen_loop_swingup, context);
  out[i++] = (long)offsetof(ipgen_loop_swingup, catch_every);
  out[i++] = (long)offsetof(ipgen_loop_swingup, release_angle);
  out[i++] = (long)offsetof(ipgen_loop_swingup, catch_reset);
  out[i++] = (long)offsetof(ipgen_loop_swingup, track_law);
  out[i++] = (long)offsetof(ipgen_loop_swingup, track_horizon);
  out[i++] = (long)offsetof(ipgen_loop_swingup, track_refs);
  out[i++] = (long)offsetof(ipgen_loop_swingup, gain_factor);
  out[i++] = (long)sizeof(ipgen_loop_swingup_state);
  out[i++] = (long)offsetof(ipgen_loop_swingup_state, k);
  out[i++] = (long)offsetof(ipgen_loop_swingup_state, hold_q1);
  out[i++] = (long)offsetof(ipgen_loop_swingup_state, catch_u);
  out[i++] = (long)offsetof(ipgen_loop_swingup_state, energy_offset);
  out[i++] = (long)offsetof(ipgen_loop_swingup_state, swinging);
  out[i++] = (long)sizeof(ipgen_loop_lag);
  out[i++] = (long)offsetof(ipgen_loop_lag, boost);
  out[i++] = (long)offsetof(ipgen_loop_lag, limit);
  out[i++] = (long)sizeof(long);
  return i;
}

/* IPGEN_LOOP_EKF_WORK(n, c): the scratch entries of one EKF sample with n states and c measured. */
long ipgen_loop_batch_ekf_work(long n, long c) { return (long)IPGEN_LOOP_EKF_WORK(n, c); }

/* The measured observation of the environments `rows` (count of them) of a batch, dof <= 64
 * coordinates each: y = ipgen_loop_quantise(q, 0, step[j]) + noise (noise: count x dof, or null
 * for none), the rates through ipgen_loop_filter (filter != 0: pole, cutoff) or
 * ipgen_loop_difference (period), sample k (0: a reset, the rates 0; else a step), with each
 * environment's previous[row] and rates[row] (dof entries each, updated); observation row
 * `row` of obs (obs_size float entries) gets (y0, sin y_i, cos y_i for i >= 1, the rates).
 * finite[j] = 1 when that observation is finite (as float), else 0. `state` rows hold 2 dof
 * entries (q, then qd). Returns the rows not finite. */
long ipgen_loop_batch_observe(long count, const long rows[], int dof, const double state[], const double step[],
                              const double noise[], int filter, double pole, double cutoff, double period, long k,
                              double previous[], double rates[], float obs[], long obs_size,
                              unsigned char finite[]) {
  double y[64], x[128];
  long j, failed = 0;
  int i;
  if (dof < 1 || dof > 64) return count;
  for (j = 0; j < count; ++j) {
    const long row = rows[j];
    const double *q = state + row * 2 * dof;
    double *last = previous + row * dof, *rate = rates + row * dof;
    float *o = obs + row * obs_size;
    unsigned char ok = 1;
    for (i = 0; i < dof; ++i) {
      y[i] = ipgen_loop_quantise(q[i], 0.0, step[i]);
      if (noise) y[i] = y[i] + noise[j * dof + i];
      x[dof + i] = rate[i];
    }
    if (filter) {
      ipgen_loop_filter(dof, pole, cutoff, k, y, last, x);
    } else {
      ipgen_loop_difference(dof, period, k, y, last, x);
    }
    o[0] = (float)y[0];
    for (i = 1; i < dof; ++i) {
      o[2 * i - 1] = (float)sin(y[i]);
      o[2 * i] = (float)cos(y[i]);
    }
    for (i = 0; i < dof; ++i) {
      rate[i] = x[dof + i];
      o[2 * dof - 1 + i] = (float)x[dof + i];
    }
    for (i = 0; i < 3 * dof - 1; ++i) ok = ok && isfinite(o[i]);
    finite[j] = ok;
    failed += !ok;
  }
  return failed;
}

/* The actions the model sees now in the environments `rows` (count of them): each row's
 * pending (delay + 1 entries, ipgen_loop_delay's) takes commands[j] and gives applied[j]. */
void ipgen_loop_batch_delay(long count, const long rows[], int delay, double pending[], const double commands[],
                            double applied[]) {
  long j;
  for (j = 0; j < count; ++j) applied[j] = ipgen_loop_delay(pending + rows[j] * (delay + 1), delay, commands[j]);
}
