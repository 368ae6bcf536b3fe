// Reader for resolved scene files (.cfg), the flat format ipgen's Python side writes after
// validating a user's TOML scene. One `key = value` per line, `#` starts a comment, lists are
// space-separated:
//
//   name = cdip_pulse          model = cdip        type = classical     links = 2
//   inertia = pivot            (rotary: must match the model; ignored for classical)
//   m = 0.3 0.275 0.275        l = 0 0.5 0.5       delta = 0.3 0.1 0.1  g = 9.81
//   theta = 0 0 0              dtheta = 0 0 0
//   angles = absolute | relative   zero = upright | hanging   positive = clockwise | counterclockwise
//                              (optional, default the first: the rig's coordinates, ipsim/coordinates.hpp; theta,
//                              dtheta and controller.* are in them, swingup.* in ipgen's)
//   input = pulse              input.amplitude = 0.4   input.start = 0   input.duration = 1
//   (input.time for step; input.frequency [Hz] and input.phase [rad] for sine; chirp: input.f0,
//   input.f1 [Hz], input.duration, input.start [s], input.sweep = linear | logarithmic; multisine:
//   input.frequencies [Hz], input.phases [rad], input.scale — the lines ipgen computed — beside
//   its input.f_min, input.f_max, input.period, which only document them)
//   limits.travel = 0.2        (optional: |theta0| limit [m or rad]; simulate_<model> stops beyond it, exit 4)
//   t_end = 10   sample = 0.01   method = bdf   rtol = 1e-10   atol = 1e-12   max_steps = 100000
//   jacobian = exact           (optional, bdf and adams: exact | dq; default exact)
//   step = 0.001               (optional; required by method = rk4: its fixed step [s])
//   energy = false             (optional: true adds the energy ledger and energy columns)
//   controller = lqr | gain    (optional, with input = zero: u = −K (x − x_eq), clipped to ±saturation)
//   controller.gain = …        controller.equilibrium = …   (2·kDof numbers each)
//   controller.saturation = 2  controller.period = 0.01     (optional: |u| bound [N or N m]; sampling [s])
//   controller = mpc           (with input = zero: ipgen_mpc.h's step every controller.period, ipsim/mpc.hpp;
//                              its keys in ipgen's coordinates and the scene's unit of u, every one resolved:)
//   controller.horizon  controller.substeps  controller.q (row-major)  controller.r  controller.p (row-major)
//   controller.reference  controller.u_min  controller.u_max  controller.bounds (index min max …, optional)
//   controller.soft_bounds (index min max …, optional)  controller.soft_penalty (with soft_bounds: ρ1 ρ2)
//   controller.mode = rti | converged   controller.iterations  controller.cold_iterations
//   controller.qp_iterations  controller.sqp_tolerance  controller.qp_tolerance
//   controller.barrier         (optional, > 0: each QP Newton steps on its log-barrier problem at this weight)
//   controller.sensitivities = exact | frozen | shifted   (optional: frozen, the Jacobians at each stage's
//                                            start; shifted, those kept from the last sample)
//   controller.model.m l delta g com J J_axial tip gain Ir gr   (optional: the loop's design model: the MPC,
//                              the energy law, the EKF and the prediction run it; absent, the scene's: a
//                              sweep's run states the nominal scene's)
//   coulomb = 0.01 0 0         coulomb_speed = 0.01          (optional: Coulomb friction [N or N m], smooth law)
//   actuator = dc_motor        actuator.gain = b            (optional: u in volts, b the force or torque per
//                              volt; the parameters are then the motor-folded ones, docs/model.md)
//   actuator = acceleration    (optional: u is the base's acceleration [m/s^2 or rad/s^2], the links follow)
//   swingup = energy | trajectory   (optional, with input = zero and no controller but mpc, which then
//                                    catches and holds: ipsim/swingup.hpp)
//   swingup.u_max  swingup.period  swingup.hold  swingup.hold_gain  swingup.target   (both methods)
//   swingup.gain_energy gain_position gain_velocity accel_max catch_angle catch_rate energy_target
//          energy_inertia energy_weight                                               (energy)
//   swingup.release_angle   (optional, energy: the hold gives the link back to the swing past it)
//   swingup.energy_step     (optional, energy: the law learns its target by steps of it [J])
//   swingup.catch_deficit swingup.catch_base  (optional, energy: a catch needs E >= -deficit [J], |θ0| <= base)
//   swingup.steps = K  swingup.inputs (K)  swingup.states ((K+1)·2·kDof)  swingup.gains (K·2·kDof)  (trajectory)
//   swingup.tracking = lqr | mpc  (optional, trajectory: the plan's gains track it, or with controller = mpc the MPC)
//   sensors.measured = 0 1   sensors.resolution = 2048 2048   sensors.noise = 0 0   sensors.delay = 0
//   sensors.seed = 0         (optional, with a sampled controller or swing-up: the measured loop, sensors.hpp)
//   sensors.zero = 0 -3.14…  (optional: the pose where the encoders read 0; absent: 0)
//   estimator = exact | difference | filter | kalman | ekf   estimator.cutoff (filter)
//   estimator.equilibrium, estimator.A, estimator.B, estimator.gain, estimator.input   (kalman, row-major)
//   estimator.equilibrium, estimator.process_noise, estimator.measurement_noise        (ekf, row-major)
//   estimator.delay = 0.02   (optional: the delay the loop is built for; absent: sensors.delay)
//   estimator.predict = 1    (optional, exact or ekf: the law sees the estimate carried over the delay)
//   estimator.compensate_lag = 1  (optional: the loop is built for actuator.lag, ipgen_loop_lag_*)
//   estimator.lag = 0.02     (optional, with compensate_lag: the lag the loop is built for; absent: actuator.lag)
//   estimator.noise_memory = 1  estimator.noise_margin = 10  estimator.noise_floor = 1e-6 1e-6  estimator.noise_ceiling = …
//                            (optional, ekf: the measurement noise learnt, ipgen_loop_ekf's noise_*)
//   actuator.noise = σ_u     actuator.lag = τ [s]     actuator.pulses = start duration amplitude …
//
// The reader only checks what the C++ side must rely on: syntax, known keys, numbers, list
// lengths against the compiled model, and the model's name, type and link count.
#pragma once

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <istream>
#include <map>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ipsim/cfg_rules.hpp"
#include "ipsim/controller.hpp"
#include "ipsim/mpc.hpp"
#include "ipsim/coordinates.hpp"
#include "ipsim/errors.hpp"
#include "ipsim/input.hpp"
#include "ipsim/limits.hpp"
#include "ipsim/linkage.hpp"
#include "ipsim/model.hpp"
#include "ipsim/sensors.hpp"
#include "ipsim/settings.hpp"
#include "ipsim/swingup.hpp"

namespace ipsim::scene {

/// A malformed or mismatched scene file; what() is "FILE:LINE: problem" (or "FILE: problem").
class SceneError : public Error {
 public:
  using Error::Error;
};

/// The key/value pairs of one scene file, with their line numbers for messages.
class SceneFile {
 public:
  /// Reads and parses `path`. Throws SceneError if it cannot be opened or has a syntax error.
  static SceneFile read(const std::string& path);

  /// Parses scene text; `origin` names the source in messages. Throws SceneError on a line that
  /// is not `key = value`, an empty value, or a repeated key.
  static SceneFile parse(std::istream& stream, std::string origin);

  /// The file name given to read() or parse().
  const std::string& origin() const noexcept { return origin_; }
  /// True if `key` is present.
  bool has(const std::string& key) const { return entries_.count(key) != 0; }
  /// All keys, sorted.
  std::vector<std::string> keys() const;
  /// Line of `key` (0 if absent).
  int line(const std::string& key) const;

  /// The raw value of a required key.
  const std::string& text(const std::string& key) const { return entry(key).value; }

  /// A required key holding one number (decimal or exponent notation; nan/inf are accepted here
  /// and rejected by validation with a better message).
  double number(const std::string& key) const;

  /// A required key holding one integer.
  long integer(const std::string& key) const;

  /// A required key holding a space-separated list of numbers.
  std::vector<double> numbers(const std::string& key) const;

  /// Throws SceneError("origin:line: message"); line 0 means the whole file.
  [[noreturn]] void fail(int line_number, const std::string& message) const;

