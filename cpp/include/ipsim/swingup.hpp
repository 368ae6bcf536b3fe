// A swing-up controller (ipgen's [swingup] scene table) as an ipsim Input, and a sink that
// writes its phase, ends the run `hold` s into the hold phase, watches divergence there and, while
// a plan is tracked, how far the links are from it.
//
// x = [θ; θ̇] (2·kDof), u the force [N] or torque [N m] on the base. The controller is sampled:
// at t_k = k·period it computes u from x(t_k) and holds it until t_k+1; |u| ≤ u_max. Phases:
//   swing  (method energy)     Åström–Furuta energy control of link 1 (generator/control/energy.py):
//                              E = ½ J θ̇1² + w (cos θ1 − 1),
//                              a = sat_amax(k_E (E − E0) sign(θ̇1 M10)) − k_x θ0 − k_v θ̇0,
//                              θ̈1 = −(M10 a + b1)/M11, u = M00 a + M01 θ̈1 + b0 (M, b the model's
//                              mass matrix and bias at x), until |θ1 − 2πk| ≤ catch_angle and
//                              |θ̇1| ≤ catch_rate: then hold about θ1 = 2πk;
//   track  (method trajectory) u_k = ū_k − K_k (x − x̄_k) along the plan (k < steps), or a
//                              scene's MPC with the plan as its reference per stage (track_law,
//                              every catch_every periods, u held in between);
//   hold                       u = −K_hold (x − x_target), or a catch controller's u (a scene's
//                              [controller] kind = "mpc" with its [swingup]: the MPC's step every
//                              catch_every periods from the catch on, fed x with θ1 − 2πk, u held
//                              in between).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ipsim/divergence.hpp"
#include "ipsim/errors.hpp"
#include "ipsim/input.hpp"
#include "ipsim/linkage.hpp"
#include "ipsim/model.hpp"
#include "ipsim/sink.hpp"
#include "ipgen_loop.h"

namespace ipsim {

/// The phase a swing-up controller is in (the phase column of the CSV).
enum class SwingPhase { swing, track, hold };

inline const char* to_string(SwingPhase phase) {
  switch (phase) {
    case SwingPhase::swing: return "swing";
    case SwingPhase::track: return "track";
    case SwingPhase::hold: return "hold";
  }
  return "?";
}

/// The data of a swing-up (what ipgen writes into the resolved scene) and its controller state.
struct SwingUp {
  enum class Method { energy, trajectory };
  Method method = Method::energy;
  double u_max = 0.0;   ///< |u| ≤ u_max [N or N m]
  int first_link = 1;   ///< link 1's coordinate: 1 behind a cart or arm, 0 on a fixed pivot
  /// The energy law's force (the design model's) per force the plant gets for the same volts: the
  /// design's force per volt over the plant's (1 unless a sweep's run changed the motor).
  double law_gain = 1.0;
  double period = 0.0;  ///< sampling period [s]
  double hold = 0.0;    ///< the run ends this long into the hold phase [s]
  Eigen::VectorXd hold_gain, target;  ///< K_hold, x_target (2·kDof)
  // energy
  double gain_energy = 0.0, gain_position = 0.0, gain_velocity = 0.0, accel_max = 0.0;
  double catch_angle = 0.0, catch_rate = 0.0, energy_target = 0.0, energy_inertia = 0.0, energy_weight = 0.0;
  /// u is the base's acceleration (Settings::acceleration): the energy law returns a itself.
  bool acceleration = false;
  // trajectory: ū_k (steps), x̄_k (steps + 1 rows), K_k (steps rows)
  Eigen::VectorXd inputs;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> states, gains;  ///< row-major: ipgen_loop.h's layout
  /// The hold's controller when not the LQR (a scene's MPC): u [N or N m] from x with θ1 taken
  /// relative to the caught upright (θ1 − 2πk); called at the catch and every catch_every
  /// periods after it, its u held in between. Empty: the hold LQR.
  std::function<double(const Eigen::VectorXd&)> catch_law;
  long catch_every = 1;
  /// Energy only: a hold that lets link 1 fall more than this from the upright it caught [rad]
  /// gives it back to the energy law (0: the hold is for good); catch_reset (if any) then makes
  /// the catch law's next catch start afresh.
  double release_angle = 0.0;
  /// J: > 0, the energy law learns its target by steps of it (ipgen_loop_energy_learn); 0: fixed
  double energy_step = 0.0;
  /// J: > 0, a catch needs the law's E >= -catch_deficit (ipgen_loop_energy_ready); 0: any E
  double catch_deficit = 0.0;
  /// rad or m: > 0, a catch needs |θ0| <= catch_base (ipgen_loop_energy_ready); 0: anywhere
  double catch_base = 0.0;
  std::function<void()> catch_reset;
  /// Trajectory only, [swingup] tracking = "mpc": the controller that tracks the plan instead of
  /// its gains, u [N or N m] from x and the plan's reference per stage (x_refs: track_horizon + 1
  /// rows of 2·kDof, u_refs: track_horizon inputs [N or N m]; ipgen_loop_plan_reference), every
  /// catch_every periods from the start, u held in between; catch_law holds at the plan's end.
  std::function<double(const Eigen::VectorXd&, const double*, const double*)> track_law;
  int track_horizon = 0;
  /// The plant's input gain over the model's (the EKF's learnt rho; null or 1: none): u is divided
  /// by it, then clipped to u_max (ipgen_loop_swingup's gain_factor).
  std::shared_ptr<const double> gain_factor;

