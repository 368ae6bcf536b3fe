// ipgen's generated functions against Pinocchio's algorithms on the same pendulum, in one binary.
//
// Build (bench/evaluation.py does this for each system):
//   g++ -O3 -march=native -DNDEBUG -DIPGEN_HEADER='"classical3.hpp"' -DIPGEN_NAMESPACE=classical3 \
//       bench.cpp reference.o
// Run: bench [rounds] [milliseconds per round, all contenders]. Prints, one per line,
//   check <function> <relative difference>        at kChecked random states, and then, if all agree,
//   time <function> <algorithm> <calls per batch> <ipgen ns> <Pinocchio ns, local> [<world>]  (medians)
// Exit status 1 when a pair disagrees: then no timing is printed.
//
// Coordinates: ipgen uses absolute link angles th (clockwise from upright), Pinocchio relative
// joint angles q = T th, with T(i, i) = 1, T(i, i - 1) = -1 (i >= 2) and T(0, 0) = +1 for a cart,
// -1 for an arm (ipgen's arm angle turns clockwise seen from above, Pinocchio's RZ the other way).
// Then M_abs = T^T M_rel T, bias_abs = T^T nle, qdd_abs = T^-1 qdd_rel, tau_rel = T^-T (u, 0, ...).
// The mapping is done once, before timing: each side is timed in its own coordinates.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Dense>

#include "reference.hpp"
#include IPGEN_HEADER

namespace model = ipgen::IPGEN_NAMESPACE;

namespace {

constexpr int kDof = model::kDof;
constexpr int kStates = 256;  // ring buffer of inputs, a power of two
constexpr int kChecked = 10;
constexpr double kTolerance = 1e-10;
constexpr bool kRotary = std::string_view(model::Model::kType) == "rotary";

using Vec = model::Vector<double>;
using Mat = model::Matrix<double>;

model::Params<double> params;
std::vector<Vec> q, qd;
std::vector<double> u;
std::vector<Eigen::VectorXd> q_rel, v_rel, tau_rel;
Eigen::MatrixXd T;  // q_rel = T q

// Results go to globals, so the compiler must compute every entry.
Mat out_M;
Vec out_b, out_a;
volatile double sink = 0.0;

#define NOINLINE __attribute__((noinline))

NOINLINE const Mat& ipgen_mass_matrix(int i) { return out_M = model::mass_matrix(q[i], params); }
NOINLINE const Vec& ipgen_bias(int i) { return out_b = model::bias(q[i], qd[i], params); }
NOINLINE const Vec& ipgen_forward_dynamics(int i) {
  return out_a = model::forward_dynamics(q[i], qd[i], u[i], params);
}
NOINLINE const Eigen::MatrixXd& pin_crba(int i) { return reference::crba(q_rel[i]); }
NOINLINE const Eigen::MatrixXd& pin_crba_world(int i) { return reference::crba(q_rel[i], true); }
NOINLINE const Eigen::VectorXd& pin_nle(int i) { return reference::nonlinear_effects(q_rel[i], v_rel[i]); }
NOINLINE const Eigen::VectorXd& pin_aba(int i) { return reference::aba(q_rel[i], v_rel[i], tau_rel[i]); }
NOINLINE const Eigen::VectorXd& pin_aba_world(int i) {
  return reference::aba(q_rel[i], v_rel[i], tau_rel[i], true);
}

void make_inputs() {
  std::mt19937_64 random(2013);
  auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(random); };
  for (int k = 0; k < kDof; ++k) {
    params.m[k] = uniform(0.1, 2.0);
    params.l[k] = uniform(0.2, 1.5);
    params.delta[k] = 0.0;  // Pinocchio's algorithms have no joint damping: compare without it
  }
  params.g = 9.81;
  reference::build({kRotary, std::vector<double>(params.m.begin(), params.m.end()),
                    std::vector<double>(params.l.begin(), params.l.end()), params.g});

  T = Eigen::MatrixXd::Identity(kDof, kDof);
  T(0, 0) = kRotary ? -1.0 : 1.0;
  for (int k = 2; k < kDof; ++k) T(k, k - 1) = -1.0;
  for (int s = 0; s < kStates; ++s) {
    Vec angles, rates;
    for (int k = 0; k < kDof; ++k) {
      angles(k) = uniform(-M_PI, M_PI);
      rates(k) = uniform(-3.0, 3.0);
    }
    q.push_back(angles);
    qd.push_back(rates);
    u.push_back(uniform(-2.0, 2.0));
    q_rel.push_back(T * angles);
    v_rel.push_back(T * rates);
    Eigen::VectorXd tau = Eigen::VectorXd::Zero(kDof);
    tau(0) = T(0, 0) * u.back();  // T^-T (u, 0, ..., 0): T is block diagonal with T(0, 0) = +-1
    tau_rel.push_back(tau);
  }
}

