// The loop as a rig runs it (a scene's [sensors], [estimator] and the drive keys of [actuator]):
// at each sampling instant t_k = k·T of a sampled controller or swing-up, the encoders measure,
// an estimator turns the measurements into a state estimate, the control law sees only that
// estimate, and its command reaches the drive `delay` later, with noise.
//
//   measure   y_k = z + Δ·floor((θ(t_k) − z)/Δ + 1/2) + n_k,  n_k ~ N(0, σ²)   per measured coordinate,
//             in the scene's coordinates (the CSV's); Δ = 2π/resolution [rad] (an angle) or
//             1/resolution [m] (a cart's position); z the pose where the encoder reads 0
//             (sensors.zero, default 0); resolution 0: no quantisation
//   estimate  x̂_k from y_0..y_k (and the inputs applied so far): exact, difference, filter, kalman, ekf
//   predict   with estimator.predict, x̂_k carried over the delay by the model with the commands
//             still in flight: the state u_k will meet (ipgen_loop_predict; exact and ekf)
//   control   u_k = law(t_k, x̂_k) (the LQR, the swing-up law or TVLQR, saturated)
//   delay     u_k is applied from t_{k+j} (delay = j·T); before the first command arrives u = 0;
//             the loop itself (its estimator's input, the prediction) assumes estimator.delay
//             (default the rig's j, known): a firmware told the wrong delay
//   drive     the command applied on [t_k, t_k+1) gets + N(0, σ_u²) (drawn once per interval, held)
//   lag       with estimator.compensate_lag the loop models the drive's first-order lag (estimator.lag,
//             else actuator.lag: known): its estimator and prediction take each period's mean lagged input, and u_k is
//             the command whose lagged mean over its first period is the law's, within the law's
//             bound (ipgen_loop_lag_*)
//
// The quantiser, the delay and the estimators are ipgen_loop.h's (C99, shared with the firmware
// header and Python); this class holds their memory and the simulated world around them.
//
// Every estimator works in the scene's coordinates (the CSV's; ipsim/coordinates.hpp): the kalman
// filter's A, B, M and x_eq are given in them, the ekf maps the model's f and A into them.
//
// Random numbers: two std::mt19937_64 streams seeded from `seed` (one for the sensors, one for the
// drive), normal deviates by Box–Muller from 53-bit uniforms (portable: no library distribution);
// one draw per measured coordinate per sample and one per interval for the drive, always (also when
// σ = 0), so that the streams depend on the sample count only, never on the integrator's steps.
// The drive's first-order lag and the disturbance pulses act inside the integrated model (rhs.hpp).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/LU>

#include "ipsim/controller.hpp"
#include "ipsim/coordinates.hpp"
#include "ipsim/errors.hpp"
#include "ipsim/input.hpp"
#include "ipsim/linkage.hpp"
#include "ipsim/model.hpp"
#include "ipgen_loop.h"

namespace ipsim {

namespace detail {
// P A P⁻¹: a Jacobian in the rig's coordinates (dynamic size, the same for every model: linkage.hpp).
Eigen::MatrixXd similar(const Eigen::MatrixXd& P, const Eigen::MatrixXd& A);
}  // namespace detail

/// Standard normal deviates from a seeded std::mt19937_64 (Box–Muller, two 53-bit uniforms a draw).
class NormalStream {
 public:
  /// `stream` tells apart the independent streams of one seed (1: sensors, 2: drive).
  NormalStream(std::uint64_t seed, std::uint32_t stream) {
    std::seed_seq sequence{static_cast<std::uint32_t>(seed & 0xffffffffu), static_cast<std::uint32_t>(seed >> 32),
                           stream};
    engine_.seed(sequence);
  }

  /// The next N(0, 1) deviate.
  double operator()() {
    const double u1 = (static_cast<double>(engine_() >> 11) + 1.0) * 0x1.0p-53;  // (0, 1]
    const double u2 = static_cast<double>(engine_() >> 11) * 0x1.0p-53;          // [0, 1)
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  }

