/* ipgen_loop.h: the sampled loop around a pendulum, written once (C99, also valid C++).
 *
 * Every place that runs a rig's loop uses these functions: ipsim's simulator (ipsim/sensors.hpp,
 * ipsim/swingup.hpp, ipsim/rhs.hpp), the firmware in a generated C header (`--emit c` prints
 * this file into it whole), and Python through ctypes (ipgen/common/loop_runtime.py compiles it with
 * IPGEN_LOOP_EXPORT into a shared library): the measurement's quantiser, the delay of the
 * commands, saturation, the drive's first-order lag, the state estimators (backward difference,
 * derivative filter, steady-state Kalman, extended Kalman) and the swing-up (Åström–Furuta
 * energy law, a tracked plan, the catch and the hold). Their formulas are docs/estimation.md's
 * and docs/control.md's.
 *
 * Sizes and parameters are given at run time; the functions keep no state of their own (the
 * caller owns every array), allocate nothing and call only <math.h>. The scalar is IPGEN_SCALAR
 * (double unless defined before the first include, e.g. float on a microcontroller). Vectors are
 * arrays, matrices row-major. x = [q; qd] in whatever coordinates the caller measures in (the
 * rig's, or ipgen's: docs/model.md); the swing-up works in ipgen's coordinates.
 */
#ifndef IPGEN_LOOP_H_INCLUDED
#define IPGEN_LOOP_H_INCLUDED

#include <math.h>

/* The loop's guards against a reading or an estimate that is not finite (a glitch:
 * the command would be NaN or +-inf at the drive) compare values with themselves, which
 * -ffast-math and -ffinite-math-only fold to true: refused there, unless the caller accepts it. */
#if defined(__FINITE_MATH_ONLY__) && __FINITE_MATH_ONLY__ && !defined(IPGEN_ALLOW_FINITE_MATH) && \
    !defined(IPGEN_FINITE_MATH_REFUSED)
#define IPGEN_FINITE_MATH_REFUSED /* said once where both runtimes are printed */
#error "ipgen: compiled with -ffast-math or -ffinite-math-only, under which the checks for NaN and inf of ipgen's loop and MPC fold away (a glitch could reach the drive as a command at its limit): compile without them, add -fno-finite-math-only, or define IPGEN_ALLOW_FINITE_MATH to accept that"
#endif

#ifndef IPGEN_SCALAR
#define IPGEN_SCALAR double
#endif

/* Static inline where a header is included; exported where ipgen compiles the library for ctypes. */
#ifdef IPGEN_LOOP_EXPORT
#define IPGEN_LOOP_API
#else
#define IPGEN_LOOP_API static inline
#endif

