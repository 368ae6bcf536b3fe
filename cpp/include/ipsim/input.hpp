// The generalised input u(t) acting on θ0: force on the cart [N] (classical) or torque on the
// arm [N m] (rotary).
#pragma once

#include <cmath>
#include <cstddef>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ipsim/errors.hpp"
#include "ipsim/linkage.hpp"

namespace ipsim {

/// π, spelled out because M_PI is not standard C++.
inline constexpr double kPi = 3.14159265358979323846;

/// Input signal u(t). Build one with the named constructors; the fields are public so a scene
/// reader can fill them, and validate() reports inconsistent values.
struct Input {
  /// Shape of the signal.
  enum class Kind {
    zero,      ///< u = 0
    constant,  ///< u = amplitude
    pulse,     ///< u = amplitude for start ≤ t < start + duration, else 0
    step,      ///< u = 0 for t < time, amplitude for t ≥ time
    sine,      ///< u = amplitude · sin(2π · frequency · t + phase)
    chirp,     ///< u = amplitude · sin φ(t − start) on [start, start + duration): a sweep f0 → f1
    multisine, ///< u = amplitude · scale · Σ_j cos(2π f_j t + φ_j) (lines computed by ipgen)
    feedback,  ///< u = feedback(t, x), e.g. a controller
    sampled,   ///< u = feedback(t_k, x(t_k)) held on [t_k, t_k + period), t_k = k · period (sampled data)
  };
  /// Controller callback: t [s] and the state x = [θ; θ̇] (dim 2·kDof) → u.
  using Feedback = std::function<double(double t, const Eigen::VectorXd& x)>;

  Kind kind = Kind::zero;
  double amplitude = 0.0;  ///< [N] or [N m]
  double start = 0.0;      ///< pulse switch-on time [s]
  double duration = 0.0;   ///< pulse length [s], ≥ 0
  double time = 0.0;       ///< step time [s]
  double frequency = 0.0;  ///< sine frequency [Hz]
  double phase = 0.0;      ///< sine phase [rad]
  double period = 0.0;     ///< sampling period [s] of Kind::sampled, > 0
  double f0 = 0.0;         ///< chirp: frequency at start [Hz]
  double f1 = 0.0;         ///< chirp: frequency at start + duration [Hz], > f0
  bool logarithmic = false;  ///< chirp: exponential (true) or linear (false) sweep
  std::vector<double> frequencies;  ///< multisine: the lines' frequencies f_j [Hz]
  std::vector<double> phases;       ///< multisine: the lines' phases φ_j [rad]
  double scale = 1.0;               ///< multisine: 1 / peak of Σ_j cos(…), so that max |u| = amplitude
  Feedback feedback;       ///< used only by Kind::feedback and Kind::sampled

  /// u = 0.
  static Input zero() { return {}; }
  /// u = amplitude for all t.
  static Input constant(double amplitude) {
    Input in;
    in.kind = Kind::constant;
    in.amplitude = amplitude;
    return in;
  }
  /// u = amplitude on [start, start + duration), 0 elsewhere; both edges are integrator stops.
  static Input pulse(double amplitude, double start, double duration) {
    Input in;
    in.kind = Kind::pulse;
    in.amplitude = amplitude;
    in.start = start;
    in.duration = duration;
    return in;
  }
  /// u = amplitude from `time` on, 0 before; `time` is an integrator stop.
  static Input step(double amplitude, double time) {
    Input in;
    in.kind = Kind::step;
    in.amplitude = amplitude;
    in.time = time;
    return in;
  }
  /// u = amplitude · sin(2π · frequency_hz · t + phase_rad).
  static Input sine(double amplitude, double frequency_hz, double phase_rad) {
    Input in;
    in.kind = Kind::sine;
    in.amplitude = amplitude;
    in.frequency = frequency_hz;
    in.phase = phase_rad;
    return in;
  }
  /// A chirp (swept sine) on [start, start + duration), 0 elsewhere: u = amplitude · sin φ(τ),
  /// τ = t − start, D = duration; linear: φ = 2π (f0 τ + (f1 − f0) τ² / (2D)); logarithmic
  /// (f0 > 0): φ = 2π f0 D (k^(τ/D) − 1) / ln k, k = f1 / f0. Both edges are integrator stops.
  static Input chirp(double amplitude, double f0_hz, double f1_hz, double duration_s, double start_s,
                     bool logarithmic_sweep) {
    Input in;
    in.kind = Kind::chirp;
    in.amplitude = amplitude;
    in.f0 = f0_hz;
    in.f1 = f1_hz;
    in.duration = duration_s;
    in.start = start_s;
    in.logarithmic = logarithmic_sweep;
    return in;
  }
  /// A multisine u = amplitude · scale · Σ_j cos(2π f_j t + φ_j) for all t (smooth and periodic;
  /// ipgen chooses the lines and Schroeder's phases and the scale that makes max |u| = amplitude).
  static Input multisine(double amplitude, std::vector<double> frequencies_hz, std::vector<double> phases_rad,
                         double scale) {
    Input in;
    in.kind = Kind::multisine;
    in.amplitude = amplitude;
    in.frequencies = std::move(frequencies_hz);
    in.phases = std::move(phases_rad);
    in.scale = scale;
    return in;
  }

