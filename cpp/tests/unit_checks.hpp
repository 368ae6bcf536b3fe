// Model-independent parts of ipsim, exercised on the stand-in: RAII wrappers, inputs, the stop
// schedule, the scene reader and the numerical guards. Included by test_model.cpp alone (one
// translation unit: `test_model_cart1 unit`), hence the unnamed namespace.
#pragma once

#include <cmath>
#include <sstream>
#include <type_traits>

#include "cart1.hpp"
#include "check.hpp"
#include "ipsim/ipsim.hpp"
#include "ipsim/scene.hpp"

namespace ipsim_test::unit {
namespace {

using Model = ipgen::cart1::Model;
using ipsim::scene::SceneError;
using ipsim::scene::SceneFile;

template <class T>
constexpr bool owns_uniquely() {
  return !std::is_copy_constructible_v<T> && !std::is_copy_assignable_v<T> && std::is_move_constructible_v<T> &&
         std::is_move_assignable_v<T>;
}
static_assert(owns_uniquely<ipsim::sundials::Context>());
static_assert(owns_uniquely<ipsim::sundials::NVector>());
static_assert(owns_uniquely<ipsim::sundials::DenseMatrix>());
static_assert(owns_uniquely<ipsim::sundials::DenseLinearSolver>());
static_assert(owns_uniquely<ipsim::sundials::CvodeMemory>());
static_assert(owns_uniquely<ipsim::sundials::ErkMemory>());
static_assert(owns_uniquely<ipsim::sundials::FixedPointSolver>());

void check_raii_moves() {
  ipsim::sundials::Context context;
  ipsim::sundials::NVector y(4, context);
  const N_Vector raw = y.get();
  ipsim::sundials::NVector moved(std::move(y));
  CHECK(moved.get() == raw && moved.length() == 4);
  CHECK(y.get() == nullptr);  // NOLINT(bugprone-use-after-move): moved-from owns nothing
  ipsim::sundials::Context other;
  other = std::move(context);
  CHECK(other.get() != nullptr && context.get() == nullptr);  // NOLINT(bugprone-use-after-move)
  CHECK(ipsim::sundials::return_flag_name(CV_TOO_MUCH_WORK) == "CV_TOO_MUCH_WORK");
  CHECK(ipsim::sundials::erk_return_flag_name(ARK_TOO_MUCH_WORK) == "ARK_TOO_MUCH_WORK");
  CHECK(ipsim::sundials::erk_return_flag_name(ARK_RHSFUNC_FAIL) == "ARK_RHSFUNC_FAIL");
}

void check_inputs() {
  const Eigen::VectorXd x = Eigen::VectorXd::Zero(4);
  const auto pulse = ipsim::Input::pulse(2.0, 1.0, 0.5);
  CHECK(pulse.value(0.999, x) == 0.0 && pulse.value(1.0, x) == 2.0 && pulse.value(1.4999, x) == 2.0);
  CHECK(pulse.value(1.5, x) == 0.0);
  CHECK(pulse.switching_times() == std::vector<double>({1.0, 1.5}));
  const auto step = ipsim::Input::step(-1.0, 2.0);
  CHECK(step.value(1.9, x) == 0.0 && step.value(2.0, x) == -1.0);
  const auto sine = ipsim::Input::sine(3.0, 0.25, 0.0);
  CHECK_NEAR(sine.value(1.0, x), 3.0, 1e-15);  // quarter period
  CHECK(!sine.piecewise_constant() && sine.switching_times().empty());
  CHECK(ipsim::Input::constant(0.5).value(7.0, x) == 0.5);
  CHECK(ipsim::Input().value(1.0, x) == 0.0);

  // Chirp: 0 outside [start, start + duration), continuous at start (u = 0 there), both edges stops.
  for (const bool logarithmic : {false, true}) {
    const auto chirp = ipsim::Input::chirp(2.0, 0.5, 8.0, 10.0, 1.0, logarithmic);
    CHECK(chirp.value(0.99, x) == 0.0 && chirp.value(1.0, x) == 0.0 && chirp.value(11.0, x) == 0.0);
    CHECK(!chirp.piecewise_constant() && chirp.switching_times() == std::vector<double>({1.0, 11.0}));
    CHECK(chirp.problems().empty());
  }
  // Linear: φ(τ) = 2π (0.5 τ + 0.375 τ²): 5π at τ = 2, 1.75π at τ = 1.
  const auto linear = ipsim::Input::chirp(2.0, 0.5, 8.0, 10.0, 1.0, false);
  CHECK_NEAR(linear.value(3.0, x), 0.0, 1e-13);
  CHECK_NEAR(linear.value(2.0, x), -std::sqrt(2.0), 1e-13);
  // Logarithmic, k = 16: 16^(τ/10) = 2 at τ = 2.5, so φ = 2π · 0.5 · 10 · (2 − 1) / ln 16.
  const auto log_sweep = ipsim::Input::chirp(2.0, 0.5, 8.0, 10.0, 1.0, true);
  CHECK_NEAR(log_sweep.value(3.5, x), 2.0 * std::sin(10.0 * ipsim::kPi / std::log(16.0)), 1e-13);
  CHECK(!ipsim::Input::chirp(1.0, 2.0, 2.0, 1.0, 0.0, false).problems().empty());  // f1 = f0
  CHECK(!ipsim::Input::chirp(1.0, 0.0, 2.0, 1.0, 0.0, true).problems().empty());   // log from 0 Hz
  // Multisine: amplitude · scale · Σ cos(2π f t + φ), as ipgen passes the lines.
  const auto multi = ipsim::Input::multisine(2.0, {1.0, 2.0}, {0.0, -ipsim::kPi / 2.0}, 0.5);
  CHECK_NEAR(multi.value(0.0, x), 2.0 * 0.5 * (1.0 + 0.0), 1e-15);
  CHECK_NEAR(multi.value(0.125, x), 2.0 * 0.5 * (std::cos(ipsim::kPi / 4.0) + 1.0), 1e-15);  // 2nd: cos 0
  CHECK(!multi.piecewise_constant() && multi.switching_times().empty() && multi.problems().empty());
  CHECK(!ipsim::Input::multisine(1.0, {1.0}, {}, 1.0).problems().empty());  // a phase missing
}

// GCC 12 at -O1 warns below that the std::optional's payload "may be used uninitialized", a known
// false positive (GCC bug 80635): it is read only when engaged. Silenced for this function (its
// reads are outside CHECK, whose own line is in check.hpp); clang has no such warning.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
/// TravelMonitor: passes samples on while |θ0| <= travel, stops at the first beyond.
void check_travel_monitor() {
  struct Count : ipsim::SampleSink {
    int seen = 0;
    bool record(const ipsim::Sample&) override { return ++seen, true; }
  } inner;
  ipsim::TravelMonitor monitor(inner, 0.5);
  double state[2] = {0.0, 0.0};
  ipsim::Sample sample;
  sample.state = state;
  sample.state_size = 2;
  for (const double position : {0.0, 0.3, -0.5}) {
    state[0] = position;
    CHECK(monitor.record(sample));
  }
  state[0] = -0.51;
  sample.t = 1.5;
  CHECK(!monitor.record(sample) && inner.seen == 4);
  const std::optional<ipsim::TravelExceeded>& exceeded = monitor.exceeded();
  const bool stopped_there = exceeded && exceeded->t == 1.5 && exceeded->position == -0.51;
  CHECK(stopped_there);
}
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

void check_schedule() {
  using ipsim::detail::make_schedule;
  const auto stops = make_schedule(1.0, 0.25, {0.1, 0.5, 1.0, -1.0});
  // 0, 0.1 (switch), 0.25, 0.5 (sample + switch), 0.75, 1.0; switches at or beyond the ends dropped.
  CHECK(stops.size() == 6);
  if (stops.size() == 6) {
    CHECK(stops[1].t == 0.1 && stops[1].restart && !stops[1].sample);
    CHECK(stops[3].t == 0.5 && stops[3].restart && stops[3].sample);
    CHECK(stops[5].t == 1.0 && stops[5].sample && !stops[5].restart);
  }
  // Sample longer than the run: just the two ends.
  CHECK(make_schedule(0.5, 2.0, {}).size() == 2);
}

const char* const kScene = R"(# a cart pendulum knocked by a pulse
name = cart_pulse
model = cart1
type = classical
links = 1
m = 0.5 0.275
l = 0 0.5      # l[0] unused for a cart
delta = 0.3 0.1
g = 9.81
theta = 0 0.1
dtheta = 0 0
input = pulse
input.amplitude = 0.4
input.start = 0
input.duration = 1
input.time = 0
input.frequency = 0
input.phase = 0
t_end = 3
sample = 0.05
method = adams
rtol = 1e-9
atol = 1e-11
max_steps = 5000
)";

ipsim::scene::Scene<Model> load_text(const std::string& text) {
  std::istringstream stream(text);
  return ipsim::scene::load<Model>(SceneFile::parse(stream, "test.cfg"));
}

/// kScene with the line for `key` replaced by `line` (or removed when `line` is empty).
std::string edited(const std::string& key, const std::string& line) {
  std::istringstream in(kScene);
  std::string out;
  for (std::string l; std::getline(in, l);) {
    if (l.rfind(key + " =", 0) == 0) {
      if (!line.empty()) out += line + "\n";
    } else {
      out += l + "\n";
    }
  }
  return out;
}

void check_scene_reader() {
  const auto scene = load_text(kScene);
  CHECK(scene.name == "cart_pulse");
  CHECK(scene.params.m[0] == 0.5 && scene.params.m[1] == 0.275 && scene.params.l[1] == 0.5);
  CHECK(scene.params.delta[1] == 0.1 && scene.params.g == 9.81);
  CHECK(scene.settings.theta(1) == 0.1 && scene.settings.method == ipsim::Method::adams);
  CHECK(scene.settings.rtol == 1e-9 && scene.settings.atol == 1e-11 && scene.settings.max_steps == 5000);
  CHECK(scene.settings.t_end == 3.0 && scene.settings.sample == 0.05);
  CHECK(scene.settings.input.kind == ipsim::Input::Kind::pulse && scene.settings.input.duration == 1.0);
  CHECK(ipsim::validate<Model>(scene.params).empty());  // l[0] = 0 is fine for a cart

  CHECK_THROWS(load_text(edited("m", "m = 0.5 0.275 0.3")), SceneError,
               "test.cfg:6: `m` has 3 values, model cart1 needs 2 (base + 1 links)");
  CHECK_THROWS(load_text(edited("links", "links = 2")), SceneError, "test.cfg:5: links = 2, model cart1 has 1");
  CHECK_THROWS(load_text(edited("model", "model = cdip")), SceneError, "scene is for model `cdip`");
  CHECK_THROWS(load_text(edited("type", "type = rotary")), SceneError, "model cart1 is classical");
  CHECK_THROWS(load_text(edited("rtol", "")), SceneError, "test.cfg: missing key `rtol`");
  CHECK_THROWS(load_text(edited("rtol", "rtol = fast")), SceneError, "`rtol`: `fast` is not a number");
  CHECK_THROWS(load_text(edited("max_steps", "max_steps = 1.5")), SceneError, "max_steps = 1.5 must be a whole number >= 1");
  CHECK_THROWS(load_text(edited("method", "method = rk5")), SceneError,
               "test.cfg:21: method must be bdf, adams, adams-fixed-point, erk-dp5, erk-fehlberg8 or rk4, "
               "got `rk5`");
  CHECK_THROWS(load_text(edited("method", "method = bdf\njacobian = numeric")), SceneError,
               "test.cfg:22: jacobian must be `exact` or `dq`, got `numeric`");
  CHECK_THROWS(load_text(edited("method", "method = rk4\nstep = fast")), SceneError, "`step`: `fast` is not a number");
  CHECK_THROWS(load_text(edited("input", "input = ramp")), SceneError, "input must be zero, constant");
  // A chirp and a multisine as ipgen writes them; limits.travel.
  const auto chirp = load_text(edited("input", "input = chirp\ninput.f0 = 0.5\ninput.f1 = 4\ninput.sweep = logarithmic"));
  CHECK(chirp.settings.input.kind == ipsim::Input::Kind::chirp && chirp.settings.input.logarithmic);
  CHECK(chirp.settings.input.f1 == 4.0 && chirp.settings.input.start == 0.0);
  CHECK_THROWS(load_text(edited("input", "input = chirp\ninput.f0 = 0\ninput.f1 = 4\ninput.sweep = cubic")), SceneError,
               "input.sweep must be `linear` or `logarithmic`");
  const auto multi = load_text(edited(
      "input", "input = multisine\ninput.frequencies = 0.5 1\ninput.phases = 0 -1.5\ninput.scale = 0.6\nlimits.travel = 0.25"));
  CHECK(multi.settings.input.kind == ipsim::Input::Kind::multisine && multi.settings.input.frequencies.size() == 2);
  CHECK(multi.settings.input.phases.at(1) == -1.5 && multi.settings.input.scale == 0.6 && multi.travel == 0.25);
  CHECK(std::isinf(scene.travel));
  CHECK_THROWS(load_text(std::string(kScene) + "limits.travel = -1\n"), SceneError, "limits.travel = -1 must be > 0");
  CHECK_THROWS(load_text(std::string(kScene) + "colour = red\n"), SceneError, "unknown key `colour`");
  CHECK_THROWS(load_text(std::string(kScene) + "g = 1\n"), SceneError, "key `g` repeated (first on line 9)");
  CHECK_THROWS(load_text(std::string(kScene) + "just words\n"), SceneError, "expected `key = value`");
  CHECK_THROWS(load_text(edited("g", "g =")), SceneError, "key `g` has no value");
  // The input's unused fields may be absent.
  const auto step = load_text(edited("input", "input = step"));
  CHECK(step.settings.input.kind == ipsim::Input::Kind::step);
  CHECK_THROWS(SceneFile::read("/nonexistent/scene.cfg"), SceneError, "cannot open scene file");
  // A number outside its key's rule (cfg_rules.hpp, from the scene schema) is refused as the .cfg
  // is read; validate() keeps the C++ API's message for parameters set in code.
  CHECK_THROWS(load_text(edited("m", "m = 0.5 -1")), SceneError, "m[1] = -1 must be > 0 (the rule of [parameters] m)");
  auto negative = load_text(std::string(kScene)).params;
  negative.m[1] = -1.0;
  CHECK(ipsim::validate<Model>(negative).at(0) == "invalid parameter m[1] = -1: masses must be > 0");
}

void check_coordinates() {
  // relative, hanging, counter-clockwise, two links: by hand, q1 = -(theta1 - pi), q2 = -(theta2 - theta1).
  ipsim::Coordinates rig;
  rig.relative = rig.hanging = rig.counterclockwise = true;
  Eigen::VectorXd x(6);
  x << 0.1, 3.0, 2.5, 0.2, -0.5, 0.7;
  Eigen::VectorXd expected(6);
  expected << 0.1, 3.141592653589793 - 3.0, 0.5, 0.2, 0.5, -1.2;
  const Eigen::VectorXd user = rig.to_user(x);
  CHECK((user - expected).cwiseAbs().maxCoeff() < 1e-15);
  CHECK((rig.to_canonical(user) - x).cwiseAbs().maxCoeff() < 1e-15);
  Eigen::VectorXd k_user(6);
  k_user << 1.0, 2.0, 3.0, 4.0, 5.0, 6.0;  // u = -K_user (x_user - x_eq,user) = -(K_user P)(x - x_eq)
  const Eigen::VectorXd k = rig.gain_to_canonical(k_user);
  CHECK(std::abs(k_user.dot(rig.to_user(x) - rig.to_user(Eigen::VectorXd::Zero(6))) - k.dot(x)) < 1e-12);
  CHECK((rig.gain_to_user(k) - k_user).cwiseAbs().maxCoeff() < 1e-14);
  CHECK(ipsim::Coordinates{}.canonical() && !rig.canonical());
  // A scene in the rig's coordinates: the initial state is mapped into ipgen's.
  const auto scene = load_text(std::string(kScene) + "zero = hanging\npositive = counterclockwise\n");
  CHECK(scene.coordinates.hanging && scene.coordinates.counterclockwise && !scene.coordinates.relative);
  CHECK(std::abs(scene.settings.theta(1) - (3.141592653589793 - 0.1)) < 1e-15 && scene.settings.theta(0) == 0.0);
  CHECK_THROWS(load_text(std::string(kScene) + "angles = joint\n"), SceneError,
               "angles must be `absolute` or `relative`, got `joint`");
}

void check_scene_method_keys() {
  // jacobian defaults to exact; step is read when present; both are optional.
  CHECK(load_text(kScene).settings.jacobian == ipsim::Jacobian::exact);
  const auto dq = load_text(edited("method", "method = bdf\njacobian = dq"));
  CHECK(dq.settings.method == ipsim::Method::bdf && dq.settings.jacobian == ipsim::Jacobian::dq);
  const auto rk4 = load_text(edited("method", "method = rk4\nstep = 0.001"));
  CHECK(rk4.settings.method == ipsim::Method::rk4 && rk4.settings.step == 0.001);
  CHECK(ipsim::validate<Model>(rk4.settings).empty());
  // rk4 without a step is read, then refused by validation with the API's message.
  const auto no_step = load_text(edited("method", "method = rk4"));
  CHECK(ipsim::validate<Model>(no_step.settings).at(0) ==
        "invalid setting step = 0: method rk4 needs a fixed step: must be finite and > 0");
  for (const char* name : {"bdf", "adams", "adams-fixed-point", "erk-dp5", "erk-fehlberg8", "rk4"}) {
    const auto method = ipsim::parse_method(name);
    CHECK(method && std::string(ipsim::to_string(*method)) == name);
  }
  CHECK(!ipsim::parse_method("BDF") && !ipsim::parse_jacobian("exactly"));
  CHECK(ipsim::family_of(ipsim::Method::adams_fixed_point) == ipsim::Family::cvode);
  CHECK(ipsim::family_of(ipsim::Method::erk_fehlberg8) == ipsim::Family::erk);
  CHECK(ipsim::uses_jacobian(ipsim::Method::adams) && !ipsim::uses_jacobian(ipsim::Method::adams_fixed_point));
  ipsim::Settings<Model> s;
  CHECK(ipsim::describe(s) == "method bdf, jacobian exact, rtol 1e-10, atol 1e-12, max_steps 100000");
  s.method = ipsim::Method::erk_dp5;
  CHECK(ipsim::describe(s) == "method erk-dp5, rtol 1e-10, atol 1e-12, max_steps 100000");
  s.method = ipsim::Method::rk4;
  s.step = 0.002;
  CHECK(ipsim::describe(s) == "method rk4, step 0.002, max_steps 100000");
}

/// A model tag without forward_dynamics_derivatives (a hand-written or older header): only
/// difference-quotient Jacobians are available, and asking for the exact one is refused.
struct NoDerivatives : ipgen::cart1::Model {
  static constexpr const char* kName = "no_derivatives";
  template <typename Scalar>
  static void forward_dynamics_derivatives() = delete;  // hides the stand-in's
};
static_assert(ipsim::has_derivatives<Model> && !ipsim::has_derivatives<NoDerivatives>);

void check_model_without_derivatives() {
  const ipsim::ParamsOf<Model> p{{0.5, 0.275}, {0.0, 0.5}, {0.3, 0.1}};
  ipsim::Settings<NoDerivatives> s;
  s.t_end = 1.0;
  s.theta(1) = 0.1;
  CHECK_THROWS(ipsim::simulate<NoDerivatives>(p, s), ipsim::InvalidInput,
               "invalid setting jacobian = exact: model no_derivatives has no forward_dynamics_derivatives");
  s.jacobian = ipsim::Jacobian::dq;
  CHECK(ipsim::simulate<NoDerivatives>(p, s).stats.linear_solver_rhs_evals > 0);
  s.method = ipsim::Method::erk_dp5;  // no Jacobian needed
  s.jacobian = ipsim::Jacobian::exact;
  CHECK(ipsim::simulate<NoDerivatives>(p, s).times.size() == 101);
}

/// A rotary tag with an inertia variant, for the reader's model checks only (never simulated).
struct RotaryPivot : ipgen::cart1::Model {
  static constexpr const char* kName = "rotary_pivot";
  static constexpr const char* kType = "rotary";
  static constexpr const char* kInertia = "pivot";
};

void check_scene_model_keys() {
  // Classical models ignore the inertia the Python side always writes.
  CHECK(load_text(std::string(kScene) + "inertia = pivot\n").name == "cart_pulse");
  CHECK_THROWS(load_text(std::string(kScene) + "inertia = heavy\n"), SceneError, "inertia must be `pivot` or `full`");

  auto rotary = edited("model", "model = rotary_pivot");
  rotary = rotary.substr(0, rotary.find("type =")) + "type = rotary\n" + rotary.substr(rotary.find("links ="));
  std::istringstream pivot(rotary + "inertia = pivot\n");
  CHECK(ipsim::scene::load<RotaryPivot>(SceneFile::parse(pivot, "r.cfg")).params.m[1] == 0.275);
  std::istringstream full(rotary + "inertia = full\n");
  CHECK_THROWS(ipsim::scene::load<RotaryPivot>(SceneFile::parse(full, "r.cfg")), SceneError,
               "r.cfg:25: inertia is `full`, model rotary_pivot was generated with `pivot`");

  const auto with_energy = load_text(std::string(kScene) + "energy = true\n");
  CHECK(with_energy.energy && with_energy.settings.energy_ledger);
  CHECK(!load_text(kScene).energy);
  CHECK_THROWS(load_text(std::string(kScene) + "energy = yes\n"), SceneError, "energy must be `true` or `false`");
}

void check_energy_helpers() {
  ipsim::ParamsOf<Model> p{{0.5, 0.275}, {0.0, 0.5}, {0.3, 0.1}};
  Eigen::VectorXd x(4);
  x << 0.0, 0.0, 0.0, 0.0;
  CHECK_NEAR(ipsim::mechanical_energy<Model>(p, x), 0.275 * 9.81 * 0.25, 1e-15);  // upright link: V = m g l/2
  CHECK_THROWS(ipsim::mechanical_energy<Model>(p, Eigen::VectorXd::Zero(3)), std::invalid_argument,
               "state has 3 entries, model cart1 needs 2·kDof = 4");
}

/// guards.hpp: condition numbers of a symmetric matrix, where a diagonal scaling (units) does not
/// count; the warning and the failure diagnoses on the stand-in.
void check_guards() {
  Eigen::Matrix2d m;
  m << 1.0, 0.0, 0.0, 1e-12;  // badly scaled, not ill-conditioned
  CHECK_NEAR(ipsim::conditioning_of(m).cond, 1e12, 1e-3);
  CHECK_NEAR(ipsim::conditioning_of(m).scaled_cond, 1.0, 1e-12);
  m << 1.0, 0.999999, 0.999999, 1.0;  // nearly singular whatever the scaling
  CHECK_NEAR(ipsim::conditioning_of(m).scaled_cond, 1.999999 / 1e-6, 1e-3);
  m << 1.0, 2.0, 2.0, 1.0;  // not positive definite
  CHECK(std::isinf(ipsim::conditioning_of(m).cond));

  ipsim::ParamsOf<Model> p{{0.5, 0.275}, {0.0, 0.5}, {0.3, 0.1}};
  static_assert(ipsim::has_mass_matrix<Model> && ipsim::has_bias<Model>);
  CHECK(ipsim::conditioning_warning<Model>(p, ipsim::VectorOf<Model>::Zero()).empty());
  CHECK(!ipsim::conditioning_warning<Model>(p, ipsim::VectorOf<Model>::Zero(), 1.0).empty());  // any cond > 1

  ipsim::Settings<Model> s;
  s.t_end = 1.0;
  s.theta(1) = 0.2;
  s.input = ipsim::Input::from_feedback([](double t, const Eigen::VectorXd&) { return t > 0.5 ? std::nan("") : 0.0; });
  for (const auto method : {ipsim::Method::bdf, ipsim::Method::erk_dp5, ipsim::Method::rk4}) {
    s.method = method;
    s.step = 1e-3;
    CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::IntegrationError,
                 "; likely cause: the input u is not finite (a feedback callback returned nan)");
  }
  s.method = ipsim::Method::bdf;
  s.input = ipsim::Input::zero();
  s.dtheta(1) = 1e160;
  CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::IntegrationError,
               "likely cause: the state grew without bound: rates of 1e+160 overflow");
  // Not stiff, just out of steps: no "use BDF".
  s.dtheta(1) = 0.0;
  s.method = ipsim::Method::erk_dp5;
  s.max_steps = 1;
  CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::IntegrationError, "not stiff at this state");
  // A light link with enormous damping: stiff.
  p.m[1] = 1e-3;
  p.delta[1] = 1e4;
  s.max_steps = 100000;
  CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::IntegrationError, "; stiff: use BDF (method bdf)");
  s.method = ipsim::Method::bdf;
  const ipsim::Result stiff = ipsim::simulate<Model>(p, s);
  CHECK(stiff.stats.steps < 2000);
}

