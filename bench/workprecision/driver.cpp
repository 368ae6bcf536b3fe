// Work–precision driver for one model: runs a resolved scene with every ipsim method over a sweep
// of tolerances (or steps), against a reference solution, and prints one JSON object per line.
//
//   driver SCENE.cfg --reference OUT.csv [--sample S] [--repeat-seconds T] [--max-repeats N]
//          [--rk4-steps a,b,...] [--rtols a,b,...] [--check-step H] [--reference-method M]
//
// Built by bench/workprecision/build.py with -DIPGEN_MODEL_HEADER="name.hpp"
// -DIPGEN_MODEL=ipgen::name::Model; or, as ipgen run's simulator is, for every model with
// -DIPSIM_RUNTIME_MODEL (link -ldl), then run with `--model LIB` first (a model library of
// `--emit library`, loaded at run time: bench/runtime.py measures it against the former). Lines printed:
//   {"kind": "reference", ...}   the reference (--reference-method, default erk-fehlberg8, at rtol
//                                 1e-13) and its agreement with rk4 at a tiny step (--check-step)
//                                 and with bdf at rtol 1e-13; written to OUT.csv
//   {"kind": "run", ...}         one setting: errors against the reference, median wall time per
//                                 simulated second over repeats, integrator statistics
#if defined(IPSIM_RUNTIME_MODEL)
#include "ipsim/runtime_model.hpp"
#else
#include IPGEN_MODEL_HEADER
#endif

#include <algorithm>
#include <chrono>
#include <optional>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "ipsim/ipsim.hpp"
#include "ipsim/scene.hpp"

namespace {

#if defined(IPSIM_RUNTIME_MODEL)
using Model = ipsim::RuntimeModel;
#else
using Model = IPGEN_MODEL;
#endif

std::vector<double> parse_list(const std::string& text) {
  std::vector<double> values;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = text.find(',', start);
    const std::string word = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (!word.empty()) values.push_back(std::strtod(word.c_str(), nullptr));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return values;
}

struct Errors {
  double final_time = 0.0;  ///< max |x(t_end) − x_ref(t_end)| over the state components
  double trajectory = 0.0;  ///< max over samples and components
};

Errors errors(const ipsim::Result& run, const ipsim::Result& reference) {
  Errors e;
  if (run.states.rows() != reference.states.rows() || !run.states.allFinite()) {
    e.final_time = e.trajectory = INFINITY;
    return e;
  }
  const Eigen::MatrixXd difference = (run.states - reference.states).cwiseAbs();
  e.final_time = difference.bottomRows(1).maxCoeff();
  e.trajectory = difference.maxCoeff();
  return e;
}

void write_csv(const std::string& path, const ipsim::Result& r) {
  std::FILE* out = std::fopen(path.c_str(), "w");
  if (out == nullptr) {
    std::fprintf(stderr, "driver: cannot write %s\n", path.c_str());
    std::exit(2);
  }
  for (std::size_t k = 0; k < r.times.size(); ++k) {
    std::fprintf(out, "%.17g", r.times[k]);
    for (Eigen::Index j = 0; j < r.states.cols(); ++j) std::fprintf(out, ",%.17g", r.states(static_cast<Eigen::Index>(k), j));
    std::fputc('\n', out);
  }
  std::fclose(out);
}

std::string number(double value) {
  if (!std::isfinite(value)) return "null";
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", value);
  return text;
}

}  // namespace

