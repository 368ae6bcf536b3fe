/* ipgen_mpc.h: constrained nonlinear model predictive control, written once (C99, also valid C++).
 *
 * One function, ipgen_mpc_step, takes the current state estimate and returns the input u
 * (ipgen_mpc_track: the same about a reference per stage, a plan to track). It solves (once per
 * sample, or to convergence) the optimal-control problem over N samples of length T (docs/mpc.md):
 *
 *   minimise   sum_{k=0}^{N-1} [ (x_k - x_ref)' Q (x_k - x_ref) + (u_k - u_ref)' R (u_k - u_ref) ]
 *              + (x_N - x_ref)' P (x_N - x_ref) + sum_{k=1}^{N} sum_soft (rho1 s + rho2 s^2)
 *              (x_ref, u_ref the settings', or per stage x_ref_k, u_ref_k: ipgen_mpc_track, a plan)
 *   subject to x_0 = the estimate,  x_{k+1} = F(x_k, u_k)  (RK4 of x' = f(x, u), u held over T),
 *              u_min <= u_k <= u_max,  hard_min <= x_k[hard] <= hard_max (k = 1..N),
 *              soft_min - s <= x_k[soft] <= soft_max + s, s >= 0 (one s per side, stage, bound),
 *
 * by sequential quadratic programming in multiple shooting: F and its exact sensitivities dF/dx,
 * dF/du (the chain rule through the RK4 stages, with the model's exact Jacobians) linearise the
 * dynamics about the guess; the QPs' Hessian is the cost's (Gauss-Newton) or, optionally, the
 * Lagrangian's (exact_hessian); each QP is solved by a primal-dual interior-point method
 * (Mehrotra predictor-corrector) whose Newton systems are solved by a Riccati recursion (O(N) in
 * the horizon). Real-time iteration: one SQP iteration per sample (sqp_iterations = 1) on the
 * previous solution shifted by one sample, a fixed budget of interior-point iterations: a
 * bounded, deterministic time per step. With a method (ipgen_mpc_method, ipgen_mpc_track_method)
 * of barrier weight kappa > 0, each QP is instead Newton's method on its log-barrier problem at
 * that fixed weight, continued from the previous sample's slacks and multipliers (shifted as the
 * trajectory is), one Riccati solve an iteration and no predictor: qp_iterations = 1 is one
 * factorisation a sample (the microcontroller's step); its frozen sensitivities take the model's
 * Jacobians at each stage's start (from the second stage on), one a stage; shifted ones keep the
 * last sample's stage Jacobians, shifted as the trajectory is, and compute the model's Jacobians
 * at the first and the last stage only. Converged mode: up to
 * sqp_iterations iterations, with a line search, until the step and the dynamics' defects are
 * below sqp_tolerance.
 *
 * Sizes are given at run time (nx states, nu inputs, horizon N). Nothing is allocated: the
 * caller owns every array, among them one workspace of IPGEN_MPC_WORK(...) reals (plus
 * IPGEN_MPC_WORK_HESSIAN(...) with exact_hessian; ipgen_mpc_work_size) that keeps the warm start
 * between calls. Only <math.h> is called. The scalar is IPGEN_MPC_REAL (double unless
 * defined before the first include, e.g. float on a Cortex-M4F). Vectors are arrays, matrices
 * row-major. The model enters as a callback (ipgen_mpc_dynamics): x' = f(x, u) and its exact
 * Jacobians, in whatever units and coordinates the caller uses (ipgen's: docs/model.md).
 */
#ifndef IPGEN_MPC_H_INCLUDED
#define IPGEN_MPC_H_INCLUDED

#include <math.h>

/* The MPC's guards against a state or a solution that is not finite (a glitch:
 * the command would be NaN or +-inf at the drive) compare values with themselves, which
 * -ffast-math and -ffinite-math-only fold to true: refused there, unless the caller accepts it. */
#if defined(__FINITE_MATH_ONLY__) && __FINITE_MATH_ONLY__ && !defined(IPGEN_ALLOW_FINITE_MATH) && \
    !defined(IPGEN_FINITE_MATH_REFUSED)
#define IPGEN_FINITE_MATH_REFUSED /* said once where both runtimes are printed */
#error "ipgen: compiled with -ffast-math or -ffinite-math-only, under which the checks for NaN and inf of ipgen's loop and MPC fold away (a glitch could reach the drive as a command at its limit): compile without them, add -fno-finite-math-only, or define IPGEN_ALLOW_FINITE_MATH to accept that"
#endif

#ifndef IPGEN_MPC_REAL
#define IPGEN_MPC_REAL double
#endif

/* Static inline where a header is included; exported where ipgen compiles the library for ctypes. */
#ifdef IPGEN_MPC_EXPORT
#define IPGEN_MPC_API
#else
#define IPGEN_MPC_API static inline
#endif
#define IPGEN_MPC_LOCAL static inline

/* Sizes fixed at compile time: defined before the first include (IPGEN_MPC_NX, IPGEN_MPC_NU,
 * IPGEN_MPC_N, IPGEN_MPC_HARD, IPGEN_MPC_SOFT: a firmware's build, as the C header of a scene
 * with an MPC defines them), every loop over the sizes has constant bounds (the compiler unrolls
 * and strength-reduces them) and ipgen_mpc_check refuses settings of other sizes; undefined (the
 * simulator, Python), the settings' sizes are read at run time. The same code either way, but for
 * the fixed-size forms of IPGEN_MPC_FIXED below. */
#ifdef IPGEN_MPC_NX
#define IPGEN_MPC_NX_OF(s) ((void)(s), IPGEN_MPC_NX)
#else
#define IPGEN_MPC_NX_OF(s) ((s)->nx)
#endif
#ifdef IPGEN_MPC_NU
#define IPGEN_MPC_NU_OF(s) ((void)(s), IPGEN_MPC_NU)
#else
#define IPGEN_MPC_NU_OF(s) ((s)->nu)
#endif
#ifdef IPGEN_MPC_N
#define IPGEN_MPC_N_OF(s) ((void)(s), IPGEN_MPC_N)
#else
#define IPGEN_MPC_N_OF(s) ((s)->N)
#endif
#ifdef IPGEN_MPC_HARD
#define IPGEN_MPC_HARD_OF(s) ((void)(s), IPGEN_MPC_HARD)
#else
#define IPGEN_MPC_HARD_OF(s) ((s)->hard_count)
#endif
/* One input fixed at compile time: the Riccati recursion's Re = 2R + diag + B' P B is a number,
 * inverted once per stage instead of factorised (the runtime path keeps its Cholesky factor). */
#if defined(IPGEN_MPC_NU) && IPGEN_MPC_NU == 1
#define IPGEN_MPC_SCALAR_INPUT 1
#else
#define IPGEN_MPC_SCALAR_INPUT 0
#endif
#ifdef IPGEN_MPC_SOFT
#define IPGEN_MPC_SOFT_OF(s) ((void)(s), IPGEN_MPC_SOFT)
#else
#define IPGEN_MPC_SOFT_OF(s) ((s)->soft_count)
#endif
/* Every size fixed and one input (what a scene's C header prints): the step's hot parts have a
 * second form on local arrays (RK4's sensitivities, the gradient, the residual, the Riccati
 * recursion) and the interior point's passes over the inequalities are specialised (their layout
 * walked stage by stage, passes fused, one division per inequality and iteration: ipgen_mpc_qp's
 * second form). The same algorithm; its rounding differs from the run-time forms'. Other fixed
 * sizes (more inputs) use the run-time forms with constant bounds. */
#if defined(IPGEN_MPC_NX) && defined(IPGEN_MPC_NU) && defined(IPGEN_MPC_N) && defined(IPGEN_MPC_HARD) && \
    defined(IPGEN_MPC_SOFT) && IPGEN_MPC_SCALAR_INPUT
#define IPGEN_MPC_FIXED 1
#endif

#ifdef __cplusplus
extern "C" {
#endif

typedef IPGEN_MPC_REAL ipgen_mpc_real;

/* The model: f = x' = f(x, u) (nx entries) and, when A and B are not null, A = df/dx (nx x nx)
 * and B = df/du (nx x nu), at the state x (nx) and input u (nu), in the caller's units (time in
 * seconds). Returns 0, non-zero if the model fails there (M(q) not positive definite). */
typedef int (*ipgen_mpc_dynamics)(void *context, const ipgen_mpc_real x[], const ipgen_mpc_real u[],
                                  ipgen_mpc_real f[], ipgen_mpc_real A[], ipgen_mpc_real B[]);

/* The problem and the solver's budget (the header's comment). Every array is the caller's and is
 * read, never written. Q, P: nx x nx symmetric positive semidefinite; R: nu x nu positive
 * definite; the bounds: u_min < u_max (nu each, finite), hard and soft bounds on the state
 * entries hard_index[0..hard_count) and soft_index[0..soft_count) (min < max; soft_linear >= 0,
 * soft_quadratic > 0 per soft bound: the penalty rho1 s + rho2 s^2 of a violation s). */
typedef struct {
  int nx, nu, N;                /* states, inputs, horizon (samples) */
  ipgen_mpc_real period;        /* T [s]: the sample period, u held over it */
  int substeps;                 /* RK4 steps per sample (>= 1) */
  ipgen_mpc_dynamics dynamics;  /* the model */
  void *context;                /* passed to dynamics */
  const ipgen_mpc_real *Q, *R, *P, *x_ref, *u_ref;
  const ipgen_mpc_real *u_min, *u_max;
  int hard_count;
  const int *hard_index;
  const ipgen_mpc_real *hard_min, *hard_max;
  int soft_count;
  const int *soft_index;
  const ipgen_mpc_real *soft_min, *soft_max, *soft_linear, *soft_quadratic;
  int sqp_iterations;           /* SQP iterations per step at most: 1 is the real-time iteration */
  ipgen_mpc_real sqp_tolerance; /* stop when max |step| and max |defect| <= it (0: run the budget) */
  int qp_iterations;            /* interior-point iterations per QP at most */
  ipgen_mpc_real qp_tolerance;  /* stop when the QP's residuals and gap are <= it */
  int shift;                    /* 1: a warm start is shifted by one sample first (a loop); 0: not */
  int line_search;              /* 1: backtrack on the l1 merit function (converged mode); 0: full steps */
  int cold_iterations;          /* SQP iterations at most on a cold start (the first step), if more */
  int exact_hessian;            /* 1: the Lagrangian's Hessian (central differences of the exact
                                 * sensitivities) from the second SQP iteration on, Gauss-Newton where
                                 * its Riccati recursion breaks down; 0: Gauss-Newton. Needs
                                 * IPGEN_MPC_WORK_HESSIAN more workspace; for double */
} ipgen_mpc_settings;

/* How a step solves, beyond the settings (ipgen_mpc_track_method; null or all zero: the interior
 * point to qp_tolerance on RK4's exact sensitivities, which is ipgen_mpc_track). A struct of its
 * own so that a caller's ipgen_mpc_settings keeps its fields. For the real-time iteration. */
typedef struct {
  ipgen_mpc_real barrier; /* 0: each QP by Mehrotra's interior point to qp_tolerance; > 0: the QP's log-barrier
                           * problem at this fixed weight (the cost's units), qp_iterations Newton steps
                           * from the last sample's slacks and multipliers, shifted (a cold start: from
                           * its central path, up to IPGEN_MPC_COLD_QP_ITERATIONS); the budget reached is OK */
  int sensitivities;      /* IPGEN_MPC_EXACT: dF/dx, dF/du of the RK4 map (the chain rule through its
                           * stages); IPGEN_MPC_FROZEN: from the second stage on, the model's Jacobians
                           * at the stage's start discretised as RK4 discretises a linear model (one
                           * Jacobian a stage instead of 4 a substep); the first stage's exact (the input
                           * applied and x_1's bounds rest on it); the defects F(x, u) - x' stay exact.
                           * IPGEN_MPC_SHIFTED: as FROZEN, but a warm, shifted step's first linearisation
                           * keeps stages 1 .. N-2's A and B from the last sample's stages 2 .. N-1 (the
                           * trajectory moves by one sample; their defects are new), computes stage 0's
                           * exactly and stage N-1's frozen: the model's Jacobians at those two stages
                           * only (4 a substep for stage 0's exact sensitivities, 1 for stage N-1's) */
} ipgen_mpc_method;

enum { IPGEN_MPC_EXACT = 0, IPGEN_MPC_FROZEN = 1, IPGEN_MPC_SHIFTED = 2 };

/* What a step did. */
typedef struct {
  int status;                 /* IPGEN_MPC_OK or one of the codes below */
  int sqp_iterations;         /* SQP iterations done */
  int qp_iterations;          /* interior-point iterations, summed over them */
  ipgen_mpc_real step;        /* max |(dx, du)| of the last SQP iteration */
  ipgen_mpc_real defect;      /* max |F(x_k, u_k) - x_{k+1}| at the last linearisation */
  ipgen_mpc_real qp_residual; /* the last QP's largest residual (relative stationarity, primal, gap) */
} ipgen_mpc_info;

enum {
  IPGEN_MPC_OK = 0,
  IPGEN_MPC_MODEL_FAILED = 1, /* the model failed: u is the warm start's, the next step starts cold */
  IPGEN_MPC_QP_BUDGET = 2,    /* the last QP stopped above qp_tolerance: its budget, or a late breakdown (u applied) */
  IPGEN_MPC_SQP_BUDGET = 3,   /* sqp_tolerance > 0 not reached within sqp_iterations (u applied) */
  IPGEN_MPC_NOT_FINITE = 4,   /* a QP's Riccati recursion broke down or produced NaN, or a QP diverged
                               * with no hard state bound to be infeasible against: as MODEL_FAILED */
  IPGEN_MPC_BAD_SETTINGS = 5, /* a size or a bound that no problem has: nothing done, u = u_ref */
  IPGEN_MPC_INFEASIBLE = 6    /* a QP diverged with hard state bounds (no solution: one the prediction cannot
                               * meet): the guess is kept, its first input applied; soft bounds avoid it */
};

/* With a barrier weight, a cold start's QPs take up to this many Newton steps (to qp_tolerance),
 * if qp_iterations is fewer: the real-time iteration starts from solved QPs. */
#define IPGEN_MPC_COLD_QP_ITERATIONS 20

/* Inequalities and soft slacks of the QP: N (2 nu + 2 hard + 4 soft), 2 N soft. */
#define IPGEN_MPC_INEQUALITIES(nu, N, hard, soft) ((N) * (2 * (nu) + 2 * (hard) + 4 * (soft)))
#define IPGEN_MPC_SLACKS(N, soft) (2 * (N) * (soft))
/* QP variables: the state deviations x_0..x_N and the input deviations u_0..u_{N-1}. */
#define IPGEN_MPC_VARIABLES(nx, nu, N) (((N) + 1) * (nx) + (N) * (nu))

/* Workspace entries (reals) for nx states, nu inputs, horizon N, `hard` hard and `soft` soft
 * state bounds. Entry 0 says whether a warm start is held; entries 1 .. 1 + (N + 1) nx are the
 * predicted states x_0..x_N, followed by the N nu inputs u_0..u_{N-1}. */
#define IPGEN_MPC_WORK(nx, nu, N, hard, soft)                                                                   \
  (1 + 6 * IPGEN_MPC_VARIABLES(nx, nu, N) + (N) * ((nx) * (nx) + (nx) * (nu) + (nx)) +                       \
   4 * IPGEN_MPC_SLACKS(N, soft) + 8 * IPGEN_MPC_INEQUALITIES(nu, N, hard, soft) +                            \
   (N) * ((nu) * (nx) + (nu) * (nu) + (nu)) + 3 * (nx) * (nx) + 2 * (nx) + 2 * (nu) * (nx) + (nu) * (nu) +    \
   (nu) + (nx) * (nx) + (nx) * (nu) + 4 * (nx) + 4 * (nx) * ((nx) + (nu)))

/* Workspace entries added when exact_hessian is set: the stage Hessians (N (nx + nu)^2), the
 * dynamics' multipliers (N nx) and the differences' temporaries. */
#define IPGEN_MPC_WORK_HESSIAN(nx, nu, N) \
  ((N) * ((nx) + (nu)) * ((nx) + (nu)) + (N) * (nx) + 2 * ((nx) + (nu)) + (nx) * (nx) + (nx) * (nu))

/* The workspace's parts (pointers into it), carved by ipgen_mpc_layout. */
typedef struct {
  ipgen_mpc_real *warm;                       /* 1: whether traj holds a warm start */
  ipgen_mpc_real *traj;                       /* x_0..x_N then u_0..u_{N-1}: the guess, then the solution */
  ipgen_mpc_real *A, *B, *d;                  /* dF/dx, dF/du, F(x_k, u_k) - x_{k+1} per stage */
  ipgen_mpc_real *z, *dir, *hd, *gl, *rhs;    /* QP variables, Newton direction, Hessian diagonal, gradients */
  ipgen_mpc_real *nu_tmp;                     /* adjoint, (N + 1) nx + N nu (only nx used at a time) */
  ipgen_mpc_real *sig, *dsig, *hs, *gs;       /* soft slacks, their step, reduced curvature and gradient */
  ipgen_mpc_real *t, *lam, *dt, *dlam, *rp, *rc; /* inequality slacks, multipliers, steps, residuals */
  ipgen_mpc_real *code, *bound;               /* per inequality: a (var + 1) (0: a slack's), its bound */
  ipgen_mpc_real *K, *L, *kff;                /* Riccati gains, Cholesky factors, feedforward */
  ipgen_mpc_real *Pm, *Pn, *AtP, *p, *pn, *BtP, *Se, *Re, *g; /* Riccati temporaries */
  ipgen_mpc_real *Ac, *Bc, *xt, *k, *ksum, *xn, *S, *Ss, *dk, *dksum; /* RK4 temporaries */
  ipgen_mpc_real *H, *costate, *fd_w, *fd_g, *fd_A, *fd_B; /* exact Hessian (null without) */
  int exact;                                  /* the QP at hand uses H (else 2Q, 2R: Gauss-Newton) */
  int qp_budget;                              /* the QP's iterations at most (ipgen_mpc_track sets it) */
  ipgen_mpc_real barrier;                     /* the method's (0: the interior point) */
  int frozen;                                 /* frozen sensitivities from the second stage on (the method's
                                               * IPGEN_MPC_FROZEN, or a stage IPGEN_MPC_SHIFTED computes) */
  int duals_warm;                             /* the QP starts from t and lam as they are (the barrier's
                                               * warm start: the last sample's, shifted) */
  const ipgen_mpc_real *x_refs, *u_refs;      /* a reference per stage (ipgen_mpc_track), or null */
} ipgen_mpc_layout;

/* The reference of stage k: row k of x_refs ((N + 1) x nx) or u_refs (N x nu) when given, else
 * the settings' x_ref or u_ref. */
#define IPGEN_MPC_X_REF(s, x_refs, k, nx) ((x_refs) ? (x_refs) + (long)(k) * (nx) : (s)->x_ref)
#define IPGEN_MPC_U_REF(s, u_refs, k, nu) ((u_refs) ? (u_refs) + (long)(k) * (nu) : (s)->u_ref)

/* Carves `work` into its parts; returns the entries used (ipgen_mpc_work_size). */
IPGEN_MPC_API long ipgen_mpc_carve(const ipgen_mpc_settings *s, ipgen_mpc_real work[], ipgen_mpc_layout *l) {
  const int nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s), N = IPGEN_MPC_N_OF(s), nz = nx + nu;
  const long Z = IPGEN_MPC_VARIABLES(nx, nu, N), M = IPGEN_MPC_INEQUALITIES(nu, N, IPGEN_MPC_HARD_OF(s), IPGEN_MPC_SOFT_OF(s));
  const long S = IPGEN_MPC_SLACKS(N, IPGEN_MPC_SOFT_OF(s));
  ipgen_mpc_real *w = work;
#define IPGEN_MPC_TAKE(field, count) (l->field = w, w += (count))
  l->x_refs = l->u_refs = 0;
  l->qp_budget = s->qp_iterations;
  l->barrier = (ipgen_mpc_real)0;
  l->frozen = l->duals_warm = 0;
  IPGEN_MPC_TAKE(warm, 1);
  IPGEN_MPC_TAKE(traj, Z);
  IPGEN_MPC_TAKE(A, (long)N * nx * nx);
  IPGEN_MPC_TAKE(B, (long)N * nx * nu);
  IPGEN_MPC_TAKE(d, (long)N * nx);
  IPGEN_MPC_TAKE(z, Z);
  IPGEN_MPC_TAKE(dir, Z);
  IPGEN_MPC_TAKE(hd, Z);
  IPGEN_MPC_TAKE(gl, Z);
  IPGEN_MPC_TAKE(rhs, Z);
  IPGEN_MPC_TAKE(sig, S);
  IPGEN_MPC_TAKE(dsig, S);
  IPGEN_MPC_TAKE(hs, S);
  IPGEN_MPC_TAKE(gs, S);
  IPGEN_MPC_TAKE(t, M);
  IPGEN_MPC_TAKE(lam, M);
  IPGEN_MPC_TAKE(dt, M);
  IPGEN_MPC_TAKE(dlam, M);
  IPGEN_MPC_TAKE(rp, M);
  IPGEN_MPC_TAKE(rc, M);
  IPGEN_MPC_TAKE(code, M);
  IPGEN_MPC_TAKE(bound, M);
  IPGEN_MPC_TAKE(K, (long)N * nu * nx);
  IPGEN_MPC_TAKE(L, (long)N * nu * nu);
  IPGEN_MPC_TAKE(kff, (long)N * nu);
  IPGEN_MPC_TAKE(Pm, nx * nx);
  IPGEN_MPC_TAKE(Pn, nx * nx);
  IPGEN_MPC_TAKE(AtP, nx * nx);
  IPGEN_MPC_TAKE(p, nx);
  IPGEN_MPC_TAKE(pn, nx);
  IPGEN_MPC_TAKE(BtP, nu * nx);
  IPGEN_MPC_TAKE(Se, nu * nx);
  IPGEN_MPC_TAKE(Re, nu * nu);
  IPGEN_MPC_TAKE(g, nu);
  IPGEN_MPC_TAKE(Ac, nx * nx);
  IPGEN_MPC_TAKE(Bc, nx * nu);
  IPGEN_MPC_TAKE(xt, nx);
  IPGEN_MPC_TAKE(k, nx);
  IPGEN_MPC_TAKE(ksum, nx);
  IPGEN_MPC_TAKE(xn, nx);
  IPGEN_MPC_TAKE(S, nx * nz);
  IPGEN_MPC_TAKE(Ss, nx * nz);
  IPGEN_MPC_TAKE(dk, nx * nz);
  IPGEN_MPC_TAKE(dksum, nx * nz);
  l->H = l->costate = l->fd_w = l->fd_g = l->fd_A = l->fd_B = 0;
  if (s->exact_hessian) {
    IPGEN_MPC_TAKE(H, (long)N * nz * nz);
    IPGEN_MPC_TAKE(costate, (long)N * nx);
    IPGEN_MPC_TAKE(fd_w, nz);
    IPGEN_MPC_TAKE(fd_g, nz);
    IPGEN_MPC_TAKE(fd_A, nx * nx);
    IPGEN_MPC_TAKE(fd_B, nx * nu);
  }
#undef IPGEN_MPC_TAKE
  l->exact = 0;
  l->nu_tmp = l->rhs; /* the adjoint pass runs before rhs is formed (the fixed forms keep theirs local) */
  return (long)(w - work);
}

