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
//   control   u_k = law(t_k, x̂_k) (the LQR, the swing-up law or TVLQR, saturated)
//   delay     u_k is applied from t_{k+j} (delay = j·T); before the first command arrives u = 0
//   drive     the command applied on [t_k, t_k+1) gets + N(0, σ_u²) (drawn once per interval, held)
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
#include <deque>
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

namespace ipsim {

namespace detail {
// The estimators' algebra on dynamic-size matrices (the same for every model, so not templates:
// linkage.hpp). x̂ = x̂⁻ + K (y − C x̂⁻) with a fixed gain K (kalman).
Eigen::VectorXd kalman_correct(const Eigen::VectorXd& predicted, const Eigen::MatrixXd& gain, const Eigen::VectorXd& y,
                               const Eigen::MatrixXd& C);
// x̂⁻ = x_eq + A (x̂ − x_eq) + B Δu (kalman).
Eigen::VectorXd kalman_predict(const Eigen::VectorXd& equilibrium, const Eigen::MatrixXd& A, const Eigen::VectorXd& estimate,
                               const Eigen::VectorXd& B, double du);
// The EKF's update: K = P Cᵀ S⁻¹ with S = C P Cᵀ + R, x̂ = x̂⁻ + K (y − C x̂⁻), P in Joseph form.
void ekf_correct(const Eigen::MatrixXd& C, const Eigen::MatrixXd& R, const Eigen::VectorXd& y,
                 const Eigen::VectorXd& predicted, Eigen::VectorXd& estimate, Eigen::MatrixXd& covariance);
// P A P⁻¹: a Jacobian in the rig's coordinates.
Eigen::MatrixXd similar(const Eigen::MatrixXd& P, const Eigen::MatrixXd& A);
// The EKF's covariance prediction P = F P Fᵀ + Q with F = I + T A + (T A)²/2.
void ekf_predict_covariance(double T, const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, Eigen::MatrixXd& covariance);
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
  long delay_periods = 0;          ///< delay = delay_periods · period
  std::uint64_t seed = 0;
  double drive_noise = 0.0;        ///< σ_u of the applied input [input unit]
  EstimatorKind kind = EstimatorKind::exact;
  double cutoff = 0.0;             ///< filter: ω_c [rad/s]
  // kalman: x̂⁺ = x_eq + A (x̂ − x_eq) + B (ū − u_eq), x̂ = x̂⁻ + M (y − C x̂⁻); ekf: x_eq (start), Qn, Rn
  Eigen::MatrixXd A, gain, process_noise, measurement_noise;
  Eigen::VectorXd B, equilibrium;
  double input_equilibrium = 0.0;
};

/// One run's measure → estimate → control → delay → drive loop around a sampled control law.
/// step() is called once per sampling instant (by the sampled Input it wraps) with the true state
/// x(t_k) in ipgen's coordinates and returns the force or torque applied on [t_k, t_k+1) [N or N m].
template <class Model>
class MeasuredLoop {
 public:
  int n = dof_of<Model>();  // degrees of freedom (before the members that use it)

  MeasuredLoop(LoopSettings settings, Input::Feedback law, double period, double input_gain,
               const ParamsOf<Model>& params, Coordinates coordinates)
      : s_(std::move(settings)),
        law_(std::move(law)),
        period_(period),
        gain_(input_gain),
        params_(with_rod_links<Model>(params)),
        coordinates_(coordinates),
        sensor_noise_(s_.seed, 1),
        drive_noise_(s_.seed, 2) {
    const auto m = static_cast<Eigen::Index>(s_.measured.size());
    y_ = Eigen::VectorXd::Zero(m);
    previous_y_ = y_;
    estimate_ = Eigen::VectorXd::Zero(2 * n);
    rate_ = Eigen::VectorXd::Zero(n);
    squared_error_ = Eigen::VectorXd::Zero(2 * n);
    C_ = Eigen::MatrixXd::Zero(m, 2 * n);
    for (Eigen::Index i = 0; i < m; ++i) C_(i, s_.measured[static_cast<std::size_t>(i)]) = 1.0;
  }