int main(int argc, char** argv) {
#if defined(IPSIM_RUNTIME_MODEL)
  // driver --model LIB SCENE.cfg ...: the model library stays loaded while the driver runs.
  std::optional<ipsim::ModelLibrary> library;
  if (argc < 4 || std::string(argv[1]) != "--model") {
    std::fprintf(stderr, "usage: driver --model LIB SCENE.cfg --reference OUT.csv [options]\n");
    return 2;
  }
  try {
    library.emplace(argv[2]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "driver: %s\n", e.what());
    return 2;
  }
  argv += 2;
  argc -= 2;
#endif
  if (argc < 2) {
    std::fprintf(stderr, "usage: driver SCENE.cfg --reference OUT.csv [options]\n");
    return 2;
  }
  auto scene = ipsim::scene::load<Model>(ipsim::scene::SceneFile::read(argv[1]));
  std::string reference_path = "reference.csv";
  double repeat_seconds = 0.2;
  int max_repeats = 25;
  std::vector<double> rtols = {1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12};
  std::vector<double> rk4_steps = {1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4};
  double check_step = 2.5e-5;
  ipsim::Method reference_method = ipsim::Method::erk_fehlberg8;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string option = argv[i], value = argv[i + 1];
    if (option == "--sample") scene.settings.sample = std::strtod(value.c_str(), nullptr);
    else if (option == "--reference") reference_path = value;
    else if (option == "--repeat-seconds") repeat_seconds = std::strtod(value.c_str(), nullptr);
    else if (option == "--max-repeats") max_repeats = std::atoi(value.c_str());
    else if (option == "--rtols") rtols = parse_list(value);
    else if (option == "--rk4-steps") rk4_steps = parse_list(value);
    else if (option == "--check-step") check_step = std::strtod(value.c_str(), nullptr);
    else if (option == "--reference-method") {
      const auto parsed = ipsim::parse_method(value);
      if (!parsed || !ipsim::uses_tolerances(*parsed)) {
        std::fprintf(stderr, "driver: --reference-method must be an adaptive method\n");
        return 2;
      }
      reference_method = *parsed;
    }
    else {
      std::fprintf(stderr, "driver: unknown option %s\n", option.c_str());
      return 2;
    }
  }
  const ipsim::ParamsOf<Model>& params = scene.params;
  ipsim::Settings<Model> base = scene.settings;
  base.max_steps = 10000000;
  base.energy_ledger = false;

  // The reference: Fehlberg 8(7) (or --reference-method) at rtol 1e-13, confirmed by RK4 at a step
  // where its error is far below the tolerances swept and by bdf at rtol 1e-13.
  auto reference_settings = base;
  reference_settings.method = reference_method;
  reference_settings.rtol = 1e-13;
  reference_settings.atol = 1e-15;
  auto check = base;
  check.method = ipsim::Method::rk4;
  check.step = check_step;
  auto check_bdf = base;
  check_bdf.rtol = 1e-13;
  check_bdf.atol = 1e-15;
  ipsim::Result reference, confirmation, confirmation_bdf;
  try {
    reference = ipsim::simulate<Model>(params, reference_settings);
    confirmation = ipsim::simulate<Model>(params, check);
    confirmation_bdf = ipsim::simulate<Model>(params, check_bdf);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "driver: the reference run failed: %s\n", e.what());
    return 1;
  }
  const Errors agreement = errors(confirmation, reference), agreement_bdf = errors(confirmation_bdf, reference);
  write_csv(reference_path, reference);
  std::printf(
      "{\"kind\": \"reference\", \"model\": \"%s\", \"method\": \"%s\", \"rtol\": 1e-13, \"t_end\": %s, "
      "\"sample\": %s, \"samples\": %zu, \"check_method\": \"rk4\", \"check_step\": %s, \"agreement_final\": %s, "
      "\"agreement_trajectory\": %s, \"bdf_agreement_final\": %s, \"bdf_agreement_trajectory\": %s}\n",
      ipsim::name_of<Model>(), ipsim::to_string(reference_method), number(base.t_end).c_str(), number(base.sample).c_str(), reference.times.size(),
      number(check.step).c_str(), number(agreement.final_time).c_str(), number(agreement.trajectory).c_str(),
      number(agreement_bdf.final_time).c_str(), number(agreement_bdf.trajectory).c_str());
  std::fflush(stdout);

  struct Setting {
    ipsim::Method method;
    ipsim::Jacobian jacobian;
    double knob;  // rtol, or the rk4 step
    const char* label;
  };
  std::vector<Setting> settings;
  const struct {
    ipsim::Method method;
    ipsim::Jacobian jacobian;
    const char* label;
  } adaptive[] = {
      {ipsim::Method::bdf, ipsim::Jacobian::exact, "bdf"},
      {ipsim::Method::bdf, ipsim::Jacobian::dq, "bdf (dq Jacobian)"},
      {ipsim::Method::adams, ipsim::Jacobian::exact, "adams"},
      {ipsim::Method::adams, ipsim::Jacobian::dq, "adams (dq Jacobian)"},
      {ipsim::Method::adams_fixed_point, ipsim::Jacobian::exact, "adams-fixed-point"},
      {ipsim::Method::erk_dp5, ipsim::Jacobian::exact, "erk-dp5"},
      {ipsim::Method::erk_fehlberg8, ipsim::Jacobian::exact, "erk-fehlberg8"},
  };
  for (const auto& a : adaptive) {
    for (double rtol : rtols) settings.push_back({a.method, a.jacobian, rtol, a.label});
  }
  for (double step : rk4_steps) settings.push_back({ipsim::Method::rk4, ipsim::Jacobian::exact, step, "rk4"});

  for (const Setting& setting : settings) {
    auto s = base;
    s.method = setting.method;
    s.jacobian = setting.jacobian;
    if (setting.method == ipsim::Method::rk4) {
      s.step = setting.knob;
    } else {
      s.rtol = setting.knob;
      s.atol = setting.knob * 1e-2;
    }
    std::vector<double> walls;
    ipsim::Result result;
    std::string failure;
    double spent = 0.0;
    try {
      // At least 3 runs (1 when a run takes more than a second), then until repeat_seconds.
      while (static_cast<int>(walls.size()) < max_repeats && (walls.size() < 3 || spent < repeat_seconds) &&
             !(spent > 1.0 && !walls.empty())) {
        result = ipsim::simulate<Model>(params, s);
        walls.push_back(result.wall_time);
        spent += result.wall_time;
      }
    } catch (const std::exception& e) {
      failure = e.what();
      for (char& c : failure) {
        if (c == '"' || c == '\\') c = '\'';
      }
    }
    if (!failure.empty()) {
      std::printf("{\"kind\": \"run\", \"method\": \"%s\", \"knob\": %s, \"failed\": \"%s\"}\n", setting.label,
                  number(setting.knob).c_str(), failure.c_str());
      std::fflush(stdout);
      continue;
    }
    std::sort(walls.begin(), walls.end());
    const double median = walls[walls.size() / 2];
    const Errors e = errors(result, reference);
    const ipsim::Statistics& st = result.stats;
    std::printf(
        "{\"kind\": \"run\", \"method\": \"%s\", \"knob\": %s, \"final_error\": %s, \"max_error\": %s, "
        "\"wall_per_second\": %s, \"repeats\": %zu, \"steps\": %ld, \"rhs_evals\": %ld, \"jacobian_evals\": %ld, "
        "\"dq_rhs_evals\": %ld, \"error_test_failures\": %ld, \"nonlinear_iterations\": %ld}\n",
        setting.label, number(setting.knob).c_str(), number(e.final_time).c_str(), number(e.trajectory).c_str(),
        number(median / s.t_end).c_str(), walls.size(), st.steps, st.rhs_evals, st.jacobian_evals,
        st.linear_solver_rhs_evals, st.error_test_failures, st.nonlinear_iterations);
    std::fflush(stdout);
  }
  return 0;
}