/* Workspace entries for these settings: IPGEN_MPC_WORK of its sizes (+ IPGEN_MPC_WORK_HESSIAN with
 * exact_hessian). */
IPGEN_MPC_API long ipgen_mpc_work_size(const ipgen_mpc_settings *s) {
  const long nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s), N = IPGEN_MPC_N_OF(s);
  return (long)IPGEN_MPC_WORK(nx, nu, N, (long)IPGEN_MPC_HARD_OF(s), (long)IPGEN_MPC_SOFT_OF(s)) +
         (s->exact_hessian ? (long)IPGEN_MPC_WORK_HESSIAN(nx, nu, N) : 0L);
}

/* sqrt in the precision of ipgen_mpc_real (sqrtf for float: no double arithmetic on an FPU of
 * single precision; the sizeof test is a compile-time constant). */
IPGEN_MPC_LOCAL ipgen_mpc_real ipgen_mpc_sqrt(ipgen_mpc_real v) {
  return sizeof(ipgen_mpc_real) == sizeof(float) ? (ipgen_mpc_real)sqrtf((float)v) : (ipgen_mpc_real)sqrt((double)v);
}
/* |v| by fabsf or fabs (one instruction on an FPU: v < 0 ? -v : v is a compare and a branch). */
IPGEN_MPC_LOCAL ipgen_mpc_real ipgen_mpc_abs(ipgen_mpc_real v) {
  return sizeof(ipgen_mpc_real) == sizeof(float) ? (ipgen_mpc_real)fabsf((float)v) : (ipgen_mpc_real)fabs((double)v);
}
IPGEN_MPC_LOCAL ipgen_mpc_real ipgen_mpc_max(ipgen_mpc_real a, ipgen_mpc_real b) { return a < b ? b : a; }
IPGEN_MPC_LOCAL int ipgen_mpc_finite(ipgen_mpc_real v) { return v == v && v - v == v - v; }

/* ---- discretisation: RK4 and its exact sensitivities ------------------------------------- */

/* The rows of Ac that are [0 I] (and of Bc that are 0), copied instead of multiplied: nx / 2 with
 * IPGEN_MPC_SECOND_ORDER (defined before the first include: a model x = [q; qd], f = [qd; qdd],
 * as every ipgen model's callback), else none. */
#ifdef IPGEN_MPC_SECOND_ORDER
#define IPGEN_MPC_COPIED_ROWS(nx) ((nx) / 2)
#else
#define IPGEN_MPC_COPIED_ROWS(nx) 0
#endif

/* dk = Ac Sv + [0 | Bc] (nx x (nx + nu)): the sensitivity of one RK4 stage's slope; the
 * IPGEN_MPC_COPIED_ROWS rows of dk are Sv's last ones, copied: the same numbers. */
IPGEN_MPC_LOCAL void ipgen_mpc_stage_sensitivity(int nx, int nu, const ipgen_mpc_real Ac[], const ipgen_mpc_real Bc[],
                                                 const ipgen_mpc_real Sv[], ipgen_mpc_real dk[]) {
  const int nz = nx + nu, first = IPGEN_MPC_COPIED_ROWS(nx);
  int i, j, m;
  for (i = 0; i < first * nz; ++i) dk[i] = Sv[first * nz + i];
  for (i = first; i < nx; ++i) {
    for (j = 0; j < nz; ++j) {
      ipgen_mpc_real v = j < nx ? (ipgen_mpc_real)0 : Bc[i * nu + (j - nx)];
      for (m = 0; m < nx; ++m) v += Ac[i * nx + m] * Sv[m * nz + j];
      dk[i * nz + j] = v;
    }
  }
}


/* P = Ac X (nx x cols, X row-major with `cols` columns); its IPGEN_MPC_COPIED_ROWS rows are X's
 * last ones, copied. */
IPGEN_MPC_LOCAL void ipgen_mpc_ac_times(int nx, int cols, const ipgen_mpc_real Ac[], const ipgen_mpc_real X[],
                                        ipgen_mpc_real P[]) {
  const int first = IPGEN_MPC_COPIED_ROWS(nx);
  int i, j, m;
  for (i = 0; i < first * cols; ++i) P[i] = X[first * cols + i];
  for (i = first; i < nx; ++i)
    for (j = 0; j < cols; ++j) {
      ipgen_mpc_real v = Ac[i * nx] * X[j];
      for (m = 1; m < nx; ++m) v += Ac[i * nx + m] * X[m * cols + j];
      P[i * cols + j] = v;
    }
}

/* Frozen sensitivities (IPGEN_MPC_FROZEN): the model's Jacobians Ac, Bc at the sample's start,
 * discretised as RK4 discretises a linear model. One RK4 step of length h of x' = Ac x + Bc u is
 * x+ = Phi x + Gamma u with M = h Ac, Phi = I + M + M^2/2 + M^3/6 + M^4/24 and
 * Gamma = h (I + M/2 + M^2/6 + M^3/24) Bc; by Horner Psi = I + M/4, then I + M Psi / 3, then
 * I + M Psi / 2, and Gamma = h Psi Bc, Phi = I + M Psi. Over `substeps` steps A = Phi^substeps
 * and B = sum_{i < substeps} Phi^i Gamma. T1, T2: nx (nx + nu) temporaries each. */
IPGEN_MPC_LOCAL void ipgen_mpc_frozen(int nx, int nu, ipgen_mpc_real h, int substeps, const ipgen_mpc_real Ac[],
                                      const ipgen_mpc_real Bc[], ipgen_mpc_real A[], ipgen_mpc_real B[],
                                      ipgen_mpc_real T1[], ipgen_mpc_real T2[]) {
  static const ipgen_mpc_real factor[3] = {(ipgen_mpc_real)0.25, (ipgen_mpc_real)1 / (ipgen_mpc_real)3,
                                           (ipgen_mpc_real)0.5};
  int i, j, m, r, step;
  for (i = 0; i < nx; ++i)
    for (j = 0; j < nx; ++j) T1[i * nx + j] = (ipgen_mpc_real)(i == j) + factor[0] * h * Ac[i * nx + j];
  for (r = 1; r < 3; ++r) {
    ipgen_mpc_ac_times(nx, nx, Ac, T1, T2);
    for (i = 0; i < nx; ++i)
      for (j = 0; j < nx; ++j) T1[i * nx + j] = (ipgen_mpc_real)(i == j) + factor[r] * h * T2[i * nx + j];
  }
  for (i = 0; i < nx; ++i)
    for (j = 0; j < nu; ++j) {
      ipgen_mpc_real v = T1[i * nx] * Bc[j];
      for (m = 1; m < nx; ++m) v += T1[i * nx + m] * Bc[m * nu + j];
      B[i * nu + j] = h * v;
    }
  ipgen_mpc_ac_times(nx, nx, Ac, T1, T2);
  for (i = 0; i < nx; ++i)
    for (j = 0; j < nx; ++j) A[i * nx + j] = (ipgen_mpc_real)(i == j) + h * T2[i * nx + j];
  if (substeps > 1) { /* T1: Phi then Gamma; T2: Phi A then Phi B + Gamma */
    ipgen_mpc_real *const Gamma = T1 + nx * nx, *const PB = T2 + nx * nx;
    for (i = 0; i < nx * nx; ++i) T1[i] = A[i];
    for (i = 0; i < nx * nu; ++i) Gamma[i] = B[i];
    for (step = 1; step < substeps; ++step) {
      for (i = 0; i < nx; ++i) {
        for (j = 0; j < nx; ++j) {
          ipgen_mpc_real v = T1[i * nx] * A[j];
          for (m = 1; m < nx; ++m) v += T1[i * nx + m] * A[m * nx + j];
          T2[i * nx + j] = v;
        }
        for (j = 0; j < nu; ++j) {
          ipgen_mpc_real v = Gamma[i * nu + j];
          for (m = 0; m < nx; ++m) v += T1[i * nx + m] * B[m * nu + j];
          PB[i * nu + j] = v;
        }
      }
      for (i = 0; i < nx * nx; ++i) A[i] = T2[i];
      for (i = 0; i < nx * nu; ++i) B[i] = PB[i];
    }
  }
}

/* xn = F(x, u): `substeps` RK4 steps, each substep's four slopes unrolled (ksum = k1 + 2 k2 + 2 k3
 * + k4 summed left to right, as the loops over the stages of ipgen_mpc_rk4_layout and
 * ipgen_mpc_rk4_fixed, which add the sensitivities: the same numbers for F). Every F alone;
 * the model's Jacobians at (x, u), the first slope's, into Ac and Bc when they are not null.
 * xs, xt, kk, ksum: nx temporaries. Returns 0, 1 if the model failed. */
IPGEN_MPC_LOCAL int ipgen_mpc_rk4_slopes(const ipgen_mpc_settings *s, const ipgen_mpc_real x[], const ipgen_mpc_real u[],
                                         ipgen_mpc_real xn[], ipgen_mpc_real Ac[], ipgen_mpc_real Bc[],
                                         ipgen_mpc_real xs[], ipgen_mpc_real xt[], ipgen_mpc_real kk[],
                                         ipgen_mpc_real ksum[]) {
  const int nx = IPGEN_MPC_NX_OF(s);
  const ipgen_mpc_real h = s->period / (ipgen_mpc_real)s->substeps, half = (ipgen_mpc_real)0.5 * h;
  const ipgen_mpc_real sixth = h / (ipgen_mpc_real)6, two = (ipgen_mpc_real)2;
  int step, i;
  for (i = 0; i < nx; ++i) xs[i] = x[i];
  for (step = 0; step < s->substeps; ++step) {
    if (s->dynamics(s->context, xs, u, kk, step == 0 ? Ac : 0, step == 0 ? Bc : 0) != 0) return 1;
    for (i = 0; i < nx; ++i) {
      ksum[i] = kk[i];
      xt[i] = xs[i] + half * kk[i];
    }
    if (s->dynamics(s->context, xt, u, kk, 0, 0) != 0) return 1;
    for (i = 0; i < nx; ++i) {
      ksum[i] += two * kk[i];
      xt[i] = xs[i] + half * kk[i];
    }
    if (s->dynamics(s->context, xt, u, kk, 0, 0) != 0) return 1;
    for (i = 0; i < nx; ++i) {
      ksum[i] += two * kk[i];
      xt[i] = xs[i] + h * kk[i];
    }
    if (s->dynamics(s->context, xt, u, kk, 0, 0) != 0) return 1;
    for (i = 0; i < nx; ++i) xs[i] += sixth * (ksum[i] + kk[i]);
  }
  for (i = 0; i < nx; ++i) xn[i] = xs[i];
  return 0;
}

/* One sample of the discretised model with frozen sensitivities: xn = F(x, u) by
 * ipgen_mpc_rk4_slopes with the model's Jacobians asked for at the first slope only (F's first:
 * a model call a stage fewer than a separate Jacobian call, on the microcontroller's hot path),
 * then A, B by ipgen_mpc_frozen. xs, xt, k, ksum: nx temporaries; Ac, Bc: the Jacobians' room;
 * T1, T2: as ipgen_mpc_frozen's. Returns 0, 1 if the model failed. */
IPGEN_MPC_LOCAL int ipgen_mpc_rk4_frozen(const ipgen_mpc_settings *s, const ipgen_mpc_real x[], const ipgen_mpc_real u[],
                                         ipgen_mpc_real xn[], ipgen_mpc_real A[], ipgen_mpc_real B[],
                                         ipgen_mpc_real xs[], ipgen_mpc_real xt[], ipgen_mpc_real k[],
                                         ipgen_mpc_real ksum[], ipgen_mpc_real Ac[], ipgen_mpc_real Bc[],
                                         ipgen_mpc_real T1[], ipgen_mpc_real T2[]) {
  const int nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s);
  const ipgen_mpc_real h = s->period / (ipgen_mpc_real)s->substeps;
  if (ipgen_mpc_rk4_slopes(s, x, u, xn, Ac, Bc, xs, xt, k, ksum) != 0) return 1;
  ipgen_mpc_frozen(nx, nu, h, s->substeps, Ac, Bc, A, B, T1, T2);
  return 0;
}

#ifdef IPGEN_MPC_FIXED
/* ipgen_mpc_rk4_layout with its sensitivities (A and B not null; F alone is ipgen_mpc_rk4_slopes)
 * and every size fixed: its temporaries in local arrays (the workspace's RK4 parts unused), the
 * stage sensitivity, its weighted sum and the next stage's point in one pass per stage. The same
 * operations, in the same order per entry. */
