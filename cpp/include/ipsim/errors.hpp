// Exceptions thrown by ipsim. All derive from ipsim::Error (a std::runtime_error), so callers can
// catch one type; the message is always a single line.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace ipsim {

namespace detail {
/// Short, round-trip-free rendering of a number for messages: -1, 0.275, 1e-10, nan, inf.
inline std::string format_number(double value) {
  std::ostringstream out;
  out.precision(10);
  out << value;
  return out.str();
}
}  // namespace detail

/// Base class of every ipsim exception.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Invalid parameters or settings, detected before integrating. what() joins all problems with
/// "; "; problems() lists them one by one (each names the offending field).
class InvalidInput : public Error {
 public:
  explicit InvalidInput(std::vector<std::string> problems)
      : Error(join(problems)), problems_(std::move(problems)) {}

  /// One message per offending field, e.g. "invalid parameter m[2] = -1: masses must be > 0".
  const std::vector<std::string>& problems() const noexcept { return problems_; }

 private:
  static std::string join(const std::vector<std::string>& problems) {
    std::string text;
    for (const auto& p : problems) text += (text.empty() ? "" : "; ") + p;
    return text;
  }
  std::vector<std::string> problems_;
};

/// The integrator failed: CVODE or ARKODE returned a failure flag, or RK4 could not go on. The
/// message names the integrator, the flag, the time reached and the settings, followed by the
/// integrator's own explanation when it gave one.
class IntegrationError : public Error {
 public:
  IntegrationError(const std::string& message, int flag, std::string flag_name, double time)
      : Error(message), flag_(flag), flag_name_(std::move(flag_name)), time_(time) {}

  /// The CVODE or ARKODE return flag (negative), e.g. CV_TOO_MUCH_WORK; -1 for RK4 failures.
  int flag() const noexcept { return flag_; }
  /// The flag's name, e.g. "CV_TOO_MUCH_WORK", "ARK_TOO_MUCH_WORK", "RK4_TOO_MUCH_WORK".
  const std::string& flag_name() const noexcept { return flag_name_; }
  /// Simulation time reached when the integrator gave up [s].
  double time() const noexcept { return time_; }

 private:
  int flag_;
  std::string flag_name_;
  double time_;
};

}  // namespace ipsim
