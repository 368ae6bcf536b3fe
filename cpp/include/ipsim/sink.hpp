// Where simulate() puts the samples: a SampleSink receives them one by one, in time order, as the
// integration proceeds. MemorySink keeps them all in a Result (what simulate(params, settings)
// returns); a sink that writes each sample to a file and forgets it (simulate_<model>'s CSV)
// keeps the memory of a run flat however many samples it has.
#pragma once

#include <cstddef>

#include <Eigen/Core>

#include "ipsim/result.hpp"

namespace ipsim {

/// One sample of the trajectory, valid during SampleSink::record only.
struct Sample {
  double t = 0.0;                 ///< time [s]
  const double* state = nullptr;  ///< x = [θ; θ̇], state_size = 2·kDof entries
  int state_size = 0;
  /// W_in(t) = ∫₀ᵗ u θ̇0 dt and E_diss(t) = ∫₀ᵗ 2D dt [J] when the energy ledger is on, else 0.
  double input_work = 0.0, dissipated_energy = 0.0;
  /// u [N or N m] at t: applied from t on (at t_end: the value applied just before).
  double input = 0.0;
  /// A fixed chain with m > 1 inputs: u_2..u_m at t (more_count = m − 1 entries), else none.
  const double* more_inputs = nullptr;
  int more_count = 0;

  /// The state as an Eigen vector (a view of `state`).
  Eigen::Map<const Eigen::VectorXd> x() const { return {state, state_size}; }
};

/// Receives the samples of a run.
class SampleSink {
 public:
  virtual ~SampleSink() = default;
  /// Called once before the first sample: the number of samples a run to t_end records, the
  /// state size 2·kDof and whether samples carry the energy ledger.
  virtual void begin(std::size_t /*samples*/, int /*state_size*/, bool /*energy_ledger*/) {}
  /// Called for each sample, in time order. Return false to stop the run after this sample:
  /// simulate() then returns with Result::stopped_early set.
  virtual bool record(const Sample& sample) = 0;
};

/// Keeps every sample in a Result: times, states, inputs and (with the energy ledger)
/// input_work and dissipated_energy.
class MemorySink : public SampleSink {
 public:
  explicit MemorySink(Result& result) : result_(result) {}

  void begin(std::size_t samples, int state_size, bool energy_ledger) override {
    result_.times.reserve(samples);
    result_.states.resize(static_cast<Eigen::Index>(samples), state_size);
    result_.inputs.reserve(samples);
    if (energy_ledger) {
      result_.input_work.reserve(samples);
      result_.dissipated_energy.reserve(samples);
    }
    energy_ledger_ = energy_ledger;
  }

  bool record(const Sample& sample) override {
    const auto row = static_cast<Eigen::Index>(result_.times.size());
    if (row >= result_.states.rows()) result_.states.conservativeResize(row + 1, sample.state_size);
    result_.times.push_back(sample.t);
    result_.states.row(row) = sample.x().transpose();
    if (energy_ledger_) {
      result_.input_work.push_back(sample.input_work);
      result_.dissipated_energy.push_back(sample.dissipated_energy);
    }
    result_.inputs.push_back(sample.input);
    return true;
  }

  /// Drops the rows reserved for samples never recorded (a run stopped early).
  void finish() {
    const auto rows = static_cast<Eigen::Index>(result_.times.size());
    if (rows < result_.states.rows()) result_.states.conservativeResize(rows, Eigen::NoChange);
  }

 private:
  Result& result_;
  bool energy_ledger_ = false;
};

}  // namespace ipsim