/// controller.hpp: a LinearFeedback whose K or x_eq has the wrong size is refused (it ran with
/// part of the state, or read past the end of x); closed_loop_poles' check is in
/// tests/test_closed_loop_cpp.py (the stand-in has no linearize).
void check_linear_feedback() {
  const ipsim::ParamsOf<Model> p{{0.5, 0.275}, {0.0, 0.5}, {0.3, 0.1}};
  ipsim::LinearFeedback c;
  c.gain = Eigen::VectorXd::Ones(3);
  c.equilibrium = Eigen::VectorXd::Zero(4);
  CHECK_THROWS(c.input(), ipsim::InvalidInput, "controller.gain: has 3 entries, controller.equilibrium 4: both need");
  c.equilibrium = Eigen::VectorXd::Zero(3);
  ipsim::Settings<Model> s;
  s.t_end = 0.1;
  s.input = c.input();
  CHECK_THROWS(ipsim::simulate<Model>(p, s), ipsim::InvalidInput,
               "controller.gain: has 3 entries and controller.equilibrium 3, the state x has 4 (2·kDof)");
  c.gain = Eigen::VectorXd::Ones(4);
  c.equilibrium = Eigen::VectorXd::Zero(4);
  s.input = c.input();
  CHECK(ipsim::simulate<Model>(p, s).times.size() == 11);
  c.saturation = 0.0;
  CHECK_THROWS(c.input(), ipsim::InvalidInput, "controller.saturation = 0: must be > 0");
}

}  // namespace

/// Every check above; the exit status: 0 when all passed, 1 otherwise.
inline int run() {
  check_guards();
  check_scene_model_keys();
  check_energy_helpers();
  check_raii_moves();
  check_inputs();
  check_travel_monitor();
  check_schedule();
  check_scene_reader();
  check_scene_method_keys();
  check_coordinates();
  check_model_without_derivatives();
  check_linear_feedback();
  return ipsim_test::finish("ipsim unit checks");
}

}  // namespace ipsim_test::unit