IPGEN_MPC_LOCAL int ipgen_mpc_rk4_fixed(const ipgen_mpc_settings *s, const ipgen_mpc_real x[], const ipgen_mpc_real u[],
                                        ipgen_mpc_real xn[], ipgen_mpc_real A[], ipgen_mpc_real B[]) {
#define IPGEN_MPC_NZ (IPGEN_MPC_NX + IPGEN_MPC_NU)
#define IPGEN_MPC_FIRST IPGEN_MPC_COPIED_ROWS(IPGEN_MPC_NX)
  const ipgen_mpc_real h = s->period / (ipgen_mpc_real)s->substeps;
  static const ipgen_mpc_real weight[4] = {(ipgen_mpc_real)1, (ipgen_mpc_real)2, (ipgen_mpc_real)2, (ipgen_mpc_real)1};
  static const ipgen_mpc_real advance[4] = {(ipgen_mpc_real)0.5, (ipgen_mpc_real)0.5, (ipgen_mpc_real)1, (ipgen_mpc_real)0};
  ipgen_mpc_real xs[IPGEN_MPC_NX], xt[IPGEN_MPC_NX], kk[IPGEN_MPC_NX], ksum[IPGEN_MPC_NX];
  ipgen_mpc_real Ac[IPGEN_MPC_NX * IPGEN_MPC_NX], Bc[IPGEN_MPC_NX * IPGEN_MPC_NU];
  ipgen_mpc_real S[IPGEN_MPC_NX][IPGEN_MPC_NZ], Ss[IPGEN_MPC_NX][IPGEN_MPC_NZ];
  ipgen_mpc_real dsum[IPGEN_MPC_NX][IPGEN_MPC_NZ];
  int step, stage, i, j, m;
  for (i = 0; i < IPGEN_MPC_NX; ++i) xs[i] = x[i];
  for (i = 0; i < IPGEN_MPC_NX; ++i)
    for (j = 0; j < IPGEN_MPC_NZ; ++j) S[i][j] = (ipgen_mpc_real)(i == j);
  for (step = 0; step < s->substeps; ++step) {
    for (i = 0; i < IPGEN_MPC_NX; ++i) xt[i] = xs[i];
    for (i = 0; i < IPGEN_MPC_NX; ++i)
      for (j = 0; j < IPGEN_MPC_NZ; ++j) Ss[i][j] = S[i][j];
    for (stage = 0; stage < 4; ++stage) {
      const ipgen_mpc_real c = advance[stage] * h;
      if (s->dynamics(s->context, xt, u, kk, Ac, Bc) != 0) return 1;
      for (i = 0; i < IPGEN_MPC_NX; ++i) {
        ksum[i] = (stage == 0 ? (ipgen_mpc_real)0 : ksum[i]) + weight[stage] * kk[i];
        if (stage < 3) xt[i] = xs[i] + c * kk[i];
      }
      /* column by column (a column of dk needs that of Ss alone): dk = Ac Ss + [0 | Bc]
       * (ipgen_mpc_stage_sensitivity's, the [0 I] rows copied), its weighted sum, the next Ss */
      for (j = 0; j < IPGEN_MPC_NZ; ++j) {
        ipgen_mpc_real col[IPGEN_MPC_NX], d[IPGEN_MPC_NX];
        for (m = 0; m < IPGEN_MPC_NX; ++m) col[m] = Ss[m][j];
        for (i = 0; i < IPGEN_MPC_FIRST; ++i) d[i] = col[IPGEN_MPC_FIRST + i];
        for (i = IPGEN_MPC_FIRST; i < IPGEN_MPC_NX; ++i) {
          ipgen_mpc_real v = j < IPGEN_MPC_NX ? Ac[i * IPGEN_MPC_NX] * col[0] : Bc[i * IPGEN_MPC_NU + (j - IPGEN_MPC_NX)] + Ac[i * IPGEN_MPC_NX] * col[0];
          for (m = 1; m < IPGEN_MPC_NX; ++m) v += Ac[i * IPGEN_MPC_NX + m] * col[m];
          d[i] = v;
        }
        for (i = 0; i < IPGEN_MPC_NX; ++i) {
          dsum[i][j] = stage == 0 ? d[i] : dsum[i][j] + weight[stage] * d[i];
          if (stage < 3) Ss[i][j] = S[i][j] + c * d[i];
        }
      }
    }
    for (i = 0; i < IPGEN_MPC_NX; ++i) xs[i] += h / (ipgen_mpc_real)6 * ksum[i];
    for (i = 0; i < IPGEN_MPC_NX; ++i)
      for (j = 0; j < IPGEN_MPC_NZ; ++j) S[i][j] += h / (ipgen_mpc_real)6 * dsum[i][j];
  }
  for (i = 0; i < IPGEN_MPC_NX; ++i) {
    xn[i] = xs[i];
    for (j = 0; j < IPGEN_MPC_NX; ++j) A[i * IPGEN_MPC_NX + j] = S[i][j];
    for (j = 0; j < IPGEN_MPC_NU; ++j) B[i * IPGEN_MPC_NU + j] = S[i][IPGEN_MPC_NX + j];
  }
  return 0;
#undef IPGEN_MPC_FIRST
#undef IPGEN_MPC_NZ
}
#endif

/* One sample of the discretised model: xn = F(x, u), `substeps` classical RK4 steps of length
 * T / substeps with u held, and, when A and B are not null, its exact sensitivities A = dF/dx
 * (nx x nx) and B = dF/du (nx x nu): the RK4 recursion differentiated stage by stage with the
 * model's Jacobians (what automatic differentiation of the same steps gives). `l`: the carved
 * workspace (its RK4 temporaries). Returns 0, 1 if the model failed. */
IPGEN_MPC_LOCAL int ipgen_mpc_rk4_layout(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l, const ipgen_mpc_real x[],
                                         const ipgen_mpc_real u[], ipgen_mpc_real xn[], ipgen_mpc_real A[],
                                         ipgen_mpc_real B[]) {
#ifdef IPGEN_MPC_FIXED
  /* the frozen stages first: the microcontroller's hot path (F alone first costs the FAST step 29
   * instructions of 85,879 on the M4F, make bench-mpc-m4) */
  if (l->frozen && A != 0 && B != 0) { /* the temporaries local, as ipgen_mpc_rk4_fixed's */
    ipgen_mpc_real xs[IPGEN_MPC_NX], xt[IPGEN_MPC_NX], k[IPGEN_MPC_NX], ksum[IPGEN_MPC_NX];
    ipgen_mpc_real Ac[IPGEN_MPC_NX * IPGEN_MPC_NX], Bc[IPGEN_MPC_NX * IPGEN_MPC_NU];
    ipgen_mpc_real T1[IPGEN_MPC_NX * (IPGEN_MPC_NX + IPGEN_MPC_NU)], T2[IPGEN_MPC_NX * (IPGEN_MPC_NX + IPGEN_MPC_NU)];
    return ipgen_mpc_rk4_frozen(s, x, u, xn, A, B, xs, xt, k, ksum, Ac, Bc, T1, T2);
  }
  if (A == 0 || B == 0) { /* F alone */
    ipgen_mpc_real xs[IPGEN_MPC_NX], xt[IPGEN_MPC_NX], k[IPGEN_MPC_NX], ksum[IPGEN_MPC_NX];
    return ipgen_mpc_rk4_slopes(s, x, u, xn, 0, 0, xs, xt, k, ksum);
  }
  return ipgen_mpc_rk4_fixed(s, x, u, xn, A, B);
#else
  const int nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s), nz = nx + nu, sens = A != 0 && B != 0;
  const ipgen_mpc_real h = s->period / (ipgen_mpc_real)s->substeps;
  static const ipgen_mpc_real weight[4] = {(ipgen_mpc_real)1, (ipgen_mpc_real)2, (ipgen_mpc_real)2, (ipgen_mpc_real)1};
  static const ipgen_mpc_real advance[4] = {(ipgen_mpc_real)0.5, (ipgen_mpc_real)0.5, (ipgen_mpc_real)1, (ipgen_mpc_real)0};
  ipgen_mpc_real *xs = l->xn, *S = l->S;
  int step, stage, i, j;
  if (!sens) return ipgen_mpc_rk4_slopes(s, x, u, xn, 0, 0, xs, l->xt, l->k, l->ksum); /* F alone */
  if (l->frozen) return ipgen_mpc_rk4_frozen(s, x, u, xn, A, B, xs, l->xt, l->k, l->ksum, l->Ac, l->Bc, S, l->Ss);
  for (i = 0; i < nx; ++i) xs[i] = x[i];
  for (i = 0; i < nx; ++i)
    for (j = 0; j < nz; ++j) S[i * nz + j] = (ipgen_mpc_real)(i == j);
  for (step = 0; step < s->substeps; ++step) {
    for (i = 0; i < nx; ++i) l->xt[i] = xs[i];
    for (i = 0; i < nx * nz; ++i) l->Ss[i] = S[i];
    for (stage = 0; stage < 4; ++stage) {
      if (s->dynamics(s->context, l->xt, u, l->k, l->Ac, l->Bc) != 0) return 1;
      for (i = 0; i < nx; ++i) l->ksum[i] = (stage == 0 ? (ipgen_mpc_real)0 : l->ksum[i]) + weight[stage] * l->k[i];
      ipgen_mpc_stage_sensitivity(nx, nu, l->Ac, l->Bc, l->Ss, l->dk);
      for (i = 0; i < nx * nz; ++i)
        l->dksum[i] = (stage == 0 ? (ipgen_mpc_real)0 : l->dksum[i]) + weight[stage] * l->dk[i];
      if (stage < 3) { /* the next stage's point: x + c h k, its sensitivity S + c h dk */
        const ipgen_mpc_real c = advance[stage] * h;
        for (i = 0; i < nx; ++i) l->xt[i] = xs[i] + c * l->k[i];
        for (i = 0; i < nx * nz; ++i) l->Ss[i] = S[i] + c * l->dk[i];
      }
    }
    for (i = 0; i < nx; ++i) xs[i] += h / (ipgen_mpc_real)6 * l->ksum[i];
    for (i = 0; i < nx * nz; ++i) S[i] += h / (ipgen_mpc_real)6 * l->dksum[i];
  }
  for (i = 0; i < nx; ++i) {
    xn[i] = xs[i];
    for (j = 0; j < nx; ++j) A[i * nx + j] = S[i * nz + j];
    for (j = 0; j < nu; ++j) B[i * nu + j] = S[i * nz + nx + j];
  }
  return 0;
#endif
}

/* ipgen_mpc_rk4_layout on a workspace of ipgen_mpc_work_size entries (its warm start untouched). */
IPGEN_MPC_API int ipgen_mpc_rk4(const ipgen_mpc_settings *s, const ipgen_mpc_real x[], const ipgen_mpc_real u[],
                                ipgen_mpc_real xn[], ipgen_mpc_real A[], ipgen_mpc_real B[], ipgen_mpc_real work[]) {
  ipgen_mpc_layout l;
  ipgen_mpc_carve(s, work, &l);
  return ipgen_mpc_rk4_layout(s, &l, x, u, xn, A, B);
}

/* ipgen_mpc_rk4 with the sensitivities of `method` (null: exact): what a step of that method
 * linearises each stage with. */
IPGEN_MPC_API int ipgen_mpc_rk4_method(const ipgen_mpc_settings *s, const ipgen_mpc_method *method,
                                       const ipgen_mpc_real x[], const ipgen_mpc_real u[], ipgen_mpc_real xn[],
                                       ipgen_mpc_real A[], ipgen_mpc_real B[], ipgen_mpc_real work[]) {
  ipgen_mpc_layout l;
  ipgen_mpc_carve(s, work, &l);
  l.frozen = method != 0 && (method->sensitivities == IPGEN_MPC_FROZEN ||
                             method->sensitivities == IPGEN_MPC_SHIFTED); /* SHIFTED: a new stage's are frozen */
  return ipgen_mpc_rk4_layout(s, &l, x, u, xn, A, B);
}

/* ---- the quadratic program ------------------------------------------------------------------
 * Variables z = (dx_0..dx_N, du_0..du_{N-1}) about the guess traj, dx_0 = estimate - x_0 fixed,
 * dx_{k+1} = A_k dx_k + B_k du_k + d_k; cost the problem's (exact in x and u: Gauss-Newton);
 * inequalities a z[var] - s[soft] <= b (a = +1 an upper bound, -1 a lower one) and -s <= 0 for the
 * soft slacks s, numbered: inputs (2 N nu), hard state bounds (2 N hard), soft ones (2 N soft),
 * then the slacks' s >= 0 (2 N soft). */

/* Inequality i decoded from the settings: the variable's index in z (-1: a slack's s >= 0), its
 * sign a and the bound's value (max for a = +1, min for a = -1; 0 for a slack's). Divisions: run
 * once per QP by ipgen_mpc_encode; the loops read the table (ipgen_mpc_inequality). */
IPGEN_MPC_LOCAL void ipgen_mpc_decode(const ipgen_mpc_settings *s, long i, long *var, ipgen_mpc_real *sign,
                                      ipgen_mpc_real *value) {
  const long N = IPGEN_MPC_N_OF(s), nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s), nh = IPGEN_MPC_HARD_OF(s), ns = IPGEN_MPC_SOFT_OF(s);
  const long nU = 2 * N * nu, nH = 2 * N * nh, nS = 2 * N * ns;
  ipgen_mpc_real lo, hi;
  long r;
  if (i < nU) {
    const long k = i / (2 * nu), j = (i % (2 * nu)) / 2;
    r = i;
    *var = (N + 1) * nx + k * nu + j;
    lo = s->u_min[j];
    hi = s->u_max[j];
  } else if (i < nU + nH) {
    /* nh > 0 here; the guard keeps a constant 0 divisor (fixed sizes, no hard bound) out of C++ */
    const long ii = i - nU, pair = nh > 0 ? 2 * nh : 1, k = 1 + ii / pair, j = (ii % pair) / 2;
    r = ii;
    *var = k * nx + s->hard_index[j];
    lo = s->hard_min[j];
    hi = s->hard_max[j];
  } else if (i < nU + nH + nS) {
    const long ii = i - nU - nH, pair = ns > 0 ? 2 * ns : 1, k = 1 + ii / pair, j = (ii % pair) / 2;
    r = ii;
    *var = k * nx + s->soft_index[j];
    lo = s->soft_min[j];
    hi = s->soft_max[j];
  } else {
    *var = -1;
    *sign = (ipgen_mpc_real)0;
    *value = (ipgen_mpc_real)0;
    return;
  }
  *sign = r % 2 == 0 ? (ipgen_mpc_real)1 : (ipgen_mpc_real)-1;
  *value = r % 2 == 0 ? hi : lo;
}

/* The table of the inequalities of the QP about the guess traj: code = a (var + 1) (0 for a
 * slack's s >= 0) and the bound b = a (value - traj[var]) (0 for a slack's), run at the start of
 * each QP (traj is constant during it). */
IPGEN_MPC_LOCAL void ipgen_mpc_encode(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l) {
  const long M = IPGEN_MPC_INEQUALITIES(IPGEN_MPC_NU_OF(s), IPGEN_MPC_N_OF(s), IPGEN_MPC_HARD_OF(s), IPGEN_MPC_SOFT_OF(s));
  long i, var;
  ipgen_mpc_real sign, value;
  for (i = 0; i < M; ++i) {
    ipgen_mpc_decode(s, i, &var, &sign, &value);
    l->code[i] = sign * (ipgen_mpc_real)(var + 1);
    l->bound[i] = var >= 0 ? sign * (value - l->traj[var]) : (ipgen_mpc_real)0;
  }
}

/* Inequality i from the table: the variable's index in z (-1: a slack's s >= 0), its sign a, the
 * slack's index (-1: none) and the bound b = a (bound - traj[var]) at the current guess. */
IPGEN_MPC_LOCAL void ipgen_mpc_inequality(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l, long i, long *var,
                                          ipgen_mpc_real *sign, long *soft, ipgen_mpc_real *b) {
  const long first_soft = 2 * (long)IPGEN_MPC_N_OF(s) * (IPGEN_MPC_NU_OF(s) + IPGEN_MPC_HARD_OF(s)), nS = IPGEN_MPC_SLACKS(IPGEN_MPC_N_OF(s), IPGEN_MPC_SOFT_OF(s));
  const ipgen_mpc_real e = l->code[i];
  *b = l->bound[i];
  if (i < first_soft || e != 0) { /* a bound on a variable (the first test: the loops' ranges fold it) */
    *sign = e > 0 ? (ipgen_mpc_real)1 : (ipgen_mpc_real)-1;
    *var = (long)(e > 0 ? e : -e) - 1;
    *soft = i >= first_soft ? i - first_soft : -1;
    return;
  }
  *var = -1;
  *sign = (ipgen_mpc_real)0;
  *soft = i - first_soft - nS;
}

/* The value a z[var] - s[soft] of inequality i at (z, sig), or a's and the slack's part of a step. */
IPGEN_MPC_LOCAL ipgen_mpc_real ipgen_mpc_constraint(long var, ipgen_mpc_real sign, long soft, const ipgen_mpc_real z[],
                                                    const ipgen_mpc_real sig[]) {
  return (var >= 0 ? sign * z[var] : (ipgen_mpc_real)0) - (soft >= 0 ? sig[soft] : (ipgen_mpc_real)0);
}

/* The soft bound (0..soft_count) of slack j. */
IPGEN_MPC_LOCAL long ipgen_mpc_soft_bound(const ipgen_mpc_settings *s, long j) {
  const long ns = IPGEN_MPC_SOFT_OF(s);
  return (j % (ns > 0 ? 2 * ns : 1)) / 2;
}

/* gl = the QP cost's gradient at z (inputs and states k >= 1; x_0's entries 0); gs = the slacks'
 * rho1 + 2 rho2 s. The QP's loop over the inequalities adds C' lam to both (gl over the variables,
 * gs minus both of a slack's lam). Returns the cost gradient's largest entry (the scale of the
 * stationarity residual). */
