// Integrator settings, and validation of settings and model parameters.
#pragma once

#include <cmath>
#include <cstddef>
#include <iterator>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ipsim/errors.hpp"
#include "ipsim/input.hpp"
#include "ipsim/limits.hpp"
#include "ipsim/model.hpp"

namespace ipsim {

/// A disturbance pulse on the base: `amplitude` [N or N m] on start ≤ t < start + duration [s].
struct Pulse {
  double start = 0.0;
  double duration = 0.0;
  double amplitude = 0.0;
};

/// Integration method.
enum class Method {
  bdf,                ///< CVODE BDF, orders 1–5, Newton iteration with a dense direct solver (stiff-safe)
  adams,              ///< CVODE Adams–Moulton, orders 1–12, Newton iteration with a dense direct solver
  adams_fixed_point,  ///< CVODE Adams–Moulton with fixed-point iteration: no Jacobian, no linear algebra
  erk_dp5,            ///< ARKODE ERKStep, Dormand–Prince 5(4), adaptive
  erk_fehlberg8,      ///< ARKODE ERKStep, Fehlberg 8(7) (13 stages), adaptive
  rk4,                ///< classic fixed-step Runge–Kutta 4 (Settings::step), ipsim's own
};

/// The integrator family a method belongs to.
enum class Family { cvode, erk, rk4 };

/// How the Newton iteration of bdf and adams gets the Jacobian ∂f/∂x of ẋ = f(x, u).
enum class Jacobian {
  exact,  ///< from the model's forward_dynamics_derivatives (one call per Jacobian)
  dq,     ///< CVODE's internal difference quotients (2·kDof extra RHS evaluations per Jacobian)
};

namespace detail {
struct MethodInfo {
  Method method;
  const char* name;  ///< as in scene files and on the command line
  Family family;
};
inline constexpr MethodInfo kMethods[] = {
    {Method::bdf, "bdf", Family::cvode},
    {Method::adams, "adams", Family::cvode},
    {Method::adams_fixed_point, "adams-fixed-point", Family::cvode},
    {Method::erk_dp5, "erk-dp5", Family::erk},
    {Method::erk_fehlberg8, "erk-fehlberg8", Family::erk},
    {Method::rk4, "rk4", Family::rk4},
};
}  // namespace detail

/// "bdf", "adams", "adams-fixed-point", "erk-dp5", "erk-fehlberg8" or "rk4".
inline const char* to_string(Method method) {
  for (const auto& info : detail::kMethods) {
    if (info.method == method) return info.name;
  }
  return "?";
}

/// The family (CVODE, ARKODE ERKStep, ipsim's RK4) that runs `method`.
inline Family family_of(Method method) {
  for (const auto& info : detail::kMethods) {
    if (info.method == method) return info.family;
  }
  return Family::cvode;
}

/// True for the methods with a Newton iteration, which use Settings::jacobian (bdf, adams).
inline bool uses_jacobian(Method method) { return method == Method::bdf || method == Method::adams; }

/// True for the adaptive methods, which use Settings::rtol and atol (all but rk4).
inline bool uses_tolerances(Method method) { return method != Method::rk4; }

/// Parses a method name (see to_string(Method)); nullopt for anything else.
inline std::optional<Method> parse_method(std::string_view text) {
  for (const auto& info : detail::kMethods) {
    if (text == info.name) return info.method;
  }
  return std::nullopt;
}

/// All method names joined for messages: "bdf, adams, …, erk-fehlberg8 or rk4".
inline std::string method_names() {
  std::string text;
  const std::size_t count = std::size(detail::kMethods);
  for (std::size_t i = 0; i < count; ++i) {
    text += (i == 0 ? "" : (i + 1 == count ? " or " : ", ")) + std::string(detail::kMethods[i].name);
  }
  return text;
}

/// "exact" or "dq".
inline const char* to_string(Jacobian jacobian) { return jacobian == Jacobian::exact ? "exact" : "dq"; }

/// Parses "exact" or "dq"; nullopt for anything else.
inline std::optional<Jacobian> parse_jacobian(std::string_view text) {
  if (text == "exact") return Jacobian::exact;
  if (text == "dq") return Jacobian::dq;
  return std::nullopt;
}

/// Everything simulate() needs besides the model parameters.
template <class Model>
struct Settings {
  Method method = Method::bdf;
  /// bdf and adams only: exact Jacobian from the model's derivatives, or CVODE's difference quotients.
  Jacobian jacobian = Jacobian::exact;
  double rtol = 1e-10;       ///< relative tolerance of the adaptive methods, > 0 (unused by rk4); a scene's default too
  double atol = 1e-12;       ///< absolute tolerance (same for every state), ≥ 0 (unused by rk4); a scene's default too
  double step = 0.0;         ///< rk4 only: the fixed step [s], > 0; shortened to land on every stop
  long max_steps = 100000;   ///< integrator steps allowed between two stops, > 0
  double sample = 0.01;      ///< output interval [s]: samples at t = k·sample, plus t_end
  double t_end = 10.0;       ///< final time [s], >= kMinTEnd (1e-9 s); the run starts at t = 0
  VectorOf<Model> theta = zero_vector<Model>();   ///< initial θ: base [m or rad], link angles [rad]
  VectorOf<Model> dtheta = zero_vector<Model>();  ///< initial θ̇ [m/s or rad/s]
  Input input;               ///< u(t) on θ0 [N or N m] (a fixed chain: the torque of its first driven joint)
  /// A fixed chain with m > 1 inputs (a model loaded at run time): u_2..u_m, the torques of its
  /// other driven joints [N m], in the order of the model's joints; open-loop signals only (no
  /// feedback or sampled input). Empty otherwise.
  std::vector<Input> more_inputs;
  /// Also integrate the input work W_in = ∫ u θ̇0 dt (∫ τ θ̇0 dt with `acceleration`) and the dissipated energy E_diss = ∫ 2D dt
  /// [J] as two extra CVODE states (they take part in error control), reported in Result.
  bool energy_ledger = false;
  /// Coulomb friction per coordinate [N or N m], ≥ 0 (default 0: none), as the smooth law
  /// f_i = coulomb[i] tanh(w_i / coulomb_speed), w_i the rate the viscous delta[i] acts on (θ̇0,
  /// θ̇1, then θ̇i − θ̇(i−1)): the generalised force Q = −∂Φ/∂θ̇ of Φ = Σ coulomb[i] coulomb_speed
  /// ln cosh(w_i / coulomb_speed), added to M θ̈ = … (not part of the model header, nor of
  /// its linearisation). Its dissipated energy is integrated and reported (Result::coulomb_dissipated).
  VectorOf<Model> coulomb = zero_vector<Model>();
  double coulomb_speed = 0.01;  ///< [m/s or rad/s], > 0: below it the friction is ~viscous
  /// A fixed chain only: DFKI's law f_i = coulomb[i] atan(coulomb_gain w_i) in place of the tanh
  /// law (w_i: θ̇1, then θ̇i − θ̇(i−1), the joints' relative rates).
  bool coulomb_atan = false;
  double coulomb_gain = 100.0;  ///< [s/rad], > 0: the atan law's k
  /// A fixed chain only: +1, or −1 when its inputs are torques in the counterclockwise sense (a rig's
  /// positive = counterclockwise: the model's B is in ipgen's clockwise sense, so it gets −u).
  double input_sign = 1.0;
  /// An acceleration-driven base ([actuator] kind = "acceleration"): u is θ̈0 [m/s² or rad/s²],
  /// imposed by a servo; the links follow θ̈_L = −M_LL⁻¹ (M_L0 u + b_L − Q_L) (rhs.hpp), and the
  /// energy ledger's input work is that of the base force τ = M_0· θ̈ + b_0 − Q_0 the servo
  /// applies. Needs the model's mass_matrix and bias.
  bool acceleration = false;
  /// The drive's first-order lag [s] ([actuator] lag), ≥ 0; 0: none. With lag > 0 the force
  /// the model sees is an extra state u_a with u_a' = (u − u_a) / lag, u_a(0) = 0 (rhs.hpp).
  double lag = 0.0;
  /// Disturbance pulses on the base ([actuator] pulses): each adds its amplitude [N or N m] to the
  /// base's generalised force on start ≤ t < start + duration; both edges are integrator stops.
  std::vector<Pulse> pulses;
};

/// The settings that shape the integration, for messages and summaries:
/// "method bdf, jacobian exact, rtol 1e-10, atol 1e-12, max_steps 100000",
/// "method erk-dp5, rtol 1e-08, atol 1e-10, max_steps 100000", "method rk4, step 0.001, max_steps 100000".
template <class Model>
std::string describe(const Settings<Model>& settings) {
  std::string text = std::string("method ") + to_string(settings.method);
  if (uses_jacobian(settings.method)) text += std::string(", jacobian ") + to_string(settings.jacobian);
  if (uses_tolerances(settings.method)) {
    text += ", rtol " + detail::format_number(settings.rtol) + ", atol " + detail::format_number(settings.atol);
  } else {
    text += ", step " + detail::format_number(settings.step);
  }
  return text + ", max_steps " + std::to_string(settings.max_steps);
}

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
  for (int i = 0; i < dof_of<Model>(); ++i) {
    const double m = params.m[i];
    if (!std::isfinite(m)) report("m", i, m, "must be finite");
    else if (m <= 0.0) report("m", i, m, "masses must be > 0");
  }
  for (int i = is_classical<Model>() ? 1 : 0; i < dof_of<Model>(); ++i) {
    const double l = params.l[i];
    if (!std::isfinite(l)) report("l", i, l, "must be finite");
    else if (l <= 0.0) report("l", i, l, "lengths must be > 0");
  }
  for (int i = 0; i < dof_of<Model>(); ++i) {
    const double d = params.delta[i];
    if (!std::isfinite(d)) report("delta", i, d, "must be finite");
    else if (d < 0.0) report("delta", i, d, "damping must be >= 0");
  }
  if (!std::isfinite(params.g)) report("g", -1, params.g, "must be finite");
  if constexpr (has_links_as_built<Model>) {
    // NaN com or J: the homogeneous rod's value (docs/model.md, "Links as built").
    for (int i = 0; i < dof_of<Model>(); ++i) {
      const auto k = static_cast<std::size_t>(i);
      if (i > 0 && std::isinf(params.com[k])) report("com", i, params.com[k], "must be finite (or NaN: l/2)");
      const double across = params.J[k];
      bool fixed = false;  // a fixed chain's J may be negative while J + m com² > 0 (identified values)
      if constexpr (is_runtime<Model>) fixed = Model::fixed_pivot();
      const double com = std::isnan(params.com[k]) ? params.l[k] / 2.0 : params.com[k];
      if (std::isinf(across)) report("J", i, across, "must be finite (or NaN: the rod's value)");
      else if (fixed && !std::isnan(across) && !(across + params.m[k] * com * com > 0.0))
        report("J", i, across, "a link needs an inertia about its pivot, J + m com² > 0");
      else if (!fixed && across < 0.0) report("J", i, across, "an inertia cannot be negative");
      if (i == 0) continue;
      const double axial = params.J_axial[k];
      if (!std::isfinite(axial)) report("J_axial", i, axial, "must be finite");
      else if (axial < 0.0) report("J_axial", i, axial, "an inertia cannot be negative");
      else if (std::isfinite(across) && axial > 2.0 * across * (1.0 + 1e-12) && !(fixed && axial == 0.0))
        report("J_axial", i, axial, "must be <= 2 J (no axisymmetric body has more)");
      const double tip = params.tip[k];
      if (!std::isfinite(tip)) report("tip", i, tip, "must be finite");
      else if (tip < 0.0) report("tip", i, tip, "a mass cannot be negative");
    }
  }
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
  for (int i = 0; i < dof_of<Model>(); ++i) {
    const double c = settings.coulomb(i);
    if (!(std::isfinite(c) && c >= 0.0)) report("coulomb[" + std::to_string(i) + "]", c, "must be finite and >= 0");
  }
  if (!(std::isfinite(settings.coulomb_speed) && settings.coulomb_speed > 0.0)) {
    report("coulomb_speed", settings.coulomb_speed, "must be finite and > 0");
  }
  if (!(std::isfinite(settings.coulomb_gain) && settings.coulomb_gain > 0.0)) {
    report("coulomb_gain", settings.coulomb_gain, "must be finite and > 0");
  }
  if (settings.input_sign != 1.0 && settings.input_sign != -1.0) {
    report("input_sign", settings.input_sign, "must be 1 or -1");
  }
  if (!(std::isfinite(settings.rtol) && settings.rtol > 0.0)) {
    report("rtol", settings.rtol, "must be finite and > 0");
  } else if (!(settings.rtol >= kRtolMin && settings.rtol < 1.0)) {  // limits.hpp, shared with ipgen
    report("rtol", settings.rtol, "must be >= 1e-15 (double precision cannot meet less) and < 1");
  }
  if (!(std::isfinite(settings.atol) && settings.atol > 0.0)) report("atol", settings.atol, "must be finite and > 0");
  if (!(std::isfinite(settings.t_end) && settings.t_end >= kMinTEnd)) {
    report("t_end", settings.t_end, "must be finite and >= 1e-9 s (kMinTEnd)");
  }
  if (!(std::isfinite(settings.sample) && settings.sample > 0.0)) {
    report("sample", settings.sample, "must be finite and > 0");
  } else if (std::isfinite(settings.t_end) && settings.t_end / settings.sample > kMaxSamples) {
    report("sample", settings.sample,
           ("t_end / sample exceeds " + std::to_string(static_cast<long>(kMaxSamples)) + " output samples").c_str());
  }
  if (settings.method == Method::rk4 && !(std::isfinite(settings.step) && settings.step > 0.0)) {
    report("step", settings.step, "method rk4 needs a fixed step: must be finite and > 0");
  }
  if (settings.max_steps <= 0) {
    found.push_back("invalid setting max_steps = " + std::to_string(settings.max_steps) + ": must be > 0");
  }
  for (int i = 0; i < dof_of<Model>(); ++i) {
    if (!std::isfinite(settings.theta(i))) {
      report("theta[" + std::to_string(i) + "]", settings.theta(i), "initial state must be finite");
    }
    if (!std::isfinite(settings.dtheta(i))) {
      report("dtheta[" + std::to_string(i) + "]", settings.dtheta(i), "initial state must be finite");
    }
  }
  if (settings.input.kind == Input::Kind::sampled && settings.input.period > 0.0 && std::isfinite(settings.t_end) &&
      settings.t_end / settings.input.period > kMaxSamples) {
    report("input.period", settings.input.period, "t_end / period exceeds 1e8 sampling instants");
  }
  if (!(std::isfinite(settings.lag) && settings.lag >= 0.0)) report("actuator.lag", settings.lag, "must be finite and >= 0 s");
  for (const Pulse& pulse : settings.pulses) {
    if (!(std::isfinite(pulse.start) && std::isfinite(pulse.duration) && std::isfinite(pulse.amplitude) &&
          pulse.start >= 0.0 && pulse.duration > 0.0)) {
      found.emplace_back("invalid setting actuator.pulses: each pulse is [start >= 0 s, duration > 0 s, amplitude], finite");
      break;
    }
  }
  if (settings.lag > 0.0 && settings.acceleration) {
    found.emplace_back("invalid setting actuator.lag: not supported with an acceleration-driven base yet");
  }
  if (!settings.pulses.empty() && settings.acceleration) {
    found.emplace_back("invalid setting actuator.pulses: an acceleration-driven base has no force to disturb");
  }
  const auto input_problems = settings.input.problems();
  found.insert(found.end(), input_problems.begin(), input_problems.end());
  for (std::size_t k = 0; k < settings.more_inputs.size(); ++k) {
    const Input& more = settings.more_inputs[k];
    const std::string name = "input" + std::to_string(k + 2);
    if (more.kind == Input::Kind::feedback || more.kind == Input::Kind::sampled) {
      // A fixed chain's controller: every input its row of u = −K (x − x_eq), all alike (sampled together).
      if (more.kind != settings.input.kind || more.period != settings.input.period) {
        found.push_back("invalid setting " + name + ": a fixed chain's further inputs are open-loop signals, or "
                        "feedback of the same kind and period as input");
      }
      continue;
    }
    for (std::string problem : more.problems()) {  // "... input.amplitude ..." -> "... input2.amplitude ..."
      if (const auto at = problem.find("input"); at != std::string::npos) problem.replace(at, 5, name);
      found.push_back(std::move(problem));
    }
  }
  if (!settings.more_inputs.empty() && (settings.acceleration || settings.lag > 0.0 || !settings.pulses.empty())) {
    found.emplace_back("invalid setting input2: more than one input with an acceleration-driven base, a lag or pulses");
  }
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
