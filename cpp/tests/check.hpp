// A minimal test harness: CHECK records a failure and keeps going; main returns failures().
#pragma once

#include <cmath>
#include <cstdio>
#include <exception>
#include <string>

#include <Eigen/Core>

#include "ipsim/result.hpp"

namespace ipsim_test {

inline int& failure_count() {
  static int count = 0;
  return count;
}

/// Process exit code: 0 when every check passed.
inline int failures() { return failure_count() == 0 ? 0 : 1; }

/// Prints the suite's one-line verdict, "<suite>: <passed>" or "<suite>: FAILED", and returns
/// the process exit code.
inline int finish(const std::string& suite, const char* passed = "all passed") {
  std::printf("%s: %s\n", suite.c_str(), failure_count() == 0 ? passed : "FAILED");
  return failures();
}

/// Full-precision text of a number (std::to_string would print 1e-12 as 0.000000).
inline std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

inline void fail(const char* file, int line, const std::string& what) {
  std::fprintf(stderr, "%s:%d: FAILED: %s\n", file, line, what.c_str());
  ++failure_count();
}

// Error measures for `measure <= bound` checks. Each propagates NaN, which then fails the check:
// Eigen's default maxCoeff skips NaN entries and std::max(worst, NaN) returns worst, so a NaN
// error would otherwise pass as the largest finite one (or as 0).

/// worst = max(worst, value); a NaN value makes worst NaN for good.
inline void raise_to(double& worst, double value) {
  if (!std::isnan(worst) && !(value <= worst)) worst = value;
}

/// max |entry| of a matrix or vector expression; NaN if any entry is NaN.
template <class Derived>
double max_abs(const Eigen::MatrixBase<Derived>& values) {
  return values.cwiseAbs().template maxCoeff<Eigen::PropagateNaN>();
}

/// max |a − b| over two equally shaped matrices; infinite if the shapes differ, NaN if any entry is NaN.
template <class A, class B>
double max_difference(const Eigen::MatrixBase<A>& a, const Eigen::MatrixBase<B>& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) return INFINITY;
  return max_abs(a - b);
}

/// max |a − b| over two trajectories (their states); infinite if they have different sample counts.
inline double max_difference(const ipsim::Result& a, const ipsim::Result& b) {
  return max_difference(a.states, b.states);
}

}  // namespace ipsim_test

/// Fails (and continues) unless `condition` holds.
#define CHECK(condition)                                                          \
  do {                                                                            \
    if (!(condition)) ::ipsim_test::fail(__FILE__, __LINE__, "CHECK(" #condition ")"); \
  } while (0)

/// Fails unless |actual − expected| ≤ tolerance; prints both values.
#define CHECK_NEAR(actual, expected, tolerance)                                                         \
  do {                                                                                                  \
    const double check_actual_ = (actual), check_expected_ = (expected), check_tol_ = (tolerance);      \
    if (!(std::abs(check_actual_ - check_expected_) <= check_tol_)) {                                   \
      ::ipsim_test::fail(__FILE__, __LINE__,                                                            \
                         std::string("CHECK_NEAR(" #actual ", " #expected "): ") +                      \
                             ::ipsim_test::number(check_actual_) + " vs " +                           \
                             ::ipsim_test::number(check_expected_) + " (tolerance " +                   \
                             ::ipsim_test::number(check_tol_) + ")");                                   \
    }                                                                                                   \
  } while (0)

/// Fails unless `statement` throws `Exception` whose what() contains `fragment`.
#define CHECK_THROWS(statement, Exception, fragment)                                                       \
  do {                                                                                                     \
    try {                                                                                                  \
      statement;                                                                                           \
      ::ipsim_test::fail(__FILE__, __LINE__, "expected " #Exception " from: " #statement);                 \
    } catch (const Exception& check_error_) {                                                              \
      if (std::string(check_error_.what()).find(fragment) == std::string::npos) {                          \
        ::ipsim_test::fail(__FILE__, __LINE__,                                                             \
                           std::string("message of " #Exception " lacks \"") + (fragment) + "\": " +        \
                               check_error_.what());                                                       \
      }                                                                                                    \
    } catch (const std::exception& check_error_) {                                                         \
      ::ipsim_test::fail(__FILE__, __LINE__,                                                               \
                         std::string("expected " #Exception ", got another exception: ") + check_error_.what()); \
    }                                                                                                      \
  } while (0)