  /// What the controller did last: its phase, the time it entered the hold phase, and the
  /// equilibrium it holds (x_target, or θ1 = 2πk for a caught energy swing-up).
  struct State {
    SwingPhase phase = SwingPhase::swing;
    double hold_since = std::numeric_limits<double>::quiet_NaN();
    Eigen::VectorXd equilibrium;
    /// track phase: at the last sampling instant, the link farthest from the plan and by how much [rad]
    int off_plan_link = 0;
    double off_plan = 0.0;
    /// release_angle: how many times the hold gave the link back to the swing
    int releases = 0;
    /// The loop runtime's memory between samples (a catch law's sample and last u, what the
    /// energy law has learnt); its phase, k and hold_q1 are set from the fields above each sample.
    ipgen_loop_swingup_state loop{};
  };

  /// Problems, one line each (empty when valid).
  std::vector<std::string> problems(int state_size) const;

  /// The sampled input that runs this swing-up on `Model` with `params`; `state` receives the
  /// phase (shared with the SwingUpMonitor).
  template <class Model>
  Input input(const ParamsOf<Model>& params, std::shared_ptr<State> state) const {
    state->equilibrium = target;
    state->phase = method == Method::energy ? SwingPhase::swing : SwingPhase::track;
    state->loop = ipgen_loop_swingup_state{};
    const SwingUp copy = *this;
    auto law = [copy, params, state](double t, const Eigen::VectorXd& x) {
      return copy.control<Model>(t, x, params, *state);
    };
    return Input::sampled(period, std::move(law));
  }

  /// u at sampling instant t (k = round(t / period)) in state x; updates `state`. The law is
  /// ipgen_loop.h's (ipgen_loop_swingup_step, shared with the firmware header and Python).
  template <class Model>
  double control(double t, const Eigen::VectorXd& x, const ParamsOf<Model>& params, State& state) const {
    const int n = dof_of<Model>();
    const long k = std::lround(t / period);
    if (state.phase == SwingPhase::track && k < inputs.size()) {  // how far the links are from the plan
      state.off_plan = 0.0;
      for (int i = first_link; i < n; ++i) {  // every link (a fixed chain's first too), not a base
        const double off = std::abs(x(i) - states(k, i));
        if (!(off <= state.off_plan)) {  // NaN counts as off
          state.off_plan = off;
          state.off_plan_link = i - first_link + 1;
        }
      }
    }
    const ipgen_loop_energy_law energy{gain_energy, gain_position, gain_velocity, accel_max, catch_angle, catch_rate,
                                       energy_target, energy_inertia, energy_weight, acceleration ? 1 : 0, law_gain, energy_step,
                                       catch_deficit, catch_base};
    const LawContext<Model> context{&params, n, hold_gain.data()};
    std::vector<double> refs(track_law ? static_cast<std::size_t>(IPGEN_LOOP_TRACK_REFS(n, track_horizon)) : 0U);
    const ipgen_loop_swingup law{n,
                                 u_max,
                                 hold_gain.data(),
                                 target.data(),
                                 energy,
                                 method == Method::trajectory ? static_cast<long>(inputs.size()) : 0L,
                                 inputs.data(),
                                 states.data(),
                                 gains.data(),
                                 &SwingUp::mass_bias<Model>,
                                 const_cast<void*>(static_cast<const void*>(&context)),
                                 &SwingUp::feedback<Model>,
                                 catch_law ? &SwingUp::call_catch_law : nullptr,
                                 const_cast<void*>(static_cast<const void*>(this)),
                                 catch_every,
                                 release_angle,
                                 catch_reset ? &SwingUp::call_catch_reset : nullptr,
                                 track_law ? &SwingUp::call_track_law : nullptr,
                                 track_horizon,
                                 refs.data(),
                                 gain_factor.get()};
    ipgen_loop_swingup_state& loop = state.loop;
    loop.phase = phase_code(state.phase);
    loop.k = k;
    loop.hold_q1 = state.equilibrium(1);
    std::vector<double> work(static_cast<std::size_t>(IPGEN_LOOP_SWINGUP_WORK(n)));
    const double u = ipgen_loop_swingup_step(&law, &loop, x.data(), work.data());
    if (loop.phase == IPGEN_LOOP_HOLD && state.phase != SwingPhase::hold) {
      state.phase = SwingPhase::hold;
      state.hold_since = t;
      state.equilibrium = target;
      state.equilibrium(1) = loop.hold_q1;
    } else if (loop.phase == IPGEN_LOOP_SWING && state.phase == SwingPhase::hold) {  // released
      state.phase = SwingPhase::swing;
      state.hold_since = std::numeric_limits<double>::quiet_NaN();
      ++state.releases;
    }
    return u;
  }

