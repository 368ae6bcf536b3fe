// simulate_<model>: runs a resolved scene file (.cfg) with ipsim and writes the trajectory as CSV.
//
// Built once per model: CMake passes the generated header and the model tag, e.g.
//   -DIPGEN_MODEL_HEADER="cdip.hpp" -DIPGEN_MODEL=ipgen::cdip::Model
//
// Usage: simulate_<model> SCENE.cfg [--csv OUT.csv] [--method M] [--jacobian exact|dq] [--rtol X]
//                          [--atol X] [--step X] [--t-end X] [--sample X] [--max-steps N] [--energy]
//                          [--force] [--check]
//   M: bdf, adams, adams-fixed-point, erk-dp5, erk-fehlberg8 or rk4 (rk4 needs a step).
//   An existing OUT.csv is replaced only if it is a CSV this simulator wrote (its first line is
//   the header `t,theta0,...,dtheta0,...`), or with --force; never the scene file itself. The CSV
//   is written to a temporary file next to it and renamed into place. --check validates the scene
//   and options and exits without integrating or writing.
// A scene with a controller adds a column u (the input applied from each sample on) to the CSV and
// states the gain, the closed-loop poles of the linearised model and the largest |u|.
// Exit codes: 0 success, 1 integration failure, 2 bad command line, scene, parameters, settings or
// CSV path (all reported before integrating).
#ifndef IPGEN_MODEL_HEADER
#error "compile with -DIPGEN_MODEL_HEADER=\"name.hpp\" -DIPGEN_MODEL=ipgen::name::Model"
#endif
#include IPGEN_MODEL_HEADER

#include <array>
#include <cerrno>
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

using Model = IPGEN_MODEL;
constexpr int kDof = Model::kDof;

/// Bad command line, scene or parameters: reported on one line, exit code 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Options {
  std::string scene_path;
  std::string csv_path;  ///< empty: the scene path with its extension replaced by .csv
  bool energy = false;   ///< add T, V, W_in, E_diss columns and an energy balance to the summary
  bool force = false;    ///< replace an existing CSV even if this simulator did not write it
  bool check = false;    ///< validate the scene and options only: no integration, no CSV
  std::optional<ipsim::Method> method;
  std::optional<ipsim::Jacobian> jacobian;
  std::optional<double> rtol, atol, step, t_end, sample;
  std::optional<long> max_steps;
};

constexpr const char* kUsage =
    "usage: simulate SCENE.cfg [--csv OUT.csv] [--method bdf|adams|adams-fixed-point|erk-dp5|"
    "erk-fehlberg8|rk4] [--jacobian exact|dq] [--rtol X] [--atol X] [--step X] [--t-end X] [--sample X] "
    "[--max-steps N] [--energy] [--force] [--check]";

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
      std::puts(kUsage);
      std::exit(0);
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

/// The energy columns of CSV row k: T, V, input work, dissipated energy. A template, so that a
/// specialised header without energy functions compiles (the simulation refuses an energy
/// ledger for it before getting here).
template <class M>
std::array<double, 4> energy_columns(const ipsim::Result& result, std::size_t k, const ipsim::ParamsOf<M>& params) {
  if constexpr (ipsim::has_energy<M>) {
    const auto row = static_cast<Eigen::Index>(k);
    const ipsim::VectorOf<M> q = result.states.row(row).template head<M::kDof>().transpose();
    const ipsim::VectorOf<M> qd = result.states.row(row).template segment<M::kDof>(M::kDof).transpose();
    return {M::template kinetic_energy<double>(q, qd, params), M::template potential_energy<double>(q, params),
            result.input_work[k], result.dissipated_energy[k]};
  } else {
    (void)result, (void)k, (void)params;
    return {};
  }
}

/// The summary's energy balance: T + V at start and end, input work, dissipated energy.
template <class M>
void print_energy_balance(const ipsim::Result& result, const ipsim::ParamsOf<M>& params) {
  if constexpr (ipsim::has_energy<M>) {
    const double start = ipsim::mechanical_energy<M>(params, result.states.topRows(1).transpose());
    const double end = ipsim::mechanical_energy<M>(params, result.states.bottomRows(1).transpose());
    const double work = result.input_work.back();
    const double dissipated = result.dissipated_energy.back();
    std::printf(" Energy: T+V %.9g J at start, %.9g J at end, input work %.9g J, dissipated %.9g J, balance error %.3g J.",
                start, end, work, dissipated, end - (start + work - dissipated));
  }
}

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
  if (!rest.empty() && rest.back() == "u") rest.pop_back();
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
    const int fd = ::mkstemp(name.data());
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
    temporary_.clear();
  }

 private:
  std::string path_;
  std::string temporary_;
  std::FILE* out_ = nullptr;
};