IPGEN_MPC_LOCAL ipgen_mpc_real ipgen_mpc_gradient(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l) {
  const int nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s), N = IPGEN_MPC_N_OF(s);
  const long Z = IPGEN_MPC_VARIABLES(nx, nu, N), nS = IPGEN_MPC_SLACKS(N, IPGEN_MPC_SOFT_OF(s));
  long i;
  int k, a, b;
  ipgen_mpc_real scale = (ipgen_mpc_real)1;
  for (i = 0; i < nx; ++i) l->gl[i] = (ipgen_mpc_real)0;
  if (l->exact) { /* the cost's gradient at the guess plus H_k (dx_k, du_k), stage by stage */
    const int nz = nx + nu;
    for (k = 0; k < N; ++k) {
      const ipgen_mpc_real *Hk = l->H + (long)k * nz * nz, *zx = l->z + (long)k * nx;
      const ipgen_mpc_real *zu = l->z + (long)(N + 1) * nx + (long)k * nu;
      const ipgen_mpc_real *xr = IPGEN_MPC_X_REF(s, l->x_refs, k, nx), *ur = IPGEN_MPC_U_REF(s, l->u_refs, k, nu);
      const long o = (long)(N + 1) * nx + (long)k * nu;
      for (a = 0; a < nz; ++a) {
        ipgen_mpc_real v = (ipgen_mpc_real)0;
        if (a < nx && k == 0) continue;
        for (b = 0; b < nx; ++b) v += Hk[a * nz + b] * zx[b];
        for (b = 0; b < nu; ++b) v += Hk[a * nz + nx + b] * zu[b];
        if (a < nx) {
          for (b = 0; b < nx; ++b) v += (ipgen_mpc_real)2 * s->Q[a * nx + b] * (l->traj[k * nx + b] - xr[b]);
          l->gl[k * nx + a] = v;
        } else {
          for (b = 0; b < nu; ++b)
            v += (ipgen_mpc_real)2 * s->R[(a - nx) * nu + b] * (l->traj[o + b] - ur[b]);
          l->gl[o + a - nx] = v;
        }
      }
    }
  }
  for (k = l->exact ? N : 1; k <= N; ++k) { /* 2 Q (x - x_ref), 2 P at k = N */
    const ipgen_mpc_real *W = k == N ? s->P : s->Q, *xr = IPGEN_MPC_X_REF(s, l->x_refs, k, nx);
    for (a = 0; a < nx; ++a) {
      ipgen_mpc_real v = (ipgen_mpc_real)0;
      for (b = 0; b < nx; ++b) v += W[a * nx + b] * (l->traj[k * nx + b] + l->z[k * nx + b] - xr[b]);
      l->gl[k * nx + a] = (ipgen_mpc_real)2 * v;
    }
  }
  for (k = 0; k < (l->exact ? 0 : N); ++k) {
    const long o = (long)(N + 1) * nx + (long)k * nu;
    const ipgen_mpc_real *ur = IPGEN_MPC_U_REF(s, l->u_refs, k, nu);
    for (a = 0; a < nu; ++a) {
      ipgen_mpc_real v = (ipgen_mpc_real)0;
      for (b = 0; b < nu; ++b) v += s->R[a * nu + b] * (l->traj[o + b] + l->z[o + b] - ur[b]);
      l->gl[o + a] = (ipgen_mpc_real)2 * v;
    }
  }
  for (i = 0; i < nS; ++i) {
    const long j = ipgen_mpc_soft_bound(s, i);
    l->gs[i] = s->soft_linear[j] + (ipgen_mpc_real)2 * s->soft_quadratic[j] * l->sig[i];
  }
  for (i = 0; i < Z; ++i) scale = ipgen_mpc_max(scale, ipgen_mpc_abs(l->gl[i]));
  for (i = 0; i < nS; ++i) scale = ipgen_mpc_max(scale, ipgen_mpc_abs(l->gs[i]));
  return scale;
}

/* The QP's largest residual: stationarity (the reduced gradient in the inputs and slacks, through
 * the adjoint of the dynamics) relative to `scale` (the cost gradient's largest entry, at least
 * 1), primal (|a z - s + t - b|) and the mean complementarity. Needs ipgen_mpc_gradient's gl, gs
 * and the primal residuals rp. `costate`: the dynamics' largest multiplier (the adjoint's entry). */
IPGEN_MPC_LOCAL ipgen_mpc_real ipgen_mpc_qp_residual(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l, ipgen_mpc_real mu,
                                                     ipgen_mpc_real scale, ipgen_mpc_real *costate) {
  const int nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s), N = IPGEN_MPC_N_OF(s);
  const long M = IPGEN_MPC_INEQUALITIES(nu, N, IPGEN_MPC_HARD_OF(s), IPGEN_MPC_SOFT_OF(s)), nS = IPGEN_MPC_SLACKS(N, IPGEN_MPC_SOFT_OF(s));
  ipgen_mpc_real worst = mu, *v = l->nu_tmp, *vn = l->pn;
  long i;
  int k, a, b;
  for (i = 0; i < M; ++i) worst = ipgen_mpc_max(worst, ipgen_mpc_abs(l->rp[i]));
  for (i = 0; i < nS; ++i) worst = ipgen_mpc_max(worst, ipgen_mpc_abs(l->gs[i]) / scale);
  for (a = 0; a < nx; ++a) v[a] = l->gl[N * nx + a];
  *costate = (ipgen_mpc_real)0;
  for (k = N - 1; k >= 0; --k) {
    for (a = 0; a < nx; ++a) *costate = ipgen_mpc_max(*costate, ipgen_mpc_abs(v[a]));
    if (l->costate)
      for (a = 0; a < nx; ++a) l->costate[(long)k * nx + a] = v[a]; /* the multiplier of x_{k+1} = F(x_k, u_k) */
    const ipgen_mpc_real *A = l->A + (long)k * nx * nx, *B = l->B + (long)k * nx * nu;
    const long o = (long)(N + 1) * nx + (long)k * nu;
    for (a = 0; a < nu; ++a) {
      ipgen_mpc_real r = l->gl[o + a];
      for (b = 0; b < nx; ++b) r += B[b * nu + a] * v[b];
      worst = ipgen_mpc_max(worst, ipgen_mpc_abs(r) / scale);
    }
    if (k == 0) break;
    for (a = 0; a < nx; ++a) {
      ipgen_mpc_real r = l->gl[k * nx + a];
      for (b = 0; b < nx; ++b) r += A[b * nx + a] * v[b];
      vn[a] = r;
    }
    for (a = 0; a < nx; ++a) v[a] = vn[a];
  }
  return worst;
}

#ifdef IPGEN_MPC_FIXED
/* ipgen_mpc_gradient with every size fixed, Gauss-Newton (the exact Hessian's QP calls
 * ipgen_mpc_gradient): the weights, the reference and the adjoint in local arrays; the same
 * operations in the same order per entry. */
IPGEN_MPC_LOCAL ipgen_mpc_real ipgen_mpc_gradient_fixed(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l) {
  ipgen_mpc_real Wq[IPGEN_MPC_NX * IPGEN_MPC_NX], Wp[IPGEN_MPC_NX * IPGEN_MPC_NX], xr[IPGEN_MPC_NX];
  ipgen_mpc_real Rw[IPGEN_MPC_NU * IPGEN_MPC_NU], ur[IPGEN_MPC_NU];
  ipgen_mpc_real scale = (ipgen_mpc_real)1;
  const ipgen_mpc_real *x_refs = l->x_refs, *u_refs = l->u_refs; /* per stage, or null: xr, ur */
  const long nS = IPGEN_MPC_SLACKS(IPGEN_MPC_N, IPGEN_MPC_SOFT);
  long i;
  int k, a, b;
  if (l->exact) return ipgen_mpc_gradient(s, l);
  for (i = 0; i < IPGEN_MPC_NX * IPGEN_MPC_NX; ++i) {
    Wq[i] = s->Q[i];
    Wp[i] = s->P[i];
  }
  for (i = 0; i < IPGEN_MPC_NU * IPGEN_MPC_NU; ++i) Rw[i] = s->R[i];
  for (a = 0; a < IPGEN_MPC_NX; ++a) xr[a] = s->x_ref[a];
  for (a = 0; a < IPGEN_MPC_NU; ++a) ur[a] = s->u_ref[a];
  for (i = 0; i < IPGEN_MPC_NX; ++i) l->gl[i] = (ipgen_mpc_real)0;
  for (k = 1; k <= IPGEN_MPC_N; ++k) { /* 2 Q (x - x_ref), 2 P at k = N */
    const ipgen_mpc_real *W = k == IPGEN_MPC_N ? Wp : Wq;
    const ipgen_mpc_real *r = x_refs ? x_refs + (long)k * IPGEN_MPC_NX : xr;
    ipgen_mpc_real e[IPGEN_MPC_NX];
    for (b = 0; b < IPGEN_MPC_NX; ++b) e[b] = l->traj[k * IPGEN_MPC_NX + b] + l->z[k * IPGEN_MPC_NX + b] - r[b];
    for (a = 0; a < IPGEN_MPC_NX; ++a) {
      ipgen_mpc_real v = W[a * IPGEN_MPC_NX] * e[0];
      for (b = 1; b < IPGEN_MPC_NX; ++b) v += W[a * IPGEN_MPC_NX + b] * e[b];
      v = (ipgen_mpc_real)2 * v;
      l->gl[k * IPGEN_MPC_NX + a] = v;
      scale = ipgen_mpc_max(scale, ipgen_mpc_abs(v));
    }
  }
  for (k = 0; k < IPGEN_MPC_N; ++k) {
    const long o = (long)(IPGEN_MPC_N + 1) * IPGEN_MPC_NX + (long)k * IPGEN_MPC_NU;
    const ipgen_mpc_real *r = u_refs ? u_refs + (long)k * IPGEN_MPC_NU : ur;
    ipgen_mpc_real e[IPGEN_MPC_NU];
    for (b = 0; b < IPGEN_MPC_NU; ++b) e[b] = l->traj[o + b] + l->z[o + b] - r[b];
    for (a = 0; a < IPGEN_MPC_NU; ++a) {
      ipgen_mpc_real v = Rw[a * IPGEN_MPC_NU] * e[0];
      for (b = 1; b < IPGEN_MPC_NU; ++b) v += Rw[a * IPGEN_MPC_NU + b] * e[b];
      v = (ipgen_mpc_real)2 * v;
      l->gl[o + a] = v;
      scale = ipgen_mpc_max(scale, ipgen_mpc_abs(v));
    }
  }
  for (i = 0; i < nS; ++i) {
    const long j = ipgen_mpc_soft_bound(s, i);
    l->gs[i] = s->soft_linear[j] + (ipgen_mpc_real)2 * s->soft_quadratic[j] * l->sig[i];
    scale = ipgen_mpc_max(scale, ipgen_mpc_abs(l->gs[i]));
  }
  return scale;
}

/* ipgen_mpc_qp_residual with every size fixed, `worst` the larger of mu and max |rp| (the QP's
 * pass takes it): the adjoint in local arrays. */
IPGEN_MPC_LOCAL ipgen_mpc_real ipgen_mpc_qp_residual_fixed(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l, ipgen_mpc_real worst,
                                                           ipgen_mpc_real scale, ipgen_mpc_real *costate) {
  const long nS = IPGEN_MPC_SLACKS(IPGEN_MPC_N, IPGEN_MPC_SOFT);
  const ipgen_mpc_real inverse = (ipgen_mpc_real)1 / scale;
  ipgen_mpc_real v[IPGEN_MPC_NX], c = (ipgen_mpc_real)0, r_max = (ipgen_mpc_real)0;
  long i;
  int k, a, b;
  (void)s;
  for (i = 0; i < nS; ++i) r_max = ipgen_mpc_max(r_max, ipgen_mpc_abs(l->gs[i]));
  for (a = 0; a < IPGEN_MPC_NX; ++a) v[a] = l->gl[IPGEN_MPC_N * IPGEN_MPC_NX + a];
  for (k = IPGEN_MPC_N - 1; k >= 0; --k) {
    const ipgen_mpc_real *A = l->A + (long)k * IPGEN_MPC_NX * IPGEN_MPC_NX, *B = l->B + (long)k * IPGEN_MPC_NX * IPGEN_MPC_NU;
    const long o = (long)(IPGEN_MPC_N + 1) * IPGEN_MPC_NX + (long)k * IPGEN_MPC_NU;
    ipgen_mpc_real vn[IPGEN_MPC_NX];
    for (a = 0; a < IPGEN_MPC_NX; ++a) c = ipgen_mpc_max(c, ipgen_mpc_abs(v[a]));
    if (l->costate)
      for (a = 0; a < IPGEN_MPC_NX; ++a) l->costate[(long)k * IPGEN_MPC_NX + a] = v[a];
    for (a = 0; a < IPGEN_MPC_NU; ++a) {
      ipgen_mpc_real r = l->gl[o + a];
      for (b = 0; b < IPGEN_MPC_NX; ++b) r += B[b * IPGEN_MPC_NU + a] * v[b];
      r_max = ipgen_mpc_max(r_max, ipgen_mpc_abs(r));
    }
    if (k == 0) break;
    for (a = 0; a < IPGEN_MPC_NX; ++a) {
      ipgen_mpc_real r = l->gl[k * IPGEN_MPC_NX + a];
      for (b = 0; b < IPGEN_MPC_NX; ++b) r += A[b * IPGEN_MPC_NX + a] * v[b];
      vn[a] = r;
    }
    for (a = 0; a < IPGEN_MPC_NX; ++a) v[a] = vn[a];
  }
  *costate = c;
  return ipgen_mpc_max(worst, r_max * inverse);
}
#endif

/* Cholesky factor (lower, in place) of the n x n matrix M; 1 if it is not positive definite. */
IPGEN_MPC_LOCAL int ipgen_mpc_cholesky(int n, ipgen_mpc_real M[]) {
  int i, j, c;
  for (j = 0; j < n; ++j) {
    ipgen_mpc_real dj = M[j * n + j];
    for (c = 0; c < j; ++c) dj -= M[j * n + c] * M[j * n + c];
    if (!(dj > (ipgen_mpc_real)0)) return 1;
    dj = ipgen_mpc_sqrt(dj);
    M[j * n + j] = dj;
    for (i = j + 1; i < n; ++i) {
      ipgen_mpc_real v = M[i * n + j];
      for (c = 0; c < j; ++c) v -= M[i * n + c] * M[j * n + c];
      M[i * n + j] = v / dj;
    }
    for (i = 0; i < j; ++i) M[i * n + j] = (ipgen_mpc_real)0;
  }
  return 0;
}

/* v = (L L')^-1 v in place for the n x n lower factor L. */
IPGEN_MPC_LOCAL void ipgen_mpc_cholesky_solve(int n, const ipgen_mpc_real L[], ipgen_mpc_real v[]) {
  int i, c;
  for (i = 0; i < n; ++i) {
    for (c = 0; c < i; ++c) v[i] -= L[i * n + c] * v[c];
    v[i] /= L[i * n + i];
  }
  for (i = n - 1; i >= 0; --i) {
    for (c = i + 1; c < n; ++c) v[i] -= L[c * n + i] * v[c];
    v[i] /= L[i * n + i];
  }
}

/* The Riccati factorisation of the Newton system's Hessian: stage weights 2Q + diag(hd_x),
 * 2R + diag(hd_u), terminal 2P + diag(hd_x_N), dynamics A_k, B_k. Stores the gains
 * K_k = -Re^-1 B' P A and the Cholesky factors of Re = 2R + diag + B' P_{k+1} B (1 / Re with
 * IPGEN_MPC_SCALAR_INPUT). Returns 1 if an
 * Re is not positive definite. Multiply-adds per stage about 1.5 nx^3 + 2.5 nx^2 nu + 2 nx nu^2
 * + nu^3 / 3. With l->exact the stage weights are H_k's blocks (H_xx, H_ux, H_uu) instead. */