 private:
  struct Entry {
    std::string value;
    int line;
  };

  const Entry& entry(const std::string& key) const;

  static std::string trim(const std::string& s);

  std::string origin_;
  std::map<std::string, Entry> entries_;
};

/// A scene ready to simulate: its name, the model parameters and the settings.
template <class Model>
struct Scene {
  std::string name;  ///< the scene's `name`, or the file name when absent
  ParamsOf<Model> params{};
  Settings<Model> settings;
  bool energy = false;  ///< `energy = true`: report energies (settings.energy_ledger is set too)
  /// `controller = lqr` or `gain`: the feedback that sets settings.input (which is then a feedback or
  /// sampled input).
  std::optional<LinearFeedback> controller;
  /// `actuator = dc_motor`: the force [N] or torque [N m] per volt, b. The file's parameters are
  /// then the equivalent direct model's (back-EMF in delta[0], the rotor's inertia in m[0] or
  /// J[0]); the inputs and the controller are in volts in the file and scaled by b here, so
  /// settings.input and controller are in N or N m. 1 for a direct drive.
  double input_gain = 1.0;
  bool motor = false;  ///< `actuator = dc_motor`
  /// The model the loop is designed with: the MPC's predictions, the energy law's mass matrix and
  /// bias, the EKF's and the delay prediction's dynamics, and its force per volt. The plant's
  /// (params, input_gain) unless controller.model.* states another: a sweep's runs keep the
  /// nominal scene's while the plant changes (generator/sweeps/design_model.py).
  ParamsOf<Model> design{};
  double design_gain = 1.0;
  /// `swingup = energy | trajectory`: the swing-up that sets settings.input (sampled), and the
  /// phase it is in (shared with the input).
  std::optional<SwingUp> swingup;
  std::shared_ptr<SwingUp::State> swingup_state;
  /// `angles`, `zero`, `positive`: the rig's coordinates. The file's theta, dtheta and controller
  /// are in them and mapped here: settings and controller are in ipgen's coordinates (what
  /// simulate() integrates); the CSV and the summary map back (CsvSink::set_coordinates).
  Coordinates coordinates;
  /// A fixed chain's `controller` (m inputs): one LinearFeedback per input, row k of K with its
  /// saturation (settings.input and more_inputs apply them); empty otherwise (`controller` then).
  std::vector<LinearFeedback> fixed_controllers;
  /// `limits.travel`: the base's limit |θ0| [m or rad]; infinity when the scene has none.
  double travel = std::numeric_limits<double>::infinity();
  /// `sensors.*`, `estimator.*`, `actuator.noise`: the measured loop around the sampled controller
  /// or swing-up (sensors.hpp); null for today's exact loop.
  std::shared_ptr<MeasuredLoop<Model>> loop;
  /// `controller = mpc`: the MPC whose step sets settings.input (sampled; ipsim/mpc.hpp).
  std::shared_ptr<MpcController<Model>> mpc;
  /// The plant's input gain over the loop's model as the EKF learns it (estimator.gain_spread;
  /// MeasuredLoop writes it, the swing-up divides its u by it); 1 when not learnt.
  std::shared_ptr<double> gain_factor = std::make_shared<double>(1.0);
};

/// `controller = mpc`: the controller.* keys into scene.mpc, its sampled input into settings.input.
template <class Model>
void load_mpc(const SceneFile& file, Scene<Model>& scene);

/// The MPC's u (the scene's unit, a fixed chain's torque in ipgen's sense: the model's input) to
/// the controller's output: × the DC motor's gain (N or N m per volt; 1 without a motor) and × a
/// fixed chain's input sign (its outputs are in the rig's positive sense, as its CSV's u).
template <class Model>
double mpc_input_scale(const Scene<Model>& scene) {
  return scene.input_gain * scene.settings.input_sign;
}

/// Fails at the first number outside its key's rule (cfg_rules.hpp: the scene schema's bounds).
void check_rules(const SceneFile& file);

/// A list of `count` numbers under `key` (fails with the key's line otherwise).
Eigen::VectorXd numbers_of(const SceneFile& file, const std::string& key, Eigen::Index count);

/// The swing-up keys of a scene file into scene.swingup, its input into scene.settings.input.
template <class Model>
void load_swingup(const SceneFile& file, Scene<Model>& scene, const std::string& kind) {
  const std::string& method = file.text("swingup");
  if (method != "energy" && method != "trajectory") {
    file.fail(file.line("swingup"), "swingup must be `energy` or `trajectory`, got `" + detail::abbreviate(method) + "`");
  }
  if (kind != "zero") file.fail(file.line("swingup"), "a swing-up sets u: input must be `zero`, got `" + kind + "`");
  if (scene.controller) file.fail(file.line("swingup"), "a swing-up has its own controller: remove `controller`");
  const Eigen::Index size = 2 * dof_of<Model>();
  SwingUp sw;
  sw.first_link = scene.coordinates.base;  // 0 on a fixed pivot: link 1 is coordinate 0
  sw.acceleration = scene.settings.acceleration;
  sw.method = method == "energy" ? SwingUp::Method::energy : SwingUp::Method::trajectory;
  sw.u_max = file.number("swingup.u_max");
  sw.period = file.number("swingup.period");
  sw.hold = file.number("swingup.hold");
  sw.hold_gain = numbers_of(file, "swingup.hold_gain", size);
  sw.target = numbers_of(file, "swingup.target", size);
  if (sw.method == SwingUp::Method::energy) {
    if (links_of<Model>() != 1) file.fail(file.line("swingup"), "energy swing-up needs a single link");
    if (!provides<Model>(Feature::mass_and_bias)) {
      file.fail(file.line("swingup"), "energy swing-up needs the model's mass_matrix and bias: regenerate its header");
    }
    sw.gain_energy = file.number("swingup.gain_energy");
    sw.gain_position = file.number("swingup.gain_position");
    sw.gain_velocity = file.number("swingup.gain_velocity");
    sw.accel_max = file.number("swingup.accel_max");
    sw.catch_angle = file.number("swingup.catch_angle");
    sw.catch_rate = file.number("swingup.catch_rate");
    sw.energy_target = file.number("swingup.energy_target");
    sw.energy_inertia = file.number("swingup.energy_inertia");
    sw.energy_weight = file.number("swingup.energy_weight");
    if (file.has("swingup.release_angle")) sw.release_angle = file.number("swingup.release_angle");
    if (file.has("swingup.energy_step")) sw.energy_step = file.number("swingup.energy_step");
    if (file.has("swingup.catch_deficit")) sw.catch_deficit = file.number("swingup.catch_deficit");
    if (file.has("swingup.catch_base")) sw.catch_base = file.number("swingup.catch_base");
  } else {
    if (sw.acceleration) file.fail(file.line("swingup"), "swingup = trajectory with actuator = acceleration is not supported yet");
    const long steps = file.integer("swingup.steps");
    if (steps < 1 || steps > 10'000'000) file.fail(file.line("swingup.steps"), "swingup.steps must be in 1 .. 10000000");
    sw.inputs = numbers_of(file, "swingup.inputs", steps);
    const Eigen::VectorXd states = numbers_of(file, "swingup.states", (steps + 1) * size);
    const Eigen::VectorXd gains = numbers_of(file, "swingup.gains", steps * size);
    // Row by row in the file: one state or gain (2·kDof numbers) after the other.
    sw.states = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(states.data(), steps + 1, size);
    sw.gains = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(gains.data(), steps, size);
  }
  const auto problems = sw.problems(static_cast<int>(size));
  if (!problems.empty()) file.fail(0, problems.front());
  if constexpr (is_runtime<Model>) {
    if (Model::fixed_pivot()) {
      // A fixed chain's plan, gains and target are in the rig's coordinates (its inputs in the
      // rig's sense, as the CSV's u): map the states and gains as a fixed chain's controller.
      if (sw.method != SwingUp::Method::trajectory) file.fail(file.line("swingup"), "a fixed chain's swing-up must be `trajectory`");
      if (!scene.settings.more_inputs.empty()) file.fail(file.line("swingup"), "a fixed chain's swing-up drives one joint");
      sw.target = scene.coordinates.to_canonical(sw.target);
      sw.hold_gain = scene.coordinates.gain_to_canonical(sw.hold_gain);
      for (Eigen::Index k = 0; k < sw.states.rows(); ++k) {
        sw.states.row(k) = scene.coordinates.to_canonical(sw.states.row(k).transpose()).transpose();
      }
      for (Eigen::Index k = 0; k < sw.gains.rows(); ++k) {
        sw.gains.row(k) = scene.coordinates.gain_to_canonical(sw.gains.row(k).transpose()).transpose();
      }
    }
  }
  // actuator = dc_motor: the file's u-valued numbers are in volts, the energy law's output is the
  // motor-folded model's torque or force; scale to N m or N like the controller (b = 1 otherwise).
  const double b = scene.input_gain;
  sw.u_max *= b;
  sw.hold_gain *= b;
  sw.inputs *= b;
  sw.gains *= b;
  if (std::isfinite(scene.settings.t_end) && scene.settings.t_end / sw.period > kMaxSamples) {
    file.fail(file.line("swingup.period"), "swingup.period = " + detail::format_number(sw.period) +
                                               ": t_end / period exceeds " + detail::format_number(kMaxSamples) + " sampling instants");
  }
  // swingup.tracking: lqr (the plan's gains, the default) or mpc (the scene's MPC tracks the plan)
  const std::string tracking = file.has("swingup.tracking") ? file.text("swingup.tracking") : "lqr";
  if (file.has("swingup.tracking") && ((tracking != "mpc" && tracking != "lqr") || sw.method != SwingUp::Method::trajectory)) {
    file.fail(file.line("swingup.tracking"), "swingup.tracking must be `lqr` or `mpc`, with swingup = trajectory");
  }
  if (tracking == "mpc" && !scene.mpc) file.fail(file.line("swingup.tracking"), "swingup.tracking = mpc needs controller = mpc");
  if (scene.mpc) {  // controller = mpc with a swing-up: the MPC catches and holds (every catch_every periods)
    const double every = std::round(scene.mpc->problem().period / sw.period);
    if (!(every >= 1.0 && std::abs(every * sw.period - scene.mpc->problem().period) <= 1e-9 * scene.mpc->problem().period)) {
      file.fail(file.line("controller.period"), "controller.period = " + detail::format_number(scene.mpc->problem().period) +
                                                    " must be a whole multiple of swingup.period = " + detail::format_number(sw.period));
    }
    sw.catch_every = static_cast<long>(every);
    const double to_input = mpc_input_scale(scene);  // the MPC's u -> the swing-up's output
    sw.catch_law = [mpc = scene.mpc, to_input](const Eigen::VectorXd& x) { return to_input * (*mpc)(x); };
    sw.catch_reset = [mpc = scene.mpc]() { mpc->reset(); };  // a released hold's next catch starts cold
    if (tracking == "mpc") {  // the MPC tracks the plan too, its reference per stage
      sw.track_horizon = scene.mpc->problem().horizon;
      // the plan's inputs are in the swing-up's output unit here (× b above), the MPC's in its own
      sw.track_law = [mpc = scene.mpc, to_input](const Eigen::VectorXd& x, const double* x_refs, const double* u_refs) {
        std::vector<double> inputs(u_refs, u_refs + mpc->problem().horizon);
        for (double& u : inputs) u /= to_input;
        return to_input * mpc->track(x, x_refs, inputs.data());
      };
    }
  }
  scene.swingup_state = std::make_shared<SwingUp::State>();
  // the energy law computes the design model's force; as volts (÷ design gain) it gives the plant b × V
  sw.law_gain = scene.design_gain / scene.input_gain;
  sw.gain_factor = scene.gain_factor;  // 1, or the gain the EKF learns (estimator.gain_spread)
  scene.settings.input = sw.input<Model>(scene.design, scene.swingup_state);
  scene.swingup = std::move(sw);
}

/// A row-major rows × cols matrix under `key`.
Eigen::MatrixXd matrix_of(const SceneFile& file, const std::string& key, Eigen::Index rows, Eigen::Index cols);

/// The bound of the sampled law's command [N or N m]: the swing-up's u_max, an MPC's u_max or a
/// controller's saturation (infinity without one), which a lag's compensation keeps to.
template <class Model>
double command_limit(const Scene<Model>& scene) {
  if (scene.swingup) return scene.swingup->u_max;
  if (scene.mpc) return std::abs(mpc_input_scale(scene)) * std::max(std::abs(scene.mpc->problem().u_min), std::abs(scene.mpc->problem().u_max));
  if (scene.controller) return scene.controller->saturation;
  return std::numeric_limits<double>::infinity();
}

/// The drive keys (actuator.lag, actuator.pulses into the settings; actuator.noise) and the
/// measured loop (sensors.*, estimator.*) around the sampled controller or swing-up (scene.loop).
template <class Model>
void load_drive(const SceneFile& file, Scene<Model>& scene) {
  const int n = dof_of<Model>();
  Settings<Model>& s = scene.settings;
  if (file.has("actuator.lag")) s.lag = file.number("actuator.lag");
  if (file.has("actuator.pulses")) {
    const auto values = file.numbers("actuator.pulses");
    if (values.size() % 3 != 0) file.fail(file.line("actuator.pulses"), "`actuator.pulses` needs 3 numbers a pulse (start duration amplitude)");
    for (std::size_t i = 0; i < values.size(); i += 3) s.pulses.push_back(Pulse{values[i], values[i + 1], values[i + 2]});
  }
  LoopSettings loop;
  // estimator.compensate_lag: the loop is built for the drive's lag (estimator.lag, else the rig's)
  const double compensate_key = file.has("estimator.compensate_lag") ? file.number("estimator.compensate_lag") : 0.0;
  if (compensate_key != 0.0 && compensate_key != 1.0) file.fail(file.line("estimator.compensate_lag"), "estimator.compensate_lag must be 0 or 1");
  const bool compensate = compensate_key == 1.0;
  if (file.has("estimator.lag") && !compensate) file.fail(file.line("estimator.lag"), "estimator.lag needs estimator.compensate_lag = 1 (the lag the loop is built for)");
  if (file.has("actuator.noise")) {
    loop.drive_noise = file.number("actuator.noise");
    if (!(std::isfinite(loop.drive_noise) && loop.drive_noise >= 0.0)) {
      file.fail(file.line("actuator.noise"), "actuator.noise must be a finite number >= 0");
    }
  }
  loop.sensors = file.has("sensors.measured");
  if (!loop.sensors && file.has("estimator")) file.fail(file.line("estimator"), "`estimator` needs the `sensors.*` keys");
  const bool wanted = loop.sensors || loop.drive_noise > 0.0;
  if (compensate && !loop.sensors) file.fail(file.line("estimator.compensate_lag"), "estimator.compensate_lag needs the sensors.* keys (the measured loop it compensates)");
  if (!wanted) return;
  const bool sampled = s.input.kind == Input::Kind::sampled;
  const int line = file.line(loop.sensors ? "sensors.measured" : "actuator.noise");
  if (!sampled) file.fail(line, "sensors, an estimator and drive noise need a sampled loop: a controller.period or a swingup");
  const double period = s.input.period;
  if (loop.sensors) {
    for (const double value : file.numbers("sensors.measured")) {
      const int i = static_cast<int>(value);
      if (value != i || i < 0 || i >= n || (!loop.measured.empty() && i <= loop.measured.back())) {
        file.fail(file.line("sensors.measured"), "sensors.measured must be ascending coordinates 0.." + std::to_string(n - 1));
      }
      loop.measured.push_back(i);
    }
    const auto m = static_cast<Eigen::Index>(loop.measured.size());
    if (m == 0) file.fail(file.line("sensors.measured"), "sensors.measured is empty");
    const Eigen::VectorXd resolution = numbers_of(file, "sensors.resolution", m);
    const Eigen::VectorXd noise = numbers_of(file, "sensors.noise", m);
    loop.resolution.assign(resolution.data(), resolution.data() + m);
    loop.noise.assign(noise.data(), noise.data() + m);
    if (file.has("sensors.zero")) {  // where the encoders read 0 (absent: 0, as before)
      const Eigen::VectorXd zero = numbers_of(file, "sensors.zero", m);
      loop.zero.assign(zero.data(), zero.data() + m);
    }
    // resolution, noise, zero, seed and cutoff: their ranges are cfg_rules.hpp's (checked in load)
    // A delay key's whole number of sampling periods (limits.hpp's rule), or its one-line failure.
    auto whole_periods = [&](const std::string& key) {
      const double delay = file.number(key);
      const double periods = std::round(delay / period);
      if (!(std::isfinite(delay) && delay >= 0.0 && std::abs(delay - periods * period) <= kDelayTolerance * std::max(delay, period) &&
            periods <= kMaxDelayPeriods)) {
        file.fail(file.line(key), key + " must be a whole multiple of the period " + detail::format_number(period) + " s");
      }
      return static_cast<long>(periods);
    };
    loop.delay_periods = whole_periods("sensors.delay");
    // the delay the loop is built for: the rig's, unless estimator.delay tells it another
    loop.assumed_delay_periods = file.has("estimator.delay") ? whole_periods("estimator.delay") : loop.delay_periods;
    const long seed = file.integer("sensors.seed");  // 64 bits: every seed ipgen accepts (<= 2^63 - 1024)
    loop.seed = static_cast<std::uint64_t>(seed);
    const std::string kind = file.has("estimator") ? file.text("estimator") : "exact";
    const std::pair<const char*, EstimatorKind> kinds[] = {{"exact", EstimatorKind::exact}, {"difference", EstimatorKind::difference},
                                                           {"filter", EstimatorKind::filter}, {"kalman", EstimatorKind::kalman},
                                                           {"ekf", EstimatorKind::ekf}};
    bool known = false;
    for (const auto& [name, value] : kinds) {
      if (kind == name) loop.kind = value, known = true;
    }
    if (!known) file.fail(file.line("estimator"), "estimator must be exact, difference, filter, kalman or ekf, got `" + detail::abbreviate(kind) + "`");
    if ((loop.kind == EstimatorKind::difference || loop.kind == EstimatorKind::filter) && m != n) {
      file.fail(file.line("estimator"), "estimator " + kind + " needs every coordinate measured (sensors.measured = 0.." + std::to_string(n - 1) + ")");
    }
    if (loop.kind == EstimatorKind::filter) {
      loop.cutoff = file.number("estimator.cutoff");
    }
    if (file.has("estimator.gain_spread")) {  // >= 0, gain_drift too: cfg_rules.hpp
      if (loop.kind != EstimatorKind::ekf) file.fail(file.line("estimator.gain_spread"), "estimator.gain_spread needs estimator = ekf (the filter learns the gain)");
      if (!scene.swingup) file.fail(file.line("estimator.gain_spread"), "estimator.gain_spread needs a swing-up (swingup = energy or trajectory), whose input it corrects");
      loop.gain_spread = file.number("estimator.gain_spread");
      if (file.has("estimator.gain_drift")) loop.gain_drift = file.number("estimator.gain_drift");
    }
    if (file.has("estimator.gain_drift") && !file.has("estimator.gain_spread")) {
      file.fail(file.line("estimator.gain_drift"), "estimator.gain_drift needs estimator.gain_spread (the gain it lets drift)");
    }
    if (file.has("estimator.predict")) {
      const double predict = file.number("estimator.predict");
      if (predict != 0.0 && predict != 1.0) file.fail(file.line("estimator.predict"), "estimator.predict must be 0 or 1");
      loop.predict = predict == 1.0;
      if (loop.predict && loop.kind != EstimatorKind::exact && loop.kind != EstimatorKind::ekf)
        file.fail(file.line("estimator.predict"), "estimator.predict needs estimator exact or ekf (the prediction runs the model)");
    }
    if (loop.kind == EstimatorKind::kalman || loop.kind == EstimatorKind::ekf) {
      loop.equilibrium = numbers_of(file, "estimator.equilibrium", 2 * n);
    }
    if (loop.kind == EstimatorKind::kalman) {
      loop.A = matrix_of(file, "estimator.A", 2 * n, 2 * n);
      loop.B = numbers_of(file, "estimator.B", 2 * n);
      loop.gain = matrix_of(file, "estimator.gain", 2 * n, m);
      loop.input_equilibrium = file.number("estimator.input");
      if (!loop.A.allFinite() || !loop.B.allFinite() || !loop.gain.allFinite() || !loop.equilibrium.allFinite() ||
          !std::isfinite(loop.input_equilibrium)) {
        file.fail(file.line("estimator.A"), "estimator.A, B, gain, equilibrium and input must be finite");
      }
    }
    if (loop.kind == EstimatorKind::ekf) {
      if (!(has_linearize<Model> && provides<Model>(Feature::derivatives))) file.fail(file.line("estimator"), "estimator ekf needs the model's linearize: regenerate its header");
      if (s.acceleration) file.fail(file.line("estimator"), "estimator ekf with actuator = acceleration is not supported yet");
      loop.process_noise = matrix_of(file, "estimator.process_noise", 2 * n, 2 * n);
      loop.measurement_noise = matrix_of(file, "estimator.measurement_noise", m, m);
      if (!loop.process_noise.allFinite() || !loop.measurement_noise.allFinite() || !loop.equilibrium.allFinite()) {
        file.fail(file.line("estimator.process_noise"), "estimator.process_noise, measurement_noise and equilibrium must be finite");
      }
    }
    for (const char* key : {"estimator.noise_margin", "estimator.noise_floor", "estimator.noise_ceiling"}) {
      if (file.has(key) && !file.has("estimator.noise_memory")) file.fail(file.line(key), std::string(key) + " needs estimator.noise_memory (the noise it bounds is not learnt)");
    }
    if (file.has("estimator.noise_memory")) {  // > 0: cfg_rules.hpp; the rest is derived by ipgen
      if (loop.kind != EstimatorKind::ekf) file.fail(file.line("estimator.noise_memory"), "estimator.noise_memory needs estimator = ekf (the filter learns the noise)");
      loop.noise_memory = file.number("estimator.noise_memory");
      if (loop.noise_memory < period) file.fail(file.line("estimator.noise_memory"), "estimator.noise_memory must be at least the loop's period " + detail::format_number(period) + " s");
      loop.noise_margin = file.number("estimator.noise_margin");
      if (!(std::isfinite(loop.noise_margin) && loop.noise_margin > 0)) file.fail(file.line("estimator.noise_margin"), "estimator.noise_margin must be finite and > 0");
      loop.noise_floor = numbers_of(file, "estimator.noise_floor", m);
      loop.noise_ceiling = numbers_of(file, "estimator.noise_ceiling", m);
      for (Eigen::Index i = 0; i < loop.noise_floor.size(); ++i) {
        if (!(std::isfinite(loop.noise_floor(i)) && loop.noise_floor(i) > 0)) file.fail(file.line("estimator.noise_floor"), "estimator.noise_floor must be finite and > 0");
        if (!(std::isfinite(loop.noise_ceiling(i)) && loop.noise_ceiling(i) >= loop.noise_floor(i))) file.fail(file.line("estimator.noise_ceiling"), "estimator.noise_ceiling must be finite and at least estimator.noise_floor");
      }
      const Eigen::MatrixXd& rn = loop.measurement_noise;  // read above (ekf)
      if (!(rn - Eigen::MatrixXd(rn.diagonal().asDiagonal())).isZero(0.0)) file.fail(file.line("estimator.noise_memory"), "estimator.noise_memory needs a diagonal estimator.measurement_noise");
    }
  }
  if (compensate) {
    loop.lag = file.has("estimator.lag") ? file.number("estimator.lag") : s.lag;  // pinned, or the rig's (known)
    loop.limit = command_limit(scene);
  }
  auto measured = std::make_shared<MeasuredLoop<Model>>(std::move(loop), s.input.feedback, period, scene.input_gain,
                                                        scene.design, scene.design_gain, scene.coordinates,
                                                        scene.gain_factor);
  s.input.feedback = [measured](double t, const Eigen::VectorXd& x) { return measured->step(t, x); };
  scene.loop = std::move(measured);
}

/// A fixed chain's rotors: `<prefix>Ir` and `<prefix>gr` (optional, one per input of m: default no
/// rotor, gr 1) into `params` (the plant's, prefix ""; the MPC's model, "controller.model.").
template <class Params>
void load_rotors(const SceneFile& file, const std::string& prefix, int m, Params& params) {
  for (int k = 0; k < m; ++k) {
    params.Ir[k] = 0.0;
    params.gr[k] = 1.0;
  }
  for (const char* name : {"Ir", "gr"}) {
    const std::string key = prefix + name;
    if (!file.has(key)) continue;
    const bool inertia = name[0] == 'I';
    const Eigen::VectorXd values = numbers_of(file, key, m);
    for (int k = 0; k < m; ++k) {
      if (!std::isfinite(values(k)) || (inertia ? values(k) < 0.0 : values(k) == 0.0)) {
        file.fail(file.line(key), key + "[" + std::to_string(k) + "] = " + detail::format_number(values(k)) +
                                      (inertia ? ": an inertia is finite and >= 0" : ": a gear ratio is finite and != 0"));
      }
      (inertia ? params.Ir : params.gr)[k] = values(k);
    }
  }
}

/// controller.model.*: the model the loop is designed with (Scene::design), stated whole (m, l, delta, g required; the
/// links as built where given, else the rods of m and l; a dc_motor's gain required; a fixed
/// chain's Ir and gr where given, else no rotor and gr 1); what does not apply is refused.
template <class Model>
void load_design_model(const SceneFile& file, const Scene<Model>& scene, ParamsOf<Model>& model, double& gain) {
  const int n = dof_of<Model>();
  bool fixed = false;
  if constexpr (is_runtime<Model>) fixed = Model::fixed_pivot();
  model = ParamsOf<Model>{};
  auto values = [&](const std::string& name, Eigen::Index count) { return numbers_of(file, "controller.model." + name, count); };
  for (const std::string name : {"m", "l", "delta", "g"}) {
    if (!file.has("controller.model." + name)) {
      file.fail(file.line("controller.model.m"), "controller.model.* states the loop's whole design model: add controller.model." + name);
    }
  }
  const Eigen::VectorXd m = values("m", n), l = values("l", n), delta = values("delta", n);
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (!(l(i) >= 0.0 && std::isfinite(l(i)))) file.fail(file.line("controller.model.l"), "`controller.model.l` must be finite and >= 0");
    model.m[k] = m(i);
    model.l[k] = l(i);
    model.delta[k] = delta(i);
  }
  model.g = values("g", 1)(0);
  for (const std::string name : {"com", "J", "J_axial", "tip"}) {
    const std::string key = "controller.model." + name;
    if (!file.has(key)) continue;
    if ((fixed && (name == "J_axial" || name == "tip")) || !has_links_as_built<Model>) {
      file.fail(file.line(key), "`" + key + "` does not apply to model " + name_of<Model>());
    }
    if constexpr (has_links_as_built<Model>) {
      const Eigen::VectorXd v = values(name, n);
      auto& field = name == "com" ? model.com : name == "J" ? model.J : name == "J_axial" ? model.J_axial : model.tip;
      for (int i = 0; i < n; ++i) field[static_cast<std::size_t>(i)] = v(i);
    }
  }
  if (file.has("controller.model.gain") != scene.motor) {
    file.fail(file.line(scene.motor ? "controller.model.m" : "controller.model.gain"),
              scene.motor ? "controller.model.* of a dc_motor scene needs controller.model.gain (N or N m per volt)"
                          : "`controller.model.gain` applies to actuator = dc_motor only");
  }
  if (scene.motor) {
    gain = file.number("controller.model.gain");
    if (!(std::isfinite(gain) && gain > 0.0)) file.fail(file.line("controller.model.gain"), "`controller.model.gain` must be > 0");
  }
  for (const char* key : {"controller.model.Ir", "controller.model.gr"}) {
    if (file.has(key) && !fixed) file.fail(file.line(key), std::string("`") + key + "` applies to a fixed chain only");
  }
  if constexpr (is_runtime<Model>) {
    if (fixed) load_rotors(file, "controller.model.", Model::inputs(), model);
  }
}

