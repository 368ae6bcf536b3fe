/* ipgen_model.h: the C interface of one compiled ipgen model.
 *
 * A model library (`ipgen run` compiles one per model from its C header and
 * templates/model_library.c.jinja, cached by content) exports one function,
 *
 *   const ipgen_model *ipgen_model_get(void);
 *
 * returning a static, immutable description of the model: its sizes, the parameter layout and
 * function pointers to the generated equations. ipsim's simulator is compiled once and loads
 * any model library at run time (ipsim/runtime_model.hpp); ctypes can load one as well.
 *
 * Coordinates are ipgen's own (docs/model.md), every link angle absolute, from the upright
 * vertical, clockwise positive:
 *   - a cart or an arm ("classical", "rotary"): dof = n + 1, q[0] the cart position [m] or the
 *     arm angle [rad], q[1..n] the link angles [rad];
 *   - a chain on a fixed pivot ("fixed"): dof = n, q[0..n-1] the angles of links 1..n [rad]
 *     (no base; link 1 hangs from the pivot).
 * qd are their rates. Vectors are plain arrays of `dof` doubles, matrices row-major. The inputs
 * u[0..inputs) enter as M(q) qdd + bias(q, qd) = B u with the constant B of `input_matrix`
 * (dof x inputs):
 *   - a cart or an arm: one input, the force [N] or torque [N m] on the base: B = e0;
 *   - a fixed chain: u[k] is the torque [N m] of the motor at joint joints[k] (1 = the shoulder,
 *     between the ground and link 1; j between links j - 1 and j), clockwise positive, acting on
 *     link j and, reacting, on link j - 1: B's column k is e_(j-1) - e_(j-2) (e_0 alone for
 *     j = 1; 0-based entries). The power input k delivers is u[k] times its joint's relative
 *     rate, (B^T qd)[k].
 *
 * C99; no allocation, no globals but the model's constant description; every function is
 * reentrant.
 */
#ifndef IPGEN_MODEL_H_INCLUDED
#define IPGEN_MODEL_H_INCLUDED

