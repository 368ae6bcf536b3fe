/* Test driver: evaluates one generated C header (ipgen --emit c) at states read from stdin,
 * in the format of tests/cpp/eval_model.cpp, so that the two headers can be compared.
 *
 *   gcc -std=c99 -I<dir> -DIPGEN_C_HEADER='"cdip.h"' -DIPGEN_C_NAME=cdip eval_model.c -lm
 *   (add -DIPGEN_SCALAR=float for single precision)
 *
 * Input (whitespace-separated numbers): m[0..dof) l[0..dof) delta[0..dof) g, count, then
 * count times q[0..dof) qd[0..dof) u. Output: "model <dof> <sizeof scalar>", then per state
 * one line per quantity, "<name> <values>" (matrices row by row, %.17g): M, bias, gravity, N,
 * qdd, T, V, D, dqdd_dq, dqdd_dqd, dqdd_du, A, B, and "status <forward_dynamics return>". */
#include <stdio.h>

#include IPGEN_C_HEADER

#define PASTE2(a, b) a##b
#define PASTE(a, b) PASTE2(a, b)
#define FN(suffix) PASTE(PASTE(ipgen_, IPGEN_C_NAME), suffix)
#define DOF_OF(name) PASTE(PASTE(IPGEN_, name), _DOF)
#ifndef IPGEN_C_NAMEU
#error define IPGEN_C_NAMEU (the model name in upper case)
#endif
#define DOF DOF_OF(IPGEN_C_NAMEU)

typedef FN(_params) params_t;

static int read_scalar(IPGEN_SCALAR *x) {
  double value = 0.0;
  if (scanf("%lf", &value) != 1) return 0;
  *x = (IPGEN_SCALAR)value;
  return 1;
}

static void print(const char *name, const IPGEN_SCALAR *x, int n) {
  int i;
  printf("%s", name);
  for (i = 0; i < n; ++i) printf(" %.17g", (double)x[i]);
  printf("\n");
}

int main(void) {
  params_t p;
  int i, k, count = 0;
  for (i = 0; i < DOF; ++i) if (!read_scalar(&p.m[i])) return 2;
  for (i = 0; i < DOF; ++i) if (!read_scalar(&p.l[i])) return 2;
  for (i = 0; i < DOF; ++i) if (!read_scalar(&p.delta[i])) return 2;
  if (!read_scalar(&p.g) || scanf("%d", &count) != 1 || count < 0) return 2;
  printf("model %d %d\n", DOF, (int)sizeof(IPGEN_SCALAR));
  for (k = 0; k < count; ++k) {
    IPGEN_SCALAR q[DOF], qd[DOF], u, out[DOF * DOF], qdd[DOF], dq[DOF * DOF], dqd[DOF * DOF], du[DOF];
    IPGEN_SCALAR A[4 * DOF * DOF], B[2 * DOF], T, V, D;
    int status;
    for (i = 0; i < DOF; ++i) if (!read_scalar(&q[i])) return 2;
    for (i = 0; i < DOF; ++i) if (!read_scalar(&qd[i])) return 2;
    if (!read_scalar(&u)) return 2;
    FN(_mass_matrix)(q, &p, out);
    print("M", out, DOF * DOF);
    FN(_bias)(q, qd, &p, out);
    print("bias", out, DOF);
    FN(_gravity)(q, &p, out);
    print("gravity", out, DOF);
    FN(_n_matrix)(q, qd, &p, out);
    print("N", out, DOF * DOF);
    for (i = 0; i < DOF; ++i) qdd[i] = (IPGEN_SCALAR)0;
    status = FN(_forward_dynamics)(q, qd, u, &p, qdd);
    print("qdd", qdd, DOF);
    T = FN(_kinetic_energy)(q, qd, &p);
    V = FN(_potential_energy)(q, &p);
    D = FN(_dissipation)(qd, &p);
    print("T", &T, 1);
    print("V", &V, 1);
    print("D", &D, 1);
    status |= FN(_forward_dynamics_derivatives)(q, qd, u, &p, qdd, dq, dqd, du) << 1;
    print("dqdd_dq", dq, DOF * DOF);
    print("dqdd_dqd", dqd, DOF * DOF);
    print("dqdd_du", du, DOF);
    status |= FN(_linearize)(q, qd, u, &p, A, B) << 2;
    print("A", A, 4 * DOF * DOF);
    print("B", B, 2 * DOF);
    printf("status %d\n", status);
  }
  return 0;
}