template <class Model>
void load_mpc(const SceneFile& file, Scene<Model>& scene) {
  const int n = dof_of<Model>(), nx = 2 * n;
  if (scene.settings.acceleration) file.fail(file.line("controller"), "controller = mpc with actuator = acceleration is not supported");
  if (!(has_derivatives<Model> && provides<Model>(Feature::derivatives))) {
    file.fail(file.line("controller"), "controller = mpc needs the model's forward_dynamics_derivatives: regenerate its header");
  }
  if constexpr (is_runtime<Model>) {  // a fixed chain: one driven joint, u its torque
    if (Model::fixed_pivot() && Model::inputs() != 1) {
      file.fail(file.line("controller"), std::string("controller = mpc drives one joint; model ") + name_of<Model>() + " has " +
                                             std::to_string(Model::inputs()) + " inputs");
    }
  }
  MpcProblem p;
  auto list = [&](const std::string& key, Eigen::Index count) {
    const Eigen::VectorXd values = numbers_of(file, key, count);
    return std::vector<double>(values.data(), values.data() + count);
  };
  auto whole = [&](const std::string& key) {
    const long value = file.integer(key);  // the range: cfg_rules.hpp
    return static_cast<int>(value);
  };
  p.period = file.number("controller.period");
  p.horizon = whole("controller.horizon");
  p.substeps = whole("controller.substeps");
  p.Q = list("controller.q", nx * nx);
  p.R = list("controller.r", 1);
  p.P = list("controller.p", nx * nx);
  p.reference = list("controller.reference", nx);
  p.u_min = file.number("controller.u_min");
  p.u_max = file.number("controller.u_max");
  auto bounds = [&](const std::string& key, std::vector<int>& index, std::vector<double>& lo, std::vector<double>& hi) {
    if (!file.has(key)) return;
    const std::vector<double> values = file.numbers(key);
    if (values.empty() || values.size() % 3 != 0) file.fail(file.line(key), "`" + key + "` needs 3 numbers a bound (index min max)");
    for (std::size_t i = 0; i < values.size(); i += 3) {
      const double at = values[i];
      if (!(at == std::floor(at) && at >= 0 && at < nx)) {
        file.fail(file.line(key), "`" + key + "`: the index " + detail::format_number(at) + " is not one of 0.." + std::to_string(nx - 1));
      }
      index.push_back(static_cast<int>(at));
      lo.push_back(values[i + 1]);
      hi.push_back(values[i + 2]);
    }
  };
  bounds("controller.bounds", p.hard_index, p.hard_min, p.hard_max);
  bounds("controller.soft_bounds", p.soft_index, p.soft_min, p.soft_max);
  if (!p.soft_index.empty()) {
    const std::vector<double> penalty = list("controller.soft_penalty", 2);
    p.soft_linear.assign(p.soft_index.size(), penalty[0]);
    p.soft_quadratic.assign(p.soft_index.size(), penalty[1]);
  }
  const std::string& mode = file.text("controller.mode");
  if (mode != "rti" && mode != "converged") {
    file.fail(file.line("controller.mode"), "controller.mode must be `rti` or `converged`, got `" + detail::abbreviate(mode) + "`");
  }
  p.converged = mode == "converged";
  p.sqp_iterations = whole("controller.iterations");
  p.cold_iterations = whole("controller.cold_iterations");
  p.qp_iterations = whole("controller.qp_iterations");
  p.sqp_tolerance = file.number("controller.sqp_tolerance");
  p.qp_tolerance = file.number("controller.qp_tolerance");
  if (file.has("controller.barrier")) p.barrier = file.number("controller.barrier");  // absent: the interior point
  if (file.has("controller.sensitivities")) {  // absent: exact
    const std::string& sensitivities = file.text("controller.sensitivities");
    if (sensitivities != "exact" && sensitivities != "frozen" && sensitivities != "shifted") {
      file.fail(file.line("controller.sensitivities"), "controller.sensitivities must be `exact`, `frozen` or `shifted`, got `" +
                                                           detail::abbreviate(sensitivities) + "`");
    }
    p.frozen = sensitivities == "frozen" || sensitivities == "shifted";
    p.shifted = sensitivities == "shifted";
  }
  if (p.converged && (p.barrier > 0.0 || p.frozen)) {
    file.fail(file.line("controller.mode"), "controller.barrier and controller.sensitivities = frozen or shifted are for mode rti");
  }
  if (!(std::isfinite(p.period) && p.period > 0.0)) file.fail(file.line("controller.period"), "controller.period must be > 0");
  for (const auto* vector : {&p.Q, &p.R, &p.P, &p.reference, &p.hard_min, &p.hard_max, &p.soft_min, &p.soft_max}) {
    for (const double v : *vector) {
      if (!std::isfinite(v)) file.fail(file.line("controller"), "controller = mpc: its numbers must be finite");
    }
  }
  // The model the MPC predicts with: the loop's design model (Scene::design).
  auto mpc = std::make_shared<MpcController<Model>>(std::move(p), scene.design, scene.design_gain);
  if (mpc->check() != 0) {
    file.fail(file.line("controller"), "controller = mpc: its settings describe no problem (sizes, bounds, weights or budgets)");
  }
  const double b = mpc_input_scale(scene);
  scene.settings.input = Input::sampled(mpc->problem().period, [mpc, b](double, const Eigen::VectorXd& x) { return b * (*mpc)(x); });
  scene.mpc = std::move(mpc);
}