  /// u = callback(t, x). The callback must be smooth in t and x between integrator stops (CVODE
  /// assumes a smooth right-hand side); an exception it throws aborts the simulation and is
  /// rethrown to the caller of simulate().
  static Input from_feedback(Feedback callback) {
    Input in;
    in.kind = Kind::feedback;
    in.feedback = std::move(callback);
    return in;
  }

  /// A sampled-data controller: u = callback(t_k, x(t_k)) at each sampling instant
  /// t_k = k · period_s (k = 0, 1, …), held constant until the next one. Every sampling instant
  /// is an integrator stop (a restart), so the held value never leaks across an instant.
  static Input sampled(double period_s, Feedback callback) {
    Input in;
    in.kind = Kind::sampled;
    in.period = period_s;
    in.feedback = std::move(callback);
    return in;
  }

  /// u at time t [s] in state x = [θ; θ̇]; x is only read by Kind::feedback and Kind::sampled
  /// (for sampled, the caller passes the state at the sampling instant t).
  double value(double t, const Eigen::VectorXd& x) const {
    switch (kind) {
      case Kind::zero: return 0.0;
      case Kind::constant: return amplitude;
      case Kind::pulse: return (t >= start && t < start + duration) ? amplitude : 0.0;
      case Kind::step: return t >= time ? amplitude : 0.0;
      case Kind::sine: return amplitude * std::sin(2.0 * kPi * frequency * t + phase);
      case Kind::chirp: return chirp_value(t);
      case Kind::multisine: {
        double total = 0.0;
        for (std::size_t j = 0; j < frequencies.size(); ++j) total += std::cos(2.0 * kPi * frequencies[j] * t + phases[j]);
        return amplitude * scale * total;
      }
      case Kind::feedback:
      case Kind::sampled: return feedback(t, x);
    }
    return 0.0;
  }

  /// The chirp's u(t) (see chirp()).
  double chirp_value(double t) const {
    const double tau = t - start;
    if (!(tau >= 0.0 && tau < duration)) return 0.0;
    double phi = 0.0;
    if (logarithmic) {
      const double log_k = std::log(f1 / f0);
      phi = 2.0 * kPi * f0 * duration * std::expm1(log_k * tau / duration) / log_k;
    } else {
      phi = 2.0 * kPi * (f0 * tau + (f1 - f0) * tau * tau / (2.0 * duration));
    }
    return amplitude * std::sin(phi);
  }

  /// True when u depends on t only through jumps, i.e. is constant between switching_times().
  bool piecewise_constant() const {
    return kind == Kind::zero || kind == Kind::constant || kind == Kind::pulse || kind == Kind::step ||
           kind == Kind::sampled;
  }

  /// Times [s] at which u jumps (pulse edges, step time, sampling instants k · period below
  /// t_end), ascending. The integrator stops and restarts exactly there instead of stepping across.
  std::vector<double> switching_times(double t_end = 0.0) const;