  /// The command applied on [t, t + period) for the true state x (ipgen's coordinates).
  double step(double t, const Eigen::VectorXd& x) {
    const Eigen::VectorXd user = coordinates_.to_user(x);
    measure(user);
    estimate(user);
    const Eigen::VectorXd seen = s_.kind == EstimatorKind::exact ? x : coordinates_.to_canonical(estimate_);
    const double command = law_(t, seen);  // N or N m (saturated)
    commands_.push_back(command);
    double applied = 0.0;  // the command that reaches the drive now (u = 0 before the first arrives)
    if (static_cast<long>(commands_.size()) > s_.delay_periods) {
      applied = commands_.front();
      commands_.pop_front();
    }
    predict(applied / gain_);
    const double noise = drive_noise_();
    ++samples_;
    return applied + gain_ * s_.drive_noise * noise;
  }

  /// Column names after the CSV's others: y_theta<i> per measured, hat_theta<i>, hat_dtheta<i>.
  std::vector<std::string> column_names() const {
    std::vector<std::string> names;
    for (const int i : s_.measured) names.push_back("y_theta" + std::to_string(i));
    for (int i = 0; i < n; ++i) names.push_back("hat_theta" + std::to_string(i));
    for (int i = 0; i < n; ++i) names.push_back("hat_dtheta" + std::to_string(i));
    return names;
  }

  /// The values of column_names() at the latest sampling instant (held between instants).
  Eigen::VectorXd column_values() const {
    Eigen::VectorXd values(y_.size() + 2 * n);
    values << y_, estimate_;
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
    previous_y_ = y_;
    for (std::size_t j = 0; j < s_.measured.size(); ++j) {
      const int i = s_.measured[j];
      double value = user(i);
      if (s_.resolution[j] > 0.0) {
        const double delta = (is_position(i) ? 1.0 : 2.0 * kPi) / s_.resolution[j];
        const double z = s_.zero.empty() ? 0.0 : s_.zero[j];  // counts from the encoder's zero pose
        value = z + delta * std::floor((value - z) / delta + 0.5);
      }
      const double noise = sensor_noise_();  // drawn even when σ = 0: the stream stays aligned
      y_(static_cast<Eigen::Index>(j)) = value + s_.noise[j] * noise;
    }
  }

  void estimate(const Eigen::VectorXd& user) {
    const bool first = samples_ == 0;
    switch (s_.kind) {
      case EstimatorKind::exact: estimate_ = user; break;
      case EstimatorKind::difference:
      case EstimatorKind::filter: {  // every angle measured, in order
        const Eigen::VectorXd step = first ? Eigen::VectorXd::Zero(n) : Eigen::VectorXd(y_ - previous_y_);
        if (s_.kind == EstimatorKind::difference) {
          rate_ = step / period_;
        } else {
          rate_ = std::exp(-s_.cutoff * period_) * rate_ + s_.cutoff * step;
        }
        estimate_ << y_, rate_;
        break;
      }
      case EstimatorKind::kalman:
        if (first) predicted_ = start_state();
        estimate_ = detail::kalman_correct(predicted_, s_.gain, y_, C_);
        break;
      case EstimatorKind::ekf: {
        if (first) {
          predicted_ = start_state();
          covariance_ = Eigen::MatrixXd::Identity(2 * n, 2 * n);
          for (std::size_t j = 0; j < s_.measured.size(); ++j) {
            const auto i = s_.measured[j];
            covariance_(i, i) = s_.measurement_noise(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(j));
          }
        }
        detail::ekf_correct(C_, s_.measurement_noise, y_, predicted_, estimate_, covariance_);
        break;
      }
    }
    squared_error_ += (estimate_ - user).cwiseAbs2();
  }

  /// x̂_{0|−1}: measured angles y_0, unmeasured ones at the equilibrium, rates 0.
  Eigen::VectorXd start_state() const {
    Eigen::VectorXd x = Eigen::VectorXd::Zero(2 * n);
    x.head(n) = s_.equilibrium.head(n);
    for (std::size_t j = 0; j < s_.measured.size(); ++j) x(s_.measured[j]) = y_(static_cast<Eigen::Index>(j));
    return x;
  }

  /// x̂_{k+1|k} from x̂_{k|k} and ū_k (the command applied on [t_k, t_k+1), scene units).
  void predict(double u) {
    if (s_.kind == EstimatorKind::kalman) {
      predicted_ = detail::kalman_predict(s_.equilibrium, s_.A, estimate_, s_.B, u - s_.input_equilibrium);
    } else if (s_.kind == EstimatorKind::ekf) {
      predict_ekf(u * gain_);
    }
  }

