// simulate_<model>: runs a resolved scene file (.cfg) with ipsim and writes the trajectory as CSV.
//
// Built two ways from this one file:
//  - compiled once for every model, -DIPSIM_RUNTIME_MODEL (ipsim/runtime_model.hpp): the model
//    comes through the C model interface (ipgen_model.h), either a model library loaded with
//    --model LIB (`ipgen run`: ipsim-simulate) or the model's adapter linked in (CMake's
//    ipgen_add_runtime_simulator: simulate_<name> links NAME_model.c to the compiled program);
//  - per model, against its C++ header (CMake's ipgen_add_simulator, for a program of one's own):
//    -DIPGEN_MODEL_HEADER="cdip.hpp" -DIPGEN_MODEL=ipgen::cdip::Model.
//
// Usage: simulate_<model> SCENE.cfg [--csv OUT.csv] [--method M] [--jacobian exact|dq] [--rtol X]
//                          [--atol X] [--step X] [--t-end X] [--sample X] [--max-steps N] [--energy]
//                          [--force] [--check]
//   M: bdf, adams, adams-fixed-point, erk-dp5, erk-fehlberg8 or rk4 (rk4 needs a step).
//   An existing OUT.csv is replaced only if it is a CSV this simulator wrote (its first line is
//   the header `t,theta0,...,dtheta0,...`), or with --force; never the scene file itself. The CSV
//   is written to a temporary file next to it and renamed into place. --check validates the scene
//   and options and exits without integrating or writing.
// A scene with a controller adds a column u (the input applied from each sample on) to the CSV (so
// does an input = chirp or multisine, without the rest) and
// states the gain, the closed-loop poles of the linearised model and the largest |u|; a closed
// loop that leaves the controller's region (a link more than --divergence-angle, default π/2,
// from the equilibrium: ipsim/divergence.hpp) is stopped there, its CSV so far kept, exit code 3.
// A swing-up scene (swingup = energy | trajectory: ipsim/swingup.hpp) adds the columns u and phase
// (swing, track or hold), checks divergence in the hold phase (exit 3) and a tracked plan in the
// track phase (a link more than --divergence-angle from it: exit 5), and ends the run
// `swingup.hold` s into the hold phase (or at t_end).
// Samples are written to the temporary CSV as the integration reaches them (memory stays flat);
// SIGINT, SIGTERM, SIGHUP and SIGXFSZ remove the temporary file, then end the process by the same
// signal (exit status 128 + signal in a shell).
// Exit codes: 0 success, 1 integration failure or write error, 2 bad command line, scene,
// parameters, settings or CSV path (all reported before integrating), 3 closed loop diverged,
// 4 the base left the scene's travel (limits.travel: |theta0| beyond it at a sample; ipsim/travel.hpp),
// 5 a swing-up lost its plan (ipsim/swingup.hpp).
#if defined(IPSIM_RUNTIME_MODEL)
#include "ipsim/runtime_model.hpp"
#elif defined(IPGEN_MODEL_HEADER)
#include IPGEN_MODEL_HEADER
#else
#error "compile with -DIPGEN_MODEL_HEADER=\"name.hpp\" -DIPGEN_MODEL=ipgen::name::Model, or -DIPSIM_RUNTIME_MODEL"
#endif

#include <array>
#include <chrono>
#include <cerrno>
#include <climits>
#include <memory>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

#include "ipsim/ipsim.hpp"
#include "ipsim/scene.hpp"

namespace {

#if defined(IPSIM_RUNTIME_MODEL)
// Compiled once for every model: the model library named by --model is loaded at run time.
using Model = ipsim::RuntimeModel;
constexpr bool kRuntimeModel = true;
#else
using Model = IPGEN_MODEL;
constexpr bool kRuntimeModel = false;
#endif
/// The model's degrees of freedom (base + links).
int dof() { return ipsim::dof_of<Model>(); }

/// Bad command line, scene or parameters: reported on one line, exit code 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Options {
  std::string scene_path;
  std::string csv_path;  ///< empty: the scene path with its extension replaced by .csv
  std::string model_path;  ///< the model library to load (compiled once: empty for the one linked in)
  bool energy = false;   ///< add T, V, W_in, E_diss columns and an energy balance to the summary
  bool force = false;    ///< replace an existing CSV even if this simulator did not write it
  bool check = false;    ///< validate the scene and options only: no integration, no CSV
  std::optional<ipsim::Method> method;
  std::optional<ipsim::Jacobian> jacobian;
  std::optional<double> rtol, atol, step, t_end, sample;
  std::optional<long> max_steps;
  /// A closed loop is stopped when a link is farther than this from the controller's equilibrium [rad].
  double divergence_angle = ipsim::DivergenceMonitor::kHalfPi;
  /// --progress: a line `progress T T_END` on stderr at most every this many seconds of wall time.
  std::optional<double> progress;
};

/// Exit code of a closed loop stopped because it diverged.
constexpr int kExitDiverged = 3;
/// Exit code of a run stopped because the base left the scene's travel (limits.travel).
constexpr int kExitTravel = 4;
/// Exit code of a swing-up stopped because a link left its plan by more than --divergence-angle.
constexpr int kExitLostPlan = 5;

constexpr const char* kUsage =
    "usage: simulate SCENE.cfg [--csv OUT.csv] [--method bdf|adams|adams-fixed-point|erk-dp5|"
    "erk-fehlberg8|rk4] [--jacobian exact|dq] [--rtol X] [--atol X] [--step X] [--t-end X] [--sample X] "
    "[--max-steps N] [--energy] [--divergence-angle RAD] [--progress S] [--force] [--check]";

/// --help: the usage line, then what the options, the scene file and the CSV hold.
constexpr const char* kHelp = R"(
Simulates a resolved scene (SCENE.cfg, written by `ipgen --scene X.toml -o DIR`) of the model this
simulator was built for and writes the trajectory as CSV.

options:
  --csv OUT.csv        output file (default: SCENE with .csv); an existing file is replaced only if
                       this simulator wrote it (its first line is a header as below), or with --force
  --method M           bdf (default), adams, adams-fixed-point, erk-dp5, erk-fehlberg8 or rk4
  --jacobian J         bdf and adams: exact (default) or dq (difference quotients)
  --rtol X, --atol X   tolerances of the adaptive methods (scene default 1e-10, 1e-12)
  --step X             rk4 only: its fixed step [s]
  --t-end X            final time [s];  --sample X: output interval [s]
  --max-steps N        integrator steps allowed between two output samples
  --energy             add the energy columns and the energy balance to the summary
  --divergence-angle RAD
                       with a controller: stop when a link is farther than RAD from the
                       controller's equilibrium (default pi/2 = 1.5708; inf: never stop)
  --progress S         write `progress T T_END` (the simulated time reached) to stderr at most
                       every S seconds of wall time (ipgen run shows it)
  --force              replace an existing file at --csv even if this simulator did not write it
  --check              validate the scene and options, integrate nothing, write nothing