IPGEN_MPC_LOCAL int ipgen_mpc_riccati_factor(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l) {
  const int nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s), N = IPGEN_MPC_N_OF(s), nz = nx + nu;
  ipgen_mpc_real *P = l->Pm;
  int k, i, j, m;
  for (i = 0; i < nx; ++i)
    for (j = 0; j < nx; ++j) P[i * nx + j] = (ipgen_mpc_real)2 * s->P[i * nx + j] + (i == j ? l->hd[N * nx + i] : (ipgen_mpc_real)0);
  for (k = N - 1; k >= 0; --k) {
    const ipgen_mpc_real *A = l->A + (long)k * nx * nx, *B = l->B + (long)k * nx * nu;
    ipgen_mpc_real *K = l->K + (long)k * nu * nx, *Lk = l->L + (long)k * nu * nu;
    const long o = (long)(N + 1) * nx + (long)k * nu;
    for (i = 0; i < nu; ++i) /* BtP = B' P */
      for (j = 0; j < nx; ++j) {
        ipgen_mpc_real v = (ipgen_mpc_real)0;
        for (m = 0; m < nx; ++m) v += B[m * nu + i] * P[m * nx + j];
        l->BtP[i * nx + j] = v;
      }
    for (i = 0; i < nu; ++i) /* Re = 2R (H_uu) + diag + BtP B, Se = (H_ux +) BtP A */
      for (j = 0; j < nu; ++j) {
        ipgen_mpc_real v = (l->exact ? l->H[(long)k * nz * nz + (nx + i) * nz + nx + j] : (ipgen_mpc_real)2 * s->R[i * nu + j]) +
                           (i == j ? l->hd[o + i] : (ipgen_mpc_real)0);
        for (m = 0; m < nx; ++m) v += l->BtP[i * nx + m] * B[m * nu + j];
        Lk[i * nu + j] = v;
      }
    for (i = 0; i < nu; ++i)
      for (j = 0; j < nx; ++j) {
        ipgen_mpc_real v = l->exact ? l->H[(long)k * nz * nz + (nx + i) * nz + j] : (ipgen_mpc_real)0;
        for (m = 0; m < nx; ++m) v += l->BtP[i * nx + m] * A[m * nx + j];
        l->Se[i * nx + j] = v;
      }
    if (IPGEN_MPC_SCALAR_INPUT) { /* nu = 1 fixed at compile time: Re a number, its reciprocal kept */
      if (!(Lk[0] > (ipgen_mpc_real)0)) return 1;
      Lk[0] = (ipgen_mpc_real)1 / Lk[0];
      for (j = 0; j < nx; ++j) K[j] = -(l->Se[j] * Lk[0]);
    } else {
      if (ipgen_mpc_cholesky(nu, Lk) != 0) return 1;
      for (j = 0; j < nx; ++j) { /* K = -Re^-1 Se, column by column */
        for (i = 0; i < nu; ++i) l->g[i] = l->Se[i * nx + j];
        ipgen_mpc_cholesky_solve(nu, Lk, l->g);
        for (i = 0; i < nu; ++i) K[i * nx + j] = -l->g[i];
      }
    }
    if (k == 0) break;
    for (i = 0; i < nx; ++i) /* AtP = A' P */
      for (j = 0; j < nx; ++j) {
        ipgen_mpc_real v = (ipgen_mpc_real)0;
        for (m = 0; m < nx; ++m) v += A[m * nx + i] * P[m * nx + j];
        l->AtP[i * nx + j] = v;
      }
    for (i = 0; i < nx; ++i) /* P_k = 2Q (H_xx) + diag + AtP A + Se' K, symmetrised */
      for (j = 0; j <= i; ++j) {
        ipgen_mpc_real v = (l->exact ? l->H[(long)k * nz * nz + i * nz + j] : (ipgen_mpc_real)2 * s->Q[i * nx + j]) +
                           (i == j ? l->hd[k * nx + i] : (ipgen_mpc_real)0);
        for (m = 0; m < nx; ++m) v += l->AtP[i * nx + m] * A[m * nx + j];
        for (m = 0; m < nu; ++m) v += l->Se[m * nx + i] * K[m * nx + j];
        l->Pn[i * nx + j] = v;
        l->Pn[j * nx + i] = v;
      }
    for (i = 0; i < nx * nx; ++i) P[i] = l->Pn[i];
  }
  return 0;
}

/* The Newton direction `dir` (dx_0 = 0) of the factorised system for the linear terms `q`
 * (indexed as z): the backward pass p_k = q_k + A' p + K' (q_u + B' p), the feedforward
 * -Re^-1 (q_u + B' p), then the forward pass du = K dx + kff, dx' = A dx + B du. */
IPGEN_MPC_LOCAL void ipgen_mpc_riccati_solve(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l, const ipgen_mpc_real q[],
                                             ipgen_mpc_real dir[]) {
  const int nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s), N = IPGEN_MPC_N_OF(s);
  int k, i, m;
  for (i = 0; i < nx; ++i) l->p[i] = q[N * nx + i];
  for (k = N - 1; k >= 0; --k) {
    const ipgen_mpc_real *A = l->A + (long)k * nx * nx, *B = l->B + (long)k * nx * nu;
    const ipgen_mpc_real *K = l->K + (long)k * nu * nx;
    const long o = (long)(N + 1) * nx + (long)k * nu;
    ipgen_mpc_real *kff = l->kff + (long)k * nu;
    for (i = 0; i < nu; ++i) {
      ipgen_mpc_real v = q[o + i];
      for (m = 0; m < nx; ++m) v += B[m * nu + i] * l->p[m];
      l->g[i] = v;
      kff[i] = v;
    }
    if (IPGEN_MPC_SCALAR_INPUT)
      kff[0] *= l->L[k]; /* Re^-1 */
    else
      ipgen_mpc_cholesky_solve(nu, l->L + (long)k * nu * nu, kff);
    for (i = 0; i < nu; ++i) kff[i] = -kff[i];
    if (k == 0) break;
    for (i = 0; i < nx; ++i) {
      ipgen_mpc_real v = q[k * nx + i];
      for (m = 0; m < nx; ++m) v += A[m * nx + i] * l->p[m];
      for (m = 0; m < nu; ++m) v += K[m * nx + i] * l->g[m];
      l->pn[i] = v;
    }
    for (i = 0; i < nx; ++i) l->p[i] = l->pn[i];
  }
  for (i = 0; i < nx; ++i) dir[i] = (ipgen_mpc_real)0;
  for (k = 0; k < N; ++k) {
    const ipgen_mpc_real *A = l->A + (long)k * nx * nx, *B = l->B + (long)k * nx * nu;
    const ipgen_mpc_real *K = l->K + (long)k * nu * nx, *kff = l->kff + (long)k * nu;
    const ipgen_mpc_real *dx = dir + (long)k * nx;
    ipgen_mpc_real *du = dir + (long)(N + 1) * nx + (long)k * nu, *dxn = dir + (long)(k + 1) * nx;
    for (i = 0; i < nu; ++i) {
      ipgen_mpc_real v = kff[i];
      for (m = 0; m < nx; ++m) v += K[i * nx + m] * dx[m];
      du[i] = v;
    }
    for (i = 0; i < nx; ++i) {
      ipgen_mpc_real v = (ipgen_mpc_real)0;
      for (m = 0; m < nx; ++m) v += A[i * nx + m] * dx[m];
      for (m = 0; m < nu; ++m) v += B[i * nu + m] * du[m];
      dxn[i] = v;
    }
  }
}

#ifdef IPGEN_MPC_FIXED
/* ipgen_mpc_riccati_factor (Gauss-Newton) with every size fixed, nu = 1: P in a local array,
 * A taken column by column (column j of P A, then entry j of B' P A and column j of A' P A below
 * the diagonal), so that one column's products stay in registers; B' P A as (P B)' A and B' P B
 * as B' (P B) (P symmetric: the same numbers up to rounding). */
IPGEN_MPC_LOCAL int ipgen_mpc_riccati_factor_fixed(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l) {
  ipgen_mpc_real P[IPGEN_MPC_NX][IPGEN_MPC_NX], Q2[IPGEN_MPC_NX][IPGEN_MPC_NX]; /* 2Q read once */
  const ipgen_mpc_real R2 = (ipgen_mpc_real)2 * s->R[0];
  int k, i, j, m;
  for (i = 0; i < IPGEN_MPC_NX; ++i)
    for (j = 0; j < IPGEN_MPC_NX; ++j) {
      Q2[i][j] = (ipgen_mpc_real)2 * s->Q[i * IPGEN_MPC_NX + j];
      P[i][j] = (ipgen_mpc_real)2 * s->P[i * IPGEN_MPC_NX + j] + (i == j ? l->hd[IPGEN_MPC_N * IPGEN_MPC_NX + i] : (ipgen_mpc_real)0);
    }
  for (k = IPGEN_MPC_N - 1; k >= 0; --k) {
    const ipgen_mpc_real *A = l->A + (long)k * IPGEN_MPC_NX * IPGEN_MPC_NX, *B = l->B + (long)k * IPGEN_MPC_NX;
    ipgen_mpc_real *K = l->K + (long)k * IPGEN_MPC_NX;
    ipgen_mpc_real PB[IPGEN_MPC_NX], Se[IPGEN_MPC_NX], Kl[IPGEN_MPC_NX], APA[IPGEN_MPC_NX][IPGEN_MPC_NX], re;
    for (i = 0; i < IPGEN_MPC_NX; ++i) { /* P B */
      ipgen_mpc_real v = P[i][0] * B[0];
      for (m = 1; m < IPGEN_MPC_NX; ++m) v += P[i][m] * B[m];
      PB[i] = v;
    }
    re = R2 + l->hd[(long)(IPGEN_MPC_N + 1) * IPGEN_MPC_NX + k]; /* Re = 2R + diag + B' P B */
    for (m = 0; m < IPGEN_MPC_NX; ++m) re += B[m] * PB[m];
    for (j = 0; j < IPGEN_MPC_NX; ++j) {
      ipgen_mpc_real pa[IPGEN_MPC_NX], v;
      for (i = 0; i < IPGEN_MPC_NX; ++i) {
        v = P[i][0] * A[j];
        for (m = 1; m < IPGEN_MPC_NX; ++m) v += P[i][m] * A[m * IPGEN_MPC_NX + j];
        pa[i] = v;
      }
      v = PB[0] * A[j];
      for (m = 1; m < IPGEN_MPC_NX; ++m) v += PB[m] * A[m * IPGEN_MPC_NX + j];
      Se[j] = v;
      for (i = j; i < IPGEN_MPC_NX; ++i) { /* 2Q + diag + A' (P A), summed in that order */
        v = Q2[i][j] + (i == j ? l->hd[k * IPGEN_MPC_NX + i] : (ipgen_mpc_real)0);
        for (m = 0; m < IPGEN_MPC_NX; ++m) v += A[m * IPGEN_MPC_NX + i] * pa[m];
        APA[i][j] = v;
      }
    }
    if (!(re > (ipgen_mpc_real)0)) return 1;
    re = (ipgen_mpc_real)1 / re; /* 1 / Re kept */
    for (j = 0; j < IPGEN_MPC_NX; ++j) {
      Kl[j] = -(Se[j] * re);
      K[j] = Kl[j];
    }
    l->L[k] = re;
    if (k == 0) break;
    for (i = 0; i < IPGEN_MPC_NX; ++i) /* P_k = 2Q + diag + A' (P A) + Se' K, symmetric */
      for (j = 0; j <= i; ++j) {
        const ipgen_mpc_real v = APA[i][j] + Se[i] * Kl[j];
        P[i][j] = v;
        P[j][i] = v;
      }
  }
  return 0;
}

/* ipgen_mpc_riccati_solve with every size fixed: the costate and the state in local arrays. */
IPGEN_MPC_LOCAL void ipgen_mpc_riccati_solve_fixed(const ipgen_mpc_layout *l, const ipgen_mpc_real q[], ipgen_mpc_real dir[]) {
  ipgen_mpc_real p[IPGEN_MPC_NX], x[IPGEN_MPC_NX];
  int k, i, m;
  for (i = 0; i < IPGEN_MPC_NX; ++i) p[i] = q[IPGEN_MPC_N * IPGEN_MPC_NX + i];
  for (k = IPGEN_MPC_N - 1; k >= 0; --k) {
    const ipgen_mpc_real *A = l->A + (long)k * IPGEN_MPC_NX * IPGEN_MPC_NX, *B = l->B + (long)k * IPGEN_MPC_NX * IPGEN_MPC_NU;
    const ipgen_mpc_real *K = l->K + (long)k * IPGEN_MPC_NU * IPGEN_MPC_NX;
    const long o = (long)(IPGEN_MPC_N + 1) * IPGEN_MPC_NX + (long)k * IPGEN_MPC_NU;
    ipgen_mpc_real g[IPGEN_MPC_NU], f[IPGEN_MPC_NU], pn[IPGEN_MPC_NX];
    for (i = 0; i < IPGEN_MPC_NU; ++i) {
      ipgen_mpc_real v = q[o + i];
      for (m = 0; m < IPGEN_MPC_NX; ++m) v += B[m * IPGEN_MPC_NU + i] * p[m];
      g[i] = v;
      f[i] = v;
    }
    f[0] *= l->L[k]; /* Re^-1 (nu = 1) */
    for (i = 0; i < IPGEN_MPC_NU; ++i) l->kff[(long)k * IPGEN_MPC_NU + i] = -f[i];
    if (k == 0) break;
    for (i = 0; i < IPGEN_MPC_NX; ++i) {
      ipgen_mpc_real v = q[k * IPGEN_MPC_NX + i];
      for (m = 0; m < IPGEN_MPC_NX; ++m) v += A[m * IPGEN_MPC_NX + i] * p[m];
      for (m = 0; m < IPGEN_MPC_NU; ++m) v += K[m * IPGEN_MPC_NX + i] * g[m];
      pn[i] = v;
    }
    for (i = 0; i < IPGEN_MPC_NX; ++i) p[i] = pn[i];
  }
  for (i = 0; i < IPGEN_MPC_NX; ++i) {
    x[i] = (ipgen_mpc_real)0;
    dir[i] = (ipgen_mpc_real)0;
  }
  for (k = 0; k < IPGEN_MPC_N; ++k) {
    const ipgen_mpc_real *A = l->A + (long)k * IPGEN_MPC_NX * IPGEN_MPC_NX, *B = l->B + (long)k * IPGEN_MPC_NX * IPGEN_MPC_NU;
    const ipgen_mpc_real *K = l->K + (long)k * IPGEN_MPC_NU * IPGEN_MPC_NX, *kff = l->kff + (long)k * IPGEN_MPC_NU;
    ipgen_mpc_real *du = dir + (long)(IPGEN_MPC_N + 1) * IPGEN_MPC_NX + (long)k * IPGEN_MPC_NU;
    ipgen_mpc_real *dxn = dir + (long)(k + 1) * IPGEN_MPC_NX;
    ipgen_mpc_real u[IPGEN_MPC_NU], xn[IPGEN_MPC_NX];
    for (i = 0; i < IPGEN_MPC_NU; ++i) {
      ipgen_mpc_real v = kff[i];
      for (m = 0; m < IPGEN_MPC_NX; ++m) v += K[i * IPGEN_MPC_NX + m] * x[m];
      u[i] = v;
    }
    for (i = 0; i < IPGEN_MPC_NX; ++i) {
      ipgen_mpc_real v = A[i * IPGEN_MPC_NX] * x[0];
      for (m = 1; m < IPGEN_MPC_NX; ++m) v += A[i * IPGEN_MPC_NX + m] * x[m];
      for (m = 0; m < IPGEN_MPC_NU; ++m) v += B[i * IPGEN_MPC_NU + m] * u[m];
      xn[i] = v;
    }
    for (i = 0; i < IPGEN_MPC_NU; ++i) du[i] = u[i];
    for (i = 0; i < IPGEN_MPC_NX; ++i) {
      dxn[i] = xn[i];
      x[i] = xn[i];
    }
  }
}
#endif

/* The effective multiplier lam + (lam rp - rc) / t of inequality i (the Newton system's). */
IPGEN_MPC_LOCAL ipgen_mpc_real ipgen_mpc_effective(const ipgen_mpc_layout *l, long i) {
  return l->lam[i] + (l->lam[i] * l->rp[i] - l->rc[i]) / l->t[i];
}

/* The Newton system's linear terms rhs (for complementarity targets rc) from gl, gs and the
 * inequalities; the slacks eliminated (their reduced gradient kept in gs' copy in dsig). */
IPGEN_MPC_LOCAL void ipgen_mpc_newton_rhs(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l) {
  const int nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s), N = IPGEN_MPC_N_OF(s);
  const long Z = IPGEN_MPC_VARIABLES(nx, nu, N), nS = IPGEN_MPC_SLACKS(N, IPGEN_MPC_SOFT_OF(s));
  const long M = IPGEN_MPC_INEQUALITIES(nu, N, IPGEN_MPC_HARD_OF(s), IPGEN_MPC_SOFT_OF(s)), first_soft = M - 2 * nS;
  long i, var, soft;
  ipgen_mpc_real sign, bound;
  for (i = 0; i < Z; ++i) l->rhs[i] = l->gl[i];
  for (i = 0; i < first_soft; ++i) { /* inputs and hard bounds: a (effective - lam) */
    ipgen_mpc_inequality(s, l, i, &var, &sign, &soft, &bound);
    l->rhs[var] += sign * (ipgen_mpc_effective(l, i) - l->lam[i]);
  }
  for (i = 0; i < nS; ++i) { /* a soft bound's relaxed inequality r and its slack's s >= 0, n */
    const long r = first_soft + i, n = first_soft + nS + i;
    const ipgen_mpc_real er = ipgen_mpc_effective(l, r), en = ipgen_mpc_effective(l, n);
    const ipgen_mpc_real sr = l->lam[r] / l->t[r];
    const ipgen_mpc_real gsig = l->gs[i] - (er - l->lam[r]) - (en - l->lam[n]);
    ipgen_mpc_inequality(s, l, r, &var, &sign, &soft, &bound);
    l->dsig[i] = gsig;
    l->rhs[var] += sign * (er - l->lam[r]) + sign * sr * gsig / l->hs[i];
  }
}

/* The step of the slacks, inequality slacks and multipliers from the direction `dir`; returns the
 * largest step in (0, 1] along (dt, dlam) keeping t and lam nonnegative. */
IPGEN_MPC_LOCAL ipgen_mpc_real ipgen_mpc_recover(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l) {
  const int nu = IPGEN_MPC_NU_OF(s), N = IPGEN_MPC_N_OF(s);
  const long nS = IPGEN_MPC_SLACKS(N, IPGEN_MPC_SOFT_OF(s)), M = IPGEN_MPC_INEQUALITIES(nu, N, IPGEN_MPC_HARD_OF(s), IPGEN_MPC_SOFT_OF(s));
  const long first_soft = M - 2 * nS;
  long i, var, soft;
  ipgen_mpc_real sign, bound, alpha = (ipgen_mpc_real)1;
  for (i = 0; i < nS; ++i) {
    const long r = first_soft + i;
    ipgen_mpc_inequality(s, l, r, &var, &sign, &soft, &bound);
    l->dsig[i] = (sign * l->lam[r] / l->t[r] * l->dir[var] - l->dsig[i]) / l->hs[i];
  }
  for (i = 0; i < M; ++i) {
    ipgen_mpc_real cd;
    ipgen_mpc_inequality(s, l, i, &var, &sign, &soft, &bound);
    cd = ipgen_mpc_constraint(var, sign, soft, l->dir, l->dsig);
    l->dt[i] = -l->rp[i] - cd;
    l->dlam[i] = (l->lam[i] * (l->rp[i] + cd) - l->rc[i]) / l->t[i];
    if (l->dt[i] < 0 && -l->t[i] / l->dt[i] < alpha) alpha = -l->t[i] / l->dt[i];
    if (l->dlam[i] < 0 && -l->lam[i] / l->dlam[i] < alpha) alpha = -l->lam[i] / l->dlam[i];
  }
  return alpha;
}