/// `input.amplitude` for `input2.amplitude` (`input` for `input2`: a fixed chain's further inputs,
/// k >= 2, take the keys of `input`); "" for any other key.
inline std::string numbered_input_key(const std::string& key) {
  if (key.rfind("input", 0) != 0) return "";
  std::size_t end = 5;
  while (end < key.size() && key[end] >= '0' && key[end] <= '9') ++end;
  if (end == 5 || key[5] == '0' || (end == 6 && key[5] == '1') || end > 8) return "";
  if (end < key.size() && key[end] != '.') return "";
  return "input" + key.substr(end);
}

/// The input of the keys `prefix` and `prefix.*` (`input`, or `input2`, … for a fixed chain's
/// further inputs), its amplitudes times b. Only the fields the kind uses are required.
Input input_of(const SceneFile& file, const std::string& prefix, double b);

/// A fixed chain's keys (a model loaded at run time with type fixed): `joints` must be the
/// model's, `Ir` and `gr` (optional, one per input: default no rotor, gr 1) into the parameters,
/// `input2` … `inputM` (required, M the model's inputs) into settings.more_inputs, `coulomb_law`
/// and `coulomb_gain` (DFKI's atan law), the inputs' sign of the rig's positive sense, and
/// `controller` = lqr | gain (u = −K (x − x_eq) per input; controller = mpc: load_mpc).
template <class Model>
void load_fixed(const SceneFile& file, Scene<Model>& scene) {
  const int m = Model::inputs();
  const std::vector<double> joints = file.numbers("joints");
  bool same = joints.size() == static_cast<std::size_t>(m);
  for (int k = 0; same && k < m; ++k) same = joints[static_cast<std::size_t>(k)] == Model::joints()[k];
  if (!same) {
    std::string model_joints;
    for (int k = 0; k < m; ++k) model_joints += (k ? " " : "") + std::to_string(Model::joints()[k]);
    file.fail(file.line("joints"), "joints = " + detail::abbreviate(file.text("joints")) + ", model " + name_of<Model>() +
                                       " is driven at joints " + model_joints);
  }
  load_rotors(file, "", m, scene.params);
  for (const char* key : {"actuator", "sensors.measured"}) {
    if (file.has(key)) file.fail(file.line(key), std::string("`") + key + "` is not supported for a fixed chain in the simulator yet");
  }
  if (file.has("coulomb_law")) {
    const std::string& law = file.text("coulomb_law");
    if (law != "tanh" && law != "atan") {
      file.fail(file.line("coulomb_law"), "coulomb_law must be `tanh` or `atan`, got `" + detail::abbreviate(law) + "`");
    }
    scene.settings.coulomb_atan = law == "atan";
  }
  if (file.has("coulomb_gain")) scene.settings.coulomb_gain = file.number("coulomb_gain");
  // The inputs are torques in the rig's positive sense (the CSV's u1..um too); the model's B is in ipgen's.
  scene.settings.input_sign = scene.coordinates.counterclockwise ? -1.0 : 1.0;
  for (int k = 2; k <= m; ++k) scene.settings.more_inputs.push_back(input_of(file, "input" + std::to_string(k), 1.0));
  if (file.has("input" + std::to_string(m + 1))) {
    file.fail(file.line("input" + std::to_string(m + 1)), "input" + std::to_string(m + 1) + ": model " + name_of<Model>() +
                                                                " has " + std::to_string(m) + " input(s)");
  }
  if (!file.has("controller") || file.text("controller") == "mpc") return;  // mpc: load_mpc
  // u = −K (x − x_eq): K m × 2n row-major, every input its row, in the rig's coordinates and sense.
  if (file.text("controller") != "lqr" && file.text("controller") != "gain") {
    file.fail(file.line("controller"), "controller must be `lqr` or `gain`, got `" + detail::abbreviate(file.text("controller")) + "`");
  }
  for (int k = 1; k <= m; ++k) {
    const std::string key = k == 1 ? "input" : "input" + std::to_string(k);
    if (file.text(key) != "zero") file.fail(file.line(key), "a controller sets u: " + key + " must be `zero`");
  }
  const Eigen::Index size = 2 * dof_of<Model>();
  const Eigen::VectorXd gain = numbers_of(file, "controller.gain", m * size);
  const Eigen::VectorXd equilibrium = scene.coordinates.to_canonical(numbers_of(file, "controller.equilibrium", size));
  Eigen::VectorXd saturation = Eigen::VectorXd::Constant(m, std::numeric_limits<double>::infinity());
  if (file.has("controller.saturation")) {
    const auto values = file.numbers("controller.saturation");
    if (values.size() != 1 && values.size() != static_cast<std::size_t>(m)) {
      file.fail(file.line("controller.saturation"), "`controller.saturation` has " + std::to_string(values.size()) +
                                                        " values, expected 1 or " + std::to_string(m) + " (one per input)");
    }
    for (int k = 0; k < m; ++k) saturation(k) = values[values.size() == 1 ? 0 : static_cast<std::size_t>(k)];
  }
  scene.settings.more_inputs.clear();
  for (int k = 0; k < m; ++k) {
    LinearFeedback row;
    row.gain = scene.coordinates.gain_to_canonical(gain.segment(k * size, size));
    row.equilibrium = equilibrium;
    row.saturation = saturation(k);
    if (file.has("controller.period")) row.period = file.number("controller.period");
    row.given = file.text("controller") == "gain";
    const auto problems = row.problems(static_cast<int>(size));
    if (!problems.empty()) file.fail(0, problems.front());
    if (k == 0) scene.settings.input = row.input();
    else scene.settings.more_inputs.push_back(row.input());
    scene.fixed_controllers.push_back(std::move(row));
  }
}