 private:
  std::mt19937_64 engine_;
};

/// The estimators of [estimator] kind.
enum class EstimatorKind { exact, difference, filter, kalman, ekf };

inline const char* to_string(EstimatorKind kind) {
  switch (kind) {
    case EstimatorKind::exact: return "exact";
    case EstimatorKind::difference: return "difference";
    case EstimatorKind::filter: return "filter";
    case EstimatorKind::kalman: return "kalman";
    case EstimatorKind::ekf: return "ekf";
  }
  return "?";
}

/// What a scene's [sensors], [estimator] and drive keys say (the .cfg's sensors.*, estimator.*,
/// actuator.noise), in the scene's coordinates and input unit (volts with a dc motor).
struct LoopSettings {
  bool sensors = false;          ///< a [sensors] or [estimator] table: the y_* and hat_* columns
  std::vector<int> measured;     ///< indices of θ measured (ascending)
  std::vector<double> resolution;  ///< counts per revolution or per metre, per measured; 0 exact
  std::vector<double> noise;       ///< σ per measured [rad or m]
  std::vector<double> zero;        ///< where the encoders read 0, per measured (empty: 0)
  long delay_periods = 0;          ///< delay = delay_periods · period (the rig's)
  long assumed_delay_periods = 0;  ///< the delay the loop is built for (estimator.delay; default the rig's)
  std::uint64_t seed = 0;
  double drive_noise = 0.0;        ///< σ_u of the applied input [input unit]
  EstimatorKind kind = EstimatorKind::exact;
  double cutoff = 0.0;             ///< filter: ω_c [rad/s]
  // kalman: x̂⁺ = x_eq + A (x̂ − x_eq) + B (ū − u_eq), x̂ = x̂⁻ + M (y − C x̂⁻); ekf: x_eq (start), Qn, Rn
  Eigen::MatrixXd A, gain, process_noise, measurement_noise;
  Eigen::VectorXd B, equilibrium;
  double input_equilibrium = 0.0;
  bool predict = false;  ///< the law sees the estimate carried over the delay (ipgen_loop_predict)
  /// ekf: > 0, the filter learns the plant's input gain over the model's (rho, ipgen_loop_ekf's
  /// gain_spread: its prior standard deviation) and its drift per sqrt(s)
  double gain_spread = 0.0, gain_drift = 0.0;
  /// ekf: > 0, the filter learns each measured coordinate's noise variance over this memory [s]
  /// (ipgen_loop_ekf's noise_weight = period / noise_memory), uses noise_margin times it within
  /// [noise_floor, noise_ceiling] (per measured) [rad² or m²]
  double noise_memory = 0.0, noise_margin = 0.0;
  Eigen::VectorXd noise_floor, noise_ceiling;
  /// estimator.compensate_lag: the drive's lag the loop is built for [s] (estimator.lag, else the
  /// rig's actuator.lag; 0: none) and the bound of its commands [N or N m] (the law's saturation)
  double lag = 0.0, limit = std::numeric_limits<double>::infinity();
};

/// One run's measure → estimate → control → delay → drive loop around a sampled control law.
/// step() is called once per sampling instant (by the sampled Input it wraps) with the true state
/// x(t_k) in ipgen's coordinates and returns the force or torque applied on [t_k, t_k+1) [N or N m].
template <class Model>
class MeasuredLoop {
 public:
  int n = dof_of<Model>();  // degrees of freedom (before the members that use it)