 private:
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  static int phase_code(SwingPhase phase) {
    switch (phase) {
      case SwingPhase::swing: return IPGEN_LOOP_SWING;
      case SwingPhase::track: return IPGEN_LOOP_TRACK;
      case SwingPhase::hold: return IPGEN_LOOP_HOLD;
    }
    return IPGEN_LOOP_HOLD;
  }

  /// What the callbacks of ipgen_loop_swingup see: the parameters, the degrees of freedom and
  /// the hold's gain (to tell the hold's feedback from the plan's).
  template <class Model>
  struct LawContext {
    const ParamsOf<Model>* params;
    int n;
    const double* hold_gain;
  };

  /// catch_law for ipgen_loop_swingup (context: this SwingUp) on x (2·kDof, θ1 relative to the
  /// caught upright).
  static double call_catch_law(void* context, const double x[]) {
    const auto& self = *static_cast<const SwingUp*>(context);
    return self.catch_law(Eigen::Map<const Eigen::VectorXd>(x, self.target.size()));
  }

  /// track_law for ipgen_loop_swingup (context: this SwingUp): x and the plan's reference.
  static double call_track_law(void* context, const double x[], const double x_refs[], const double u_refs[]) {
    const auto& self = *static_cast<const SwingUp*>(context);
    return self.track_law(Eigen::Map<const Eigen::VectorXd>(x, self.target.size()), x_refs, u_refs);
  }

  /// catch_reset for ipgen_loop_swingup (context: this SwingUp).
  static void call_catch_reset(void* context) { static_cast<const SwingUp*>(context)->catch_reset(); }

  /// u_ref − K (x − x_ref) summed as the simulator summed it before ipgen_loop.h, so that its runs
  /// keep their bits (ipgen_loop_swingup.feedback): the hold as LinearFeedback does (Eigen's dot),
  /// a plan's step in the order of x (ipgen_loop_feedback, as Eigen summed the plan's gain row).
  template <class Model>
  static double feedback(void* context, int states, double u_ref, const double K[], const double x[],
                         const double x_ref[]) {
    if (K != static_cast<const LawContext<Model>*>(context)->hold_gain) {
      return ipgen_loop_feedback(states, u_ref, K, x, x_ref);
    }
    const Eigen::Map<const Eigen::VectorXd> gain(K, states), state(x, states), reference(x_ref, states);
    return u_ref - gain.dot(state - reference);
  }

  /// M(q) and bias(q, qd) row-major, for the energy law (ipgen_loop_mass_bias); context: the
  /// parameters and the degrees of freedom.
  template <class Model>
  static int mass_bias(void* context, const double q_in[], const double qd_in[], double M[], double b[]) {
    if constexpr (has_mass_and_bias<Model>) {
      const auto& [params, n, hold] = *static_cast<const LawContext<Model>*>(context);
      (void)hold;
      const VectorOf<Model> q = Eigen::Map<const Eigen::VectorXd>(q_in, n);
      const VectorOf<Model> qd = Eigen::Map<const Eigen::VectorXd>(qd_in, n);
      Eigen::Map<RowMajor>(M, n, n) = Model::template mass_matrix<double>(q, *params);
      Eigen::Map<Eigen::VectorXd>(b, n) = Model::template bias<double>(q, qd, *params);
      return 0;
    } else {  // scene::load refuses this case before any run
      (void)context, (void)q_in, (void)qd_in, (void)M, (void)b;
      throw InvalidInput({"swingup = energy needs the model's mass_matrix and bias (regenerate its header)"});
    }
  }
};

/// Where a tracked swing-up lost its plan: a link more than `angle` from the plan's angle at the
/// last sampling instant.
struct LostPlan {
  double t = 0.0;          ///< time of the sample that found it [s]
  int link = 0;            ///< the link (1..n)
  double deviation = 0.0;  ///< |θ_link − θ̄_link| [rad]
};

/// Passes every sample on to `inner`; in the track phase stops the run at a link more than `angle`
/// from the plan (lost(): the plan cannot be recovered, and running on only turns the links and
/// runs the base away), in the hold phase at a link more than `angle` from the held equilibrium
/// (divergence()), and `hold` s after the hold began (finished()).
class SwingUpMonitor : public SampleSink {
 public:
  SwingUpMonitor(SampleSink& inner, std::shared_ptr<const SwingUp::State> state, int dof, double hold,
                 double angle = DivergenceMonitor::kHalfPi, int first = 1)
      : inner_(inner), state_(std::move(state)), dof_(dof), hold_(hold), angle_(angle), first_(first) {}