double relative_difference(const Eigen::MatrixXd& ours, const Eigen::MatrixXd& theirs) {
  const double scale = std::max(theirs.cwiseAbs().maxCoeff(), 1e-300);
  return (ours - theirs).cwiseAbs().maxCoeff() / scale;
}

// Largest relative difference over kChecked states, for each of the three pairs (both conventions).
std::array<double, 3> compare() {
  std::array<double, 3> worst{};
  for (int s = 0; s < kChecked; ++s) {
    for (bool world : {false, true}) {
      Eigen::MatrixXd M_rel = world ? pin_crba_world(s) : pin_crba(s);
      M_rel.triangularView<Eigen::StrictlyLower>() = M_rel.transpose().triangularView<Eigen::StrictlyLower>();
      const Eigen::MatrixXd M_abs = T.transpose() * M_rel * T;
      const Eigen::VectorXd b_abs = T.transpose() * pin_nle(s);
      const Eigen::VectorXd a_abs = T.triangularView<Eigen::Lower>().solve(world ? pin_aba_world(s) : pin_aba(s));
      worst[0] = std::max(worst[0], relative_difference(ipgen_mass_matrix(s), M_abs));
      worst[1] = std::max(worst[1], relative_difference(ipgen_bias(s), b_abs));
      worst[2] = std::max(worst[2], relative_difference(ipgen_forward_dynamics(s), a_abs));
    }
  }
  return worst;
}

// CPU time of this thread [ns]: time spent preempted by other processes of the (shared) machine
// does not count, which keeps the medians stable under load.
double thread_ns() {
  timespec now{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) * 1e9 + static_cast<double>(now.tv_nsec);
}

// Nanoseconds per call of f over `calls` calls, cycling through the input ring.
template <typename F>
double batch(F f, long calls) {
  double accumulated = 0.0;
  const double start = thread_ns();
  for (long k = 0; k < calls; ++k) accumulated += f(static_cast<int>(k & (kStates - 1)))(0, 0);
  const double stop = thread_ns();
  sink = sink + accumulated;
  return (stop - start) / static_cast<double>(calls);
}

// One contender: runs `calls` calls, returns nanoseconds per call.
using Timer = double (*)(long calls);
template <auto f>
double timed(long calls) {
  return batch(f, calls);
}

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

// Warm-up, then rounds of one batch per contender in rotating order (AB, BA, ... for two),
// each batch ~milliseconds / contenders; prints the median of each contender.
void race(const char* ours, const char* theirs, const std::vector<Timer>& contenders, int rounds,
          double milliseconds) {
  long calls = 16;
  double slowest = 0.0;
  while (slowest * static_cast<double>(calls) < 1e6) {  // warm-up: until a batch takes 1 ms
    calls *= 2;
    slowest = 0.0;
    for (Timer t : contenders) slowest = std::max(slowest, t(calls));
  }
  const std::size_t n = contenders.size();
  calls = std::max(16L, static_cast<long>(milliseconds * 1e6 / slowest / static_cast<double>(n)));
  std::vector<std::vector<double>> times(n);
  for (int r = 0; r < rounds; ++r) {
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t which = (static_cast<std::size_t>(r) + k) % n;
      times[which].push_back(contenders[which](calls));
    }
  }
  std::printf("time %s %s %ld", ours, theirs, calls);
  for (const auto& t : times) std::printf(" %.3f", median(t));
  std::printf("\n");
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  const int rounds = argc > 1 ? std::atoi(argv[1]) : 30;
  const double milliseconds = argc > 2 ? std::atof(argv[2]) : 5.0;
  make_inputs();
  const std::array<double, 3> worst = compare();
  const char* names[] = {"mass_matrix", "bias", "forward_dynamics"};
  bool agree = true;
  for (int k = 0; k < 3; ++k) {
    std::printf("check %s %.3e\n", names[k], worst[k]);
    agree = agree && worst[k] <= kTolerance;
  }
  if (!agree) {
    std::printf("disagree: ipgen and Pinocchio differ by more than %g relative; no timing\n", kTolerance);
    return 1;
  }
  race("mass_matrix", "crba", {timed<ipgen_mass_matrix>, timed<pin_crba>, timed<pin_crba_world>}, rounds,
       milliseconds);
  race("bias", "nonLinearEffects", {timed<ipgen_bias>, timed<pin_nle>}, rounds, milliseconds);
  race("forward_dynamics", "aba", {timed<ipgen_forward_dynamics>, timed<pin_aba>, timed<pin_aba_world>}, rounds,
       milliseconds);
  return 0;
}
