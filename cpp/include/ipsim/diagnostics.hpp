// How integrator failures and messages reach the caller: SUNDIALS messages are collected instead
// of printed, set-up failures and integration failures become ipsim exceptions.
#pragma once

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "ipsim/errors.hpp"
#include "ipsim/linkage.hpp"
#include "ipsim/settings.hpp"

namespace ipsim::detail {

/// Collects SUNDIALS' messages (CVODE and ARKODE share the handler signature).
struct Diagnostics {
  std::string last_error;             ///< most recent error message, for the exception text
  std::vector<std::string>* warnings;  ///< destination of warnings (Result::warnings)
};

/// CVErrHandlerFn / ARKErrHandlerFn: stores the message in the Diagnostics passed as `data`.
void collect_message(int code, const char* /*module*/, const char* function, char* message, void* data);

/// Throws ipsim::Error naming a failed set-up call and its flag, unless flag == 0 (success).
template <class FlagName>
void check_setup(int flag, const char* call, FlagName flag_name) {
  if (flag != 0) throw Error(std::string(call) + " failed with " + flag_name(flag));
}

/// Why a run whose step underflowed (t + h = t) stops: the integrator's time no longer moves.
inline std::string step_underflow() {
  return "the step size underflowed (t + h = t), so the integrator's time stopped while the output went on: the "
         "derivatives are too large for double precision (rates, forces or parameters near 1e300?): check the "
         "scene's numbers";
}

/// "`integrator` failed with FLAG at t = … s (settings)[: explanation]" as an IntegrationError.
template <class Model>
IntegrationError integration_error(const char* integrator, int flag, std::string flag_name, double t,
                                   const Settings<Model>& settings, const std::string& explanation) {
  std::string message = std::string(integrator) + " failed with " + flag_name + " at t = " + format_number(t) +
                        " s (" + describe(settings) + ")";
  if (!explanation.empty()) message += ": " + explanation;
  return IntegrationError(message, flag, std::move(flag_name), t);
}

}  // namespace ipsim::detail

#if IPSIM_DEFINITIONS
namespace ipsim::detail {

IPSIM_DECL void collect_message(int code, const char* /*module*/, const char* function, char* message, void* data) {
  try {
    auto& diagnostics = *static_cast<Diagnostics*>(data);
    std::string text = std::string(function ? function : "SUNDIALS") + ": " + (message ? message : "");
    std::replace(text.begin(), text.end(), '\n', ' ');  // exception messages stay on one line
    if (code < 0) diagnostics.last_error = std::move(text);
    else diagnostics.warnings->push_back(std::move(text));
  } catch (...) {
    // Running out of memory while recording a message must not unwind through C code.
  }
}

}  // namespace ipsim::detail
#endif  // IPSIM_DEFINITIONS