  /// `input_gain`: the plant's force per unit of u; `design`, `design_gain`: the model the EKF and
  /// the prediction run (Scene::design: the plant's, or a sweep's nominal one) and its force per unit.
  /// `gain_factor`: where the learnt gain goes (estimator.gain_spread), read by the swing-up.
  MeasuredLoop(LoopSettings settings, Input::Feedback law, double period, double input_gain,
               const ParamsOf<Model>& design, double design_gain, Coordinates coordinates,
               std::shared_ptr<double> gain_factor = nullptr)
      : s_(std::move(settings)),
        law_(std::move(law)),
        period_(period),
        gain_(input_gain),
        design_gain_(design_gain),
        params_(with_rod_links<Model>(design)),
        coordinates_(coordinates),
        sensor_noise_(s_.seed, 1),
        drive_noise_(s_.seed, 2),
        gain_factor_(gain_factor ? std::move(gain_factor) : std::make_shared<double>(1.0)) {
    const auto m = static_cast<Eigen::Index>(s_.measured.size());
    y_ = Eigen::VectorXd::Zero(m);
    previous_y_ = y_;
    estimate_ = Eigen::VectorXd::Zero(2 * n);
    squared_error_ = Eigen::VectorXd::Zero(2 * n);
    pending_.assign(static_cast<std::size_t>(s_.delay_periods) + 1, 0.0);
    believed_.assign(static_cast<std::size_t>(s_.assumed_delay_periods) + 1, 0.0);
    pole_ = std::exp(-s_.cutoff * period_);
    measured_.assign(s_.measured.begin(), s_.measured.end());
    A_ = s_.A;
    gain_rows_ = s_.gain;
    process_noise_ = s_.process_noise;
    measurement_noise_ = s_.measurement_noise;
    const int states = IPGEN_LOOP_EKF_STATES(n, learns());  // rho after the state when learnt
    filtered_ = Eigen::VectorXd::Zero(states);
    if (learns()) filtered_(2 * n) = 1.0;  // rho before the first sample (ipgen_loop_ekf)
    covariance_ = RowMajor::Zero(states, states);
    learnt_noise_ = Eigen::VectorXd::Zero(m);
    work_ = Eigen::VectorXd::Zero(IPGEN_LOOP_EKF_WORK(states, static_cast<int>(m)));
    predict_work_ = Eigen::VectorXd::Zero(6 * 2 * n);
    means_.assign(believed_.size(), 0.0);
    lag_ = ipgen_loop_lag_of(s_.lag, period_, s_.limit);
  }

  /// The command applied on [t, t + period) for the true state x (ipgen's coordinates).
  double step(double t, const Eigen::VectorXd& x) {
    const Eigen::VectorXd user = coordinates_.to_user(x);
    measure(user);
    estimate(user);
    Eigen::VectorXd seen = s_.kind == EstimatorKind::exact ? x : coordinates_.to_canonical(estimate_);
    const int assumed = static_cast<int>(s_.assumed_delay_periods);
    // the inputs over the delay as the model sees them (with a known lag: their means) and the
    // drive's input when this sample's command starts to act
    const double applied_then = ipgen_loop_lag_ahead(&lag_, lag_applied_, assumed, believed_.data(), means_.data());
    if (s_.predict && assumed > 0) {  // the state the command will meet, `assumed` periods later
      Eigen::VectorXd ahead(2 * n);
      // A failed prediction (M(q) not positive definite on the way) leaves the estimate as it is.
      // believed_ holds the plant's forces or torques (gain_ per unit of u), the model the design's
      if (ipgen_loop_predict(&MeasuredLoop::field, this, 2 * n, period_, design_gain_ / gain_ * *gain_factor_, assumed, means_.data(),
                             estimate_.data(), ahead.data(), predict_work_.data()) == 0) {
        seen = coordinates_.to_canonical(ahead);
      }
    }
    // N or N m (saturated); with a known lag, the command whose lagged mean is the law's
    const double command = ipgen_loop_lag_command(&lag_, law_(t, seen), applied_then);
    // the command that reaches the drive now (u = 0 before the first arrives)
    const double applied = ipgen_loop_delay(pending_.data(), static_cast<int>(s_.delay_periods), command);
    // the one the loop believes acts now: its own queue of the delay it is built for (the rig's
    // unless estimator.delay says otherwise), which its estimator predicts with (its mean, lagged)
    last_input_ = ipgen_loop_lag_mean(&lag_, ipgen_loop_delay(believed_.data(), assumed, command), &lag_applied_) / gain_;
    const double noise = drive_noise_();
    ++samples_;
    return applied + gain_ * s_.drive_noise * noise;
  }