#ifdef IPGEN_MPC_FIXED
/* The inequalities in ipgen_mpc_decode's order, ROW(i, var, sign, soft, kind) for each: the
 * variable's index in z, its sign a, the slack's index and the kind (0: a bound on a variable,
 * 1: a soft bound's relaxed inequality, 2: a slack's s >= 0: var and sign unused), the kind and
 * the sign constants, the layout walked stage by stage. */
#define IPGEN_MPC_EACH_INEQUALITY(s, ROW)                                                                \
  do {                                                                                                   \
    long i_ = 0, k_, j_;                                                                                 \
    for (k_ = 0; k_ < IPGEN_MPC_N; ++k_)                                                                 \
      for (j_ = 0; j_ < IPGEN_MPC_NU; ++j_, i_ += 2) {                                                   \
        const long v_ = (long)(IPGEN_MPC_N + 1) * IPGEN_MPC_NX + k_ * IPGEN_MPC_NU + j_;                 \
        ROW(i_, v_, 1, -1L, 0);                                                                          \
        ROW(i_ + 1, v_, -1, -1L, 0);                                                                     \
      }                                                                                                  \
    for (k_ = 1; k_ <= IPGEN_MPC_N; ++k_)                                                                \
      for (j_ = 0; j_ < IPGEN_MPC_HARD; ++j_, i_ += 2) {                                                 \
        const long v_ = k_ * IPGEN_MPC_NX + (s)->hard_index[j_];                                         \
        ROW(i_, v_, 1, -1L, 0);                                                                          \
        ROW(i_ + 1, v_, -1, -1L, 0);                                                                     \
      }                                                                                                  \
    for (k_ = 1; k_ <= IPGEN_MPC_N; ++k_)                                                                \
      for (j_ = 0; j_ < IPGEN_MPC_SOFT; ++j_, i_ += 2) {                                                 \
        const long v_ = k_ * IPGEN_MPC_NX + (s)->soft_index[j_];                                         \
        const long f_ = i_ - 2L * IPGEN_MPC_N * (IPGEN_MPC_NU + IPGEN_MPC_HARD);                         \
        (void)f_;                                                                                        \
        ROW(i_, v_, 1, f_, 1);                                                                           \
        ROW(i_ + 1, v_, -1, f_ + 1, 1);                                                                  \
      }                                                                                                  \
    for (j_ = 0; j_ < 2L * IPGEN_MPC_N * IPGEN_MPC_SOFT; ++j_, ++i_) ROW(i_, 0L, 0, j_, 2);             \
  } while (0)
/* The soft bounds' relaxed inequalities, SOFT(f, var, sign, j): slack f, soft bound j. */
#define IPGEN_MPC_EACH_SOFT(s, SOFT)                                                                     \
  do {                                                                                                   \
    long f_ = 0, k_, j_;                                                                                 \
    for (k_ = 1; k_ <= IPGEN_MPC_N; ++k_)                                                                \
      for (j_ = 0; j_ < IPGEN_MPC_SOFT; ++j_, f_ += 2) {                                                 \
        const long v_ = k_ * IPGEN_MPC_NX + (s)->soft_index[j_];                                         \
        SOFT(f_, v_, 1, j_);                                                                             \
        SOFT(f_ + 1, v_, -1, j_);                                                                        \
      }                                                                                                  \
  } while (0)

/* ipgen_mpc_encode's bounds b = a (value - traj[var]) with every size fixed, written stage by
 * stage without decoding each index (the fixed form's ipgen_mpc_qp keeps 1/t in the code table). */
IPGEN_MPC_LOCAL void ipgen_mpc_bounds_fixed(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l) {
  const ipgen_mpc_real *const x = l->traj;
  ipgen_mpc_real *const b = l->bound;
  long i = 0;
  int k, j;
  for (k = 0; k < IPGEN_MPC_N; ++k)
    for (j = 0; j < IPGEN_MPC_NU; ++j, i += 2) {
      const ipgen_mpc_real v = x[(long)(IPGEN_MPC_N + 1) * IPGEN_MPC_NX + k * IPGEN_MPC_NU + j];
      b[i] = s->u_max[j] - v;
      b[i + 1] = -(s->u_min[j] - v);
    }
  for (k = 1; k <= IPGEN_MPC_N; ++k)
    for (j = 0; j < IPGEN_MPC_HARD; ++j, i += 2) {
      const ipgen_mpc_real v = x[k * IPGEN_MPC_NX + s->hard_index[j]];
      b[i] = s->hard_max[j] - v;
      b[i + 1] = -(s->hard_min[j] - v);
    }
  for (k = 1; k <= IPGEN_MPC_N; ++k)
    for (j = 0; j < IPGEN_MPC_SOFT; ++j, i += 2) {
      const ipgen_mpc_real v = x[k * IPGEN_MPC_NX + s->soft_index[j]];
      b[i] = s->soft_max[j] - v;
      b[i + 1] = -(s->soft_min[j] - v);
    }
  for (j = 0; j < 2 * IPGEN_MPC_N * IPGEN_MPC_SOFT; ++j, ++i) b[i] = (ipgen_mpc_real)0;
}

/* ipgen_mpc_qp (below) with every size fixed: the same iterates in exact arithmetic, fewer passes
 * over the inequalities. Per inequality 1/t is kept (l->code: the table is not read here) and
 * the Newton system's linear terms are rewritten without the multipliers that cancel: rhs = the
 * cost's gradient + sum a (lam / t) rp for the predictor (the effective multiplier minus lam is
 * lam rp / t - lam, and C' lam adds lam back), and the corrector's rhs is the predictor's minus
 * a w with w = (dt dlam - centring mu) / t (kept in l->rc). The predictor's mu_aff is summed
 * during its recovery (sum lam t + alpha sum (lam dt + t dlam) + alpha^2 sum dt dlam); the step
 * of t and lam is taken in the next iteration's first pass; the step length compares t < -alpha
 * dt before dividing. Rounding differs from the run-time path's. */
IPGEN_MPC_LOCAL int ipgen_mpc_qp(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l, ipgen_mpc_info *info,
                                  ipgen_mpc_real *costate) {
  const int nx = IPGEN_MPC_NX, N = IPGEN_MPC_N;
  const long Z = IPGEN_MPC_VARIABLES(IPGEN_MPC_NX, IPGEN_MPC_NU, IPGEN_MPC_N), nS = IPGEN_MPC_SLACKS(IPGEN_MPC_N, IPGEN_MPC_SOFT);
  const long M = IPGEN_MPC_INEQUALITIES(IPGEN_MPC_NU, IPGEN_MPC_N, IPGEN_MPC_HARD, IPGEN_MPC_SOFT), first_soft = M - 2 * nS;
  const ipgen_mpc_real one = (ipgen_mpc_real)1, zero = (ipgen_mpc_real)0;
  ipgen_mpc_real *const t = l->t, *const lam = l->lam, *const dt = l->dt, *const dlam = l->dlam, *const rp = l->rp;
  ipgen_mpc_real *const w = l->rc, *const inv = l->code, *const z = l->z, *const dir = l->dir, *const hd = l->hd;
  ipgen_mpc_real *const gl = l->gl, *const rhs = l->rhs, *const sig = l->sig, *const dsig = l->dsig, *const gs = l->gs;
  ipgen_mpc_real *const hs = l->hs;
  const ipgen_mpc_real *const bound = l->bound;
  const ipgen_mpc_real kappa = l->barrier, t_floor = kappa > zero ? kappa : one; /* t at least this at the start */
  ipgen_mpc_real step = zero;
  long i;
  int k, a, m, iteration;
  (void)first_soft;
  ipgen_mpc_bounds_fixed(s, l);
  for (i = (long)(N + 1) * nx; i < Z; ++i) z[i] = zero;
  for (k = 0; k < N; ++k) {
    const ipgen_mpc_real *A = l->A + (long)k * nx * nx;
    for (a = 0; a < nx; ++a) {
      ipgen_mpc_real v = l->d[(long)k * nx + a];
      for (m = 0; m < nx; ++m) v += A[a * nx + m] * z[(long)k * nx + m];
      z[(long)(k + 1) * nx + a] = v;
    }
  }
#define IPGEN_MPC_C(i, var, sign, soft, kind, x, sv) \
  (((kind) != 2 ? (ipgen_mpc_real)(sign) * (x)[var] : zero) - ((kind) != 0 ? (sv)[soft] : zero))
  for (i = 0; i < nS; ++i) sig[i] = zero;
#define IPGEN_MPC_ROW(i, var, sign, soft, kind) \
  if ((kind) == 1) sig[soft] = ipgen_mpc_max(sig[soft], (ipgen_mpc_real)(sign) * z[var] - bound[i]);
  IPGEN_MPC_EACH_INEQUALITY(s, IPGEN_MPC_ROW);
#undef IPGEN_MPC_ROW
#define IPGEN_MPC_ROW(i, var, sign, soft, kind)                                                   \
  {                                                                                               \
    t[i] = ipgen_mpc_max(bound[i] - IPGEN_MPC_C(i, var, sign, soft, kind, z, sig), t_floor);        \
    lam[i] = kappa > zero ? kappa / t[i] : one;                                                   \
  }
  if (!l->duals_warm) IPGEN_MPC_EACH_INEQUALITY(s, IPGEN_MPC_ROW);
#undef IPGEN_MPC_ROW
  for (iteration = 0;; ++iteration) {
    ipgen_mpc_real mu = zero, worst = zero, mu_aff, alpha = one, centring, residual, s1 = zero, s2 = zero;
    const ipgen_mpc_real scale = ipgen_mpc_gradient_fixed(s, l);
    for (i = 0; i < Z; ++i) {
      hd[i] = zero;
      rhs[i] = gl[i];
    }
    /* t, lam stepped; rp, the gap (the barrier's: |t lam - kappa|), max |rp|, C' lam into gl and gs,
     * 1/t, Sigma on the bounded variables and the predictor's a (lam / t) rp into rhs (the
     * barrier's Newton step: a (lam rp + kappa) / t) */
#define IPGEN_MPC_ROW(i, var, sign, soft, kind)                                                   \
  {                                                                                               \
    ipgen_mpc_real ti = t[i], li = lam[i], r, q, sg;                                              \
    if (iteration > 0) {                                                                          \
      ti += step * dt[i];                                                                         \
      li += step * dlam[i];                                                                       \
      t[i] = ti;                                                                                  \
      lam[i] = li;                                                                                \
    }                                                                                             \
    r = IPGEN_MPC_C(i, var, sign, soft, kind, z, sig) + ti - bound[i];                            \
    q = one / ti;                                                                                 \
    sg = li * q;                                                                                  \
    rp[i] = r;                                                                                    \
    inv[i] = q;                                                                                   \
    mu += ipgen_mpc_abs(li * ti - kappa);                                                         \
    worst = ipgen_mpc_max(worst, ipgen_mpc_abs(r));                                               \
    if ((kind) != 2) {                                                                            \
      gl[var] += (ipgen_mpc_real)(sign) * li;                                                     \
      rhs[var] += (ipgen_mpc_real)(sign) * (sg * r + kappa * q);                                  \
    }                                                                                             \
    if ((kind) != 0) gs[soft] -= li;                                                              \
    if ((kind) == 0) hd[var] += sg;                                                               \
  }
    IPGEN_MPC_EACH_INEQUALITY(s, IPGEN_MPC_ROW);
#undef IPGEN_MPC_ROW
    residual = ipgen_mpc_qp_residual_fixed(s, l, ipgen_mpc_max(mu / (ipgen_mpc_real)M, worst), scale, costate);
    mu = mu / (ipgen_mpc_real)M;
    info->qp_residual = residual;
    if (!ipgen_mpc_finite(residual)) return IPGEN_MPC_NOT_FINITE;
    if (residual <= s->qp_tolerance) return IPGEN_MPC_OK;
    if (iteration >= l->qp_budget) return IPGEN_MPC_QP_BUDGET;
    info->qp_iterations += 1;
    /* the slacks eliminated: their curvature, Sigma's part and the predictor's reduced gradient */
#define IPGEN_MPC_SOFT_ROW(f, var, sign, j)                                                                  \
  {                                                                                                          \
    const long r_ = first_soft + (f), n_ = first_soft + nS + (f);                                            \
    const ipgen_mpc_real sr = lam[r_] * inv[r_], sn = lam[n_] * inv[n_];                                     \
    const ipgen_mpc_real h = (ipgen_mpc_real)2 * s->soft_quadratic[j] + sr + sn;                             \
    const ipgen_mpc_real gsig =                                                                              \
        gs[f] - (sr * rp[r_] - lam[r_]) - (sn * rp[n_] - lam[n_]) - kappa * (inv[r_] + inv[n_]);             \
    hs[f] = h;                                                                                               \
    hd[var] += sr - sr * sr / h;                                                                             \
    dsig[f] = gsig;                                                                                          \
    rhs[var] += (ipgen_mpc_real)(sign) * sr * gsig / h;                                                      \
  }
    IPGEN_MPC_EACH_SOFT(s, IPGEN_MPC_SOFT_ROW);
#undef IPGEN_MPC_SOFT_ROW
    if ((l->exact ? ipgen_mpc_riccati_factor(s, l) : ipgen_mpc_riccati_factor_fixed(s, l)) != 0) return iteration > 0 ? IPGEN_MPC_QP_BUDGET : IPGEN_MPC_NOT_FINITE;
/* the slacks' step from the direction (the predictor's and the corrector's) */
#define IPGEN_MPC_SOFT_STEP(f, var, sign, j)                                                                 \
  {                                                                                                          \
    const long r_ = first_soft + (f);                                                                        \
    dsig[f] = ((ipgen_mpc_real)(sign) * lam[r_] * inv[r_] * dir[var] - dsig[f]) / hs[f];                     \
  }
/* the inequalities' steps dt, dlam and the step length; WTERM: the complementarity target's term */
#define IPGEN_MPC_ROW(i, var, sign, soft, kind)                                                   \
  {                                                                                               \
    const ipgen_mpc_real ti = t[i], li = lam[i], r = rp[i], cd = IPGEN_MPC_C(i, var, sign, soft, kind, dir, dsig); \
    const ipgen_mpc_real d_t = -r - cd, d_l = li * inv[i] * (r + cd) - li - IPGEN_MPC_WTERM(i);   \
    dt[i] = d_t;                                                                                  \
    dlam[i] = d_l;                                                                                \
    if (d_t < 0 && ti < -alpha * d_t) alpha = -ti / d_t;                                          \
    if (d_l < 0 && li < -alpha * d_l) alpha = -li / d_l;                                          \
    IPGEN_MPC_SUMS                                                                                \
  }
    /* the barrier's Newton step (its target t lam = kappa is in rhs), or the predictor */
    ipgen_mpc_riccati_solve_fixed(l, rhs, dir);
    IPGEN_MPC_EACH_SOFT(s, IPGEN_MPC_SOFT_STEP);
    if (kappa > zero) {
#define IPGEN_MPC_WTERM(i) (-kappa * inv[i])
#define IPGEN_MPC_SUMS
      IPGEN_MPC_EACH_INEQUALITY(s, IPGEN_MPC_ROW);
#undef IPGEN_MPC_WTERM
#undef IPGEN_MPC_SUMS
    } else {
#define IPGEN_MPC_WTERM(i) zero
#define IPGEN_MPC_SUMS           \
  s1 += li * d_t + ti * d_l;   \
  s2 += d_t * d_l;
      IPGEN_MPC_EACH_INEQUALITY(s, IPGEN_MPC_ROW);
#undef IPGEN_MPC_WTERM
#undef IPGEN_MPC_SUMS
      mu_aff = ipgen_mpc_max((mu * (ipgen_mpc_real)M + alpha * (s1 + alpha * s2)) / (ipgen_mpc_real)M, zero);
      centring = mu > zero ? mu_aff / mu : zero;
      centring = centring * centring * centring * mu;
      /* corrector: targets centring mu with the predictor's second-order term */
#define IPGEN_MPC_W(i, var, sign, soft, kind)                                                     \
  {                                                                                               \
    const ipgen_mpc_real wi = (dt[i] * dlam[i] - centring) * inv[i];                              \
    w[i] = wi;                                                                                    \
    if ((kind) != 2) rhs[var] -= (ipgen_mpc_real)(sign) * wi;                                     \
  }
      IPGEN_MPC_EACH_INEQUALITY(s, IPGEN_MPC_W);
#undef IPGEN_MPC_W
#define IPGEN_MPC_SOFT_ROW(f, var, sign, j)                                                                  \
  {                                                                                                          \
    const long r_ = first_soft + (f), n_ = first_soft + nS + (f);                                            \
    const ipgen_mpc_real sr = lam[r_] * inv[r_], sn = lam[n_] * inv[n_];                                     \
    dsig[f] = gs[f] - (sr * rp[r_] - lam[r_] - w[r_]) - (sn * rp[n_] - lam[n_] - w[n_]);                     \
    rhs[var] += (ipgen_mpc_real)(sign) * sr * (w[r_] + w[n_]) / hs[f];                                      \
  }
      IPGEN_MPC_EACH_SOFT(s, IPGEN_MPC_SOFT_ROW);
#undef IPGEN_MPC_SOFT_ROW
      ipgen_mpc_riccati_solve_fixed(l, rhs, dir);
      IPGEN_MPC_EACH_SOFT(s, IPGEN_MPC_SOFT_STEP);
      alpha = one;
#define IPGEN_MPC_WTERM(i) w[i]
#define IPGEN_MPC_SUMS
      IPGEN_MPC_EACH_INEQUALITY(s, IPGEN_MPC_ROW);
#undef IPGEN_MPC_WTERM
#undef IPGEN_MPC_SUMS
    }
#undef IPGEN_MPC_SOFT_STEP
#undef IPGEN_MPC_ROW
    alpha = alpha < one ? (ipgen_mpc_real)0.995 * alpha : one;
    for (i = 0; i < Z; ++i) z[i] += alpha * dir[i];
    for (i = 0; i < nS; ++i) sig[i] += alpha * dsig[i];
    step = alpha; /* t and lam: in the next pass */
    /* the barrier's budget spent: the step is the answer (its residual is the one before it); t and
     * lam stepped, the next sample's warm start */
    if (kappa > zero && iteration + 1 >= l->qp_budget) {
      for (i = 0; i < M; ++i) {
        t[i] += step * dt[i];
        lam[i] += step * dlam[i];
      }
      return residual <= (ipgen_mpc_real)1e6 ? IPGEN_MPC_OK : IPGEN_MPC_QP_BUDGET;
    }
  }
#undef IPGEN_MPC_C
}
#else
/* Solves the QP about the guess (z's x_0 part and the defects d set by the caller) by the
 * primal-dual interior-point method with Mehrotra's predictor-corrector; at most qp_iterations
 * iterations. Returns 0 (converged to qp_tolerance), 2 (budget reached), 4 (a breakdown);
 * `costate`: the dynamics' largest multiplier at the last iterate. */
