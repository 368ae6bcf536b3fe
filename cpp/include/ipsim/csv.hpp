// CsvSink: writes each sample as a CSV row the moment simulate() reaches it (simulate_<model>'s
// output), so a run of any length needs the memory of one row. Columns:
//   t,theta0,…,thetaN,dtheta0,…,dthetaN[,kinetic,potential,input_work,dissipated][,u | ,u1,…,um][,y_…,hat_…][,phase]
// (u1..um: a fixed chain with m > 1 inputs, set_inputs)
// every value printed with %.17g (round-trips to the same double). The state columns are in the
// rig's coordinates when set_coordinates() says so (ipsim/coordinates.hpp), else in ipgen's.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <functional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ipsim/coordinates.hpp"
#include "ipsim/model.hpp"
#include "ipsim/sink.hpp"

namespace ipsim {

/// Writes the samples of a run of `Model` to an open stdio stream, one CSV row each, and keeps
/// what a summary needs (first and last sample, count). Refuses a row with a NaN or infinite
/// value (throws std::runtime_error): ipsim never records such a state, this guards the derived
/// energy columns and anything that slips through. A write error (disk full, file size limit)
/// throws at the row where it happens.
template <class Model>
class CsvSink : public SampleSink {
 public:
  /// \param out            open stream, written from its current position; not closed here
  /// \param params         the model's parameters (for the energy columns)
  /// \param energy_columns add kinetic, potential, input_work, dissipated [J] (needs the energy
  ///                       ledger in the settings, and a model with energy functions)
  /// \param input_column   add u [N or N m]
  /// \param name           the file's name for messages
  CsvSink(std::FILE* out, const ParamsOf<Model>& params, bool energy_columns, bool input_column, std::string name)
      : out_(out), params_(params), energy_(energy_columns), input_(input_column), name_(std::move(name)) {}

  void begin(std::size_t /*samples*/, int state_size, bool /*energy_ledger*/) override {
    std::fputs("t", out_);
    for (int i = 0; i < dof_of<Model>(); ++i) std::fprintf(out_, ",theta%d", i);
    for (int i = 0; i < dof_of<Model>(); ++i) std::fprintf(out_, ",dtheta%d", i);
    if (energy_) std::fputs(",kinetic,potential,input_work,dissipated", out_);
    if (inputs_ > 1) {
      for (int k = 1; k <= inputs_; ++k) std::fprintf(out_, ",u%d", k);
    } else if (input_) {
      std::fputs(",u", out_);
    }
    for (const auto& name : extra_names_) std::fprintf(out_, ",%s", name.c_str());
    if (phase_) std::fputs(",phase", out_);
    std::fputc('\n', out_);
    first_ = Eigen::VectorXd::Zero(state_size);
    last_ = Eigen::VectorXd::Zero(state_size);
    check_stream();
  }

  bool record(const Sample& sample) override {
    const auto x = sample.x();
    const std::array<double, 4> energies = energy_ ? energy_columns(sample) : std::array<double, 4>{};
    bool finite = std::isfinite(sample.t) && x.allFinite() && std::isfinite(sample.input);
    for (const double value : energies) finite = finite && std::isfinite(value);
    if (!finite) {
      throw std::runtime_error("refusing to write `" + name_ + "`: the row at t = " + std::to_string(sample.t) +
                               " s has a non-finite value (NaN or inf)");
    }
    std::fprintf(out_, "%.17g", sample.t);
    if (coordinates_.canonical()) {
      for (Eigen::Index j = 0; j < x.size(); ++j) std::fprintf(out_, ",%.17g", x(j));
    } else {
      const Eigen::VectorXd user = coordinates_.to_user(x);
      for (Eigen::Index j = 0; j < user.size(); ++j) std::fprintf(out_, ",%.17g", user(j));
    }
    if (energy_) {
      for (const double value : energies) std::fprintf(out_, ",%.17g", value);
    }
    if (inputs_ > 1) {
      std::fprintf(out_, ",%.17g", sample.input);
      for (int k = 0; k < sample.more_count; ++k) {
        if (!std::isfinite(sample.more_inputs[k])) {
          throw std::runtime_error("refusing to write `" + name_ + "`: the row at t = " + std::to_string(sample.t) +
                                   " s has a non-finite input (NaN or inf)");
        }
        std::fprintf(out_, ",%.17g", sample.more_inputs[k]);
      }
    } else if (input_) {
      std::fprintf(out_, ",%.17g", sample.input / input_gain_);
    }
    if (extra_) {
      const Eigen::VectorXd values = extra_();
      if (!values.allFinite()) {
        throw std::runtime_error("refusing to write `" + name_ + "`: the row at t = " + std::to_string(sample.t) +
                                 " s has a non-finite measurement or estimate (NaN or inf)");
      }
      for (Eigen::Index j = 0; j < values.size(); ++j) std::fprintf(out_, ",%.17g", values(j));
    }
    if (phase_) std::fprintf(out_, ",%s", phase_());
    std::fputc('\n', out_);
    check_stream();
    if (rows_ == 0) first_ = x;
    last_ = x;
    last_t_ = sample.t;
    last_input_work_ = sample.input_work;
    last_dissipated_ = sample.dissipated_energy;
    ++rows_;
    return true;
  }

