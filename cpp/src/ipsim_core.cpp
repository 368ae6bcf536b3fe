// ipsim's non-template functions (the scene reader, messages, coordinates, the estimators'
// algebra, eigenvalues) and the small models' LDLT solves (ipsim/ldlt.hpp), compiled once: a
// program built with -DIPSIM_SEPARATE_COMPILATION declares them only and links this object
// (ipsim/linkage.hpp). Everything else that depends on the model stays a template in the headers.
#ifndef IPSIM_SEPARATE_COMPILATION
#define IPSIM_SEPARATE_COMPILATION
#endif
#define IPSIM_CORE_SOURCE

#include "ipsim/ipsim.hpp"
#include "ipsim/scene.hpp"
#include "ipsim/diagnostics.hpp"
#include "ipsim/eigenvalues.hpp"
#include "ipsim/ldlt.hpp"
#include "ipsim/sensors.hpp"

// The LDLT solves of matrices of 1 to kCoreLdltSize rows, with one right-hand side or a square one.
#define IPSIM_CORE_LDLT(N, C)                                                   \
  template Eigen::Matrix<double, N, C> ipsim::detail::core_ldlt_solve<N, C>( \
      const Eigen::Matrix<double, N, N>&, const Eigen::Matrix<double, N, C>&);
IPSIM_CORE_LDLT(1, 1)
IPSIM_CORE_LDLT(2, 1)
IPSIM_CORE_LDLT(2, 2)
IPSIM_CORE_LDLT(3, 1)
IPSIM_CORE_LDLT(3, 3)
IPSIM_CORE_LDLT(4, 1)
IPSIM_CORE_LDLT(4, 4)
#undef IPSIM_CORE_LDLT
static_assert(ipsim::detail::kCoreLdltSize == 4, "instantiate every size up to kCoreLdltSize above");