IPGEN_MPC_LOCAL int ipgen_mpc_qp(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l, ipgen_mpc_info *info,
                                  ipgen_mpc_real *costate) {
  const int nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s), N = IPGEN_MPC_N_OF(s);
  const long Z = IPGEN_MPC_VARIABLES(nx, nu, N), nS = IPGEN_MPC_SLACKS(N, IPGEN_MPC_SOFT_OF(s));
  const long M = IPGEN_MPC_INEQUALITIES(nu, N, IPGEN_MPC_HARD_OF(s), IPGEN_MPC_SOFT_OF(s)), first_soft = M - 2 * nS;
  const ipgen_mpc_real one = (ipgen_mpc_real)1, zero = (ipgen_mpc_real)0;
  const ipgen_mpc_real kappa = l->barrier, t_floor = kappa > zero ? kappa : one; /* t at least this at the start */
  long i, var, soft;
  int k, a, m, iteration;
  ipgen_mpc_real sign, bound;
  /* start: the dynamics rolled out with du = 0 (every later step keeps them), slacks at the
   * violation, t at the distance to the bound (at least 1), lam = 1; with a barrier weight on
   * its central path, t at the distance (at least kappa), lam = kappa / t, unless t and lam are
   * the last sample's (l->duals_warm) */
  ipgen_mpc_encode(s, l);
  for (i = (long)(N + 1) * nx; i < Z; ++i) l->z[i] = zero;
  for (k = 0; k < N; ++k) {
    const ipgen_mpc_real *A = l->A + (long)k * nx * nx;
    for (a = 0; a < nx; ++a) {
      ipgen_mpc_real v = l->d[(long)k * nx + a];
      for (m = 0; m < nx; ++m) v += A[a * nx + m] * l->z[(long)k * nx + m];
      l->z[(long)(k + 1) * nx + a] = v;
    }
  }
  for (i = 0; i < nS; ++i) l->sig[i] = zero;
  for (i = 0; i < first_soft + nS; ++i) {
    ipgen_mpc_inequality(s, l, i, &var, &sign, &soft, &bound);
    if (soft >= 0) l->sig[soft] = ipgen_mpc_max(l->sig[soft], sign * l->z[var] - bound);
  }
  for (i = 0; i < M && !l->duals_warm; ++i) {
    ipgen_mpc_inequality(s, l, i, &var, &sign, &soft, &bound);
    l->t[i] = ipgen_mpc_max(bound - ipgen_mpc_constraint(var, sign, soft, l->z, l->sig), t_floor);
    l->lam[i] = kappa > zero ? kappa / l->t[i] : one;
  }
  for (iteration = 0;; ++iteration) {
    ipgen_mpc_real mu = zero, mu_aff = zero, alpha, centring, residual;
    const ipgen_mpc_real scale = ipgen_mpc_gradient(s, l);
    /* one pass over the inequalities: the primal residuals, the gap, C' lam into the gradients and
     * the Hessian's diagonal Sigma = lam / t on each bounded variable (the slacks' below) */
    for (i = 0; i < Z; ++i) l->hd[i] = zero;
    for (i = 0; i < M; ++i) {
      ipgen_mpc_inequality(s, l, i, &var, &sign, &soft, &bound);
      l->rp[i] = ipgen_mpc_constraint(var, sign, soft, l->z, l->sig) + l->t[i] - bound;
      mu += ipgen_mpc_abs(l->lam[i] * l->t[i] - kappa); /* the gap, or the barrier's distance to its path */
      if (var >= 0) l->gl[var] += sign * l->lam[i];
      if (soft >= 0) l->gs[soft] -= l->lam[i];
      if (i < first_soft) l->hd[var] += l->lam[i] / l->t[i];
    }
    mu = M > 0 ? mu / (ipgen_mpc_real)M : zero;
    residual = ipgen_mpc_qp_residual(s, l, mu, scale, costate);
    info->qp_residual = residual;
    if (!ipgen_mpc_finite(residual)) return IPGEN_MPC_NOT_FINITE;
    if (residual <= s->qp_tolerance) return IPGEN_MPC_OK;
    if (iteration >= l->qp_budget) return IPGEN_MPC_QP_BUDGET;
    info->qp_iterations += 1;
    for (i = 0; i < nS; ++i) { /* the slacks eliminated */
      const long r = first_soft + i, n = first_soft + nS + i;
      const ipgen_mpc_real sr = l->lam[r] / l->t[r];
      l->hs[i] = (ipgen_mpc_real)2 * s->soft_quadratic[ipgen_mpc_soft_bound(s, i)] + sr + l->lam[n] / l->t[n];
      ipgen_mpc_inequality(s, l, r, &var, &sign, &soft, &bound);
      l->hd[var] += sr - sr * sr / l->hs[i];
    }
    /* A Riccati breakdown (Re not positive definite: Sigma's spread beyond the precision, at the
     * end of a solve) keeps the iterate reached, which satisfies the dynamics. */
    if (ipgen_mpc_riccati_factor(s, l) != 0) return iteration > 0 ? IPGEN_MPC_QP_BUDGET : IPGEN_MPC_NOT_FINITE;
    if (kappa > zero) { /* Newton's step on the barrier problem: complementarity targets kappa */
      for (i = 0; i < M; ++i) l->rc[i] = l->lam[i] * l->t[i] - kappa;
    } else {
      /* predictor: complementarity targets 0 */
      for (i = 0; i < M; ++i) l->rc[i] = l->lam[i] * l->t[i];
      ipgen_mpc_newton_rhs(s, l);
      ipgen_mpc_riccati_solve(s, l, l->rhs, l->dir);
      alpha = ipgen_mpc_recover(s, l);
      for (i = 0; i < M; ++i) mu_aff += (l->lam[i] + alpha * l->dlam[i]) * (l->t[i] + alpha * l->dt[i]);
      mu_aff = M > 0 ? mu_aff / (ipgen_mpc_real)M : zero;
      centring = mu > zero ? mu_aff / mu : zero;
      centring = centring * centring * centring;
      /* corrector: targets centring mu, with the predictor's second-order term */
      for (i = 0; i < M; ++i) l->rc[i] = l->lam[i] * l->t[i] + l->dt[i] * l->dlam[i] - centring * mu;
    }
    ipgen_mpc_newton_rhs(s, l);
    ipgen_mpc_riccati_solve(s, l, l->rhs, l->dir);
    alpha = ipgen_mpc_recover(s, l);
    alpha = alpha < one ? (ipgen_mpc_real)0.995 * alpha : one;
    for (i = 0; i < Z; ++i) l->z[i] += alpha * l->dir[i];
    for (i = 0; i < nS; ++i) l->sig[i] += alpha * l->dsig[i];
    for (i = 0; i < M; ++i) {
      l->t[i] += alpha * l->dt[i];
      l->lam[i] += alpha * l->dlam[i];
    }
    /* the barrier's budget spent: the step is the answer (its residual is the one before it) */
    if (kappa > zero && iteration + 1 >= l->qp_budget) return residual <= (ipgen_mpc_real)1e6 ? IPGEN_MPC_OK : IPGEN_MPC_QP_BUDGET;
  }
}

#endif

/* The Lagrangian's Hessian per stage, H_k = blockdiag(2Q, 2R) + sum_i nu_i d2F_i/dw2 at w = (x_k,
 * u_k), nu the multipliers of x_{k+1} = F(x_k, u_k) (l->costate, from the last QP): column j by
 * central differences of the exact sensitivities' transposed products [A' nu; B' nu] at w +- h e_j,
 * h = 1e-5 max(1, |w_j|) (1e-2 in float), symmetrised. 2 (nx + nu) RK4 samples with
 * sensitivities per stage. Returns 1 if the model failed. */
IPGEN_MPC_LOCAL int ipgen_mpc_exact_hessian(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l) {
  const int nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s), N = IPGEN_MPC_N_OF(s), nz = nx + nu;
  const ipgen_mpc_real relative = sizeof(ipgen_mpc_real) == sizeof(float) ? (ipgen_mpc_real)1e-2 : (ipgen_mpc_real)1e-5;
  int k, i, j, side;
  for (k = 0; k < N; ++k) {
    ipgen_mpc_real *Hk = l->H + (long)k * nz * nz;
    const ipgen_mpc_real *v = l->costate + (long)k * nx;
    for (j = 0; j < nz; ++j) {
      const ipgen_mpc_real w0 = j < nx ? l->traj[(long)k * nx + j] : l->traj[(long)(N + 1) * nx + (long)k * nu + j - nx];
      const ipgen_mpc_real h = relative * ipgen_mpc_max((ipgen_mpc_real)1, ipgen_mpc_abs(w0));
      for (side = 0; side < 2; ++side) {
        for (i = 0; i < nx; ++i) l->fd_w[i] = l->traj[(long)k * nx + i];
        for (i = 0; i < nu; ++i) l->fd_w[nx + i] = l->traj[(long)(N + 1) * nx + (long)k * nu + i];
        l->fd_w[j] = side == 0 ? w0 + h : w0 - h;
        if (ipgen_mpc_rk4_layout(s, l, l->fd_w, l->fd_w + nx, l->p, l->fd_A, l->fd_B) != 0) return 1;
        for (i = 0; i < nz; ++i) { /* [A' nu; B' nu] */
          ipgen_mpc_real g = (ipgen_mpc_real)0;
          int r;
          for (r = 0; r < nx; ++r) g += (i < nx ? l->fd_A[r * nx + i] : l->fd_B[r * nu + i - nx]) * v[r];
          if (side == 0)
            Hk[i * nz + j] = g;
          else
            Hk[i * nz + j] = (Hk[i * nz + j] - g) / ((ipgen_mpc_real)2 * h);
        }
      }
    }
    for (i = 0; i < nz; ++i)
      for (j = 0; j < i; ++j) {
        const ipgen_mpc_real mean = (ipgen_mpc_real)0.5 * (Hk[i * nz + j] + Hk[j * nz + i]);
        Hk[i * nz + j] = Hk[j * nz + i] = mean;
      }
    for (i = 0; i < nx; ++i)
      for (j = 0; j < nx; ++j) Hk[i * nz + j] += (ipgen_mpc_real)2 * s->Q[i * nx + j];
    for (i = 0; i < nu; ++i)
      for (j = 0; j < nu; ++j) Hk[(nx + i) * nz + nx + j] += (ipgen_mpc_real)2 * s->R[i * nu + j];
  }
  return 0;
}

/* Shifts the inequalities' values v (t or lam) by one stage: each of their four blocks, stage by
 * stage over N stages (u's bounds 2 nu a stage, the hard bounds' 2 hard, the soft bounds' 2 soft,
 * their slacks' 2 soft), takes its next stage's values; the last stage keeps its own. */
IPGEN_MPC_LOCAL void ipgen_mpc_shift_inequalities(const ipgen_mpc_settings *s, ipgen_mpc_real v[]) {
  const int N = IPGEN_MPC_N_OF(s);
  const long width[4] = {2L * IPGEN_MPC_NU_OF(s), 2L * IPGEN_MPC_HARD_OF(s), 2L * IPGEN_MPC_SOFT_OF(s),
                         2L * IPGEN_MPC_SOFT_OF(s)};
  long base = 0, i;
  int b;
  for (b = 0; b < 4; ++b) {
    for (i = 0; i < (long)(N - 1) * width[b]; ++i) v[base + i] = v[base + width[b] + i];
    base += (long)N * width[b];
  }
}

/* ---- the controller ----------------------------------------------------------------------- */

/* Forgets the warm start: the next step starts cold (every state x_k at the estimate, every
 * input at u_ref clipped to its bounds; ipgen_mpc_track: at its reference's rows). */
IPGEN_MPC_API void ipgen_mpc_reset(ipgen_mpc_real work[]) { work[0] = (ipgen_mpc_real)0; }

/* The problem's cost (the header's comment) of the trajectory traj (states x_0..x_N, then the
 * inputs; soft violations from the states) and, when dz is not null, its derivative along dz
 * (the soft penalty's where a bound is violated). */
IPGEN_MPC_LOCAL ipgen_mpc_real ipgen_mpc_trajectory_cost(const ipgen_mpc_settings *s, const ipgen_mpc_real x_refs[],
                                                         const ipgen_mpc_real u_refs[], const ipgen_mpc_real traj[],
                                                         const ipgen_mpc_real dz[], ipgen_mpc_real *slope) {
  const int nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s), N = IPGEN_MPC_N_OF(s);
  const ipgen_mpc_real *x = traj, *u = traj + (long)(N + 1) * nx;
  const ipgen_mpc_real *dx = dz, *du = dz ? dz + (long)(N + 1) * nx : 0;
  ipgen_mpc_real cost = (ipgen_mpc_real)0, d = (ipgen_mpc_real)0;
  int k, a, b, j;
  for (k = 0; k <= N; ++k) {
    const ipgen_mpc_real *W = k == N ? s->P : s->Q, *xr = IPGEN_MPC_X_REF(s, x_refs, k, nx);
    const ipgen_mpc_real *ur = IPGEN_MPC_U_REF(s, u_refs, k < N ? k : 0, nu);
    for (a = 0; a < nx; ++a)
      for (b = 0; b < nx; ++b) {
        const ipgen_mpc_real w = (x[k * nx + a] - xr[a]) * W[a * nx + b];
        cost += w * (x[k * nx + b] - xr[b]);
        if (dz && k > 0) d += (ipgen_mpc_real)2 * w * dx[k * nx + b];
      }
    if (k > 0)
      for (j = 0; j < IPGEN_MPC_SOFT_OF(s); ++j) {
        const int i = k * nx + s->soft_index[j];
        const ipgen_mpc_real above = x[i] - s->soft_max[j], below = s->soft_min[j] - x[i];
        const ipgen_mpc_real over = ipgen_mpc_max(above, below);
        if (over > 0) {
          cost += s->soft_linear[j] * over + s->soft_quadratic[j] * over * over;
          if (dz) d += (s->soft_linear[j] + (ipgen_mpc_real)2 * s->soft_quadratic[j] * over) * (above > below ? dx[i] : -dx[i]);
        }
      }
    if (k == N) break;
    for (a = 0; a < nu; ++a)
      for (b = 0; b < nu; ++b) {
        const ipgen_mpc_real w = (u[k * nu + a] - ur[a]) * s->R[a * nu + b];
        cost += w * (u[k * nu + b] - ur[b]);
        if (dz) d += (ipgen_mpc_real)2 * w * du[k * nu + b];
      }
  }
  if (slope) *slope = d;
  return cost;
}

/* The l1 merit function cost + weight (sum_k |F(x_k, u_k) - x_{k+1}|_1 + |x - x_0|_1) of the
 * trajectory traj for the estimate x; `defects` the sum when already known (negative: computed
 * here, by one RK4 sample per stage without sensitivities). Returns 1 if the model failed. */
IPGEN_MPC_LOCAL int ipgen_mpc_merit(const ipgen_mpc_settings *s, const ipgen_mpc_layout *l, const ipgen_mpc_real traj[],
                                    const ipgen_mpc_real x[], ipgen_mpc_real weight, ipgen_mpc_real defects,
                                    ipgen_mpc_real *merit) {
  const int nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s), N = IPGEN_MPC_N_OF(s);
  int k, i;
  if (defects < 0) {
    defects = (ipgen_mpc_real)0;
    for (k = 0; k < N; ++k) {
      if (ipgen_mpc_rk4_layout(s, l, traj + (long)k * nx, traj + (long)(N + 1) * nx + (long)k * nu, l->p, 0, 0) != 0)
        return 1;
      for (i = 0; i < nx; ++i) defects += ipgen_mpc_abs(l->p[i] - traj[(long)(k + 1) * nx + i]);
    }
    for (i = 0; i < nx; ++i) defects += ipgen_mpc_abs(x[i] - traj[i]);
  }
  *merit = ipgen_mpc_trajectory_cost(s, l->x_refs, l->u_refs, traj, 0, 0) + weight * defects;
  return 0;
}

/* The problem's cost (the header's comment) of the trajectory held in `work` (states and inputs
 * as they are, soft violations from the states) about a reference per stage (ipgen_mpc_track's
 * x_refs, u_refs; null: the settings' constant x_ref, u_ref). */
IPGEN_MPC_API ipgen_mpc_real ipgen_mpc_cost_tracking(const ipgen_mpc_settings *s, const ipgen_mpc_real x_refs[],
                                                     const ipgen_mpc_real u_refs[], const ipgen_mpc_real work[]) {
  return ipgen_mpc_trajectory_cost(s, x_refs, u_refs, work + 1, 0, 0);
}

/* ipgen_mpc_cost_tracking about the settings' constant x_ref and u_ref. */
IPGEN_MPC_API ipgen_mpc_real ipgen_mpc_cost(const ipgen_mpc_settings *s, const ipgen_mpc_real work[]) {
  return ipgen_mpc_cost_tracking(s, 0, 0, work);
}