CSV (one row per sample at t = k*sample and t_end, values %.17g, SI units):
  t                    time [s]
  theta0               cart position [m] (classical) or arm angle [rad] (rotary)
  theta1..thetaN       link angles [rad] from the upward vertical (absolute, clockwise positive)
  dtheta0..dthetaN     their rates [m/s or rad/s]
  kinetic,potential    T and V [J] (--energy or energy = true)
  input_work,dissipated  W_in = int u dtheta0 dt and E_diss = int 2D dt from t = 0 [J] (same;
                       actuator = acceleration: W_in = int tau dtheta0 dt, tau the base's force)
  u                    scenes with a controller, a swing-up, or input = chirp or multisine: the
                       input [N or N m; V with actuator = dc_motor; m/s^2 or rad/s^2 with
                       actuator = acceleration] applied from t on
  u1..um               a fixed chain (type fixed) with m > 1 driven joints, always: each joint's
                       torque [N m] (in the order of joints) in place of u
  y_thetaI             scenes with sensors.*: the measured value of each measured coordinate I
  hat_theta0..N, hat_dtheta0..N  and the estimate the controller sees (both at the latest
                       sampling instant; in the CSV's coordinates; docs/scenes.md)
  phase                swing-up scenes: swing, track or hold (the controller's phase from t on)
The CSV is written to a temporary file .simulate.XXXXXX beside it as the run proceeds and renamed
into place at the end: a failed or interrupted run (SIGINT, SIGTERM, SIGHUP, SIGXFSZ) leaves any
earlier file untouched and no temporary file.

SCENE.cfg: one `key = value` a line (# comments), lists space-separated, per coordinate
base first: name, model, type (classical|rotary), links, inertia (pivot|full); m [kg], l [m],
delta [kg/s or N m s], g [m/s^2]; theta, dtheta (initial state); input = zero|constant|pulse|step|sine
with input.amplitude [N or N m], input.start, input.duration, input.time [s], input.frequency [Hz],
input.phase [rad]; input = chirp with input.f0, input.f1 [Hz], input.sweep = linear|logarithmic
(and amplitude, start, duration); input = multisine with input.frequencies [Hz], input.phases [rad]
and input.scale (u = amplitude scale sum cos(2 pi f t + phase), lines computed by ipgen);
type fixed (a chain on a fixed pivot, one coordinate per link): joints (the driven joints, the
model's), Ir, gr (rotor inertia and gear ratio per input), input2 .. inputM with the keys of input
(input2.amplitude, ...): the torques at the other driven joints, in the order of joints;
limits.travel [m or rad]: stop when |theta0| exceeds it (exit status 4); t_end, sample [s], method, jacobian, rtol, atol, step, max_steps, energy
(true|false); controller = lqr or gain (either: state feedback) with controller.gain K and controller.equilibrium x_eq (2*(links+1)
numbers each, order theta0..thetaN, dtheta0..dthetaN), controller.saturation [N or N m],
controller.period [s] (u = -K (x - x_eq), clipped, sampled every period; 0 or absent: continuous);
controller = mpc (written by ipgen from a scene's [controller] kind = "mpc": ipgen_mpc.h's step every
controller.period, docs/mpc.md; ipgen's coordinates, u in the scene's unit) with controller.horizon,
controller.substeps, controller.q, controller.r, controller.p (row-major), controller.reference,
controller.u_min, controller.u_max, controller.bounds and controller.soft_bounds (index min max ...),
controller.soft_penalty, controller.mode (rti|converged), controller.iterations,
controller.cold_iterations, controller.qp_iterations, controller.sqp_tolerance, controller.qp_tolerance;
optional controller.barrier (> 0: each QP Newton steps on its log-barrier problem) and
controller.sensitivities (exact|frozen|shifted); optional controller.model.m, controller.model.l, controller.model.delta, controller.model.g,
controller.model.com, controller.model.J, controller.model.J_axial, controller.model.tip,
controller.model.gain (a motor's), controller.model.Ir, controller.model.gr (a fixed chain's): the
model the MPC predicts with (absent: the scene's; a sweep's run states the nominal scene's);
coulomb [N or N m] per coordinate and coulomb_speed [m/s or rad/s]: Coulomb friction
c tanh(w / coulomb_speed) on the rate delta acts on (its dissipated energy is in the summary); a fixed
chain: coulomb_law = atan with coulomb_gain k [s/rad] for DFKI's c atan(k w), and its inputs are
torques in the rig's sense (counterclockwise when it counts so);
actuator = dc_motor with actuator.gain b [N/V or N m/V]: amplitudes, K and saturation are in volts
and multiplied by b (the parameters are the motor-folded ones ipgen writes); actuator = acceleration:
u (amplitudes, K, saturation) is the base's acceleration [m/s^2 or rad/s^2], the links follow it.
swingup = energy|trajectory with swingup.* (written by ipgen from a scene's [swingup] table): the run
ends swingup.hold s after the hold phase begins, divergence is checked in the hold phase, and a
tracked plan (trajectory) is given up when a link is more than --divergence-angle from it (exit 5);
with controller = mpc too, the MPC catches and holds (every controller.period, a whole multiple of
the swing-up's period) instead of the hold LQR; with swingup.release_angle (energy), a hold whose
link falls past it from the caught upright gives the link back to the swing, for another catch;
with swingup.energy_step (energy), the law learns its target from the swing by steps of it (joules);
with swingup.catch_deficit and swingup.catch_base (energy), a catch also needs the link's energy at
most catch_deficit below upright's (joules) and the base within catch_base of its centre;
with swingup.tracking = mpc (trajectory), the MPC tracks the plan too, the plan its reference.
sensors.measured, sensors.resolution, sensors.noise, sensors.delay, sensors.seed, sensors.zero (where
the encoders read 0; absent: 0), estimator = exact|difference|filter|kalman|ekf with estimator.*
(with a sampled controller or swing-up): the controller sees the estimate from quantised (whole
counts from sensors.zero), noisy, delayed measurements (estimator.delay: the delay the loop is built
for, absent: sensors.delay; with estimator.predict = 1, exact or ekf: the estimate carried over it
by the model with the commands in flight; with estimator.gain_spread, ekf with a swing-up: the
filter also learns the plant's input gain over the model's, starting from that standard deviation,
estimator.gain_drift its growth per square root of a second, and the swing-up divides its input by
it; with estimator.compensate_lag = 1: the loop is built for the drive's first-order lag, actuator.lag:
it predicts with each period's lagged input and sends the command whose lagged mean is the law's,
within the law's bound; estimator.lag: the lag it is built for, absent: actuator.lag; with
estimator.noise_memory, ekf: the filter learns each measured coordinate's noise variance over that
memory in seconds and uses estimator.noise_margin times it within estimator.noise_floor and
estimator.noise_ceiling, one each per measured); actuator.noise, actuator.lag,
actuator.pulses: drive noise per sampling interval, a first-order drive, disturbance pulses
(written by ipgen from [sensors], [estimator] and [actuator]; ipsim/sensors.hpp, docs/scenes.md).

exit status: 0 success; 1 integration failure or write error (no CSV written); 2 bad command line,
scene, parameters, settings or CSV path (reported before integrating); 3 the closed loop diverged
(a link left the controller's region: the CSV up to that sample is written); 4 the base left the
scene's travel (limits.travel = X: |theta0| > X at a sample; the CSV up to it is written); 5 a
swing-up lost its plan (a link more than --divergence-angle from the planned angle while tracking:
the CSV up to that sample is written); 128 + n when ended
by signal n (the temporary file removed).
)";

using ipsim::detail::abbreviate;

/// A path for a message: abbreviated to ipsim::kMessagePathChars.
std::string shown_path(const std::string& path) { return abbreviate(path, ipsim::kMessagePathChars); }

double parse_number(const std::string& option, const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0' || errno == ERANGE) {
    throw UsageError(option + " expects a number, got `" + abbreviate(text) + "`");
  }
  return value;
}

Options parse_command_line(int argc, char** argv) {
  Options options;
  bool csv_given = false;
  std::vector<std::string> args(argv + 1, argv + argc);
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    auto value = [&]() -> const std::string& {
      if (i + 1 >= args.size()) throw UsageError(arg + " needs a value");
      return args[++i];
    };
    if (arg == "-h" || arg == "--help") {
      std::fputs(kUsage, stdout);
      std::fputs(kHelp, stdout);
      if constexpr (kRuntimeModel) {
        std::puts("\nThis simulator is compiled once for every model: --model LIB loads a model library "
                  "(`ipgen run` builds and passes it; without it, the model linked in); its CSV header is "
                  "t,theta0..N,dtheta0..N (then the optional columns).");
      } else {
        std::printf("\nThis simulator: model %s (%s, %d link%s); its CSV header is t", ipsim::name_of<Model>(),
                    ipsim::type_of<Model>(), ipsim::links_of<Model>(), ipsim::links_of<Model>() == 1 ? "" : "s");
        for (int i = 0; i < dof(); ++i) std::printf(",theta%d", i);
        for (int i = 0; i < dof(); ++i) std::printf(",dtheta%d", i);
        std::puts(" (then the optional columns).");
      }
      std::exit(0);
    } else if (arg == "--sources-digest" && kRuntimeModel && args.size() == 1) {
      // The SHA-256 of the ipsim sources this program was compiled from, as cmake/ipgen.cmake
      // computed it (IPSIM_SOURCES_DIGEST): `ipgen run` with $IPGEN_SIMULATOR compares it with its
      // own sources' before using this program. Without it (not a CMake build), "unknown".
#ifdef IPSIM_SOURCES_DIGEST
      std::puts(IPSIM_SOURCES_DIGEST);
#else
      std::puts("unknown");
#endif
      std::exit(0);
    } else if (arg == "--model" && kRuntimeModel) {
      options.model_path = value();
      if (options.model_path.empty()) throw UsageError("--model \"\" is empty: name the model library");
    } else if (arg == "--csv") {
      options.csv_path = value();
      csv_given = true;
    } else if (arg == "--method") {
      const std::string& text = value();
      options.method = ipsim::parse_method(text);
      if (!options.method) {
        throw UsageError("--method must be " + ipsim::method_names() + ", got `" + abbreviate(text) + "`");
      }
    } else if (arg == "--jacobian") {
      const std::string& text = value();
      options.jacobian = ipsim::parse_jacobian(text);
      if (!options.jacobian) throw UsageError("--jacobian must be exact or dq, got `" + abbreviate(text) + "`");
    } else if (arg == "--step") {
      options.step = parse_number(arg, value());
    } else if (arg == "--rtol") {
      options.rtol = parse_number(arg, value());
    } else if (arg == "--atol") {
      options.atol = parse_number(arg, value());
    } else if (arg == "--t-end") {
      options.t_end = parse_number(arg, value());
    } else if (arg == "--sample") {
      options.sample = parse_number(arg, value());
    } else if (arg == "--max-steps") {
      const std::string& text = value();
      errno = 0;
      char* end = nullptr;
      options.max_steps = std::strtol(text.c_str(), &end, 10);
      if (end == text.c_str() || *end != '\0' || errno == ERANGE) {
        throw UsageError("--max-steps expects an integer, got `" + abbreviate(text) + "`");
      }
    } else if (arg == "--energy") {
      options.energy = true;
    } else if (arg == "--divergence-angle") {
      options.divergence_angle = parse_number(arg, value());
      if (!(options.divergence_angle > 0.0)) {
        throw UsageError("--divergence-angle must be > 0 [rad] (inf: never stop), got `" + abbreviate(args[i]) + "`");
      }
    } else if (arg == "--progress") {
      options.progress = parse_number(arg, value());
      if (!(*options.progress > 0.0 && std::isfinite(*options.progress))) {
        throw UsageError("--progress must be a finite number of seconds > 0, got `" + abbreviate(args[i]) + "`");
      }
    } else if (arg == "--force") {
      options.force = true;
    } else if (arg == "--check") {
      options.check = true;
    } else if (arg.size() > 1 && arg[0] == '-') {
      throw UsageError("unknown option `" + abbreviate(arg) + "` (" + kUsage + ")");
    } else if (options.scene_path.empty()) {
      options.scene_path = arg;
    } else {
      throw UsageError("more than one scene file given (`" + shown_path(options.scene_path) + "` and `" +
                       abbreviate(arg) + "`)");
    }
  }
  if (options.scene_path.empty()) throw UsageError(std::string("no scene file given (") + kUsage + ")");
  if (options.csv_path.empty() && csv_given) throw UsageError("--csv \"\" is empty: name the CSV file");
  if (options.csv_path.empty()) {
    const auto slash = options.scene_path.find_last_of('/');
    const auto dot = options.scene_path.find_last_of('.');
    const bool has_extension = dot != std::string::npos && (slash == std::string::npos || dot > slash);
    options.csv_path = (has_extension ? options.scene_path.substr(0, dot) : options.scene_path) + ".csv";
  }
  return options;
}

/// The summary's energy balance: T + V at start and end, input work, dissipated energy.
template <class M>
void print_energy_balance(const ipsim::CsvSink<M>& csv, const ipsim::ParamsOf<M>& params) {
  if constexpr (ipsim::has_energy<M>) {
    const double start = ipsim::mechanical_energy<M>(params, csv.first_state());
    const double end = ipsim::mechanical_energy<M>(params, csv.last_state());
    const double work = csv.last_input_work();
    const double dissipated = csv.last_dissipated_energy();
    std::printf(" Energy: T+V %.9g J at start, %.9g J at end, input work %.9g J, dissipated %.9g J, balance error %.3g J.",
                start, end, work, dissipated, end - (start + work - dissipated));
  } else {
    (void)csv, (void)params;
  }
}

// ---------------------------------------------------------------- signals
//
// While the temporary CSV exists, SIGINT, SIGTERM, SIGHUP and SIGXFSZ (the file-size limit,
// RLIMIT_FSIZE) remove it before the process ends. The handler only calls async-signal-safe
// functions (unlink, sigaction, raise) on a path stored beforehand in a static buffer, then
// re-raises the signal with its default action, so the process ends by that signal (exit status
// 128 + signal in a shell) as it would have without the handler.

constexpr int kCleanupSignals[] = {SIGINT, SIGTERM, SIGHUP, SIGXFSZ};
char g_temporary_path[PATH_MAX + 1];
volatile std::sig_atomic_t g_temporary_set = 0;

extern "C" void remove_temporary_and_reraise(int signal_number) {
  if (g_temporary_set) ::unlink(g_temporary_path);
  struct sigaction action {};
  action.sa_handler = SIG_DFL;
  sigemptyset(&action.sa_mask);
  ::sigaction(signal_number, &action, nullptr);
  ::raise(signal_number);  // blocked while the handler runs: delivered, with the default action, on return
}

/// Installs the handler for each cleanup signal that is not ignored (a signal the parent set to
/// be ignored stays ignored: a nohup run is not ended by SIGHUP; an ignored SIGXFSZ makes the
/// write fail instead, which removes the file through ~PendingCsv), then unblocks them: a parent
/// may start the simulator with them blocked (`ipgen run` does, so that an interruption while it
/// starts the simulator waits until it holds the process to stop), and one that came meanwhile is
/// delivered now, to the handler.
void install_cleanup_handlers() {
  sigset_t cleanup;
  sigemptyset(&cleanup);
  for (const int signal_number : kCleanupSignals) {
    sigaddset(&cleanup, signal_number);
    struct sigaction current {};
    if (::sigaction(signal_number, nullptr, &current) != 0 || current.sa_handler == SIG_IGN) continue;
    struct sigaction action {};
    action.sa_handler = remove_temporary_and_reraise;
    sigemptyset(&action.sa_mask);
    for (const int other : kCleanupSignals) sigaddset(&action.sa_mask, other);  // one handler at a time
    ::sigaction(signal_number, &action, nullptr);
  }
  ::sigprocmask(SIG_UNBLOCK, &cleanup, nullptr);
}

/// Stores the temporary file's path for the handler (false if it does not fit the buffer).
bool set_signal_temporary(const std::string& path) {
  g_temporary_set = 0;
  if (path.size() > PATH_MAX) return false;
  std::memcpy(g_temporary_path, path.c_str(), path.size() + 1);
  g_temporary_set = 1;
  return true;
}

void clear_signal_temporary() { g_temporary_set = 0; }

/// True if the first line of `path` is a header this simulator writes (for any model):
/// `t,theta0,...,thetaN,dtheta0,...,dthetaN` with optional energy columns. That line is how a
/// CSV of an earlier run is told from a user's file, which is never replaced without --force.
bool written_by_simulator(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  char buffer[4096];
  if (!in.getline(buffer, sizeof buffer)) return false;
  line = buffer;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  std::vector<std::string> fields;
  for (std::size_t start = 0;;) {
    const auto comma = line.find(',', start);
    fields.push_back(line.substr(start, comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  std::size_t n = 0;  // coordinates
  while (1 + n < fields.size() && fields[1 + n] == "theta" + std::to_string(n)) ++n;
  if (n == 0 || fields[0] != "t" || fields.size() < 1 + 2 * n) return false;
  for (std::size_t i = 0; i < n; ++i) {
    if (fields[1 + n + i] != "dtheta" + std::to_string(i)) return false;
  }
  // Optional columns: the energies, then u (scenes with a controller).
  std::vector<std::string> rest(fields.begin() + static_cast<std::ptrdiff_t>(1 + 2 * n), fields.end());
  if (!rest.empty() && rest.back() == "phase") rest.pop_back();
  // The measured loop's columns (ipsim/sensors.hpp): y_theta<i>..., hat_theta<i>..., hat_dtheta<i>..., hat_gain.
  if (!rest.empty() && rest.back() == "hat_gain") rest.pop_back();
  for (const char* prefix : {"hat_dtheta", "hat_theta", "y_theta"}) {
    while (!rest.empty() && rest.back().rfind(prefix, 0) == 0) rest.pop_back();
  }
  if (!rest.empty() && rest.back() == "u") {
    rest.pop_back();
  } else if (!rest.empty() && rest.back().size() > 1 && rest.back()[0] == 'u') {  // u1..um (a fixed chain's inputs)
    const std::size_t m = rest.size() >= 2 ? std::strtoul(rest.back().c_str() + 1, nullptr, 10) : 0;
    if (m < 2 || m > rest.size()) return false;
    for (std::size_t k = 1; k <= m; ++k) {
      if (rest[rest.size() - m + k - 1] != "u" + std::to_string(k)) return false;
    }
    rest.resize(rest.size() - m);
  }
  const std::vector<std::string> energy = {"kinetic", "potential", "input_work", "dissipated"};
  return rest.empty() || rest == energy;
}

/// The CSV's destination, checked and claimed before integrating: a user's file there (or the
/// scene file itself) is refused, and a temporary file is created next to it, so that a path
/// that cannot be written is reported before the run. commit() renames the temporary file into
/// place; otherwise it is removed, leaving any earlier result untouched.
class PendingCsv {
 public:
  PendingCsv(const std::string& path, const std::string& scene_path, bool force) : path_(path) {
    const std::string shown = "--csv " + shown_path(path);
    struct stat target {};
    if (::stat(path.c_str(), &target) == 0) {
      struct stat scene {};
      if (S_ISDIR(target.st_mode)) throw UsageError(shown + " is a directory: name a file");
      // A device, FIFO or socket: the CSV replaced it by a rename (even /dev/null, as root), or
      // reading it for the simulator's header blocked.
      if (!S_ISREG(target.st_mode)) throw UsageError(shown + " is not a regular file: name a file");
      if (::stat(scene_path.c_str(), &scene) == 0 && scene.st_dev == target.st_dev && scene.st_ino == target.st_ino) {
        throw UsageError(shown + " is the scene file itself: choose another CSV path");
      }
      if (!force && !written_by_simulator(path)) {
        throw UsageError(shown + " exists and was not written by this simulator: move it away, choose another --csv, "
                                 "or pass --force");
      }
    } else if (errno != ENOENT) {
      throw UsageError("cannot write " + shown + ": " + std::strerror(errno) + "; choose another --csv");
    }
    const auto slash = path.find_last_of('/');
    const std::string directory = slash == std::string::npos ? "." : slash == 0 ? "/" : path.substr(0, slash);
    std::string name = directory + "/.simulate.XXXXXX";
    // Block the cleanup signals from before the file exists until its name is stored for the
    // handler, so that no signal can leave it behind.
    sigset_t cleanup, previous;
    sigemptyset(&cleanup);
    for (const int signal_number : kCleanupSignals) sigaddset(&cleanup, signal_number);
    ::sigprocmask(SIG_BLOCK, &cleanup, &previous);
    const int fd = ::mkstemp(name.data());
    if (fd >= 0) set_signal_temporary(name);
    const int saved_errno = errno;
    ::sigprocmask(SIG_SETMASK, &previous, nullptr);
    errno = saved_errno;
    if (fd < 0) {
      throw UsageError("cannot write " + shown + ": " + std::strerror(errno) + " (in " + shown_path(directory) +
                       "); choose another --csv");
    }
    temporary_ = name;
    const mode_t mask = ::umask(0);
    ::umask(mask);
    ::fchmod(fd, 0666 & ~mask);  // as fopen would create it
    out_ = ::fdopen(fd, "w");
    if (out_ == nullptr) {
      ::close(fd);
      throw std::runtime_error("cannot write `" + shown_path(temporary_) + "`");
    }
  }
  PendingCsv(const PendingCsv&) = delete;
  PendingCsv& operator=(const PendingCsv&) = delete;
  ~PendingCsv() {
    if (out_ != nullptr) std::fclose(out_);
    if (!temporary_.empty()) std::remove(temporary_.c_str());
    clear_signal_temporary();
  }

  std::FILE* stream() const { return out_; }

  /// Closes the temporary file and renames it to the destination.
  void commit() {
    const bool written = std::ferror(out_) == 0;
    const bool closed = std::fclose(out_) == 0;
    out_ = nullptr;
    if (!written || !closed) throw std::runtime_error("error while writing `" + shown_path(temporary_) + "`");
    if (std::rename(temporary_.c_str(), path_.c_str()) != 0) {
      throw std::runtime_error("cannot rename `" + shown_path(temporary_) + "` to `" + shown_path(path_) + "`: " +
                               std::strerror(errno));
    }
    clear_signal_temporary();  // after the rename: a signal in between finds nothing to unlink
    temporary_.clear();
  }

 private:
  std::string path_;
  std::string temporary_;
  std::FILE* out_ = nullptr;
};

/// The integrator and its counters, e.g. "CVODE BDF (exact Jacobian): 812 steps, …".
std::string describe_run(const ipsim::Settings<Model>& s, const ipsim::Statistics& st) {
  char text[512];
  switch (ipsim::family_of(s.method)) {
    case ipsim::Family::cvode: {
      const bool newton = ipsim::uses_jacobian(s.method);
      std::snprintf(text, sizeof text,
                    "CVODE %s %s rtol %g atol %g: %ld steps, %ld RHS evals, %ld Jacobian evals, %ld linear-solver RHS "
                    "evals, %ld error-test failures, %ld nonlinear iterations, %ld nonlinear convergence failures",
                    s.method == ipsim::Method::bdf ? "BDF" : "Adams",
                    !newton ? "(fixed-point iteration)"
                            : s.jacobian == ipsim::Jacobian::exact ? "(exact Jacobian)" : "(difference-quotient Jacobian)",
                    s.rtol, s.atol, st.steps, st.rhs_evals, st.jacobian_evals, st.linear_solver_rhs_evals,
                    st.error_test_failures, st.nonlinear_iterations, st.nonlinear_convergence_failures);
      break;
    }
    case ipsim::Family::erk:
      std::snprintf(text, sizeof text, "ARKODE ERKStep %s rtol %g atol %g: %ld steps, %ld RHS evals, %ld error-test failures",
                    ipsim::to_string(s.method), s.rtol, s.atol, st.steps, st.rhs_evals, st.error_test_failures);
      break;
    case ipsim::Family::rk4:
      std::snprintf(text, sizeof text, "RK4 step %g: %ld steps, %ld RHS evals", s.step, st.steps, st.rhs_evals);
      break;
  }
  return text;
}

/// The summary's controller part: gain, closed-loop poles of the linear model, largest |u|.
template <class M>
void print_controller(const ipsim::LinearFeedback& c, const ipsim::ParamsOf<M>& params, const ipsim::Result& result,
                      double volts = 0.0, const ipsim::Coordinates& coordinates = {}, bool acceleration = false) {
  // volts = b > 0 (actuator = dc_motor): K, the saturation and u are stated in volts, c holds them times b.
  // K and x_eq are stated in the scene's coordinates (c holds ipgen's).
  const double per = volts > 0.0 ? volts : 1.0;
  const Eigen::VectorXd gain = coordinates.gain_to_user(c.gain) / per;
  const Eigen::VectorXd equilibrium = coordinates.to_user(c.equilibrium);
  const std::string timing = c.period > 0.0 ? "sampled every " + ipsim::detail::format_number(c.period) + " s"
                                            : std::string("continuous");
  std::printf(" Controller: %s, %s, u = -K (x - x_eq), K = %s, x_eq = %s", c.given ? "given gain" : "LQR", timing.c_str(),
              ipsim::detail::format_values(gain.data(), gain.size()).c_str(),
              ipsim::detail::format_values(equilibrium.data(), equilibrium.size()).c_str());
  if (std::isfinite(c.saturation)) std::printf(", |u| <= %g", c.saturation / per);
  if constexpr (ipsim::has_linearize<M>) {
    const Eigen::VectorXcd poles = ipsim::closed_loop_poles<M>(params, c, acceleration);
    std::string text;
    for (Eigen::Index i = 0; i < poles.size(); ++i) {
      char pole[64];
      const double im = poles(i).imag();
      if (im == 0.0) std::snprintf(pole, sizeof pole, "%.6g", poles(i).real());
      else std::snprintf(pole, sizeof pole, "%.6g%c%.6gi", poles(i).real(), im < 0 ? '-' : '+', std::abs(im));
      text += (i == 0 ? "" : ", ") + std::string(pole);
    }
    std::printf("; closed-loop poles of the linear model [1/s]: %s", text.c_str());
  } else {
    (void)params;  // a model without linearize (a hand-written tag): no poles to state
  }
  std::printf("; largest |u| %.6g%s.", result.max_abs_input / per, volts > 0.0 ? " V" : acceleration ? (ipsim::is_classical<M>() ? " m/s^2" : " rad/s^2") : "");
}

/// Passes every sample on to `inner`; for an acceleration-driven base (Settings::acceleration)
/// it also finds the largest |τ| over the samples, τ = M_0· θ̈ + b_0 − Q_0 the force [N] or
/// torque [N m] the base's drive applies (for sizing it).
class BaseForceMonitor : public ipsim::SampleSink {
 public:
  BaseForceMonitor(ipsim::SampleSink& inner, const ipsim::ParamsOf<Model>& params, const ipsim::Settings<Model>& settings)
      : inner_(inner), params_(params), enabled_(settings.acceleration) {
    context_.coulomb = settings.coulomb;
    context_.coulomb_speed = settings.coulomb_speed;
  }

  void begin(std::size_t samples, int state_size, bool energy_ledger) override {
    inner_.begin(samples, state_size, energy_ledger);
  }

  bool record(const ipsim::Sample& sample) override {
    if (enabled_) {
      const ipsim::VectorOf<Model> q = sample.x().head(dof());
      const ipsim::VectorOf<Model> qd = sample.x().segment(dof(), dof());
      double force = 0.0;
      ipsim::detail::acceleration_dynamics<Model>(q, qd, sample.input, ipsim::detail::coulomb_force<Model>(context_, qd),
                                                  params_, force);
      largest_ = std::max(largest_, std::abs(force));
    }
    return inner_.record(sample);
  }

  /// The largest |τ| seen [N or N m] (0 unless the base is acceleration-driven).
  double largest() const noexcept { return largest_; }

 private:
  ipsim::SampleSink& inner_;
  const ipsim::ParamsOf<Model>& params_;
  bool enabled_;
  ipsim::detail::RhsContext<Model> context_;
  double largest_ = 0.0;
};

/// Passes every sample on and, every `interval` seconds of wall time, writes `progress T T_END`
/// to stderr: how far a long run has come (ipgen run turns it into its progress line).
class ProgressReporter : public ipsim::SampleSink {
 public:
  ProgressReporter(ipsim::SampleSink& inner, double interval, double t_end)
      : inner_(inner), interval_(interval), t_end_(t_end), last_(std::chrono::steady_clock::now()) {}

  void begin(std::size_t samples, int state_size, bool energy_ledger) override {
    inner_.begin(samples, state_size, energy_ledger);
  }

  bool record(const ipsim::Sample& sample) override {
    const auto now = std::chrono::steady_clock::now();
    if (std::chrono::duration<double>(now - last_).count() >= interval_) {
      std::fprintf(stderr, "progress %.6g %.6g\n", sample.t, t_end_);
      std::fflush(stderr);
      last_ = now;
    }
    return inner_.record(sample);
  }

 private:
  ipsim::SampleSink& inner_;
  double interval_, t_end_;
  std::chrono::steady_clock::time_point last_;
};

/// The summary's measured loop: sensors, delay, drive, estimator and its RMS error per state.
void print_loop(const ipsim::scene::Scene<Model>& scene) {
  const ipsim::Settings<Model>& s = scene.settings;
  const char* unit = scene.motor ? "V" : ipsim::is_classical<Model>() ? "N" : "N m";
  if (s.lag > 0.0) std::printf(" Drive: first-order lag %g s.", s.lag);
  for (const ipsim::Pulse& pulse : s.pulses) {
    std::printf(" Disturbance pulse %g %s on the base from t = %g s for %g s.", pulse.amplitude,
                ipsim::is_classical<Model>() ? "N" : "N m", pulse.start, pulse.duration);
  }
  if (!scene.loop) return;
  const ipsim::LoopSettings& loop = scene.loop->settings();
  if (loop.drive_noise > 0.0) std::printf(" Drive noise: sigma %g %s per sampling interval.", loop.drive_noise, unit);
  if (!loop.sensors) return;
  std::string measured;
  for (std::size_t j = 0; j < loop.measured.size(); ++j) {
    char text[120];
    std::snprintf(text, sizeof text, "%stheta%d (%s, sigma %g)", j == 0 ? "" : ", ", loop.measured[j],
                  loop.resolution[j] > 0.0 ? (ipsim::detail::format_number(loop.resolution[j]) + " counts").c_str() : "exact",
                  loop.noise[j]);
    measured += text;
  }
  std::printf(" Sensors: %s, delay %ld sampling period%s, seed %llu. Estimator: %s", measured.c_str(),
              loop.delay_periods, loop.delay_periods == 1 ? "" : "s", static_cast<unsigned long long>(loop.seed),
              ipsim::to_string(loop.kind));
  if (loop.kind == ipsim::EstimatorKind::filter) std::printf(" (cutoff %g rad/s)", loop.cutoff);
  if (loop.assumed_delay_periods != loop.delay_periods)
    std::printf(", built for a delay of %ld sampling period%s", loop.assumed_delay_periods,
                loop.assumed_delay_periods == 1 ? "" : "s");
  if (loop.predict && loop.assumed_delay_periods > 0) std::printf(", the law's estimate predicted over the delay");
  const Eigen::VectorXd rms = scene.loop->rms_error();
  std::printf("; RMS estimation error over %ld samples:", scene.loop->samples());
  for (int i = 0; i < 2 * dof(); ++i) {
    std::printf("%s %s%d %.3g", i == 0 ? "" : ",", i < dof() ? "theta" : "dtheta", i % dof(), rms(i));
  }
  std::putchar('.');
}

void print_summary(const Options& options, const ipsim::scene::Scene<Model>& scene, const ipsim::Result& result,
                   const ipsim::CsvSink<Model>& csv, const BaseForceMonitor& base_force) {
  const ipsim::Settings<Model>& s = scene.settings;
  const ipsim::Statistics& st = result.stats;
  const Eigen::VectorXd final_state = scene.coordinates.to_user(csv.last_state());
  std::printf(
      "scene %s: model %s (%s, %d link%s), input %s, method %s, t = 0 to %g s, %zu samples written to %s. "
      "Final state theta = %s, dtheta = %s. %s, %ld restart%s at input discontinuities. Wall time %.3g s.",
      abbreviate(scene.name).c_str(), ipsim::name_of<Model>(), ipsim::type_of<Model>(), ipsim::links_of<Model>(), ipsim::links_of<Model>() == 1 ? "" : "s",
      ipsim::to_string(s.input.kind), ipsim::to_string(s.method), csv.last_time(), csv.rows(),
      shown_path(options.csv_path).c_str(), ipsim::detail::format_values(final_state.data(), dof()).c_str(),
      ipsim::detail::format_values(final_state.data() + dof(), dof()).c_str(), describe_run(s, st).c_str(), st.restarts,
      st.restarts == 1 ? "" : "s", result.wall_time);
  for (std::size_t k = 0; k < s.more_inputs.size(); ++k) {
    std::printf("%s input%zu %s", k == 0 ? " Further inputs (fixed chain, torques at its other driven joints):" : ",",
                k + 2, ipsim::to_string(s.more_inputs[k].kind));
    if (k + 1 == s.more_inputs.size()) std::putchar('.');
  }
  if (!scene.coordinates.canonical()) {
    std::printf(" Coordinates: the rig's (%s): the CSV's angles and rates, the states and the controller here are in them.",
                scene.coordinates.describe().c_str());
  }
  if (options.energy) print_energy_balance<Model>(csv, scene.params);
  if ((s.coulomb.array() != 0.0).any()) {
    if (s.coulomb_atan) {
      std::printf(" Coulomb friction (atan law, coulomb_gain %g): dissipated %.9g J%s.", s.coulomb_gain,
                  result.coulomb_dissipated, options.energy ? " (included in the dissipated energy above)" : "");
    } else {
      std::printf(" Coulomb friction (tanh law, coulomb_speed %g): dissipated %.9g J%s.", s.coulomb_speed,
                  result.coulomb_dissipated, options.energy ? " (included in the dissipated energy above)" : "");
    }
  }
  if (scene.motor) {
    std::printf(" Actuator: dc motor, u in volts, %.6g %s per volt (back-EMF and rotor folded into the parameters).",
                scene.input_gain, ipsim::type_of<Model>() == std::string_view("rotary") ? "N m" : "N");
  }
  if (s.acceleration) {
    std::printf(" Actuator: acceleration, u is the base's acceleration [%s]; the base's %s peaked at %.6g %s "
                "over the samples.",
                ipsim::is_classical<Model>() ? "m/s^2" : "rad/s^2", ipsim::is_classical<Model>() ? "force" : "torque",
                base_force.largest(), ipsim::is_classical<Model>() ? "N" : "N m");
  }
  if (scene.controller) {
    print_controller<Model>(*scene.controller, scene.params, result, scene.motor ? scene.input_gain : 0.0,
                            scene.coordinates, s.acceleration);
  }
  if (!scene.fixed_controllers.empty()) {  // a fixed chain's controller: one row of K per input
    const ipsim::LinearFeedback& first = scene.fixed_controllers.front();
    const Eigen::VectorXd equilibrium = scene.coordinates.to_user(first.equilibrium);
    std::printf(" Controller: %s, %s, u = -K (x - x_eq), x_eq = %s", first.given ? "given gain" : "LQR",
                first.period > 0.0 ? ("sampled every " + ipsim::detail::format_number(first.period) + " s").c_str()
                                   : "continuous",
                ipsim::detail::format_values(equilibrium.data(), equilibrium.size()).c_str());
    for (std::size_t k = 0; k < scene.fixed_controllers.size(); ++k) {
      const ipsim::LinearFeedback& row = scene.fixed_controllers[k];
      const Eigen::VectorXd gain = scene.coordinates.gain_to_user(row.gain);
      std::printf(", K row %zu (u%zu) = %s", k + 1, k + 1, ipsim::detail::format_values(gain.data(), gain.size()).c_str());
      if (std::isfinite(row.saturation)) std::printf(" with |u%zu| <= %g", k + 1, row.saturation);
    }
    std::printf("; largest |u| %.6g N m.", result.max_abs_input);
  }
  if (scene.mpc) {
    const ipsim::MpcProblem& p = scene.mpc->problem();
    const ipsim::MpcTally& t = scene.mpc->tally();
    const char* unit = scene.motor ? " V" : "";
    std::printf(" Controller: MPC (ipgen_mpc.h, %s), N = %d samples of %g s, %g%s <= u <= %g%s, %zu hard and %zu soft "
                "state bounds; %ld steps, %.3g interior-point iterations a step on average (at most %d), ",
                p.converged ? "converged" : "real-time iteration", p.horizon, p.period, p.u_min, unit, p.u_max, unit,
                p.hard_index.size(), p.soft_index.size(), t.steps,
                t.steps > 0 ? static_cast<double>(t.qp_iterations) / static_cast<double>(t.steps) : 0.0,
                t.max_qp_iterations);
    if (t.not_ok == 0) std::printf("every status ok");
    else std::printf("%ld not ok (the last: status %d, ipgen_mpc.h)", t.not_ok, t.last_bad_status);
    std::printf("; largest |u| %.6g%s.", result.max_abs_input / scene.input_gain, unit);
  }
  if (scene.swingup) {
    const ipsim::SwingUp::State& state = *scene.swingup_state;
    const double per = scene.input_gain;  // volts for a dc motor (b), else 1
    std::printf(" Swing-up: %s, sampled every %g s, |u| <= %g%s; ",
                scene.swingup->method == ipsim::SwingUp::Method::energy ? "energy control"
                : scene.swingup->track_law                              ? "planned trajectory tracked by the MPC"
                                                                        : "planned trajectory tracked by TVLQR",
                scene.swingup->period, scene.swingup->u_max / per, scene.motor ? " V" : "");
    if (state.phase == ipsim::SwingPhase::hold) std::printf("hold (%s) from t = %.6g s", scene.mpc ? "MPC" : "LQR", state.hold_since);
    else if (state.releases > 0) std::printf("in the swing at the end");
    else std::printf("never reached the hold phase (still in %s at the end)", ipsim::to_string(state.phase));
    if (state.releases > 0) std::printf(" (the hold released the link back to the swing %d time%s)", state.releases, state.releases == 1 ? "" : "s");
    std::printf("; largest |u| %.6g%s.", result.max_abs_input / per, scene.motor ? " V" : "");
  }
  print_loop(scene);
  std::putchar('\n');
  for (const auto& warning : result.warnings) std::fprintf(stderr, "simulate: warning: %s\n", warning.c_str());
}

/// The one-line report of a closed loop stopped because it left the controller's region: when,
/// which link, where the CSV is, and what to change in the scene.
std::string divergence_message(const ipsim::Divergence& d, double angle, const Eigen::VectorXd& goal,
                               const ipsim::LinearFeedback* controller, const Options& options, std::size_t rows,
                               const ipsim::Coordinates& coordinates, int first_link) {
  // `controller`: the linear law whose equilibrium `goal` is (a cart's or arm's, a fixed chain's
  // first row); null for an MPC, whose reference it is
  const int coordinate = d.link - 1 + first_link;
  char where[240];
  std::snprintf(where, sizeof where,
                "the closed loop diverged at t = %.6g s: link %d is %.4g rad from the %s (theta%d = %.4g), beyond "
                "%.4g rad (--divergence-angle%s)",
                d.t, d.link, d.deviation, controller ? "controller's equilibrium" : "MPC's reference", coordinate,
                coordinates.to_user(goal)(coordinate), angle, controller ? "" : ", twice it for an MPC");
  std::string fixes = "a smaller initial tilt ([initial] theta), other weights ([controller] q, r)";
  if (controller && controller->period > 0.0) fixes += ", a shorter [controller] period";
  if (controller && std::isfinite(controller->saturation)) fixes += ", a larger [controller] saturation";
  if (!controller) fixes += ", a longer [controller] horizon, a larger [controller] u_max";
  return std::string(where) + "; stopped there, the " + std::to_string(rows) + " samples up to then are in " +
         shown_path(options.csv_path) + ". Try " + fixes +
         ", or a swing-up that brings the pendulum near the equilibrium first";
}

int run(int argc, char** argv) {
  Options options = parse_command_line(argc, argv);
#if defined(IPSIM_RUNTIME_MODEL)
  std::optional<ipsim::ModelLibrary> library;  // the active model while it lives
  try {
    if (options.model_path.empty()) {
      library.emplace();  // the model linked in
    } else {
      library.emplace(options.model_path);
    }
  } catch (const ipsim::Error& e) {
    throw UsageError(e.what());
  }
#endif
  ipsim::scene::Scene<Model> scene = ipsim::scene::load<Model>(ipsim::scene::SceneFile::read(options.scene_path));
  ipsim::Settings<Model>& s = scene.settings;
  if (options.method) s.method = *options.method;
  if (options.jacobian) s.jacobian = *options.jacobian;
  if (options.step) s.step = *options.step;
  if (options.step && s.method != ipsim::Method::rk4) {
    throw UsageError(std::string("--step applies to method rk4 only (the method is ") + ipsim::to_string(s.method) + ")");
  }
  if (options.jacobian && !ipsim::uses_jacobian(s.method)) {
    throw UsageError(std::string("--jacobian applies to methods bdf and adams only (the method is ") +
                     ipsim::to_string(s.method) + ")");
  }
  if (options.rtol) s.rtol = *options.rtol;
  if (options.atol) s.atol = *options.atol;
  if (options.t_end) s.t_end = *options.t_end;
  if (options.sample) s.sample = *options.sample;
  if (options.max_steps) s.max_steps = *options.max_steps;
  options.energy = options.energy || scene.energy;
  s.energy_ledger = options.energy;

  ipsim::require_valid_run<Model>(scene.params, s);
  if (options.check) return 0;
  install_cleanup_handlers();
  PendingCsv csv(options.csv_path, options.scene_path, options.force);  // before integrating
  // The u column: closed loops, and the excitation signals (a recording of an identification
  // experiment carries its input).
  const bool excitation = s.input.kind == ipsim::Input::Kind::chirp || s.input.kind == ipsim::Input::Kind::multisine;
  ipsim::CsvSink<Model> rows(csv.stream(), scene.params, options.energy,
                             scene.controller.has_value() || !scene.fixed_controllers.empty() ||
                                 scene.swingup.has_value() || scene.mpc || excitation,
                             shown_path(options.csv_path));
  rows.set_input_gain(scene.input_gain);  // the u column in the scene's unit (volts for a dc motor)
  rows.set_inputs(static_cast<int>(s.more_inputs.size()) + 1);  // a fixed chain's m > 1 inputs: u1..um
  rows.set_coordinates(scene.coordinates);  // the state columns in the scene's coordinates
  if (scene.loop && scene.loop->settings().sensors) {  // y_* and hat_*, in the scene's coordinates
    const std::shared_ptr<const ipsim::MeasuredLoop<Model>> loop = scene.loop;
    rows.extra_columns(loop->column_names(), [loop] { return loop->column_values(); });
  }
  const int first_link = scene.coordinates.base;  // link 1's coordinate: 0 on a fixed pivot
  std::optional<ipsim::SwingUpMonitor> swing_monitor;
  if (scene.swingup) {
    const std::shared_ptr<const ipsim::SwingUp::State> state = scene.swingup_state;
    rows.phase_column([state] { return ipsim::to_string(state->phase); });
    swing_monitor.emplace(rows, state, dof(), scene.swingup->hold, options.divergence_angle, first_link);
  }
  // The goal a closed loop holds (in ipgen's coordinates): the controller's equilibrium, a fixed
  // chain's, or the MPC's reference; a swing-up's hold is watched by its own monitor above.
  std::optional<Eigen::VectorXd> goal;
  if (scene.controller) goal = scene.controller->equilibrium;
  else if (!scene.fixed_controllers.empty()) goal = scene.fixed_controllers.front().equilibrium;
  else if (scene.mpc && !scene.swingup) {
    const std::vector<double>& reference = scene.mpc->problem().reference;
    goal = Eigen::Map<const Eigen::VectorXd>(reference.data(), static_cast<Eigen::Index>(reference.size()));
  }
  // An MPC predicts with the nonlinear model and brings links back from beyond where a linear
  // law's region ends: it is watched at twice the angle (pi by default: a link through hanging).
  const bool nonlinear = !scene.controller && scene.fixed_controllers.empty();
  const double region = nonlinear ? 2.0 * options.divergence_angle : options.divergence_angle;
  std::optional<ipsim::DivergenceMonitor> monitor;
  if (goal && std::isfinite(region)) {
    monitor.emplace(rows, *goal, dof(), region, first_link);
    Eigen::VectorXd start(2 * dof());
    start << s.theta, s.dtheta;
    if (const auto [link, deviation] = ipsim::farthest_link(start, *goal, dof(), first_link); deviation > region) {
      std::fprintf(stderr,
                   "simulate: warning: the initial state is outside the controller's region: link %d is %.4g rad "
                   "from the equilibrium, more than %.4g rad (--divergence-angle%s); divergence is checked only "
                   "once every link is within it\n",
                   link, deviation, region, nonlinear ? ", twice it for an MPC" : "");
    }
  }
  ipsim::SampleSink& inner = swing_monitor ? static_cast<ipsim::SampleSink&>(*swing_monitor)
                             : monitor     ? static_cast<ipsim::SampleSink&>(*monitor)
                                           : rows;
  std::optional<ipsim::TravelMonitor> travel;
  if (std::isfinite(scene.travel)) travel.emplace(inner, scene.travel);
  ipsim::SampleSink& sink = travel ? static_cast<ipsim::SampleSink&>(*travel) : inner;
  BaseForceMonitor base_force(sink, scene.params, s);
  std::optional<ProgressReporter> progress;
  if (options.progress) progress.emplace(base_force, *options.progress, s.t_end);
  ipsim::SampleSink& reported = progress ? static_cast<ipsim::SampleSink&>(*progress) : base_force;
  const ipsim::Result result = ipsim::simulate<Model>(scene.params, s, reported);
  csv.commit();
  print_summary(options, scene, result, rows, base_force);
  if (travel && travel->exceeded()) {
    const ipsim::TravelExceeded& e = *travel->exceeded();
    const bool cart = ipsim::is_classical<Model>();
    std::fflush(stdout);
    std::fprintf(stderr,
                 "simulate: error: the base left its travel at t = %.6g s: theta0 = %.6g %s, beyond limits.travel = "
                 "%.6g %s; stopped there, the %zu samples up to then are in %s. Lower the input's amplitude (ipgen "
                 "excite scales it to the travel) or widen limits.travel if the rig allows\n",
                 e.t, e.position, cart ? "m" : "rad", travel->travel(), cart ? "m" : "rad", rows.rows(),
                 shown_path(options.csv_path).c_str());
    return kExitTravel;
  }
  if (monitor && monitor->divergence()) {
    std::fflush(stdout);
    std::fprintf(stderr, "simulate: error: %s\n",
                 divergence_message(*monitor->divergence(), monitor->angle(), *goal,
                                    scene.controller ? &*scene.controller
                                    : scene.fixed_controllers.empty() ? nullptr
                                                                      : &scene.fixed_controllers.front(),
                                    options, rows.rows(), scene.coordinates, first_link)
                     .c_str());
    return kExitDiverged;
  }
  if (swing_monitor && swing_monitor->lost()) {
    const ipsim::LostPlan& lost = *swing_monitor->lost();
    std::fflush(stdout);
    std::fprintf(stderr,
                 "simulate: error: the swing-up lost its plan at t = %.6g s: link %d is %.4g rad from the planned "
                 "angle, beyond --divergence-angle %.4g rad, so the tracking cannot bring it back; stopped there "
                 "(before the hold), the %zu samples up to then are in %s\n",
                 lost.t, lost.link, lost.deviation, swing_monitor->angle(), rows.rows(),
                 shown_path(options.csv_path).c_str());
    return kExitLostPlan;
  }
  if (swing_monitor && swing_monitor->divergence()) {
    const ipsim::Divergence& d = *swing_monitor->divergence();
    std::fflush(stdout);
    std::fprintf(stderr,
                 "simulate: error: the swing-up's hold diverged at t = %.6g s: link %d is %.4g rad from upright, beyond "
                 "--divergence-angle %.4g rad; stopped there, the %zu samples up to then are in %s. Try a larger "
                 "[swingup] u_max, a shorter period or (trajectory) a longer duration\n",
                 d.t, d.link, d.deviation, swing_monitor->angle(), rows.rows(), shown_path(options.csv_path).c_str());
    return kExitDiverged;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const UsageError& e) {
    std::fprintf(stderr, "simulate: error: %s\n", e.what());
    return 2;
  } catch (const ipsim::scene::SceneError& e) {
    std::fprintf(stderr, "simulate: error: %s\n", e.what());
    return 2;
  } catch (const ipsim::InvalidInput& e) {
    std::fprintf(stderr, "simulate: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "simulate: error: %s\n", e.what());
    return 1;
  }
}