/// Builds a Scene for `Model` from a parsed file. Throws SceneError when a key is unknown or
/// missing, a value does not parse, a list has the wrong length, or the file was written for a
/// different model (name, type or link count). Parameter and setting ranges are left to
/// ipsim::validate so that their messages are the same as for the C++ API.
template <class Model>
Scene<Model> load(const SceneFile& file) {
  static const std::set<std::string> known(std::begin(cfg::kKeys), std::end(cfg::kKeys));
  for (const auto& key : file.keys()) {
    if (known.count(key) == 0 && known.count(numbered_input_key(key)) == 0) {
      file.fail(file.line(key), "unknown key `" + detail::abbreviate(key) + "`");
    }
  }
  check_rules(file);

  if (file.text("model") != name_of<Model>()) {
    file.fail(file.line("model"), "scene is for model `" + detail::abbreviate(file.text("model")) + "`, this simulator is built for `" +
                                      name_of<Model>() + "`");
  }
  if (file.text("type") != type_of<Model>()) {
    file.fail(file.line("type"), "type is `" + detail::abbreviate(file.text("type")) + "`, model " + name_of<Model>() + " is " + type_of<Model>());
  }
  if (file.integer("links") != links_of<Model>()) {
    file.fail(file.line("links"), "links = " + detail::abbreviate(file.text("links")) + ", model " + name_of<Model>() + " has " +
                                      std::to_string(links_of<Model>()));
  }

  if (file.has("inertia")) {
    const std::string& inertia = file.text("inertia");
    if (inertia != "pivot" && inertia != "full") {
      file.fail(file.line("inertia"), "inertia must be `pivot` or `full`, got `" + detail::abbreviate(inertia) + "`");
    }
    // Classical models have no inertia variant; the Python side writes the default anyway.
    if (!inertia_of<Model>().empty() && inertia != inertia_of<Model>()) {
      file.fail(file.line("inertia"), "inertia is `" + inertia + "`, model " + name_of<Model>() + " was generated with `" +
                                          std::string(inertia_of<Model>()) + "`");
    }
  }

  // Every per-coordinate list has one entry for the base and one per link.
  auto list = [&](const std::string& key) {
    const auto values = file.numbers(key);
    if (values.size() != static_cast<std::size_t>(dof_of<Model>())) {
      file.fail(file.line(key), "`" + key + "` has " + std::to_string(values.size()) + " values, model " +
                                    name_of<Model>() + " needs " + std::to_string(dof_of<Model>()) + " (base + " +
                                    std::to_string(links_of<Model>()) + " links)");
    }
    return values;
  };

  Scene<Model> scene;
  scene.name = file.has("name") ? file.text("name") : file.origin();
  if (file.has("energy")) {
    const std::string& energy = file.text("energy");
    if (energy != "true" && energy != "false") {
      file.fail(file.line("energy"), "energy must be `true` or `false`, got `" + detail::abbreviate(energy) + "`");
    }
    scene.energy = energy == "true";
    scene.settings.energy_ledger = scene.energy;
  }
  // The rig's coordinates (optional; default ipgen's).
  auto convention = [&](const char* key, const char* usual, const char* other) {
    if (!file.has(key)) return false;
    const std::string& value = file.text(key);
    if (value != usual && value != other) {
      file.fail(file.line(key), std::string(key) + " must be `" + usual + "` or `" + other + "`, got `" +
                                    detail::abbreviate(value) + "`");
    }
    return value == other;
  };
  scene.coordinates.relative = convention("angles", "absolute", "relative");
  scene.coordinates.hanging = convention("zero", "upright", "hanging");
  scene.coordinates.counterclockwise = convention("positive", "clockwise", "counterclockwise");
  if constexpr (is_runtime<Model>) {
    if (Model::fixed_pivot()) scene.coordinates.base = 0;  // no base: link 1 is coordinate 0
  }
  const auto m = list("m");
  const auto l = list("l");
  const auto delta = list("delta");
  const auto theta = list("theta");
  const auto dtheta = list("dtheta");
  for (int i = 0; i < dof_of<Model>(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    scene.params.m[k] = m[k];
    scene.params.l[k] = l[k];
    scene.params.delta[k] = delta[k];
    scene.settings.theta(i) = theta[k];
    scene.settings.dtheta(i) = dtheta[k];
  }
  if (!scene.coordinates.canonical()) {  // the rig's initial state -> ipgen's
    Eigen::VectorXd start(2 * dof_of<Model>());
    start << scene.settings.theta, scene.settings.dtheta;
    const Eigen::VectorXd x = scene.coordinates.to_canonical(start);
    scene.settings.theta = x.head(dof_of<Model>());
    scene.settings.dtheta = x.tail(dof_of<Model>());
  }
  scene.params.g = file.number("g");
  // The links as built (optional; absent: the homogeneous rods, the Params defaults).
  for (const char* key : {"com", "J", "J_axial", "tip"}) {
    if (!file.has(key)) continue;
    if constexpr (has_links_as_built<Model>) {
      const auto values = list(key);
      auto& field = std::string_view(key) == "com"       ? scene.params.com
                    : std::string_view(key) == "J"       ? scene.params.J
                    : std::string_view(key) == "J_axial" ? scene.params.J_axial
                                                         : scene.params.tip;
      for (int i = 0; i < dof_of<Model>(); ++i) field[static_cast<std::size_t>(i)] = values[static_cast<std::size_t>(i)];
    } else {
      file.fail(file.line(key), std::string("`") + key + "` needs a model generated with the links as built (regenerate it)");
    }
  }

  if (file.has("actuator")) {
    const std::string& actuator = file.text("actuator");
    if (actuator != "direct" && actuator != "dc_motor" && actuator != "acceleration") {
      file.fail(file.line("actuator"),
                "actuator must be `direct` or `dc_motor` (or `acceleration`), got `" + detail::abbreviate(actuator) + "`");
    }
    scene.motor = actuator == "dc_motor";
    scene.settings.acceleration = actuator == "acceleration";
    if (scene.settings.acceleration && !provides<Model>(Feature::mass_and_bias)) {
      file.fail(file.line("actuator"), "actuator = acceleration needs the model's mass_matrix and bias: regenerate its header");
    }
    if (scene.motor) {
      scene.input_gain = file.number("actuator.gain");
      if (!(std::isfinite(scene.input_gain) && scene.input_gain > 0.0)) {
        file.fail(file.line("actuator.gain"), "actuator.gain must be a finite number > 0 (N or N m per volt)");
      }
    }
  }
  if (!scene.motor && file.has("actuator.gain")) {  // read for a motor only: any other drive ignored it
    file.fail(file.line("actuator.gain"), "actuator.gain applies to actuator = dc_motor only");
  }
  const double b = scene.input_gain;
  if (file.has("coulomb")) {
    const auto coulomb = list("coulomb");
    for (int i = 0; i < dof_of<Model>(); ++i) scene.settings.coulomb(i) = coulomb[static_cast<std::size_t>(i)];
  }
  if (file.has("coulomb_speed")) scene.settings.coulomb_speed = file.number("coulomb_speed");

  Settings<Model>& s = scene.settings;
  const std::string& method = file.text("method");
  const auto parsed_method = parse_method(method);
  if (!parsed_method) file.fail(file.line("method"), "method must be " + method_names() + ", got `" + detail::abbreviate(method) + "`");
  s.method = *parsed_method;
  if (file.has("jacobian")) {
    const std::string& jacobian = file.text("jacobian");
    const auto parsed_jacobian = parse_jacobian(jacobian);
    if (!parsed_jacobian) file.fail(file.line("jacobian"), "jacobian must be `exact` or `dq`, got `" + detail::abbreviate(jacobian) + "`");
    s.jacobian = *parsed_jacobian;
  }
  if (file.has("step")) s.step = file.number("step");
  s.rtol = file.number("rtol");
  s.atol = file.number("atol");
  s.max_steps = file.integer("max_steps");
  s.t_end = file.number("t_end");
  s.sample = file.number("sample");

  const std::string& kind = file.text("input");
  s.input = input_of(file, "input", b);
  if constexpr (is_runtime<Model>) {
    if (Model::fixed_pivot()) load_fixed<Model>(file, scene);
  }
  if (file.has("limits.travel")) {
    scene.travel = file.number("limits.travel");  // > 0: cfg_rules.hpp
  }
  // The loop's design model (Scene::design): the plant's, or the one controller.model.* states.
  scene.design = scene.params;
  scene.design_gain = scene.input_gain;
  bool stated = false;
  for (const auto& key : file.keys()) stated = stated || key.rfind("controller.model.", 0) == 0;
  if (stated) load_design_model<Model>(file, scene, scene.design, scene.design_gain);
  if (file.has("controller") && scene.fixed_controllers.empty() && file.text("controller") == "mpc") {
    if (kind != "zero") {
      file.fail(file.line("controller"), "a controller sets u: input must be `zero`, got `" + kind + "`");
    }
    load_mpc<Model>(file, scene);
  } else if (file.has("controller") && scene.fixed_controllers.empty()) {
    if (file.text("controller") != "lqr" && file.text("controller") != "gain") {
      file.fail(file.line("controller"),
                "controller must be `lqr`, `gain` or `mpc`, got `" + detail::abbreviate(file.text("controller")) + "`");
    }
    if (kind != "zero") {
      file.fail(file.line("controller"), "a controller sets u: input must be `zero`, got `" + kind + "`");
    }
    auto state_list = [&](const std::string& key) {
      const auto values = file.numbers(key);
      if (values.size() != static_cast<std::size_t>(2 * dof_of<Model>())) {
        file.fail(file.line(key), "`" + key + "` has " + std::to_string(values.size()) + " values, model " +
                                      name_of<Model>() + " needs 2·kDof = " + std::to_string(2 * dof_of<Model>()));
      }
      return Eigen::Map<const Eigen::VectorXd>(values.data(), static_cast<Eigen::Index>(values.size())).eval();
    };
    LinearFeedback controller;
    // In the rig's coordinates in the file: u = −K_user (x_user − x_eq,user) = −(K_user P) (x − x_eq).
    controller.gain = scene.coordinates.gain_to_canonical(state_list("controller.gain"));
    controller.equilibrium = scene.coordinates.to_canonical(state_list("controller.equilibrium"));
    if (file.has("controller.saturation")) controller.saturation = file.number("controller.saturation");
    if (file.has("controller.period")) controller.period = file.number("controller.period");
    controller.given = file.text("controller") == "gain";
    const auto problems = controller.problems(2 * dof_of<Model>());
    if (!problems.empty()) file.fail(0, problems.front());
    controller.gain *= b;  // volts per unit of state -> N or N m (b = 1 for a direct drive)
    controller.saturation *= b;
    s.input = controller.input();
    scene.controller = std::move(controller);
  }
  if (file.has("swingup")) load_swingup<Model>(file, scene, kind);
  load_drive<Model>(file, scene);
  return scene;
}

}  // namespace ipsim::scene

