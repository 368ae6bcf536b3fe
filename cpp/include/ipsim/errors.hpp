// Exceptions thrown by ipsim. All derive from ipsim::Error (a std::runtime_error), so callers can
// catch one type; the message is always a single line.
#pragma once

#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "ipsim/limits.hpp"
#include "ipsim/linkage.hpp"

namespace ipsim {

namespace detail {
/// Short, round-trip-free rendering of a number for messages: -1, 0.275, 1e-10, nan, inf.
std::string format_number(double value);

/// A user-supplied value for a message: control characters and Unicode line separators escaped
/// (\n, \x01, \u0085, \u2028), so the message stays one line, and cut in the middle to at most
/// `limit` characters ("abc...xyz").
std::string abbreviate(const std::string& text, std::size_t limit = kMessageValueChars);
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

#if IPSIM_DEFINITIONS
namespace ipsim {
namespace detail {
IPSIM_DECL std::string format_number(double value) {
  std::ostringstream out;
  out.precision(10);
  out << value;
  return out.str();
}

IPSIM_DECL std::string abbreviate(const std::string& text, std::size_t limit) {
  std::string shown;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    const auto byte = static_cast<unsigned char>(c);
    const auto next = [&](std::size_t k) { return i + k < text.size() ? static_cast<unsigned char>(text[i + k]) : 0; };
    if (byte == 0xC2 && next(1) >= 0x80 && next(1) <= 0x9F) {  // a C1 control (U+0085 breaks lines)
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\u%04x", next(1));
      shown += escaped;
      ++i;
    } else if (byte == 0xE2 && next(1) == 0x80 && (next(2) == 0xA8 || next(2) == 0xA9)) {  // U+2028, U+2029
      shown += next(2) == 0xA8 ? "\\u2028" : "\\u2029";
      i += 2;
    } else if (c == '\n') {
      shown += "\\n";
    } else if (c == '\r') {
      shown += "\\r";
    } else if (c == '\t') {
      shown += "\\t";
    } else if (byte < 0x20 || byte == 0x7f) {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\x%02x", byte);
      shown += escaped;
    } else {
      shown += c;
    }
  }
  if (shown.size() <= limit || limit < 8) return shown;
  auto continuation = [&](std::size_t i) { return (static_cast<unsigned char>(shown[i]) & 0xC0) == 0x80; };
  std::size_t head = (limit - 3) * 2 / 3;  // both cuts at UTF-8 character boundaries
  while (head > 0 && continuation(head)) --head;
  std::size_t tail = shown.size() - (limit - 3 - head);
  while (tail < shown.size() && continuation(tail)) ++tail;
  return shown.substr(0, head) + "..." + shown.substr(tail);
}
}  // namespace detail
}  // namespace ipsim
#endif