#ifdef __cplusplus
extern "C" {
#endif

typedef IPGEN_SCALAR ipgen_real;

/* floor and sqrt in the precision of ipgen_real (floorf, sqrtf for float: no double arithmetic
 * on a single-precision FPU; the sizeof test is a compile-time constant). */
IPGEN_LOOP_API ipgen_real ipgen_loop_floor(ipgen_real v) {
  return sizeof(ipgen_real) == sizeof(float) ? (ipgen_real)floorf((float)v) : (ipgen_real)floor((double)v);
}
IPGEN_LOOP_API ipgen_real ipgen_loop_sqrt(ipgen_real v) {
  return sizeof(ipgen_real) == sizeof(float) ? (ipgen_real)sqrtf((float)v) : (ipgen_real)sqrt((double)v);
}
IPGEN_LOOP_API ipgen_real ipgen_loop_cos(ipgen_real v) {
  return sizeof(ipgen_real) == sizeof(float) ? (ipgen_real)cosf((float)v) : (ipgen_real)cos((double)v);
}

/* ---- measurement, command and drive ---------------------------------------------------- */

/* An encoder's reading of `value` [rad or m]: the nearest multiple of `step` (2 pi / counts per
 * revolution, or 1 / counts per metre) counted from `zero`, the pose where the encoder reads 0:
 * zero + step floor((value - zero) / step + 1/2). step <= 0: value itself (no quantisation). */
IPGEN_LOOP_API ipgen_real ipgen_loop_quantise(ipgen_real value, ipgen_real zero, ipgen_real step) {
  if (!(step > 0)) return value;
  return zero + step * ipgen_loop_floor((value - zero) / step + (ipgen_real)0.5);
}

/* u limited to [-limit, limit] (NaN passes through, for the caller to see). */
IPGEN_LOOP_API ipgen_real ipgen_loop_saturate(ipgen_real u, ipgen_real limit) {
  return u < -limit ? -limit : (limit < u ? limit : u);
}

/* The transport delay of `delay` >= 0 whole sampling periods: pending[0..delay] holds the commands
 * sent and not yet applied, oldest first (all 0 at the start: u = 0 until the first command
 * arrives). Sends `command` and returns the command that acts over the next period (command
 * itself when delay = 0). pending[0] before the call is the command that acted over the period
 * that just ended (what a model-based estimator predicts with). */
IPGEN_LOOP_API ipgen_real ipgen_loop_delay(ipgen_real pending[], int delay, ipgen_real command) {
  int i;
  for (i = 0; i < delay; ++i) pending[i] = pending[i + 1];
  pending[delay] = command;
  return pending[0];
}

/* The drive's first-order lag: d(u_a)/dt = (command - u_a) / lag [input unit / s], lag > 0 [s]. */
IPGEN_LOOP_API ipgen_real ipgen_loop_lag_rate(ipgen_real command, ipgen_real applied, ipgen_real lag) {
  return (command - applied) / lag;
}

/* A known first-order drive lag ([estimator] compensate_lag), as the loop models it: over a
 * period T with the command u held, the drive's input is u + (a - u) e^(-t / lag) from its value a
 * at the start. The loop tracks a (no measurement: the lag is deterministic), predicts with the
 * input's mean over each period, and sends the command whose mean is the law's, within +-limit.
 * decay = e^(-T / lag); weight = (lag / T)(1 - e^(-T / lag)), a's weight in the period's mean;
 * boost = 1 / (1 - weight), the inverse's gain (about 2 lag / T), taken in double. */
typedef struct {
  ipgen_real decay, weight, boost, limit;
} ipgen_loop_lag;

/* The lag of time constant `lag` [s] over `period` [s], commands within +-limit (>= 0, may be
 * infinite). lag <= 0: none (decay = weight = 0: each period's input is its command). The exponentials
 * are taken in double, once. */
IPGEN_LOOP_API ipgen_loop_lag ipgen_loop_lag_of(double lag, double period, double limit) {
  ipgen_loop_lag result;
  result.decay = 0, result.weight = 0, result.boost = 1, result.limit = (ipgen_real)limit;
  if (lag > 0 && period > 0) {
    const double weight = -(lag / period) * expm1(-period / lag);
    result.decay = (ipgen_real)exp(-period / lag);
    result.weight = (ipgen_real)weight;
    result.boost = (ipgen_real)(1 / (1 - weight));
  }
  return result;
}

/* The mean of the drive's input over the period in which `command` is held, from *applied (its
 * value at the period's start), which moves to its value at the period's end. No lag: the
 * command, exactly (whatever *applied held). */
IPGEN_LOOP_API ipgen_real ipgen_loop_lag_mean(const ipgen_loop_lag *lag, ipgen_real command, ipgen_real *applied) {
  ipgen_real mean;
  if (lag->weight == 0) return *applied = command;
  mean = command + (*applied - command) * lag->weight;
  *applied = command + (*applied - command) * lag->decay;
  return mean;
}

/* The inputs the model sees over the `delay` periods still in flight: means[j] = the mean over
 * period j of pending[j] (j = 1..delay, as ipgen_loop_delay keeps them before this sample's call;
 * means[0] = pending[0]), from `applied`, the drive's input now. Returns the drive's input when
 * this sample's command starts to act. */
IPGEN_LOOP_API ipgen_real ipgen_loop_lag_ahead(const ipgen_loop_lag *lag, ipgen_real applied, int delay,
                                               const ipgen_real pending[], ipgen_real means[]) {
  int j;
  means[0] = pending[0];
  for (j = 1; j <= delay; ++j) means[j] = ipgen_loop_lag_mean(lag, pending[j], &applied);
  return applied;
}

/* The command whose input has the mean `wanted` over its first period, the drive's input then
 * being `applied` (the inverse of ipgen_loop_lag_mean), within +-limit. No lag: `wanted`. */
IPGEN_LOOP_API ipgen_real ipgen_loop_lag_command(const ipgen_loop_lag *lag, ipgen_real wanted, ipgen_real applied) {
  if (lag->weight == 0) return wanted;
  return ipgen_loop_saturate((wanted - applied * lag->weight) * lag->boost, lag->limit);
}

/* ---- state estimators ----------------------------------------------------------------------
 * Each is called once per sample k = 0, 1, ... with the measured coordinates y and leaves the
 * estimate x_{k|k} = [q; qd] in x. */

/* A sample counter advanced: it stays at IPGEN_LOOP_COUNT_CAP (2^30) from there on, so that a loop
 * runs for good where a long has 32 bits (2^31 samples are 24.8 days at 1 kHz, and a signed
 * overflow is undefined). An estimator's counter only tells its first sample from the others; the
 * swing-up's is moved back instead (ipgen_loop_swingup_step). */
#define IPGEN_LOOP_COUNT_CAP 1073741824L
IPGEN_LOOP_API long ipgen_loop_count(long k) { return k < IPGEN_LOOP_COUNT_CAP ? k + 1 : k; }

/* 1 if the count entries of y and u are all finite, else 0: a generated header's estimator
 * skips such a sample (its state unchanged), which a filter's recursion would otherwise carry
 * on for ever. */
IPGEN_LOOP_API int ipgen_loop_finite(int count, const ipgen_real y[], ipgen_real u) {
  int i;
  if (!(u - u == (ipgen_real)0)) return 0; /* NaN or inf: inf - inf is NaN */
  for (i = 0; i < count; ++i)
    if (!(y[i] - y[i] == (ipgen_real)0)) return 0;
  return 1;
}

/* Backward difference, every coordinate measured (dof of them, in order): q = y_k,
 * qd = (y_k - y_{k-1}) / period, qd = 0 at k = 0. `previous` keeps y_{k-1}. */
IPGEN_LOOP_API void ipgen_loop_difference(int dof, ipgen_real period, long k, const ipgen_real y[],
                                          ipgen_real previous[], ipgen_real x[]) {
  int i;
  for (i = 0; i < dof; ++i) {
    x[dof + i] = k == 0 ? (ipgen_real)0 : (y[i] - previous[i]) / period;
    x[i] = y[i];
    previous[i] = y[i];
  }
}

/* Derivative filter wc s / (s + wc) as Quanser's rigs discretise it, every coordinate measured:
 * q = y_k, qd_k = pole qd_{k-1} + wc (y_k - y_{k-1}), pole = exp(-wc period), qd_0 = 0.
 * x keeps qd_{k-1} between calls (x[dof..2 dof)); `previous` keeps y_{k-1}. */
IPGEN_LOOP_API void ipgen_loop_filter(int dof, ipgen_real pole, ipgen_real cutoff, long k, const ipgen_real y[],
                                      ipgen_real previous[], ipgen_real x[]) {
  int i;
  for (i = 0; i < dof; ++i) {
    x[dof + i] = k == 0 ? (ipgen_real)0 : pole * x[dof + i] + cutoff * (y[i] - previous[i]);
    x[i] = y[i];
    previous[i] = y[i];
  }
}

/* What the Kalman filters share: sizes, the measured coordinates and the equilibrium. */
typedef struct {
  int dof;               /* q has dof entries, x = [q; qd] 2 dof */
  int count;             /* measured coordinates */
  const int *measured;   /* their indices in q, ascending (count) */
  const ipgen_real *x_eq; /* the equilibrium (2 dof): the start for the unmeasured angles */
} ipgen_loop_measurement;

/* x_{0|-1}: the measured coordinates at y_0, the others at x_eq, rates 0. */
IPGEN_LOOP_API void ipgen_loop_start_state(const ipgen_loop_measurement *m, const ipgen_real y[], ipgen_real x[]) {
  int i;
  for (i = 0; i < m->dof; ++i) x[i] = m->x_eq[i];
  for (i = m->dof; i < 2 * m->dof; ++i) x[i] = (ipgen_real)0;
  for (i = 0; i < m->count; ++i) x[m->measured[i]] = y[i];
}

/* Steady-state Kalman filter (current form) on the linearisation at (x_eq, u_eq), discretised with
 * the input held: predict xp = x_eq + A (x - x_eq) + B (u_previous - u_eq), update
 * x = xp + M (y - C xp), C selecting the measured coordinates; at k = 0 xp = x_{0|-1}.
 * A (2 dof x 2 dof), B (2 dof), M (2 dof x count). `work`: 2 dof + count entries. */
typedef struct {
  ipgen_loop_measurement measurement;
  const ipgen_real *A, *B, *M;
  ipgen_real u_eq;
} ipgen_loop_kalman;

IPGEN_LOOP_API void ipgen_loop_kalman_update(const ipgen_loop_kalman *f, long k, const ipgen_real y[],
                                             ipgen_real u_previous, ipgen_real x[], ipgen_real work[]) {
  const int n = 2 * f->measurement.dof, c = f->measurement.count;
  const int *measured = f->measurement.measured;
  const ipgen_real *x_eq = f->measurement.x_eq;
  ipgen_real *xp = work, *innovation = work + n;
  int i, j;
  if (k == 0) {
    ipgen_loop_start_state(&f->measurement, y, xp);
  } else {
    const ipgen_real du = u_previous - f->u_eq;
    for (i = 0; i < n; ++i) {
      ipgen_real v = (ipgen_real)0;
      for (j = 0; j < n; ++j) v += f->A[i * n + j] * (x[j] - x_eq[j]);
      xp[i] = x_eq[i] + v + f->B[i] * du;
    }
  }
  for (j = 0; j < c; ++j) innovation[j] = y[j] - xp[measured[j]];
  for (i = 0; i < n; ++i) {
    ipgen_real v = (ipgen_real)0;
    for (j = 0; j < c; ++j) v += f->M[i * c + j] * innovation[j];
    x[i] = xp[i] + v;
  }
}

/* The model an extended Kalman filter predicts with: f = x' = f(x, u) (2 dof entries) at the
 * input u the model sees (the force or torque), and, when A is not null, A = df/dx
 * (2 dof x 2 dof), both in the coordinates of x. Returns 0, non-zero if the model fails there
 * (M(q) not positive definite). */
typedef int (*ipgen_loop_field)(void *context, const ipgen_real x[], ipgen_real u, ipgen_real f[], ipgen_real A[]);

/* One classical Runge-Kutta (RK4) step of length T of x' = f(x, u), the input held: from x
 * (states entries) to x_next (not x); A, when not null, gets df/dx at x (the first slope's).
 * `work`: 5 states entries. Returns 0, 1 if the model failed. */
IPGEN_LOOP_API int ipgen_loop_rk4(ipgen_loop_field field, void *context, int states, ipgen_real T, ipgen_real u,
                                  const ipgen_real x[], ipgen_real x_next[], ipgen_real A[], ipgen_real work[]) {
  ipgen_real *xs = work, *k1 = xs + states, *k2 = k1 + states, *k3 = k2 + states, *k4 = k3 + states;
  int i;
  if (field(context, x, u, k1, A) != 0) return 1;
  for (i = 0; i < states; ++i) xs[i] = x[i] + (ipgen_real)0.5 * T * k1[i];
  if (field(context, xs, u, k2, 0) != 0) return 1;
  for (i = 0; i < states; ++i) xs[i] = x[i] + (ipgen_real)0.5 * T * k2[i];
  if (field(context, xs, u, k3, 0) != 0) return 1;
  for (i = 0; i < states; ++i) xs[i] = x[i] + T * k3[i];
  if (field(context, xs, u, k4, 0) != 0) return 1;
  for (i = 0; i < states; ++i)
    x_next[i] = x[i] + T / (ipgen_real)6 * (k1[i] + (ipgen_real)2 * k2[i] + (ipgen_real)2 * k3[i] + k4[i]);
  return 0;
}

/* A known transport delay compensated: the state `delay` periods after x, when the command the
 * law computes now will act. The commands already sent act until then: pending[1..delay] as
 * ipgen_loop_delay keeps them before this sample's call (oldest first), each over one period.
 * x_ahead (states entries, not x) = x carried by one RK4 step of x' = f(x, gain pending[j]) per
 * period, j = 1..delay (x itself for delay 0). `work`: 6 states entries. Returns 0, 1 if the
 * model failed (x_ahead = x then: the law sees the estimate unpredicted). */
IPGEN_LOOP_API int ipgen_loop_predict(ipgen_loop_field field, void *context, int states, ipgen_real period,
                                      ipgen_real gain, int delay, const ipgen_real pending[], const ipgen_real x[],
                                      ipgen_real x_ahead[], ipgen_real work[]) {
  ipgen_real *next = work;
  int i, j;
  for (i = 0; i < states; ++i) x_ahead[i] = x[i];
  for (j = 1; j <= delay; ++j) {
    if (ipgen_loop_rk4(field, context, states, period, gain * pending[j], x_ahead, next, 0, work + states) != 0) {
      for (i = 0; i < states; ++i) x_ahead[i] = x[i];
      return 1;
    }
    for (i = 0; i < states; ++i) x_ahead[i] = next[i];
  }
  return 0;
}

/* Extended Kalman filter on the nonlinear model: predict with one RK4 step of length `period`
 * of x' = f(x, gain u_previous) and P- = F P F^T + Qn, F = I + T A + (T A)^2 / 2 with A = df/dx
 * at the last estimate; update with K = P- C^T (C P- C^T + Rn)^-1 (Cholesky), x = xp + K (y - C xp),
 * P = (I - K C) P- (I - K C)^T + K Rn K^T (Joseph form), made symmetric. At k = 0: xp = x_{0|-1},
 * P- = identity with Rn's diagonal at the measured coordinates.
 * With gain_spread > 0 it also learns the plant's input gain: x gets one more entry, rho = the
 * plant's force per unit of u over `gain` (a motor's Rm or torque constant unlike the model's),
 * predicted with x' = f(x, rho gain u_previous), rho' = 0 (a random walk). A = df/dx gets the
 * column df/drho = f(x, gain u) - f(x, 0) (f is affine in u) and the row 0; Qn gets
 * gain_drift^2 T for rho; at k = 0 rho = 1 with variance gain_spread^2. rho is kept within
 * [1/2, 2]. x and P then have IPGEN_LOOP_EKF_STATES(dof, 1) entries a side: start x's rho at 1
 * (a filter whose first sample fails predicts with it).
 * With noise_weight > 0 it learns each measured coordinate's noise variance (a rig noisier or
 * quieter than Rn says; Rn diagonal, noise_weight <= 1): noise[r] is an exponential mean, weight
 * noise_weight a sample, of innovation_r^2 - (C P- C^T)_rr (kept >= 0; a non-finite sample
 * leaves it), from Rn_rr / noise_margin at k = 0; each sample after the first uses R = Rn with
 * the diagonal noise_margin noise[r] clamped to [noise_floor[r], noise_ceiling[r]] (the first:
 * Rn) in place of Rn in the update above. */
typedef struct {
  ipgen_loop_measurement measurement;
  ipgen_real period;    /* T [s] */
  ipgen_real gain;      /* force or torque per unit of u (a motor's volts), 1 without */
  const ipgen_real *Qn; /* process noise (2 dof x 2 dof) */
  const ipgen_real *Rn; /* measurement noise (count x count) */
  ipgen_loop_field field;
  void *context;        /* passed to field */
  /* Fields appended over releases: zero the struct, then set them by name. */
  /* > 0: the input gain is learnt (above), rho's standard deviation at the start; 0: not learnt */
  ipgen_real gain_spread;
  ipgen_real gain_drift; /* rho's random walk: its standard deviation grows by this per sqrt(s) */
  /* > 0: the measurement noise is learnt (above), the mean's weight a sample (period / memory) */
  ipgen_real noise_weight;
  ipgen_real noise_margin;           /* the learnt variance's multiple the filter uses */
  const ipgen_real *noise_floor;     /* count entries: the lowest variance used (the encoders') */
  const ipgen_real *noise_ceiling;   /* count entries: the highest variance used */
  ipgen_real *noise;                 /* count entries, the caller's: the learnt variances */
} ipgen_loop_ekf;

/* The entries of an EKF's x: 2 dof, and rho when it learns the input gain (learns: 0 or 1). */
#define IPGEN_LOOP_EKF_STATES(dof, learns) (2 * (dof) + ((learns) ? 1 : 0))

/* Scratch entries ipgen_loop_ekf_update needs for n = IPGEN_LOOP_EKF_STATES states and count = c
 * measured. */
#define IPGEN_LOOP_EKF_WORK(n, c) (6 * (n) + 4 * (n) * (n) + (n) * (c) + 2 * (c) * (c) + 2 * (c))

/* One EKF sample (above): x (n = IPGEN_LOOP_EKF_STATES entries), P (n x n) updated in place;
 * `work` holds IPGEN_LOOP_EKF_WORK(n, count) entries. Returns 0, 1 if the model failed, 2 if the
 * innovation covariance is not positive definite; x, P (and a learnt noise) are unchanged then. */
IPGEN_LOOP_API int ipgen_loop_ekf_update(const ipgen_loop_ekf *e, long k, const ipgen_real y[], ipgen_real u_previous,
                                         ipgen_real x[], ipgen_real P[], ipgen_real work[]) {
  const int m = 2 * e->measurement.dof, learns = e->gain_spread > 0, n = m + learns;
  const int c = e->measurement.count;
  const int *measured = e->measurement.measured;
  const ipgen_real T = e->period;
  ipgen_real *xs = work, *xp = xs + 5 * n; /* xs: ipgen_loop_rk4's 5 n entries */
  ipgen_real *A = xp + n, *F = A + n * n, *W = F + n * n, *Pp = W + n * n;
  ipgen_real *K = Pp + n * n, *S = K + n * c, *v = S + c * c, *innovation = v + c;
  ipgen_real *R = innovation + c; /* Rn, or Rn with the learnt diagonal */
  const int learns_noise = e->noise_weight > 0;
  int i, j, r, col;
  if (k == 0) {
    ipgen_loop_start_state(&e->measurement, y, xp);
    for (i = 0; i < n * n; ++i) Pp[i] = (ipgen_real)0;
    for (i = 0; i < n; ++i) Pp[i * n + i] = (ipgen_real)1;
    for (r = 0; r < c; ++r) Pp[measured[r] * n + measured[r]] = e->Rn[r * c + r];
    if (learns) {
      xp[m] = (ipgen_real)1;
      Pp[m * n + m] = e->gain_spread * e->gain_spread;
    }
  } else {
    const ipgen_real rho = learns ? x[m] : (ipgen_real)1, u = u_previous * e->gain * rho;
    if (ipgen_loop_rk4(e->field, e->context, m, T, u, x, xp, A, xs) != 0) return 1;
    for (i = 0; i < m * m; ++i) A[i] *= T; /* T A (m x m) */
    for (r = 0; r < n; ++r) {              /* F = I + T A + (T A)^2 / 2 */
      for (col = 0; col < n; ++col) {
        ipgen_real sq = (ipgen_real)0;
        if (r < m && col < m) {
          for (j = 0; j < m; ++j) sq += A[r * m + j] * A[j * m + col];
          F[r * n + col] = (ipgen_real)(r == col) + A[r * m + col] + (ipgen_real)0.5 * sq;
        } else {
          F[r * n + col] = (ipgen_real)(r == col);
        }
      }
    }
    if (learns) { /* rho's column of F: T b + (T A) T b / 2, b = df/drho (W as scratch) */
      ipgen_real *b = W, *f0 = W + m; /* f is affine in u: df/drho = f(x, gain u) - f(x, 0) */
      if (e->field(e->context, x, u_previous * e->gain, b, 0) != 0 || e->field(e->context, x, (ipgen_real)0, f0, 0) != 0)
        return 1;
      for (r = 0; r < m; ++r) b[r] = T * (b[r] - f0[r]);
      for (r = 0; r < m; ++r) {
        ipgen_real s = (ipgen_real)0;
        for (j = 0; j < m; ++j) s += A[r * m + j] * b[j];
        F[r * n + m] = b[r] + (ipgen_real)0.5 * s;
      }
      xp[m] = rho;
    }
    for (r = 0; r < n; ++r) {              /* W = F P */
      for (col = 0; col < n; ++col) {
        ipgen_real s = (ipgen_real)0;
        for (j = 0; j < n; ++j) s += F[r * n + j] * P[j * n + col];
        W[r * n + col] = s;
      }
    }
    for (r = 0; r < n; ++r) {              /* P- = W F^T + Qn */
      for (col = 0; col < n; ++col) {
        ipgen_real s = (ipgen_real)0;
        for (j = 0; j < n; ++j) s += W[r * n + j] * F[col * n + j];
        if (r < m && col < m) s += e->Qn[r * m + col];
        else if (r == m && col == m) s += e->gain_drift * e->gain_drift * T;
        Pp[r * n + col] = s;
      }
    }
  }
  for (r = 0; r < c; ++r) innovation[r] = y[r] - xp[measured[r]];
  for (r = 0; r < c * c; ++r) R[r] = e->Rn[r];
  if (learns_noise) { /* the new learnt variances in v (free until K), kept once S factorises */
    for (r = 0; r < c; ++r) {
      ipgen_real used;
      if (k == 0) {
        v[r] = e->Rn[r * c + r] / e->noise_margin;
        continue;
      }
      used = innovation[r] * innovation[r] - Pp[measured[r] * n + measured[r]];
      used = e->noise[r] + e->noise_weight * (used - e->noise[r]);
      if (!(used - used == (ipgen_real)0)) used = e->noise[r]; /* a non-finite sample: kept */
      v[r] = used > (ipgen_real)0 ? used : (ipgen_real)0;
      used = e->noise_margin * v[r];
      if (!(used >= e->noise_floor[r])) used = e->noise_floor[r];
      if (used > e->noise_ceiling[r]) used = e->noise_ceiling[r];
      R[r * c + r] = used;
    }
  }
  /* S = C P- C^T + R, factorised S = L L^T in place (lower triangle) */
  for (r = 0; r < c; ++r)
    for (col = 0; col < c; ++col) S[r * c + col] = Pp[measured[r] * n + measured[col]] + R[r * c + col];
  for (j = 0; j < c; ++j) {
    ipgen_real d = S[j * c + j];
    for (col = 0; col < j; ++col) d -= S[j * c + col] * S[j * c + col];
    if (!(d > (ipgen_real)0)) return 2;
    d = ipgen_loop_sqrt(d);
    S[j * c + j] = d;
    for (r = j + 1; r < c; ++r) {
      ipgen_real s = S[r * c + j];
      for (col = 0; col < j; ++col) s -= S[r * c + col] * S[j * c + col];
      S[r * c + j] = s / d;
    }
  }
  if (learns_noise)
    for (r = 0; r < c; ++r) e->noise[r] = v[r];
  /* K = P- C^T S^-1, row by row: L L^T K_i^T = (P- C^T)_i^T */
  for (i = 0; i < n; ++i) {
    for (r = 0; r < c; ++r) v[r] = Pp[i * n + measured[r]];
    for (r = 0; r < c; ++r) { /* L z = v */
      for (col = 0; col < r; ++col) v[r] -= S[r * c + col] * v[col];
      v[r] /= S[r * c + r];
    }
    for (r = c - 1; r >= 0; --r) { /* L^T k = z */
      for (col = r + 1; col < c; ++col) v[r] -= S[col * c + r] * v[col];
      v[r] /= S[r * c + r];
    }
    for (r = 0; r < c; ++r) K[i * c + r] = v[r];
  }
  for (i = 0; i < n; ++i) {
    ipgen_real s = (ipgen_real)0;
    for (r = 0; r < c; ++r) s += K[i * c + r] * innovation[r];
    x[i] = xp[i] + s;
  }
  if (learns && !(x[m] >= (ipgen_real)0.5)) x[m] = (ipgen_real)0.5; /* NaN too */
  if (learns && x[m] > (ipgen_real)2) x[m] = (ipgen_real)2;
  /* Joseph form, F reused for I - K C */
  for (r = 0; r < n; ++r)
    for (col = 0; col < n; ++col) F[r * n + col] = (ipgen_real)(r == col);
  for (r = 0; r < n; ++r)
    for (j = 0; j < c; ++j) F[r * n + measured[j]] -= K[r * c + j];
  for (r = 0; r < n; ++r) {
    for (col = 0; col < n; ++col) {
      ipgen_real s = (ipgen_real)0;
      for (j = 0; j < n; ++j) s += F[r * n + j] * Pp[j * n + col];
      W[r * n + col] = s;
    }
  }
  for (r = 0; r < n; ++r) {
    for (col = 0; col < n; ++col) {
      ipgen_real s = (ipgen_real)0;
      int a, b;
      for (j = 0; j < n; ++j) s += W[r * n + j] * F[col * n + j];
      for (a = 0; a < c; ++a)
        for (b = 0; b < c; ++b) s += K[r * c + a] * R[a * c + b] * K[col * c + b];
      P[r * n + col] = s;
    }
  }
  for (r = 0; r < n; ++r) /* symmetric to rounding */
    for (col = 0; col < r; ++col) P[r * n + col] = P[col * n + r] = (ipgen_real)0.5 * (P[r * n + col] + P[col * n + r]);
  return 0;
}

/* ---- swing-up --------------------------------------------------------------------------
 * In ipgen's coordinates: q[0] the base, q[1] link 1's absolute angle from upright. */

/* The Åström–Furuta energy law on link 1 (docs/control.md):
 *   E = 1/2 energy_inertia qd1^2 + energy_weight (cos q1 - 1),
 *   a = sat_accel_max(gain_energy (E - energy_target) sign(qd1 M10)) - gain_position q0 - gain_velocity qd0,
 * the base's acceleration; the input is a itself (acceleration), or the force or torque that
 * gives it, M00 a + M01 qdd1 + b0 with qdd1 = -(M10 a + b1) / M11 (M, b the mass matrix and bias
 * at q, qd), divided by input_gain. Caught when |q1 - 2 pi k| <= catch_angle and |qd1| <= catch_rate,
 * and, where set, E >= -catch_deficit and |q0| <= catch_base (ipgen_loop_energy_ready). */
typedef struct {
  ipgen_real gain_energy, gain_position, gain_velocity, accel_max;
  ipgen_real catch_angle, catch_rate, energy_target, energy_inertia, energy_weight;
  int acceleration;      /* 1: the input is the base's acceleration */
  ipgen_real input_gain; /* force or torque per unit of u (a motor's volts): the law's force is divided by it */
  ipgen_real energy_step; /* > 0: energy_target is learnt by steps of it (ipgen_loop_energy_learn); 0: fixed */
  /* > 0: a catch needs E >= -catch_deficit, the link within it of upright's energy (one too slow
   * to reach upright is left to the swing); 0: any E */
  ipgen_real catch_deficit;
  /* > 0: a catch needs |q0| <= catch_base, the base (rad or m) near its centre; 0: anywhere */
  ipgen_real catch_base;
} ipgen_loop_energy_law;

/* The multiple of 2 pi nearest q1 (half-way rounds up). */
IPGEN_LOOP_API ipgen_real ipgen_loop_upright(ipgen_real q1) {
  const ipgen_real two_pi = (ipgen_real)6.283185307179586;
  return two_pi * ipgen_loop_floor(q1 / two_pi + (ipgen_real)0.5);
}

/* 1 if link 1 is caught at (q1, qd1): near the upright 2 pi k and slow enough. */
IPGEN_LOOP_API int ipgen_loop_energy_caught(const ipgen_loop_energy_law *law, ipgen_real q1, ipgen_real qd1) {
  const ipgen_real dev = q1 - ipgen_loop_upright(q1);
  return (dev < 0 ? -dev : dev) <= law->catch_angle && (qd1 < 0 ? -qd1 : qd1) <= law->catch_rate;
}

/* The law's energy E of link 1 at (q1, qd1) [J]: 0 upright at rest. */
IPGEN_LOOP_API ipgen_real ipgen_loop_link_energy(const ipgen_loop_energy_law *law, ipgen_real q1, ipgen_real qd1) {
  return (ipgen_real)0.5 * law->energy_inertia * qd1 * qd1 + law->energy_weight * (ipgen_loop_cos(q1) - (ipgen_real)1);
}

/* 1 if the hold may take x = [q; qd] (2 dof entries): link 1 caught (ipgen_loop_energy_caught),
 * with energy enough to reach upright (catch_deficit) and the base near its centre (catch_base). */
IPGEN_LOOP_API int ipgen_loop_energy_ready(const ipgen_loop_energy_law *law, int dof, const ipgen_real x[]) {
  const ipgen_real base = x[0] < 0 ? -x[0] : x[0];
  if (!ipgen_loop_energy_caught(law, x[1], x[dof + 1])) return 0;
  if (law->catch_deficit > 0 && ipgen_loop_link_energy(law, x[1], x[dof + 1]) < -law->catch_deficit) return 0;
  return !(law->catch_base > 0 && base > law->catch_base);
}

/* The energy law's input at q, qd (above); M (dof x dof) and b (dof) at q, qd; not saturated. */
IPGEN_LOOP_API ipgen_real ipgen_loop_energy_input(const ipgen_loop_energy_law *law, int dof, const ipgen_real q[],
                                                  const ipgen_real qd[], const ipgen_real M[], const ipgen_real b[]) {
  const ipgen_real energy = ipgen_loop_link_energy(law, q[1], qd[1]);
  const ipgen_real direction = qd[1] * M[dof] < 0 ? (ipgen_real)-1 : (ipgen_real)1;
  ipgen_real a = ipgen_loop_saturate(law->gain_energy * (energy - law->energy_target) * direction, law->accel_max);
  ipgen_real qdd1;
  a -= law->gain_position * q[0] + law->gain_velocity * qd[0];
  if (law->acceleration) return a;
  qdd1 = -(M[dof] * a + b[1]) / M[dof + 1];
  return (M[0] * a + M[1] * qdd1 + b[0]) / law->input_gain;
}

/* u = u_ref - K (x - x_ref) over x's 2 dof entries (a tracked plan's step, or the hold's LQR). */
IPGEN_LOOP_API ipgen_real ipgen_loop_feedback(int states, ipgen_real u_ref, const ipgen_real K[], const ipgen_real x[],
                                              const ipgen_real x_ref[]) {
  ipgen_real s = (ipgen_real)0;
  int i;
  for (i = 0; i < states; ++i) s += K[i] * (x[i] - x_ref[i]);
  return u_ref - s;
}

/* The phases of a swing-up: the energy law swings, a plan is tracked, the upright is held. */
enum { IPGEN_LOOP_SWING = 0, IPGEN_LOOP_TRACK = 1, IPGEN_LOOP_HOLD = 2 };

/* The mass matrix M (dof x dof) and bias b (dof) at q, qd, for the energy law. Returns 0. */
typedef int (*ipgen_loop_mass_bias)(void *context, const ipgen_real q[], const ipgen_real qd[], ipgen_real M[],
                                    ipgen_real b[]);

/* A swing-up: the energy law (plan 0) or a plan of `steps` inputs u_k, states x_k ((steps + 1)
 * x 2 dof) and gains K_k (steps x 2 dof) tracked as u = u_k - K_k (x - x_k) (or by a track_law,
 * below); then the hold u = -hold_gain (x - x_hold), x_hold = target with q1 at the caught
 * upright, or a catch_law; |u| <= u_max. */
typedef struct { /* fields are appended over releases: zero it, then set them by name */
  int dof;
  ipgen_real u_max;
  const ipgen_real *hold_gain, *target; /* 2 dof each */
  ipgen_loop_energy_law energy;
  long steps; /* 0: the energy law */
  const ipgen_real *inputs, *states, *gains;
  ipgen_loop_mass_bias mass_bias; /* the energy law's M and b */
  void *context;                  /* passed to mass_bias and feedback */
  /* The plan's and the hold's u_ref - K (x - x_ref) over 2 dof states; null: ipgen_loop_feedback.
   * (ipsim passes the sum its LQR controllers form, so that its runs keep their bits.) */
  ipgen_real (*feedback)(void *context, int states, ipgen_real u_ref, const ipgen_real K[], const ipgen_real x[],
                         const ipgen_real x_ref[]);
  /* Optional: a controller that catches and holds instead of hold_gain (a scene's MPC): its u for
   * x with q1 relative to the caught upright (q1 - 2 pi k), at the catch and every catch_every
   * (>= 1; 0 or less is taken as 1) samples after it, held in between; catch_context is passed to
   * it. Null: the hold's LQR. */
  ipgen_real (*catch_law)(void *catch_context, const ipgen_real x[]);
  void *catch_context;
  long catch_every;
  /* Optional, the energy law only: a hold that lets link 1 fall more than release_angle from the
   * upright it caught gives the pendulum back to the energy law, which swings it up again for
   * another catch (0: the hold is for good). catch_reset (null: none) is called then with
   * catch_context, so that a catch law starts its next catch afresh (the MPC: cold). */
  ipgen_real release_angle;
  void (*catch_reset)(void *catch_context);
  /* Optional, a plan only: the catch law's controller tracks the plan too (a scene's MPC with the
   * plan as its reference per stage, instead of the plan's gains): in the track phase, at k = 0
   * and every catch_every samples, u = track_law(catch_context, x, x_refs, u_refs) with the
   * plan's reference over the next track_horizon of its samples (ipgen_loop_plan_reference,
   * written into track_refs: IPGEN_LOOP_TRACK_REFS(dof, track_horizon) entries, the caller's),
   * held in between; at the plan's end the catch_law holds, its steps on the same grid (a plan
   * of steps not a multiple of catch_every: the last u held to the grid's next sample). Null:
   * the plan's gains. */
  ipgen_real (*track_law)(void *catch_context, const ipgen_real x[], const ipgen_real x_refs[],
                          const ipgen_real u_refs[]);
  int track_horizon;
  ipgen_real *track_refs;
  /* Optional: the plant's input gain over the model's as the loop learns it (an EKF's rho, the
   * entry after its 2 dof states); every u is divided by it, then clipped to u_max, so that the
   * plant gets the force the law asks of the model (a catch or track law's u is clipped to u_max
   * before as well, as without it). Null: 1. */
  const ipgen_real *gain_factor;
} ipgen_loop_swingup;

/* Entries of track_refs: the states (horizon + 1) x 2 dof, then the inputs (horizon). */
#define IPGEN_LOOP_TRACK_REFS(dof, horizon) (((horizon) + 1) * 2 * (dof) + (horizon))

/* The plan's reference for a controller that samples every `every` plan samples from sample k,
 * over `horizon` of its samples: x_refs row j (j = 0..horizon) the plan's state at sample
 * k + j every (its last state, the target, from the plan's end on), u_refs[j] the mean of the
 * plan's inputs over samples k + j every .. k + (j + 1) every - 1 (0 past its end: the input
 * that holds the upright). */
IPGEN_LOOP_API void ipgen_loop_plan_reference(const ipgen_loop_swingup *law, long k, long every, int horizon,
                                              ipgen_real x_refs[], ipgen_real u_refs[]) {
  const int n = 2 * law->dof;
  int j, i;
  if (every < 1) every = 1;
  for (j = 0; j <= horizon; ++j) {
    long m = k + (long)j * every;
    if (m > law->steps) m = law->steps;
    for (i = 0; i < n; ++i) x_refs[j * n + i] = law->states[m * n + i];
  }
  for (j = 0; j < horizon; ++j) {
    ipgen_real sum = (ipgen_real)0;
    long m;
    for (m = k + (long)j * every; m < k + (long)(j + 1) * every; ++m)
      if (m < law->steps) sum += law->inputs[m];
    u_refs[j] = sum / (ipgen_real)every;
  }
}

/* What a swing-up remembers: its phase, the samples seen and the upright held (q1); with a
 * catch_law, the sample of the catch and the u it last gave; with energy_step, what the energy
 * law has learnt (ipgen_loop_energy_learn). */
typedef struct {
  int phase;
  long k;
  ipgen_real hold_q1;
  long hold_sample;
  ipgen_real catch_u;
  ipgen_real energy_offset; /* J, added to energy_target */
  ipgen_real rate_before;   /* qd1 at the last swing sample */
  ipgen_real last_peak;     /* |q1 - 2 pi k| at the last turn short of the catch (0: none) */
  int in_window;            /* 1: the last swing sample was within catch_angle of upright */
  int swinging;             /* 1: |qd1| passed catch_rate since the last turn */
} ipgen_loop_swingup_state;

IPGEN_LOOP_API void ipgen_loop_swingup_start(const ipgen_loop_swingup *law, ipgen_loop_swingup_state *s) {
  s->phase = law->steps > 0 ? IPGEN_LOOP_TRACK : IPGEN_LOOP_SWING;
  s->k = 0;
  s->hold_q1 = law->target[1];
  s->hold_sample = 0;
  s->catch_u = (ipgen_real)0;
  s->energy_offset = s->rate_before = s->last_peak = (ipgen_real)0;
  s->in_window = s->swinging = 0;
}

/* The energy law's target learnt from the swing (law->energy_step > 0; the law then pumps to
 * energy_target + s->energy_offset). A law whose model is not its rig settles on a swing that
 * whirls past the catch (a lighter pendulum, a stronger motor) or turns short of it, because its
 * E weighs speed and height in the model's ratio. So at a swing sample (x: q1, qd1):
 * - entering the catch angle faster than catch_rate lowers the target by energy_step (the law
 *   then brakes, and the link may still slow to the catch rate inside the window and be caught);
 * - a turn of link 1 (qd1 changes sign, counted once: |qd1| must pass catch_rate in between)
 *   short of the catch angle and above the horizontal, no nearer upright than the last such turn
 *   by more than a tenth of the catch angle (the swing has stopped growing; the margin takes the
 *   sampling's jitter of a turn's angle) raises it by energy_step.
 * The offset stays within +-2 energy_weight (E's range from hanging to upright). */
IPGEN_LOOP_API void ipgen_loop_energy_learn(const ipgen_loop_energy_law *law, ipgen_loop_swingup_state *s,
                                            ipgen_real q1, ipgen_real qd1) {
  const ipgen_real dev = q1 - ipgen_loop_upright(q1);
  const ipgen_real off = dev < 0 ? -dev : dev, rate = qd1 < 0 ? -qd1 : qd1;
  const ipgen_real limit = (ipgen_real)2 * law->energy_weight;
  const int in_window = off <= law->catch_angle;
  if (in_window && !s->in_window && rate > law->catch_rate) s->energy_offset -= law->energy_step;
  s->in_window = in_window;
  if (rate > law->catch_rate) s->swinging = 1;
  if (s->swinging && qd1 * s->rate_before < 0) { /* a turn */
    s->swinging = 0;
    if (!in_window && off < (ipgen_real)1.5707963267948966) {
      const ipgen_real margin = (ipgen_real)0.1 * law->catch_angle;
      if (s->last_peak > 0 && off >= s->last_peak - margin) s->energy_offset += law->energy_step;
      s->last_peak = off;
    } else {
      s->last_peak = (ipgen_real)0;
    }
  }
  if (qd1 != 0) s->rate_before = qd1; /* a rate read as exactly 0 (quantised) does not hide a turn */
  if (s->energy_offset > limit) s->energy_offset = limit;
  if (s->energy_offset < -limit) s->energy_offset = -limit;
}

/* Scratch entries ipgen_loop_swingup_step needs. */
#define IPGEN_LOOP_SWINGUP_WORK(dof) ((dof) * (dof) + 3 * (dof))

/* The input at sample s->k for x = [q; qd] (ipgen's coordinates), saturated; advances s.
 * `work`: IPGEN_LOOP_SWINGUP_WORK(dof) entries. */
IPGEN_LOOP_API ipgen_real ipgen_loop_swingup_step(const ipgen_loop_swingup *law, ipgen_loop_swingup_state *s,
                                                  const ipgen_real x[], ipgen_real work[]) {
  const int dof = law->dof;
  ipgen_real u = (ipgen_real)0;
  if (s->phase == IPGEN_LOOP_HOLD && law->steps == 0 && law->release_angle > 0) { /* released: swing again */
    const ipgen_real dev = x[1] - s->hold_q1;
    if ((dev < 0 ? -dev : dev) > law->release_angle) {
      s->phase = IPGEN_LOOP_SWING;
      s->rate_before = s->last_peak = (ipgen_real)0; /* the learning starts afresh, its offset kept */
      s->in_window = s->swinging = 0;
      if (law->catch_reset) law->catch_reset(law->catch_context);
    }
  }
  if (s->phase == IPGEN_LOOP_TRACK) {
    if (s->k < law->steps && law->track_law) { /* the controller tracks the plan, every catch_every */
      const long every = law->catch_every <= 1 ? 1 : law->catch_every;
      if (s->k % every == 0) {
        ipgen_real *x_refs = law->track_refs, *u_refs = law->track_refs + (law->track_horizon + 1) * 2 * dof;
        ipgen_loop_plan_reference(law, s->k, every, law->track_horizon, x_refs, u_refs);
        s->catch_u = ipgen_loop_saturate(law->track_law(law->catch_context, x, x_refs, u_refs), law->u_max);
      }
      u = s->catch_u;
    } else if (s->k < law->steps) {
      const ipgen_real *K = law->gains + s->k * 2 * dof, *x_ref = law->states + s->k * 2 * dof;
      u = law->feedback ? law->feedback(law->context, 2 * dof, law->inputs[s->k], K, x, x_ref)
                        : ipgen_loop_feedback(2 * dof, law->inputs[s->k], K, x, x_ref);
    } else {
      s->phase = IPGEN_LOOP_HOLD;
      s->hold_sample = s->k;
      if (law->track_law && law->catch_every > 1) /* the hold's steps stay on the tracking's grid */
        s->hold_sample -= s->k % law->catch_every;
    }
  } else if (s->phase == IPGEN_LOOP_SWING) {
    if (ipgen_loop_energy_ready(&law->energy, dof, x)) {
      s->phase = IPGEN_LOOP_HOLD;
      s->hold_q1 = ipgen_loop_upright(x[1]);
      s->hold_sample = s->k;
    } else {
      ipgen_real *M = work, *b = work + dof * dof;
      if (law->mass_bias(law->context, x, x + dof, M, b) != 0) {
        u = (ipgen_real)0;
      } else {
        ipgen_loop_energy_law learnt = law->energy;
        if (law->energy.energy_step > 0) ipgen_loop_energy_learn(&law->energy, s, x[1], x[dof + 1]);
        learnt.energy_target += s->energy_offset;
        u = ipgen_loop_energy_input(&learnt, dof, x, x + dof, M, b);
      }
    }
  }
  if (s->phase == IPGEN_LOOP_HOLD && law->catch_law) {
    if (law->catch_every <= 1 || (s->k - s->hold_sample) % law->catch_every == 0) {
      ipgen_real *relative = work + dof * dof + dof;
      int i;
      for (i = 0; i < 2 * dof; ++i) relative[i] = x[i];
      relative[1] -= s->hold_q1;
      s->catch_u = ipgen_loop_saturate(law->catch_law(law->catch_context, relative), law->u_max);
    }
    u = s->catch_u;
  } else if (s->phase == IPGEN_LOOP_HOLD) {
    ipgen_real *reference = work + dof * dof + dof;
    int i;
    for (i = 0; i < 2 * dof; ++i) reference[i] = law->target[i];
    reference[1] = s->hold_q1;
    u = law->feedback ? law->feedback(law->context, 2 * dof, (ipgen_real)0, law->hold_gain, x, reference)
                      : ipgen_loop_feedback(2 * dof, (ipgen_real)0, law->hold_gain, x, reference);
  }
  s->k += 1;
  if (s->k >= IPGEN_LOOP_COUNT_CAP && s->phase != IPGEN_LOOP_TRACK) {
    /* Moved back past the plan by whole catch periods (k itself counts only in the track phase),
     * the samples since the catch kept modulo catch_every: the hold's cadence goes on, and k
     * never overflows (also when a caller sets k from its own clock each sample, as ipgen's
     * simulator does). */
    const long every = law->catch_every <= 1 ? 1 : law->catch_every;
    const long since = (s->k - s->hold_sample) % every;
    s->k = (law->steps / every + 1) * every + s->k % every;
    s->hold_sample = s->k - since;
  }
  if (law->gain_factor && *law->gain_factor > 0) u /= *law->gain_factor;
  return ipgen_loop_saturate(u, law->u_max);
}

#ifdef __cplusplus
}
#endif

#endif /* IPGEN_LOOP_H_INCLUDED */