#if IPSIM_DEFINITIONS
namespace ipsim::scene {

IPSIM_DECL SceneFile SceneFile::read(const std::string& path) {
  std::ifstream stream(path);
  if (!stream) throw SceneError(path + ": cannot open scene file");
  return parse(stream, path);
}

IPSIM_DECL SceneFile SceneFile::parse(std::istream& stream, std::string origin) {
  SceneFile file;
  file.origin_ = std::move(origin);
  std::string line;
  for (int number = 1; std::getline(stream, line); ++number) {
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    if (trim(line).empty()) continue;
    const auto equals = line.find('=');
    if (equals == std::string::npos) file.fail(number, "expected `key = value`, got `" + detail::abbreviate(trim(line)) + "`");
    const std::string key = trim(line.substr(0, equals));
    const std::string value = trim(line.substr(equals + 1));
    if (key.empty()) file.fail(number, "missing key before `=`");
    if (value.empty()) file.fail(number, "key `" + detail::abbreviate(key) + "` has no value");
    if (const auto seen = file.entries_.find(key); seen != file.entries_.end()) {
      file.fail(number, "key `" + detail::abbreviate(key) + "` repeated (first on line " + std::to_string(seen->second.line) + ")");
    }
    file.entries_.emplace(key, Entry{value, number});
  }
  return file;
}

IPSIM_DECL std::vector<std::string> SceneFile::keys() const {
  std::vector<std::string> all;
  for (const auto& entry : entries_) all.push_back(entry.first);
  return all;
}

IPSIM_DECL int SceneFile::line(const std::string& key) const {
  const auto it = entries_.find(key);
  return it == entries_.end() ? 0 : it->second.line;
}

IPSIM_DECL double SceneFile::number(const std::string& key) const {
  const auto values = numbers(key);
  if (values.size() != 1) fail(line(key), "`" + key + "` must be one number, got " + std::to_string(values.size()));
  return values.front();
}

IPSIM_DECL long SceneFile::integer(const std::string& key) const {
  const std::string& value = text(key);
  errno = 0;
  char* end = nullptr;
  const long parsed = std::strtol(value.c_str(), &end, 10);
  if (end == value.c_str() || *end != '\0' || errno == ERANGE) {
    fail(line(key), "`" + key + "` must be an integer, got `" + detail::abbreviate(value) + "`");
  }
  return parsed;
}

IPSIM_DECL std::vector<double> SceneFile::numbers(const std::string& key) const {
  std::istringstream words(text(key));
  std::vector<double> values;
  for (std::string word; words >> word;) {
    errno = 0;
    char* end = nullptr;
    const double parsed = std::strtod(word.c_str(), &end);
    // ERANGE on underflow gives a subnormal or zero, the double ipgen wrote: accepted.
    if (end == word.c_str() || *end != '\0' || (errno == ERANGE && std::abs(parsed) > 1.0)) {
      fail(line(key), "`" + key + "`: `" + detail::abbreviate(word) + "` is not a number");
    }
    values.push_back(parsed);
  }
  return values;
}

IPSIM_DECL void SceneFile::fail(int line_number, const std::string& message) const {
  throw SceneError(detail::abbreviate(origin_, kMessagePathChars) + (line_number > 0 ? ":" + std::to_string(line_number) : std::string()) + ": " + message);
}

IPSIM_DECL const SceneFile::Entry& SceneFile::entry(const std::string& key) const {
  const auto it = entries_.find(key);
  if (it == entries_.end()) fail(0, "missing key `" + key + "`");
  return it->second;
}

IPSIM_DECL std::string SceneFile::trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r") - first + 1);
}

}  // namespace ipsim::scene
#endif  // IPSIM_DEFINITIONS

