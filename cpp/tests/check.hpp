// A minimal test harness: CHECK records a failure and keeps going; main returns failures().
#pragma once

#include <cmath>
#include <cstdio>
#include <exception>
#include <string>

namespace ipsim_test {

inline int& failure_count() {
  static int count = 0;
  return count;
}

/// Process exit code: 0 when every check passed.
inline int failures() { return failure_count() == 0 ? 0 : 1; }

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