/* What every step checks of the settings (cheap: no pass over the weights): sizes >= 1, a
 * positive period, budgets >= 1, bounds ordered, indices in range, the soft bounds' weights
 * valid; 0, else IPGEN_MPC_BAD_SETTINGS. ipgen_mpc_check adds finiteness. */
IPGEN_MPC_LOCAL int ipgen_mpc_check_shape(const ipgen_mpc_settings *s) {
  int j;
  if (s->nx < 1 || s->nu < 1 || s->N < 1 || s->substeps < 1 || !(s->period > 0) || s->dynamics == 0) return IPGEN_MPC_BAD_SETTINGS;
  if (s->sqp_iterations < 1 || s->qp_iterations < 1 || s->hard_count < 0 || s->soft_count < 0) return IPGEN_MPC_BAD_SETTINGS;
  /* sizes fixed at compile time that the settings do not have */
#ifdef IPGEN_MPC_NX
  if (s->nx != IPGEN_MPC_NX) return IPGEN_MPC_BAD_SETTINGS;
#endif
#ifdef IPGEN_MPC_NU
  if (s->nu != IPGEN_MPC_NU) return IPGEN_MPC_BAD_SETTINGS;
#endif
#ifdef IPGEN_MPC_N
  if (s->N != IPGEN_MPC_N) return IPGEN_MPC_BAD_SETTINGS;
#endif
#ifdef IPGEN_MPC_HARD
  if (s->hard_count != IPGEN_MPC_HARD) return IPGEN_MPC_BAD_SETTINGS;
#endif
#ifdef IPGEN_MPC_SOFT
  if (s->soft_count != IPGEN_MPC_SOFT) return IPGEN_MPC_BAD_SETTINGS;
#endif
  for (j = 0; j < s->nu; ++j)
    if (!(s->u_min[j] < s->u_max[j])) return IPGEN_MPC_BAD_SETTINGS;
  for (j = 0; j < s->hard_count; ++j)
    if (s->hard_index[j] < 0 || s->hard_index[j] >= s->nx || !(s->hard_min[j] < s->hard_max[j])) return IPGEN_MPC_BAD_SETTINGS;
  for (j = 0; j < s->soft_count; ++j)
    if (s->soft_index[j] < 0 || s->soft_index[j] >= s->nx || !(s->soft_min[j] < s->soft_max[j]) ||
        !(s->soft_linear[j] >= 0) || !(s->soft_quadratic[j] > 0))
      return IPGEN_MPC_BAD_SETTINGS;
  return IPGEN_MPC_OK;
}

/* 0 if the settings describe a problem: ipgen_mpc_check_shape's conditions, and a finite period,
 * u bounds, state bounds, soft weights, Q, R, P and x_ref, u_ref (a caller's check once, before
 * its first step: the steps check only the shape), else IPGEN_MPC_BAD_SETTINGS. */
IPGEN_MPC_API int ipgen_mpc_check(const ipgen_mpc_settings *s) {
  const int nx = s->nx, nu = s->nu;
  int j;
  if (ipgen_mpc_check_shape(s) != IPGEN_MPC_OK || !ipgen_mpc_finite(s->period)) return IPGEN_MPC_BAD_SETTINGS;
  for (j = 0; j < nu; ++j)
    if (!ipgen_mpc_finite(s->u_min[j]) || !ipgen_mpc_finite(s->u_max[j]) || !ipgen_mpc_finite(s->u_ref[j]))
      return IPGEN_MPC_BAD_SETTINGS;
  for (j = 0; j < nu * nu; ++j)
    if (!ipgen_mpc_finite(s->R[j])) return IPGEN_MPC_BAD_SETTINGS;
  for (j = 0; j < nx * nx; ++j)
    if (!ipgen_mpc_finite(s->Q[j]) || !ipgen_mpc_finite(s->P[j])) return IPGEN_MPC_BAD_SETTINGS;
  for (j = 0; j < nx; ++j)
    if (!ipgen_mpc_finite(s->x_ref[j])) return IPGEN_MPC_BAD_SETTINGS;
  for (j = 0; j < s->hard_count; ++j)
    if (!ipgen_mpc_finite(s->hard_min[j]) || !ipgen_mpc_finite(s->hard_max[j])) return IPGEN_MPC_BAD_SETTINGS;
  for (j = 0; j < s->soft_count; ++j)
    if (!ipgen_mpc_finite(s->soft_min[j]) || !ipgen_mpc_finite(s->soft_max[j]) || !ipgen_mpc_finite(s->soft_linear[j]) ||
        !ipgen_mpc_finite(s->soft_quadratic[j]))
      return IPGEN_MPC_BAD_SETTINGS;
  return IPGEN_MPC_OK;
}

/* One controller step: u (nu) for the state estimate x (nx), from the problem of the header's
 * comment about the reference x_refs ((N + 1) x nx, row k for x_k) and u_refs (N x nu, row k for
 * u_k), each null for the settings' constant x_ref or u_ref, solved about the warm start held in
 * `work` (ipgen_mpc_work_size entries; shifted by one sample first when s->shift), or cold after
 * ipgen_mpc_reset (every x_k at the estimate, or at x_refs' row k; u_k at its u_ref clipped): a
 * tracked plan's rows from this sample on are its x_refs and u_refs. Up to sqp_iterations
 * Gauss-Newton SQP iterations (cold_iterations on a cold start, if more), each: the RK4 map and its
 * sensitivities at every stage (with shifted sensitivities a warm step's first iteration keeps most
 * stages' from the last sample), then one QP. u is
 * clipped to [u_min, u_max] (an interior-point solution within qp_tolerance of a bound may lie
 * beyond it by that much). `info` (may be null) reports what was done; returns its status.
 * `method` (may be null): how each QP is solved and the model linearised (ipgen_mpc_method); a
 * barrier weight that is negative or not finite, unknown sensitivities, or frozen or shifted ones
 * with the exact Hessian (which differentiates the sensitivities) are IPGEN_MPC_BAD_SETTINGS. */
IPGEN_MPC_API int ipgen_mpc_track_method(const ipgen_mpc_settings *s, const ipgen_mpc_method *method,
                                         const ipgen_mpc_real x_refs[], const ipgen_mpc_real u_refs[],
                                         const ipgen_mpc_real x[], ipgen_mpc_real u[], ipgen_mpc_real work[],
                                         ipgen_mpc_info *info) {
  const int nx = IPGEN_MPC_NX_OF(s), nu = IPGEN_MPC_NU_OF(s), N = IPGEN_MPC_N_OF(s);
  const long Z = IPGEN_MPC_VARIABLES(nx, nu, N);
  ipgen_mpc_info own;
  ipgen_mpc_layout l;
  ipgen_mpc_real *us, weight = (ipgen_mpc_real)0, previous = (ipgen_mpc_real)0;
  int k, i, iteration, budget, stalled = 0, status = IPGEN_MPC_OK, frozen = 0, shifted = 0, kept = 0;
  if (info == 0) info = &own;
  info->status = IPGEN_MPC_OK;
  info->sqp_iterations = info->qp_iterations = 0;
  info->step = info->defect = info->qp_residual = (ipgen_mpc_real)0;
  if (ipgen_mpc_check_shape(s) != IPGEN_MPC_OK ||
      (method != 0 && (!(method->barrier >= 0) || !ipgen_mpc_finite(method->barrier) ||
                       (method->sensitivities != IPGEN_MPC_EXACT && method->sensitivities != IPGEN_MPC_FROZEN &&
                        method->sensitivities != IPGEN_MPC_SHIFTED) ||
                       (method->sensitivities != IPGEN_MPC_EXACT && s->exact_hessian)))) {
    for (i = 0; i < nu && i < s->nu; ++i) u[i] = IPGEN_MPC_U_REF(s, u_refs, 0, nu)[i];
    return info->status = IPGEN_MPC_BAD_SETTINGS;
  }
  ipgen_mpc_carve(s, work, &l);
  if (method != 0) {
    l.barrier = method->barrier;
    frozen = method->sensitivities != IPGEN_MPC_EXACT;
    shifted = method->sensitivities == IPGEN_MPC_SHIFTED;
  }
  l.x_refs = x_refs;
  l.u_refs = u_refs;
  us = l.traj + (long)(N + 1) * nx;
  budget = s->sqp_iterations;
  l.qp_budget = s->qp_iterations;
  if (!(*l.warm > 0)) {
    if (s->cold_iterations > budget) budget = s->cold_iterations;
    /* the barrier's warm start is the previous solution: a cold start solves its QPs first */
    if (l.barrier > 0 && l.qp_budget < IPGEN_MPC_COLD_QP_ITERATIONS) l.qp_budget = IPGEN_MPC_COLD_QP_ITERATIONS;
    for (k = 0; k <= N; ++k)
      for (i = 0; i < nx; ++i) l.traj[k * nx + i] = x_refs ? x_refs[(long)k * nx + i] : x[i];
    for (k = 0; k < N; ++k)
      for (i = 0; i < nu; ++i) {
        const ipgen_mpc_real v = IPGEN_MPC_U_REF(s, u_refs, k, nu)[i];
        us[k * nu + i] = v < s->u_min[i] ? s->u_min[i] : (v > s->u_max[i] ? s->u_max[i] : v);
      }
  } else if (s->shift) {
    kept = shifted; /* the last sample's stage Jacobians, shifted below */
    for (k = 0; k < N; ++k)
      for (i = 0; i < nx; ++i) l.traj[k * nx + i] = l.traj[(k + 1) * nx + i];
    for (k = 0; k + 1 < N; ++k)
      for (i = 0; i < nu; ++i) us[k * nu + i] = us[(k + 1) * nu + i];
    if (l.barrier > 0 && l.t[0] > 0) { /* the barrier's QP continues from the last sample's slacks and
                                           * multipliers (t[0] = 0: dropped after an infeasible QP) */
      ipgen_mpc_shift_inequalities(s, l.t);
      ipgen_mpc_shift_inequalities(s, l.lam);
      l.duals_warm = 1;
    }
  }
  *l.warm = (ipgen_mpc_real)1;
  for (iteration = 0; iteration < budget; ++iteration) {
    ipgen_mpc_real defect = (ipgen_mpc_real)0, defects = (ipgen_mpc_real)0, step = (ipgen_mpc_real)0;
    ipgen_mpc_real costate = (ipgen_mpc_real)0, alpha = (ipgen_mpc_real)1;
    int qp;
    if (kept) /* stage k's A, B from the last sample's stage k + 1 (shifted sensitivities) */
      for (k = 1; k + 1 < N; ++k) {
        for (i = 0; i < nx * nx; ++i) l.A[(long)k * nx * nx + i] = l.A[(long)(k + 1) * nx * nx + i];
        for (i = 0; i < nx * nu; ++i) l.B[(long)k * nx * nu + i] = l.B[(long)(k + 1) * nx * nu + i];
      }
    for (k = 0; k < N; ++k) { /* linearise: F, dF/dx, dF/du and the defects */
      ipgen_mpc_real *dk = l.d + (long)k * nx;
      const int keep = kept && k > 0 && k + 1 < N; /* F only: A, B kept */
      l.frozen = frozen && k > 0; /* the first stage exact: the input applied and x_1's bounds rest on it */
      if (ipgen_mpc_rk4_layout(s, &l, l.traj + (long)k * nx, us + (long)k * nu, dk,
                               keep ? 0 : l.A + (long)k * nx * nx, keep ? 0 : l.B + (long)k * nx * nu) != 0) {
        status = IPGEN_MPC_MODEL_FAILED;
        break;
      }
      for (i = 0; i < nx; ++i) {
        dk[i] -= l.traj[(long)(k + 1) * nx + i];
        defect = ipgen_mpc_max(defect, ipgen_mpc_abs(dk[i]));
        defects += ipgen_mpc_abs(dk[i]);
      }
    }
    kept = 0; /* a later iteration linearises about its own guess */
    if (status != IPGEN_MPC_OK) break;
    info->defect = defect;
    /* converged: the step and the defects below the tolerance; or the step below its square root
     * and no longer halving for 3 iterations (the interior point's accuracy at a degenerate
     * constraint, O(sqrt(gap)) in the primal, is the floor: the input is then exact far below it) */
    if (iteration > 0 && s->sqp_tolerance > 0 && defect <= s->sqp_tolerance &&
        (info->step <= s->sqp_tolerance || stalled >= 3))
      break;
    for (i = 0; i < nx; ++i) {
      l.z[i] = x[i] - l.traj[i];
      defects += ipgen_mpc_abs(l.z[i]);
    }
    /* the exact Hessian once a QP has given the multipliers; Gauss-Newton where the QP is not
     * convex (its Riccati recursion breaks down: measured better than adding delta I, whose large
     * delta crawls) or the model fails */
    l.exact = s->exact_hessian && info->sqp_iterations > 0 && ipgen_mpc_exact_hessian(s, &l) == 0;
    qp = ipgen_mpc_qp(s, &l, info, &costate);
    /* a step's later QPs continue from this one's slacks and multipliers (unshifted: the next
     * linearisation is about its solution), the barrier's path-following across iterations */
    l.duals_warm = l.barrier > 0;
    if (qp == IPGEN_MPC_NOT_FINITE && l.exact) {
      l.exact = 0;
      l.duals_warm = 0;
      qp = ipgen_mpc_qp(s, &l, info, &costate);
      l.duals_warm = l.barrier > 0;
    }
    info->sqp_iterations += 1;
    if (qp == IPGEN_MPC_NOT_FINITE) {
      status = qp;
      break;
    }
    if (qp == IPGEN_MPC_QP_BUDGET && !(info->qp_residual <= (ipgen_mpc_real)1e6)) { /* its iterates diverge */
      if (s->hard_count == 0) {
        status = IPGEN_MPC_NOT_FINITE; /* no hard bound to be infeasible against: a breakdown, the next step cold */
        break;
      }
      info->status = IPGEN_MPC_INFEASIBLE; /* keep the guess */
      l.t[0] = (ipgen_mpc_real)0;          /* but not the barrier's slacks and multipliers */
      break;
    }
    info->status = qp == IPGEN_MPC_QP_BUDGET ? IPGEN_MPC_QP_BUDGET : IPGEN_MPC_OK; /* the last QP's */
    for (i = 0; i < Z; ++i) step = ipgen_mpc_max(step, ipgen_mpc_abs(l.z[i]));
    /* backtracking (Armijo) on the l1 merit function, its weight above the costates; full steps
     * once the step is small (1e-3: the local phase, where the merit function would cut steps
     * that are good: the Maratos effect) */
    if (s->line_search && step > (ipgen_mpc_real)1e-3) {
      ipgen_mpc_real merit0 = (ipgen_mpc_real)0, merit = (ipgen_mpc_real)0, slope = (ipgen_mpc_real)0;
      int tries;
      weight = ipgen_mpc_max(weight, (ipgen_mpc_real)1.1 * costate + (ipgen_mpc_real)1e-3);
      ipgen_mpc_merit(s, &l, l.traj, x, weight, defects, &merit0);
      ipgen_mpc_trajectory_cost(s, l.x_refs, l.u_refs, l.traj, l.z, &slope);
      slope -= weight * defects;
      for (tries = 0; tries < 20; ++tries, alpha *= (ipgen_mpc_real)0.5) {
        for (i = 0; i < Z; ++i) l.dir[i] = l.traj[i] + alpha * l.z[i];
        if (ipgen_mpc_merit(s, &l, l.dir, x, weight, (ipgen_mpc_real)-1, &merit) != 0) continue;
        if (merit <= merit0 + (ipgen_mpc_real)1e-4 * alpha * slope) break;
      }
      if (tries == 20) alpha = (ipgen_mpc_real)1; /* no decrease found (rounding at the optimum): take the step */
    }
    for (i = 0; i < Z; ++i) l.traj[i] += alpha * l.z[i];
    if (!ipgen_mpc_finite(step)) {
      status = IPGEN_MPC_NOT_FINITE;
      break;
    }
    stalled = iteration > 0 && step <= ipgen_mpc_sqrt(s->sqp_tolerance) && step > (ipgen_mpc_real)0.5 * previous ? stalled + 1 : 0;
    previous = step;
    info->step = step;
    if (iteration + 1 == budget && s->sqp_tolerance > 0 && !(step <= s->sqp_tolerance))
      info->status = IPGEN_MPC_SQP_BUDGET;
  }
  if (status != IPGEN_MPC_OK) {
    info->status = status;
    *l.warm = (ipgen_mpc_real)0;
  }
  for (i = 0; i < nu; ++i) {
    const ipgen_mpc_real v = us[i];
    u[i] = ipgen_mpc_finite(v) ? (v < s->u_min[i] ? s->u_min[i] : (v > s->u_max[i] ? s->u_max[i] : v))
                               : IPGEN_MPC_U_REF(s, u_refs, 0, nu)[i]; /* the reference's first input */
  }
  return info->status;
}

/* ipgen_mpc_track_method with the default method: the interior point, RK4's exact sensitivities. */
IPGEN_MPC_API int ipgen_mpc_track(const ipgen_mpc_settings *s, const ipgen_mpc_real x_refs[],
                                  const ipgen_mpc_real u_refs[], const ipgen_mpc_real x[], ipgen_mpc_real u[],
                                  ipgen_mpc_real work[], ipgen_mpc_info *info) {
  return ipgen_mpc_track_method(s, 0, x_refs, u_refs, x, u, work, info);
}

/* ipgen_mpc_track about the settings' constant x_ref and u_ref: the controller's step. */
IPGEN_MPC_API int ipgen_mpc_step(const ipgen_mpc_settings *s, const ipgen_mpc_real x[], ipgen_mpc_real u[],
                                 ipgen_mpc_real work[], ipgen_mpc_info *info) {
  return ipgen_mpc_track(s, 0, 0, x, u, work, info);
}

#ifdef __cplusplus
}
#endif

#endif /* IPGEN_MPC_H_INCLUDED */