/// Writes the CSV into `csv` and renames it into place, so a reader never sees a half-written
/// file and a failed run leaves any previous result untouched. Refuses (writing nothing) when a
/// value is NaN or infinite: ipsim stops before recording such a state, this guards the derived
/// columns and anything that slips through.
void write_csv(PendingCsv& csv, const std::string& path, const ipsim::Result& result,
               const ipsim::ParamsOf<Model>& params, bool energy, bool input_column) {
  std::vector<std::array<double, 4>> energies;  // each row's energy columns, computed once
  for (std::size_t k = 0; k < result.times.size(); ++k) {
    bool finite = std::isfinite(result.times[k]) && result.states.row(static_cast<Eigen::Index>(k)).allFinite();
    if (energy) {
      energies.push_back(energy_columns<Model>(result, k, params));
      for (const double value : energies.back()) finite = finite && std::isfinite(value);
    }
    if (!finite) {
      throw std::runtime_error("refusing to write `" + shown_path(path) + "`: the row at t = " + std::to_string(result.times[k]) +
                               " s has a non-finite value (NaN or inf)");
    }
  }
  std::FILE* out = csv.stream();
  std::fputs("t", out);
  for (int i = 0; i < kDof; ++i) std::fprintf(out, ",theta%d", i);
  for (int i = 0; i < kDof; ++i) std::fprintf(out, ",dtheta%d", i);
  if (energy) std::fputs(",kinetic,potential,input_work,dissipated", out);
  if (input_column) std::fputs(",u", out);
  std::fputc('\n', out);
  for (std::size_t k = 0; k < result.times.size(); ++k) {
    const auto row = static_cast<Eigen::Index>(k);
    std::fprintf(out, "%.17g", result.times[k]);
    for (Eigen::Index j = 0; j < result.states.cols(); ++j) std::fprintf(out, ",%.17g", result.states(row, j));
    if (energy) {
      for (const double value : energies[k]) std::fprintf(out, ",%.17g", value);
    }
    if (input_column) std::fprintf(out, ",%.17g", result.inputs[k]);
    std::fputc('\n', out);
  }
  csv.commit();
}

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
void print_controller(const ipsim::LinearFeedback& c, const ipsim::ParamsOf<M>& params, const ipsim::Result& result) {
  const std::string timing = c.period > 0.0 ? "sampled every " + ipsim::detail::format_number(c.period) + " s"
                                            : std::string("continuous");
  std::printf(" Controller: LQR, %s, u = -K (x - x_eq), K = %s, x_eq = %s", timing.c_str(),
              ipsim::detail::format_values(c.gain.data(), c.gain.size()).c_str(),
              ipsim::detail::format_values(c.equilibrium.data(), c.equilibrium.size()).c_str());
  if (std::isfinite(c.saturation)) std::printf(", |u| <= %g", c.saturation);
  if constexpr (ipsim::has_linearize<M>) {
    const Eigen::VectorXcd poles = ipsim::closed_loop_poles<M>(params, c);
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
  std::printf("; largest |u| %.6g.", result.max_abs_input);
}

void print_summary(const Options& options, const ipsim::scene::Scene<Model>& scene, const ipsim::Result& result) {
  const ipsim::Settings<Model>& s = scene.settings;
  const ipsim::Statistics& st = result.stats;
  const Eigen::VectorXd final_state = result.states.bottomRows(1).transpose();
  std::printf(
      "scene %s: model %s (%s, %d link%s), input %s, method %s, t = 0 to %g s, %zu samples written to %s. "
      "Final state theta = %s, dtheta = %s. %s, %ld restart%s at input discontinuities. Wall time %.3g s.",
      abbreviate(scene.name).c_str(), Model::kName, Model::kType, Model::kLinks, Model::kLinks == 1 ? "" : "s",
      ipsim::to_string(s.input.kind), ipsim::to_string(s.method), s.t_end, result.times.size(),
      shown_path(options.csv_path).c_str(), ipsim::detail::format_values(final_state.data(), kDof).c_str(),
      ipsim::detail::format_values(final_state.data() + kDof, kDof).c_str(), describe_run(s, st).c_str(), st.restarts,
      st.restarts == 1 ? "" : "s", result.wall_time);
  if (options.energy) print_energy_balance<Model>(result, scene.params);
  if (scene.controller) print_controller<Model>(*scene.controller, scene.params, result);
  std::putchar('\n');
  for (const auto& warning : result.warnings) std::fprintf(stderr, "simulate: warning: %s\n", warning.c_str());
}

int run(int argc, char** argv) {
  Options options = parse_command_line(argc, argv);
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
  PendingCsv csv(options.csv_path, options.scene_path, options.force);  // before integrating
  const ipsim::Result result = ipsim::simulate<Model>(scene.params, s);
  write_csv(csv, options.csv_path, result, scene.params, options.energy, scene.controller.has_value());
  print_summary(options, scene, result);
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
