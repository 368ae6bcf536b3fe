// x = A⁻¹ B for the small symmetric positive definite matrices of the right-hand side, its exact
// Jacobian and the controller (a model's mass matrix, or its links' block), by Eigen's LDLT.
//
// Eigen's fixed-size LDLT is about a third of a simulator's compile time (docs/testing.md). A
// program built with -DIPSIM_SEPARATE_COMPILATION (ipsim/linkage.hpp) calls the instances compiled
// once in ipsim's core (cpp/src/ipsim_core.cpp) for matrices of up to kCoreLdltSize rows with one
// right-hand side or a square one (the mass matrix of a model of up to three links, the links'
// block of one of up to four); it compiles the other sizes itself, as a header-only program
// compiles them all. The code is the same either way, so
// are the numbers.
#pragma once

#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "ipsim/linkage.hpp"

namespace ipsim::detail {

/// The largest matrix (rows) whose solves ipsim's core compiles: a three-link model's mass matrix.
inline constexpr int kCoreLdltSize = 4;

/// A⁻¹ B by Eigen's LDLT with pivoting: compiled once in ipsim's core for the sizes of `ldlt_solve`.
template <int N, int C>
Eigen::Matrix<double, N, C> core_ldlt_solve(const Eigen::Matrix<double, N, N>& a,
                                            const Eigen::Matrix<double, N, C>& b);

/// A⁻¹ B for a symmetric positive definite N × N matrix A (Eigen's LDLT with pivoting), B with
/// one column or N.
template <int N, int C>
Eigen::Matrix<double, N, C> ldlt_solve(const Eigen::Matrix<double, N, N>& a, const Eigen::Matrix<double, N, C>& b) {
  if constexpr (N <= kCoreLdltSize && (C == 1 || C == N)) {
    return core_ldlt_solve<N, C>(a, b);
  } else {
    return a.ldlt().solve(b);
  }
}

namespace solve {
/// A⁻¹ B with the sizes fixed at N (a run-time size that equals N), into `Result`: the same
/// instance, and so the same bits, as a model compiled for that size.
template <int N, class Result, class MatrixA, class MatrixB>
Result fixed(const MatrixA& a, const MatrixB& b) {
  if constexpr (N == 1) {
    // What Eigen's LDLT of a 1 × 1 matrix computes (its solve divides by D = a where |D| exceeds
    // the smallest normal double, else gives 0), bit for bit, without the copies through 1 × 1
    // matrices, on which gcc 12 at -O2 warns (-Warray-bounds, a false positive: Eigen's two-wide
    // packet copy of the 1 × 1 source into `Result`) and -Werror would stop the build.
    const double d = a(0, 0);
    if (std::abs(d) > std::numeric_limits<double>::min()) return Result(b / d);
    return Result(Result::Zero(b.rows(), b.cols()));
  } else if constexpr (MatrixB::ColsAtCompileTime == 1) {
    return Result(ldlt_solve<N, 1>(Eigen::Matrix<double, N, N>(a), Eigen::Matrix<double, N, 1>(b)));
  } else if (b.cols() == 1) {
    return Result(ldlt_solve<N, 1>(Eigen::Matrix<double, N, N>(a), Eigen::Matrix<double, N, 1>(b)));
  } else {
    return Result(ldlt_solve<N, N>(Eigen::Matrix<double, N, N>(a), Eigen::Matrix<double, N, N>(b)));
  }
}
}  // namespace solve

/// A⁻¹ B for matrices of any sizes (expressions too), B with one column or as many as A: for
/// sizes fixed at compile time ldlt_solve; for the capacity-bounded sizes of a model loaded at
/// run time, the fixed-size instance of the same size up to kCoreLdltSize rows (bit for bit what a
/// simulator compiled for the model computes), else Eigen's LDLT over the run-time sizes (no
/// allocation). The result has B's columns.
template <class MatrixA, class MatrixB>
auto solve_spd(const MatrixA& a, const MatrixB& b) {
  constexpr int N = MatrixA::RowsAtCompileTime;
  constexpr int C = MatrixB::ColsAtCompileTime;
  if constexpr (N != Eigen::Dynamic && C != Eigen::Dynamic) {
    return ldlt_solve<N, C>(Eigen::Matrix<double, N, N>(a), Eigen::Matrix<double, N, C>(b));
  } else {
    using Result = decltype(a.eval().ldlt().solve(b).eval());
    static_assert(kCoreLdltSize == 4, "dispatch every size up to kCoreLdltSize below");
    if (b.cols() == 1 || b.cols() == a.rows()) {
      switch (a.rows()) {
        case 1: return solve::fixed<1, Result>(a, b);
        case 2: return solve::fixed<2, Result>(a, b);
        case 3: return solve::fixed<3, Result>(a, b);
        case 4: return solve::fixed<4, Result>(a, b);
        default: break;
      }
    }
    return Result(a.eval().ldlt().solve(b));
  }
}

#if IPSIM_DEFINITIONS
template <int N, int C>
Eigen::Matrix<double, N, C> core_ldlt_solve(const Eigen::Matrix<double, N, N>& a,
                                            const Eigen::Matrix<double, N, C>& b) {
  return a.ldlt().solve(b);
}
#endif  // IPSIM_DEFINITIONS

}  // namespace ipsim::detail