  /// The u column is the applied force or torque divided by `gain` (> 0; default 1): with a DC
  /// motor, gain = b [N or N m per volt] writes u in volts.
  void set_input_gain(double gain) noexcept { input_gain_ = gain; }

  /// A fixed chain's m > 1 inputs: the columns u1..um (in place of u, always written) from the
  /// samples' input and more_inputs. Call before the run.
  void set_inputs(int inputs) noexcept { inputs_ = inputs; }

  /// Writes the state columns in the rig's `coordinates` (default: ipgen's). first_state() and
  /// last_state() stay in ipgen's. Call before the run.
  void set_coordinates(const Coordinates& coordinates) { coordinates_ = coordinates; }
  const Coordinates& coordinates() const noexcept { return coordinates_; }

  /// Adds a last column `phase` whose text at each row is `phase()` (a swing-up's phase: swing,
  /// track or hold). Call before the run.
  void phase_column(std::function<const char*()> phase) { phase_ = std::move(phase); }

  /// Adds columns `names` (after u, before phase, which stays last) whose values at each row are `values()` (the measured loop's
  /// y_* and hat_* columns, sensors.hpp). Call before the run.
  void extra_columns(std::vector<std::string> names, std::function<Eigen::VectorXd()> values) {
    extra_names_ = std::move(names);
    extra_ = std::move(values);
  }

  /// Rows written (not counting the header).
  std::size_t rows() const noexcept { return rows_; }
  /// The first and the last state written, x = [θ; θ̇], in ipgen's coordinates.
  const Eigen::VectorXd& first_state() const noexcept { return first_; }
  const Eigen::VectorXd& last_state() const noexcept { return last_; }
  /// Time of the last row [s].
  double last_time() const noexcept { return last_t_; }
  /// The energy ledger at the last row [J] (0 without it).
  double last_input_work() const noexcept { return last_input_work_; }
  double last_dissipated_energy() const noexcept { return last_dissipated_; }

 private:
  /// T, V, W_in, E_diss of a sample. A specialised header without energy functions compiles
  /// (simulate() refuses an energy ledger for it before any sample).
  std::array<double, 4> energy_columns(const Sample& sample) const {
    if constexpr (has_energy<Model>) {
      const int n = dof_of<Model>();
      const VectorOf<Model> q = sample.x().head(n);
      const VectorOf<Model> qd = sample.x().segment(n, n);
      return {Model::template kinetic_energy<double>(q, qd, params_),
              Model::template potential_energy<double>(q, params_), sample.input_work, sample.dissipated_energy};
    } else {
      (void)sample;
      return {};
    }
  }

  void check_stream() const {
    if (std::ferror(out_) != 0) throw std::runtime_error("error while writing `" + name_ + "`");
  }

  std::FILE* out_;
  const ParamsOf<Model>& params_;
  bool energy_, input_;
  std::string name_;
  std::function<const char*()> phase_;
  std::vector<std::string> extra_names_;
  std::function<Eigen::VectorXd()> extra_;
  std::size_t rows_ = 0;
  Eigen::VectorXd first_, last_;
  double last_t_ = 0.0, last_input_work_ = 0.0, last_dissipated_ = 0.0;
  double input_gain_ = 1.0;
  int inputs_ = 1;
  Coordinates coordinates_;
};

}  // namespace ipsim
