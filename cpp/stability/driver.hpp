// The stability driver on one generated model: runs the stability scenarios (scenarios.hpp;
// precision.hpp when compiled with -DIPGEN_STABILITY_PRECISION=1) and prints one JSON object per
// row on stdout (tools/stability.py turns them into docs/stability.md), a one-line verdict per
// failed row on stderr.
//
//   [--quick]              every scenario (--quick: the ctest subset)
//   --long T_END SAMPLE    only the long-horizon run, with the peak RSS
//   --long-undamped T_END  only an undamped run to T_END (sample 1 s)
// Exit status: 0 when every row passed, 1 otherwise, 2 for a bad command line.
//
// stability.cpp makes it the program stability_<model> (`make stability`); ctest runs the quick
// set through the model's test program, test_model_<model> stability --quick (cpp/tests), which
// compiles ipsim for the model once for both.
#pragma once

#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "scenarios.hpp"
#if IPGEN_STABILITY_PRECISION
#include "precision.hpp"
#endif

namespace stability::driver {

inline std::string json_string(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\u%04x", c);
      out += escaped;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

inline std::string json_number(double value) {
  if (!std::isfinite(value)) return "null";
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", value);
  return text;
}

/// Peak resident set size of this process [MB].
inline double peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: kilobytes
}

inline void print(const stability::Row& row, double rss_mb = stability::kNaN) {
  std::printf(
      "{\"scenario\": %s, \"model\": %s, \"what\": %s, \"measure\": %s, \"value\": %s, \"bound\": %s, "
      "\"steps\": %ld, \"wall\": %s, \"outcome\": %s, \"passed\": %s, \"note\": %s, \"rss_mb\": %s}\n",
      json_string(row.scenario).c_str(), json_string(row.model).c_str(), json_string(row.what).c_str(),
      json_string(row.measure).c_str(), json_number(row.value).c_str(), json_number(row.bound).c_str(), row.steps,
      json_number(row.wall).c_str(), json_string(row.outcome).c_str(), row.passed ? "true" : "false",
      json_string(row.note).c_str(), json_number(rss_mb).c_str());
  std::fflush(stdout);
  if (!row.passed) {
    std::fprintf(stderr, "stability: %s, %s, %s: %s\n", row.scenario.c_str(), row.model.c_str(), row.what.c_str(),
                 row.outcome.c_str());
  }
}

inline int usage() {
  std::fputs("usage: stability [--quick] | --long T_END SAMPLE | --long-undamped T_END\n", stderr);
  return 2;
}

/// The driver's command line (above) on `Model`; returns the exit status.
template <class Model>
int run(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (!args.empty() && args[0] == "--long" && args.size() == 3) {
    const Row row = long_horizon<Model>(std::atof(args[1].c_str()), std::atof(args[2].c_str()));
    print(row, peak_rss_mb());
    return row.passed ? 0 : 1;
  }
  if (!args.empty() && args[0] == "--long-undamped" && args.size() == 2) {
    const Row row = long_undamped<Model>(std::atof(args[1].c_str()));
    print(row, peak_rss_mb());
    return row.passed ? 0 : 1;
  }
  Options options;
  if (args.size() == 1 && args[0] == "--quick") {
    options.quick = true;
  } else if (!args.empty()) {
    return usage();
  }

  bool passed = true;
  auto emit = [&](const Row& row) {
    print(row);
    passed = passed && row.passed;
  };
  emit(undamped<Model>(10.0, 0.01));
  // Zero damping over 1000 s (100 s in the quick set); the long runs only for small n, where
  // they take seconds (n = 20 needs about 30 s per simulated 100 s).
  if (ipsim::links_of<Model>() <= 3) emit(undamped<Model>(options.quick ? 100.0 : 1000.0, 0.1));
#if IPGEN_STABILITY_PRECISION
  for (const Row& row : ratios_and_float<Model>(options)) emit(row);
#endif
  for (const Row& row : stiff_damping<Model>(options)) emit(row);
  for (const Row& row : fast_motion<Model>(options)) emit(row);
  emit(through_horizontal<Model>(options));
  for (const Row& row : many_turns<Model>(options)) emit(row);
  return passed ? 0 : 1;
}

}  // namespace stability::driver
