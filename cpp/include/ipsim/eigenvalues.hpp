// Eigenvalues of the small dense matrices the guards look at (M, and ∂f/∂x of the mechanical
// state), computed by LAPACK (dsyev, dgeev) rather than by Eigen's eigen-solvers.
//
// Why LAPACK: Eigen's SelfAdjointEigenSolver and EigenSolver are templates that every program
// including ipsim instantiated and optimised again (about 12 s of CPU at -O2, a third of compiling
// one model's simulator; docs/bench/compile.md). LAPACK is already compiled and is installed with
// SUNDIALS on Debian (liblapack-dev); linking it costs nothing at compile time. These functions are
// plain inline functions over dynamic-size matrices, independent of the model.
#pragma once

#include "ipsim/linkage.hpp"

#include <complex>
#include <cstddef>
#include <limits>
#include <utility>
#include <vector>

#include <Eigen/Core>

// LAPACK's Fortran entry points (gfortran calling convention: every CHARACTER argument adds a
// hidden length argument at the end). Declared here so that no LAPACK header is needed.
extern "C" {
void dsyev_(const char* jobz, const char* uplo, const int* n, double* a, const int* lda, double* w, double* work,
            const int* lwork, int* info, std::size_t jobz_length, std::size_t uplo_length);
void dgeev_(const char* jobvl, const char* jobvr, const int* n, double* a, const int* lda, double* wr, double* wi,
            double* vl, const int* ldvl, double* vr, const int* ldvr, double* work, const int* lwork, int* info,
            std::size_t jobvl_length, std::size_t jobvr_length);
}

namespace ipsim::detail {

/// The eigenvalues of the symmetric matrix `a` (its lower triangle is read), ascending; all NaN
/// when LAPACK's dsyev fails to converge or `a` is not finite.
Eigen::VectorXd symmetric_eigenvalues(Eigen::MatrixXd a);

/// The eigenvalues of the general square matrix `a` (in LAPACK's order); all NaN when LAPACK's
/// dgeev fails or `a` is not finite.
Eigen::VectorXcd general_eigenvalues(Eigen::MatrixXd a);

/// The real parts of the eigenvalues of the general square matrix `a` (in LAPACK's order); all
/// NaN when LAPACK's dgeev fails or `a` is not finite.
inline Eigen::VectorXd eigenvalue_real_parts(Eigen::MatrixXd a) { return general_eigenvalues(std::move(a)).real(); }

}  // namespace ipsim::detail

#if IPSIM_DEFINITIONS
namespace ipsim::detail {

IPSIM_DECL Eigen::VectorXd symmetric_eigenvalues(Eigen::MatrixXd a) {
  const int n = static_cast<int>(a.rows());
  Eigen::VectorXd w = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::quiet_NaN());
  if (n == 0 || !a.allFinite()) return w;
  const int lwork = 3 * n;
  std::vector<double> work(static_cast<std::size_t>(lwork));
  int info = 0;
  dsyev_("N", "L", &n, a.data(), &n, w.data(), work.data(), &lwork, &info, 1, 1);
  if (info != 0) w.setConstant(std::numeric_limits<double>::quiet_NaN());
  return w;
}

IPSIM_DECL Eigen::VectorXcd general_eigenvalues(Eigen::MatrixXd a) {
  const int n = static_cast<int>(a.rows());
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  Eigen::VectorXcd values = Eigen::VectorXcd::Constant(n, std::complex<double>(nan, nan));
  if (n == 0 || !a.allFinite()) return values;
  Eigen::VectorXd real(n), imaginary(n);
  const int lwork = 4 * n, one = 1;
  std::vector<double> work(static_cast<std::size_t>(lwork));
  double unused = 0.0;
  int info = 0;
  dgeev_("N", "N", &n, a.data(), &n, real.data(), imaginary.data(), &unused, &one, &unused, &one, work.data(), &lwork,
         &info, 1, 1);
  if (info != 0) return values;
  for (int i = 0; i < n; ++i) values(i) = std::complex<double>(real(i), imaginary(i));
  return values;
}

}  // namespace ipsim::detail
#endif  // IPSIM_DEFINITIONS
