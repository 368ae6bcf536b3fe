// Test driver: evaluates generated ipgen model headers at states read from stdin.
//
// One model:
//   g++ -std=c++17 -I<dir> -I/usr/include/eigen3 -DIPGEN_HEADER='"cdip.hpp"'
//       -DIPGEN_NAMESPACE=cdip eval_model.cpp -o eval
// Several models in one program (one parse of Eigen for all): IPGEN_HEADER names a file that
// includes every header, IPGEN_MODELS lists their namespaces as X(name) items:
//   -DIPGEN_HEADER='"models.hpp"' -DIPGEN_MODELS='X(cdip) X(rsip)'
//
// Usage: eval <namespace> double|float < input
// Input (whitespace-separated numbers):
//   m[0..kDof) l[0..kDof) delta[0..kDof) g
//   count
//   count times: q[0..kDof) qd[0..kDof) u
// Output: "model <Model::kName> <Model::kType> <Model::kInertia or -> <kDof>", then for each
// state one line per quantity, "<name> <values>", matrices row by row, numbers with %.17g:
//   M, bias, gravity, N, qdd (forward_dynamics), T, V, D, then from forward_dynamics_derivatives
//   dqdd_dq, dqdd_dqd, dqdd_du.
// Every call goes through the header's Model struct, which forwards to the free functions.

#include <cstdio>
#include <cstring>
#include <iostream>

#include IPGEN_HEADER

#ifndef IPGEN_MODELS
#define IPGEN_MODELS X(IPGEN_NAMESPACE)
#endif
#define IPGEN_STRINGIFY(x) #x

namespace {

template <typename Scalar>
bool read_scalar(Scalar& value) {
  double x = 0.0;
  if (!(std::cin >> x)) {
    return false;
  }
  value = static_cast<Scalar>(x);
  return true;
}

template <typename Derived>
void print_matrix(const char* name, const Eigen::MatrixBase<Derived>& a) {
  std::printf("%s", name);
  for (Eigen::Index r = 0; r < a.rows(); ++r) {  // row by row, whatever the storage order
    for (Eigen::Index c = 0; c < a.cols(); ++c) {
      std::printf(" %.17g", static_cast<double>(a(r, c)));
    }
  }
  std::printf("\n");
}

template <typename Scalar>
void print_scalar(const char* name, Scalar x) {
  std::printf("%s %.17g\n", name, static_cast<double>(x));
}

template <typename Model, typename Scalar>
int run() {
  constexpr int kDof = Model::kDof;
  static_assert(Model::kLinks + 1 == kDof, "kDof must be kLinks + 1");
  using Params = typename Model::template Params<Scalar>;
  using Vector = typename Model::template Vector<Scalar>;
  Params p;
  for (auto* group : {&p.m, &p.l, &p.delta}) {
    for (Scalar& x : *group) {
      if (!read_scalar(x)) {
        std::fprintf(stderr, "eval_model: cannot read the parameters\n");
        return 2;
      }
    }
  }
  int count = 0;
  if (!read_scalar(p.g) || !(std::cin >> count) || count < 0) {
    std::fprintf(stderr, "eval_model: cannot read g and the number of states\n");
    return 2;
  }
  const char* inertia = Model::kInertia[0] != '\0' ? Model::kInertia : "-";
  std::printf("model %s %s %s %d\n", Model::kName, Model::kType, inertia, kDof);
  for (int k = 0; k < count; ++k) {
    Vector q;
    Vector qd;
    Scalar u = Scalar(0);
    bool ok = true;
    for (int i = 0; i < kDof; ++i) {
      ok = ok && read_scalar(q(i));
    }
    for (int i = 0; i < kDof; ++i) {
      ok = ok && read_scalar(qd(i));
    }
    ok = ok && read_scalar(u);
    if (!ok) {
      std::fprintf(stderr, "eval_model: cannot read state %d\n", k);
      return 2;
    }
    print_matrix("M", Model::mass_matrix(q, p));
    print_matrix("bias", Model::bias(q, qd, p));
    print_matrix("gravity", Model::gravity(q, p));
    print_matrix("N", Model::n_matrix(q, qd, p));
    print_matrix("qdd", Model::forward_dynamics(q, qd, u, p));
    print_scalar("T", Model::kinetic_energy(q, qd, p));
    print_scalar("V", Model::potential_energy(q, p));
    print_scalar("D", Model::dissipation(qd, p));
    const auto derivatives = Model::forward_dynamics_derivatives(q, qd, u, p);
    print_matrix("dqdd_dq", derivatives.dqdd_dq);
    print_matrix("dqdd_dqd", derivatives.dqdd_dqd);
    print_matrix("dqdd_du", derivatives.dqdd_du);
  }
  return 0;
}

template <typename Model>
int run_scalar(const char* scalar) {
  if (std::strcmp(scalar, "double") == 0) {
    return run<Model, double>();
  }
  if (std::strcmp(scalar, "float") == 0) {
    return run<Model, float>();
  }
  std::fprintf(stderr, "eval_model: unknown scalar type %s (double or float)\n", scalar);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s <namespace> double|float < input\n", argv[0]);
    return 2;
  }
  const char* name = argv[1];
#define X(ns)                                       \
  if (std::strcmp(name, IPGEN_STRINGIFY(ns)) == 0) {  \
    return run_scalar<::ipgen::ns::Model>(argv[2]);   \
  }
  IPGEN_MODELS
#undef X
  std::fprintf(stderr, "eval_model: no model %s in this program\n", name);
  return 2;
}