#if IPSIM_DEFINITIONS
namespace ipsim::scene {

IPSIM_DECL void check_rules(const SceneFile& file) {
  // A fixed chain's J may be negative (identified values): validate() asks J + m com² > 0 of it.
  const bool fixed = file.has("type") && file.text("type") == "fixed";
  for (const cfg::Rule& rule : cfg::kRules) {
    if (!file.has(rule.key) || (fixed && std::string_view(rule.key) == "J")) continue;
    const std::vector<double> values = file.numbers(rule.key);
    for (std::size_t i = 0; i < values.size(); ++i) {
      if (!cfg::admits(rule, values[i])) {
        const std::string entry = values.size() > 1 ? std::string(rule.key) + "[" + std::to_string(i) + "]" : rule.key;
        file.fail(file.line(rule.key), entry + " = " + detail::format_number(values[i]) + " must be " + rule.says +
                                           " (the rule of " + rule.source + ")");
      }
    }
  }
}

IPSIM_DECL Eigen::VectorXd numbers_of(const SceneFile& file, const std::string& key, Eigen::Index count) {
  const auto values = file.numbers(key);
  if (static_cast<Eigen::Index>(values.size()) != count) {
    file.fail(file.line(key), "`" + key + "` has " + std::to_string(values.size()) + " values, expected " + std::to_string(count));
  }
  return Eigen::Map<const Eigen::VectorXd>(values.data(), count).eval();
}

IPSIM_DECL Input input_of(const SceneFile& file, const std::string& prefix, double b) {
  const std::string& kind = file.text(prefix);
  auto key = [&](const char* field) { return prefix + "." + field; };
  if (kind == "zero") return Input::zero();
  if (kind == "constant") return Input::constant(b * file.number(key("amplitude")));
  if (kind == "pulse") return Input::pulse(b * file.number(key("amplitude")), file.number(key("start")), file.number(key("duration")));
  if (kind == "step") return Input::step(b * file.number(key("amplitude")), file.number(key("time")));
  if (kind == "sine") {
    return Input::sine(b * file.number(key("amplitude")), file.number(key("frequency")),
                       file.has(key("phase")) ? file.number(key("phase")) : 0.0);
  }
  if (kind == "chirp") {
    const std::string sweep = file.has(key("sweep")) ? file.text(key("sweep")) : "linear";
    if (sweep != "linear" && sweep != "logarithmic") {
      file.fail(file.line(key("sweep")), key("sweep") + " must be `linear` or `logarithmic`, got `" + detail::abbreviate(sweep) + "`");
    }
    return Input::chirp(b * file.number(key("amplitude")), file.number(key("f0")), file.number(key("f1")),
                        file.number(key("duration")), file.has(key("start")) ? file.number(key("start")) : 0.0,
                        sweep == "logarithmic");
  }
  if (kind == "multisine") {
    return Input::multisine(b * file.number(key("amplitude")), file.numbers(key("frequencies")), file.numbers(key("phases")),
                            file.number(key("scale")));
  }
  file.fail(file.line(prefix), prefix + " must be zero, constant, pulse, step, sine, chirp or multisine, got `" +
                                   detail::abbreviate(kind) + "`");
}

IPSIM_DECL Eigen::MatrixXd matrix_of(const SceneFile& file, const std::string& key, Eigen::Index rows, Eigen::Index cols) {
  const Eigen::VectorXd values = numbers_of(file, key, rows * cols);
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(values.data(), rows, cols);
}

}  // namespace ipsim::scene
#endif  // IPSIM_DEFINITIONS