  void begin(std::size_t samples, int state_size, bool energy_ledger) override {
    inner_.begin(samples, state_size, energy_ledger);
  }

  bool record(const Sample& sample) override {
    const bool more = inner_.record(sample);
    if (state_->phase == SwingPhase::track) {
      if (!(state_->off_plan <= angle_)) {
        lost_ = LostPlan{sample.t, state_->off_plan_link, state_->off_plan};
        return false;
      }
      return more;
    }
    if (state_->phase != SwingPhase::hold) return more;
    const auto [link, deviation] = farthest_link(sample.x(), state_->equilibrium, dof_, first_);
    if (deviation > angle_) {
      divergence_ = Divergence{sample.t, link, deviation};
      return false;
    }
    // Half a sampling period of slack: t is a multiple of sample, hold_since of period.
    if (sample.t - state_->hold_since >= hold_ - 1e-9 * std::max(1.0, sample.t)) {
      finished_ = true;
      return false;
    }
    return more;
  }

  const std::optional<Divergence>& divergence() const noexcept { return divergence_; }
  const std::optional<LostPlan>& lost() const noexcept { return lost_; }
  bool finished() const noexcept { return finished_; }
  double angle() const noexcept { return angle_; }

 private:
  SampleSink& inner_;
  std::shared_ptr<const SwingUp::State> state_;
  int dof_;
  double hold_, angle_;
  int first_;
  bool finished_ = false;
  std::optional<Divergence> divergence_;
  std::optional<LostPlan> lost_;
};

}  // namespace ipsim

#if IPSIM_DEFINITIONS
namespace ipsim {

IPSIM_DECL std::vector<std::string> SwingUp::problems(int state_size) const {
  std::vector<std::string> found;
  auto positive = [&](const char* name, double value) {
    if (!(std::isfinite(value) && value > 0.0)) {
      found.push_back(std::string("invalid setting swingup.") + name + " = " + detail::format_number(value) + ": must be finite and > 0");
    }
  };
  positive("u_max", u_max);
  positive("period", period);
  if (!(std::isfinite(hold) && hold >= 0.0)) found.push_back("invalid setting swingup.hold: must be finite and >= 0");
  if (hold_gain.size() != state_size || target.size() != state_size || !hold_gain.allFinite() || !target.allFinite()) {
    found.push_back("invalid setting swingup.hold_gain or swingup.target: 2·kDof finite numbers each");
  }
  if (method == Method::trajectory) {
    const auto steps = inputs.size();
    if (steps < 1 || states.rows() != steps + 1 || gains.rows() != steps || states.cols() != state_size ||
        gains.cols() != state_size || !inputs.allFinite() || !states.allFinite() || !gains.allFinite()) {
      found.emplace_back("invalid setting swingup.inputs, states or gains: steps, (steps + 1)·2·kDof and steps·2·kDof finite numbers");
    }
  } else {
    positive("energy_inertia", energy_inertia);
    positive("catch_angle", catch_angle);
    positive("catch_rate", catch_rate);
    if (!(std::isfinite(release_angle) && release_angle >= 0.0)) {
      found.push_back("invalid setting swingup.release_angle = " + detail::format_number(release_angle) + ": must be finite and >= 0");
    } else if (release_angle > 0.0 && !(release_angle > catch_angle)) {
      found.push_back("invalid setting swingup.release_angle = " + detail::format_number(release_angle) +
                      ": must be more than swingup.catch_angle (the hold would give back the link it has just caught)");
    }
    for (const auto& [name, value] : {std::pair<const char*, double>{"gain_energy", gain_energy},
                                      {"gain_position", gain_position}, {"gain_velocity", gain_velocity},
                                      {"accel_max", accel_max}, {"energy_step", energy_step},
                                      {"catch_deficit", catch_deficit}, {"catch_base", catch_base}}) {
      if (!(std::isfinite(value) && value >= 0.0)) {
        found.push_back(std::string("invalid setting swingup.") + name + " = " + detail::format_number(value) + ": must be finite and >= 0");
      }
    }
    if (!std::isfinite(energy_target) || !std::isfinite(energy_weight)) {
      found.emplace_back("invalid setting swingup.energy_target or energy_weight: must be finite");
    }
  }
  return found;
}

}  // namespace ipsim
#endif  // IPSIM_DEFINITIONS