  /// Column names after the CSV's others: y_theta<i> per measured, hat_theta<i>, hat_dtheta<i>,
  /// and hat_gain (rho) when the EKF learns the input gain.
  std::vector<std::string> column_names() const {
    std::vector<std::string> names;
    for (const int i : s_.measured) names.push_back("y_theta" + std::to_string(i));
    for (int i = 0; i < n; ++i) names.push_back("hat_theta" + std::to_string(i));
    for (int i = 0; i < n; ++i) names.push_back("hat_dtheta" + std::to_string(i));
    if (learns()) names.emplace_back("hat_gain");
    return names;
  }

  /// The values of column_names() at the latest sampling instant (held between instants).
  Eigen::VectorXd column_values() const {
    Eigen::VectorXd values(y_.size() + 2 * n + (learns() ? 1 : 0));
    values.head(y_.size() + 2 * n) << y_, estimate_;
    if (learns()) values(values.size() - 1) = *gain_factor_;
    return values;
  }

  const LoopSettings& settings() const noexcept { return s_; }
  long samples() const noexcept { return samples_; }

  /// √(mean over the sampling instants of (x̂ − x)²) per state, in the scene's coordinates.
  Eigen::VectorXd rms_error() const {
    if (samples_ == 0) return squared_error_;
    return (squared_error_ / static_cast<double>(samples_)).cwiseSqrt();
  }

 private:
  /// True if coordinate i is a cart's position (metres), not an angle.
  static bool is_position(int i) { return i == 0 && is_classical<Model>(); }

  void measure(const Eigen::VectorXd& user) {
    for (std::size_t j = 0; j < s_.measured.size(); ++j) {
      const int i = s_.measured[j];
      double value = user(i);
      if (s_.resolution[j] > 0.0) {
        const double delta = (is_position(i) ? 1.0 : 2.0 * kPi) / s_.resolution[j];
        const double z = s_.zero.empty() ? 0.0 : s_.zero[j];  // counts from the encoder's zero pose
        value = ipgen_loop_quantise(value, z, delta);
      }
      const double noise = sensor_noise_();  // drawn even when σ = 0: the stream stays aligned
      y_(static_cast<Eigen::Index>(j)) = value + s_.noise[j] * noise;
    }
  }

  /// x̂_k from y_k and the input the model saw over the last period (ipgen_loop.h's estimators).
  void estimate(const Eigen::VectorXd& user) {
    const long k = samples_;
    switch (s_.kind) {
      case EstimatorKind::exact: estimate_ = user; break;
      case EstimatorKind::difference:  // every angle measured, in order
        ipgen_loop_difference(n, period_, k, y_.data(), previous_y_.data(), estimate_.data());
        break;
      case EstimatorKind::filter:
        ipgen_loop_filter(n, pole_, s_.cutoff, k, y_.data(), previous_y_.data(), estimate_.data());
        break;
      case EstimatorKind::kalman: {
        const ipgen_loop_kalman filter{measurement(), A_.data(), s_.B.data(), gain_rows_.data(), s_.input_equilibrium};
        ipgen_loop_kalman_update(&filter, k, y_.data(), last_input_, estimate_.data(), work_.data());
        break;
      }
      case EstimatorKind::ekf: {
        const ipgen_loop_ekf filter{measurement(), period_, design_gain_, process_noise_.data(), measurement_noise_.data(),
                                    &MeasuredLoop::field, this, s_.gain_spread, s_.gain_drift,
                                    s_.noise_memory > 0 ? period_ / s_.noise_memory : 0.0, s_.noise_margin,
                                    s_.noise_floor.data(), s_.noise_ceiling.data(), learnt_noise_.data()};
        // A failed step (M(q) or the innovation covariance not positive definite) keeps the
        // last estimate, as the firmware does.
        (void)ipgen_loop_ekf_update(&filter, k, y_.data(), last_input_, filtered_.data(), covariance_.data(), work_.data());
        estimate_ = filtered_.head(2 * n);
        if (learns()) *gain_factor_ = filtered_(2 * n);
        break;
      }
    }
    squared_error_ += (estimate_ - user).cwiseAbs2();
  }