  /// Inconsistent fields, one message each (empty when valid).
  std::vector<std::string> problems() const;
};

/// Lower-case name of an input kind, as used in scene files ("pulse", …).
inline const char* to_string(Input::Kind kind) {
  switch (kind) {
    case Input::Kind::zero: return "zero";
    case Input::Kind::constant: return "constant";
    case Input::Kind::pulse: return "pulse";
    case Input::Kind::step: return "step";
    case Input::Kind::sine: return "sine";
    case Input::Kind::chirp: return "chirp";
    case Input::Kind::multisine: return "multisine";
    case Input::Kind::feedback: return "feedback";
    case Input::Kind::sampled: return "sampled";
  }
  return "?";
}

}  // namespace ipsim

#if IPSIM_DEFINITIONS
namespace ipsim {

IPSIM_DECL std::vector<double> Input::switching_times(double t_end) const {
  if (kind == Kind::pulse || kind == Kind::chirp) return {start, start + duration};
  if (kind == Kind::step) return {time};
  std::vector<double> instants;
  if (kind == Kind::sampled && period > 0.0 && std::isfinite(period)) {
    // k · period, not a running sum, so the instants carry no accumulated round-off.
    for (long k = 1; static_cast<double>(k) * period < t_end; ++k) instants.push_back(static_cast<double>(k) * period);
  }
  return instants;
}

IPSIM_DECL std::vector<std::string> Input::problems() const {
  std::vector<std::string> found;
  auto need_finite = [&](const char* field, double v) {
    if (!std::isfinite(v)) {
      found.push_back(std::string("invalid setting input.") + field + " = " + detail::format_number(v) +
                      ": must be finite");
      return false;
    }
    return true;
  };
  switch (kind) {
    case Kind::zero: break;
    case Kind::constant: need_finite("amplitude", amplitude); break;
    case Kind::pulse:
      need_finite("amplitude", amplitude);
      need_finite("start", start);
      if (need_finite("duration", duration) && duration < 0.0) {
        found.push_back("invalid setting input.duration = " + detail::format_number(duration) +
                        ": must be >= 0");
      }
      break;
    case Kind::step:
      need_finite("amplitude", amplitude);
      need_finite("time", time);
      break;
    case Kind::sine:
      need_finite("amplitude", amplitude);
      need_finite("frequency", frequency);
      need_finite("phase", phase);
      break;
    case Kind::chirp:
      need_finite("amplitude", amplitude);
      need_finite("start", start);
      if (need_finite("duration", duration) && !(duration > 0.0)) {
        found.push_back("invalid setting input.duration = " + detail::format_number(duration) + ": must be > 0");
      }
      if (need_finite("f0", f0) && need_finite("f1", f1) && !(f1 > f0 && f0 >= 0.0 && (!logarithmic || f0 > 0.0))) {
        found.push_back("invalid setting input.f0 = " + detail::format_number(f0) + ", input.f1 = " +
                        detail::format_number(f1) + ": need 0 <= f0 < f1 (f0 > 0 for a logarithmic sweep)");
      }
      break;
    case Kind::multisine:
      need_finite("amplitude", amplitude);
      need_finite("scale", scale);
      if (frequencies.empty() || frequencies.size() != phases.size()) {
        found.push_back("invalid setting input.frequencies: need one or more lines and as many input.phases (" +
                        std::to_string(frequencies.size()) + " frequencies, " + std::to_string(phases.size()) +
                        " phases)");
      }
      for (std::size_t j = 0; j < frequencies.size(); ++j) {
        if (!std::isfinite(frequencies[j]) || (j < phases.size() && !std::isfinite(phases[j]))) {
          found.emplace_back("invalid setting input.frequencies/phases: must be finite");
          break;
        }
      }
      break;
    case Kind::feedback:
      if (!feedback) found.emplace_back("invalid setting input: feedback input without a callback");
      break;
    case Kind::sampled:
      if (!feedback) found.emplace_back("invalid setting input: sampled feedback input without a callback");
      if (!(std::isfinite(period) && period > 0.0)) {
        found.push_back("invalid setting input.period = " + detail::format_number(period) + ": must be finite and > 0");
      }
      break;
  }
  return found;
}

}  // namespace ipsim
#endif  // IPSIM_DEFINITIONS
