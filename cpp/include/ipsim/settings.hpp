// Integrator settings, and validation of settings and model parameters.
#pragma once

#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ipsim/errors.hpp"
#include "ipsim/input.hpp"
#include "ipsim/model.hpp"

namespace ipsim {

/// CVODE's linear multistep family.
enum class Method {
  bdf,    ///< backward differentiation formulas, orders 1–5 (stiff problems; the default)
  adams,  ///< Adams–Moulton, orders 1–12 (smooth, non-stiff problems)
};

/// "bdf" or "adams".
inline const char* to_string(Method method) { return method == Method::bdf ? "bdf" : "adams"; }

/// Parses "bdf" or "adams"; nullopt for anything else.
inline std::optional<Method> parse_method(std::string_view text) {
  if (text == "bdf") return Method::bdf;
  if (text == "adams") return Method::adams;
  return std::nullopt;
}

/// Everything simulate() needs besides the model parameters.
template <class Model>
struct Settings {
  Method method = Method::bdf;
  double rtol = 1e-8;        ///< CVODE relative tolerance, > 0
  double atol = 1e-10;       ///< CVODE absolute tolerance (same for every state), ≥ 0
  long max_steps = 100000;   ///< CVODE internal steps allowed between two stops (CVodeSetMaxNumSteps), > 0
  double sample = 0.01;      ///< output interval [s]: samples at t = k·sample, plus t_end
  double t_end = 10.0;       ///< final time [s], > 0; the run starts at t = 0
  VectorOf<Model> theta = VectorOf<Model>::Zero();   ///< initial θ: base [m or rad], link angles [rad]
  VectorOf<Model> dtheta = VectorOf<Model>::Zero();  ///< initial θ̇ [m/s or rad/s]
  Input input;               ///< u(t) on θ0 [N or N m]
  /// Also integrate the input work W_in = ∫ u θ̇0 dt and the dissipated energy E_diss = ∫ 2D dt
  /// [J] as two extra CVODE states (they take part in error control), reported in Result.
  bool energy_ledger = false;
};

/// Largest number of output samples accepted, to fail early instead of exhausting memory.
inline constexpr double kMaxSamples = 1e8;

/// Problems with the parameters, one line each, empty when valid: masses and used lengths must
/// be finite and > 0 (l[0] is skipped for a cart, where it is unused), damping finite and ≥ 0,
/// g finite.
template <class Model>
std::vector<std::string> validate(const ParamsOf<Model>& params) {
  std::vector<std::string> found;
  auto report = [&](const char* field, int i, double v, const char* rule) {
    std::string name = field;
    if (i >= 0) name += "[" + std::to_string(i) + "]";
    found.push_back("invalid parameter " + name + " = " + detail::format_number(v) + ": " + rule);
  };
  for (int i = 0; i < Model::kDof; ++i) {
    const double m = params.m[i];
    if (!std::isfinite(m)) report("m", i, m, "must be finite");
    else if (m <= 0.0) report("m", i, m, "masses must be > 0");
  }
  for (int i = is_classical<Model>() ? 1 : 0; i < Model::kDof; ++i) {
    const double l = params.l[i];
    if (!std::isfinite(l)) report("l", i, l, "must be finite");
    else if (l <= 0.0) report("l", i, l, "lengths must be > 0");
  }
  for (int i = 0; i < Model::kDof; ++i) {
    const double d = params.delta[i];
    if (!std::isfinite(d)) report("delta", i, d, "must be finite");
    else if (d < 0.0) report("delta", i, d, "damping must be >= 0");
  }
  if (!std::isfinite(params.g)) report("g", -1, params.g, "must be finite");
  return found;
}

/// Problems with the settings, one line each, empty when valid. Field names follow the scene
/// file keys (rtol, theta[1], input.duration, …).
template <class Model>
std::vector<std::string> validate(const Settings<Model>& settings) {
  std::vector<std::string> found;
  auto report = [&](const std::string& field, double v, const char* rule) {
    found.push_back("invalid setting " + field + " = " + detail::format_number(v) + ": " + rule);
  };
  if (!(std::isfinite(settings.rtol) && settings.rtol > 0.0)) report("rtol", settings.rtol, "must be finite and > 0");
  if (!(std::isfinite(settings.atol) && settings.atol >= 0.0)) report("atol", settings.atol, "must be finite and >= 0");
  if (!(std::isfinite(settings.t_end) && settings.t_end > 0.0)) report("t_end", settings.t_end, "must be finite and > 0");
  if (!(std::isfinite(settings.sample) && settings.sample > 0.0)) {
    report("sample", settings.sample, "must be finite and > 0");
  } else if (std::isfinite(settings.t_end) && settings.t_end / settings.sample > kMaxSamples) {
    report("sample", settings.sample, "t_end / sample exceeds 1e8 output samples");
  }
  if (settings.max_steps <= 0) {
    found.push_back("invalid setting max_steps = " + std::to_string(settings.max_steps) + ": must be > 0");
  }
  for (int i = 0; i < Model::kDof; ++i) {
    if (!std::isfinite(settings.theta(i))) {
      report("theta[" + std::to_string(i) + "]", settings.theta(i), "initial state must be finite");
    }
    if (!std::isfinite(settings.dtheta(i))) {
      report("dtheta[" + std::to_string(i) + "]", settings.dtheta(i), "initial state must be finite");
    }
  }
  const auto input_problems = settings.input.problems();
  found.insert(found.end(), input_problems.begin(), input_problems.end());
  return found;
}

/// Throws InvalidInput listing every problem validate() finds in `params`.
template <class Model>
void require_valid(const ParamsOf<Model>& params) {
  auto found = validate<Model>(params);
  if (!found.empty()) throw InvalidInput(std::move(found));
}

/// Throws InvalidInput listing every problem validate() finds in `settings`.
template <class Model>
void require_valid(const Settings<Model>& settings) {
  auto found = validate<Model>(settings);
  if (!found.empty()) throw InvalidInput(std::move(found));
}

}  // namespace ipsim