#ifdef __cplusplus
extern "C" {
#endif

/* Bumped whenever this struct or the parameter layout changes: a library built for another
 * ABI is refused when it is loaded. 2: gravity and n_matrix appended. 3: fixed-pivot chains
 * with m inputs: input_matrix and joints appended to ipgen_model, the rotors Ir and gr to
 * ipgen_parameters. 4: rk4_step appended. */
#define IPGEN_MODEL_ABI 4

/* The largest number of degrees of freedom (base + links) a parameter struct holds. */
#define IPGEN_MAX_DOF 41

/* The largest number of inputs a model has (a fixed chain: one per driven joint). */
#define IPGEN_MAX_INPUTS IPGEN_MAX_DOF

/* Physical parameters in SI units, index k the body of coordinate k: for a cart or an arm 0 the
 * base and 1..n the links, for a fixed chain 0..n-1 the links 1..n; entries at and beyond `dof`
 * are not read. As the C header's params and links structs together: masses m [kg], lengths
 * l [m], viscous damping delta (base [kg/s] or [N m s], joints [N m s]; a fixed chain's
 * delta[0] is joint 1's, against the ground), gravity g [m/s^2]; the links as built: com [m]
 * from the pivot to the CoG, J [kg m^2] about the CoG (J[0] of an arm: its inertia about the
 * vertical), J_axial [kg m^2] about the link's own axis, tip [kg] a point mass at the far end
 * (a fixed chain reads neither). NaN in com or J means the homogeneous rod's value
 * (ipgen_model.rod_links replaces them). Per input k (a fixed chain's motors; a cart or an arm
 * reads neither): the rotor's inertia Ir[k] [kg m^2] (0: none) and gear ratio gr[k]. */
typedef struct {
  double m[IPGEN_MAX_DOF], l[IPGEN_MAX_DOF], delta[IPGEN_MAX_DOF];
  double g;
  double com[IPGEN_MAX_DOF], J[IPGEN_MAX_DOF], J_axial[IPGEN_MAX_DOF], tip[IPGEN_MAX_DOF];
  double Ir[IPGEN_MAX_INPUTS], gr[IPGEN_MAX_INPUTS];
} ipgen_parameters;

/* One model. A function pointer is null when the model does not provide that function (a
 * header specialised to a scene may omit some). Functions returning int return 0 on success
 * and non-zero when M(q) is not positive definite (then their outputs are not written). */
typedef struct {
  int abi;             /* IPGEN_MODEL_ABI of the library */
  const char *name;    /* the model's name, e.g. "rotary2" */
  const char *type;    /* "classical" (cart), "rotary" (Furuta arm) or "fixed" (fixed pivot) */
  const char *inertia; /* rotary: "pivot" or "full"; classical, fixed: "" */
  int links;           /* n >= 1 */
  int dof;             /* n + 1 (cart, arm) or n (fixed), <= IPGEN_MAX_DOF */
  int inputs;          /* m >= 1, <= IPGEN_MAX_INPUTS: the length of u and the columns of B */
  int links_as_built;  /* 1: com, J, J_axial and tip are read; 0: the rods only */

  /* qdd (dof) = M^-1 (B u - bias). */
  int (*forward_dynamics)(const double q[], const double qd[], const double u[], const ipgen_parameters *p,
                          double qdd[]);
  /* qdd and its exact derivatives: dqdd_dq and dqdd_dqd (dof x dof), dqdd_du (dof x inputs). */
  int (*forward_dynamics_derivatives)(const double q[], const double qd[], const double u[],
                                      const ipgen_parameters *p, double qdd[], double dqdd_dq[],
                                      double dqdd_dqd[], double dqdd_du[]);
  /* x' = f(x, u), x = [q; qd]: A = df/dx (2 dof x 2 dof), B = df/du (2 dof x inputs). */
  int (*linearize)(const double q[], const double qd[], const double u[], const ipgen_parameters *p, double A[],
                   double B[]);
  /* M(q) (dof x dof, symmetric positive definite) and bias(q, qd) = N(q, qd) qd + P(q) (dof). */
  void (*mass_matrix)(const double q[], const ipgen_parameters *p, double M[]);
  void (*bias)(const double q[], const double qd[], const ipgen_parameters *p, double b[]);
  /* Kinetic and potential energy [J] and Rayleigh's dissipation function D [W/2]. */
  double (*kinetic_energy)(const double q[], const double qd[], const ipgen_parameters *p);
  double (*potential_energy)(const double q[], const ipgen_parameters *p);
  double (*dissipation)(const double qd[], const ipgen_parameters *p);
  /* Replaces every NaN com and J entry by the homogeneous rod's value. */
  void (*rod_links)(ipgen_parameters *p);
  /* The first parameter ("m1", ...) that differs from a value folded into a specialised
   * model, or null (always null for a general model). */
  const char *(*check_folded)(const ipgen_parameters *p);
  /* Optional (null when absent; the simulator never calls them): P(q) = dV/dq (dof) and N(q, qd)
   * (dof x dof), the parts of bias = N qd + P, for checks of a model's functions against each
   * other. */
  void (*gravity)(const double q[], const ipgen_parameters *p, double P[]);
  void (*n_matrix)(const double q[], const double qd[], const ipgen_parameters *p, double N[]);
  /* B of M qdd + bias = B u (dof x inputs, row-major, constant; see above). */
  const double *input_matrix;
  /* A fixed chain: the driven joint of each input (inputs entries, 1 = the shoulder); a cart or
   * an arm: null (its input drives the base). */
  const int *joints;
  /* Optional: one step h [s] of ipgen_rk4 (below) of x = [q; qd] (2 dof), in place, with the
   * inputs u held: what ipsim's method rk4 computes, in one call instead of four. Non-zero, x
   * unchanged, when M(q) is not positive definite or a derivative is not finite at a stage. */
  int (*rk4_step)(double x[], const double u[], double h, const ipgen_parameters *p);
} ipgen_model;

/* The classic fourth-order Runge-Kutta step of x' = f(t, x) (n states) from t to t + h, written
 * once for ipsim's fixed-step method rk4 and for every model library's rk4_step:
 *   k1 = f(t, x), k2 = f(t + h/2, x + h/2 k1), k3 = f(t + h/2, x + h/2 k2), k4 = f(t + h, x + h k3),
 *   x <- x + h/6 (k1 + 2 k2 + 2 k3 + k4),
 * in this order of operations (so both give the same bits where neither compiler fuses a
 * multiply and an add: GCC's defaults on x86-64; with FMA enabled, e.g. -march=native, compile
 * with -ffp-contract=off for that). `work` holds 5 n doubles. Returns 0, or the first non-zero
 * return of f (x then unchanged). Named without a suffix: every symbol of a model's header is
 * ipgen_<name>_<something>, so none can be this one. */
static inline int ipgen_rk4(int n, double x[], double t, double h,
                            int (*f)(void *context, double t, const double x[], double dx[]), void *context,
                            double work[]) {
  double *k1 = work, *k2 = work + n, *k3 = work + 2 * n, *k4 = work + 3 * n, *stage = work + 4 * n;
  const double half = 0.5 * h, sixth = h / 6.0;
  int i, flag;
  if ((flag = f(context, t, x, k1)) != 0) return flag;
  for (i = 0; i < n; ++i) stage[i] = x[i] + half * k1[i];
  if ((flag = f(context, t + half, stage, k2)) != 0) return flag;
  for (i = 0; i < n; ++i) stage[i] = x[i] + half * k2[i];
  if ((flag = f(context, t + half, stage, k3)) != 0) return flag;
  for (i = 0; i < n; ++i) stage[i] = x[i] + h * k3[i];
  if ((flag = f(context, t + h, stage, k4)) != 0) return flag;
  for (i = 0; i < n; ++i) x[i] += sixth * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
  return 0;
}

/* The symbol every model library exports. */
typedef const ipgen_model *(*ipgen_model_get_fn)(void);
#define IPGEN_MODEL_SYMBOL "ipgen_model_get"

#ifdef __cplusplus
}
#endif

#endif /* IPGEN_MODEL_H_INCLUDED */