  /// True if the EKF learns the input gain (estimator.gain_spread > 0).
  bool learns() const { return s_.kind == EstimatorKind::ekf && s_.gain_spread > 0.0; }

  /// The Kalman filters' sizes, measured coordinates and equilibrium.
  ipgen_loop_measurement measurement() const {
    return ipgen_loop_measurement{n, static_cast<int>(measured_.size()), measured_.data(), s_.equilibrium.data()};
  }

  /// ẋ = f(x, u) of the model in the scene's coordinates (x_user = P x + c, so ẋ_user = P f(x)),
  /// u in N or N m: the header's forward dynamics, no Coulomb friction; with A, also ∂f/∂x in the
  /// scene's coordinates (P A P⁻¹), exact. The EKF's model (ipgen_loop_field).
  static int field(void* context, const double x_user[], double u, double f[], double A[]) {
    const auto& self = *static_cast<const MeasuredLoop*>(context);
    const int n = self.n;
    const Eigen::VectorXd x = self.coordinates_.to_canonical(Eigen::Map<const Eigen::VectorXd>(x_user, 2 * n));
    const VectorOf<Model> q = x.head(n);
    const VectorOf<Model> qd = x.segment(n, n);
    Eigen::VectorXd derivative(2 * n);
    derivative << qd, Model::template forward_dynamics<double>(q, qd, u, self.params_);
    Eigen::Map<Eigen::VectorXd>(f, 2 * n) =
        self.coordinates_.canonical() ? derivative : Eigen::VectorXd(self.coordinates_.matrix(n) * derivative);
    if (A == nullptr) return 0;
    if constexpr (has_linearize<Model>) {
      Eigen::MatrixXd jacobian = Model::template linearize<double>(q, qd, u, self.params_).A;  // ∂f/∂x, exact
      if (!self.coordinates_.canonical()) jacobian = detail::similar(self.coordinates_.matrix(n), jacobian);
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(A, 2 * n, 2 * n) = jacobian;
      return 0;
    } else {
      throw InvalidInput({"estimator = ekf needs the model's linearize (regenerate its header)"});
    }
  }

  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  LoopSettings s_;
  Input::Feedback law_;
  double period_, gain_, design_gain_;
  ParamsOf<Model> params_;
  Coordinates coordinates_;
  NormalStream sensor_noise_, drive_noise_;
  std::vector<double> pending_;          ///< the commands sent, not yet applied (ipgen_loop_delay)
  std::vector<double> believed_;         ///< the same as the loop believes them (its assumed delay)
  double last_input_ = 0.0;              ///< the input applied over the last period [scene units]
  double pole_ = 0.0;                    ///< filter: exp(−ω_c T)
  std::vector<int> measured_;            ///< s_.measured as ipgen_loop.h takes it
  RowMajor A_, gain_rows_, process_noise_, measurement_noise_, covariance_;  ///< row-major copies, P
  std::shared_ptr<double> gain_factor_;  ///< rho, the learnt input gain over the model's (1: not learnt)
  Eigen::VectorXd y_, previous_y_, estimate_, squared_error_, work_, predict_work_;
  Eigen::VectorXd filtered_;             ///< the EKF's x: the estimate, and rho when it learns
  Eigen::VectorXd learnt_noise_;         ///< the EKF's learnt measurement variances (noise_memory)
  long samples_ = 0;
  ipgen_loop_lag lag_{};                 ///< the known lag (estimator.compensate_lag; none: zeros)
  double lag_applied_ = 0.0;             ///< the drive's input now, as the loop models it [N or N m]
  std::vector<double> means_;            ///< the inputs over the delay the model predicts with
};

}  // namespace ipsim

#if IPSIM_DEFINITIONS
namespace ipsim::detail {

IPSIM_DECL Eigen::MatrixXd similar(const Eigen::MatrixXd& P, const Eigen::MatrixXd& A) { return P * A * P.inverse(); }

}  // namespace ipsim::detail
#endif  // IPSIM_DEFINITIONS