  /// ẋ = f(x, u) of the model in the scene's coordinates (x_user = P x + c, so ẋ_user = P f(x)),
  /// u in N or N m: the header's forward dynamics, no Coulomb friction.
  Eigen::VectorXd derivative(const Eigen::VectorXd& x_user, double u) const {
    const Eigen::VectorXd x = coordinates_.to_canonical(x_user);
    const VectorOf<Model> q = x.head(n);
    const VectorOf<Model> qd = x.segment(n, n);
    Eigen::VectorXd f(2 * n);
    f << qd, Model::template forward_dynamics<double>(q, qd, u, params_);
    return coordinates_.canonical() ? f : Eigen::VectorXd(coordinates_.matrix(n) * f);
  }

  void predict_ekf(double u) {
    if constexpr (has_linearize<Model>) {
      const double T = period_;
      const Eigen::VectorXd& x = estimate_;
      const Eigen::VectorXd k1 = derivative(x, u);
      const Eigen::VectorXd k2 = derivative(x + 0.5 * T * k1, u);
      const Eigen::VectorXd k3 = derivative(x + 0.5 * T * k2, u);
      const Eigen::VectorXd k4 = derivative(x + T * k3, u);
      predicted_ = x + T / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
      const Eigen::VectorXd canonical = coordinates_.to_canonical(x);
      const VectorOf<Model> q = canonical.head(n);
      const VectorOf<Model> qd = canonical.segment(n, n);
      Eigen::MatrixXd A = Model::template linearize<double>(q, qd, u, params_).A;  // ∂f/∂x, exact
      if (!coordinates_.canonical()) {  // A_user = P A P⁻¹
        const Eigen::MatrixXd P = coordinates_.matrix(n);
        A = detail::similar(P, A);
      }
      detail::ekf_predict_covariance(T, A, s_.process_noise, covariance_);
    } else {
      (void)u;
      throw InvalidInput({"estimator = ekf needs the model's linearize (regenerate its header)"});
    }
  }

  LoopSettings s_;
  Input::Feedback law_;
  double period_, gain_;
  ParamsOf<Model> params_;
  Coordinates coordinates_;
  NormalStream sensor_noise_, drive_noise_;
  std::deque<double> commands_;
  Eigen::VectorXd y_, previous_y_, estimate_, rate_, predicted_, squared_error_;
  Eigen::MatrixXd C_, covariance_;
  long samples_ = 0;
};

}  // namespace ipsim

#if IPSIM_DEFINITIONS
namespace ipsim::detail {

IPSIM_DECL Eigen::VectorXd kalman_correct(const Eigen::VectorXd& predicted, const Eigen::MatrixXd& gain,
                                          const Eigen::VectorXd& y, const Eigen::MatrixXd& C) {
  return predicted + gain * (y - C * predicted);
}

IPSIM_DECL Eigen::VectorXd kalman_predict(const Eigen::VectorXd& equilibrium, const Eigen::MatrixXd& A,
                                          const Eigen::VectorXd& estimate, const Eigen::VectorXd& B, double du) {
  return equilibrium + A * (estimate - equilibrium) + B * du;
}

IPSIM_DECL void ekf_correct(const Eigen::MatrixXd& C, const Eigen::MatrixXd& R, const Eigen::VectorXd& y,
                            const Eigen::VectorXd& predicted, Eigen::VectorXd& estimate, Eigen::MatrixXd& covariance) {
  const Eigen::MatrixXd innovation = C * covariance * C.transpose() + R;
  const Eigen::MatrixXd K = innovation.ldlt().solve(C * covariance).transpose();  // P Cᵀ S⁻¹ (S, P symmetric)
  estimate = predicted + K * (y - C * predicted);
  const Eigen::MatrixXd joseph = Eigen::MatrixXd::Identity(covariance.rows(), covariance.cols()) - K * C;
  covariance = joseph * covariance * joseph.transpose() + K * R * K.transpose();
}

IPSIM_DECL Eigen::MatrixXd similar(const Eigen::MatrixXd& P, const Eigen::MatrixXd& A) { return P * A * P.inverse(); }

IPSIM_DECL void ekf_predict_covariance(double T, const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q,
                                       Eigen::MatrixXd& covariance) {
  const Eigen::MatrixXd TA = T * A;
  const Eigen::MatrixXd F = Eigen::MatrixXd::Identity(A.rows(), A.cols()) + TA + 0.5 * TA * TA;
  covariance = F * covariance * F.transpose() + Q;
}

}  // namespace ipsim::detail
#endif  // IPSIM_DEFINITIONS
