// Streaming output (ipsim/sink.hpp, csv.hpp, schedule.hpp) and divergence detection
// (divergence.hpp), on the stand-in:
// - StopSchedule, which generates the stops one at a time, gives exactly the stops of the list
//   algorithm it replaced (kept below as the reference) over random schedules;
// - CsvSink, which writes each row as the run reaches it, gives byte for byte the CSV that
//   simulate_<model> wrote before from the complete in-memory Result (the old writer, kept
//   below), for every input kind and the energy and u columns;
// - a sink can stop a run; DivergenceMonitor stops a closed loop that leaves its region, and
//   only one that was inside it.
// Included by test_model.cpp alone (one translation unit: `test_model_cart1 streaming`), hence the
// unnamed namespace.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "cart1.hpp"
#include "check.hpp"
#include "ipsim/ipsim.hpp"

namespace ipsim_test::streaming {
namespace {

using Model = ipgen::cart1::Model;
using ipsim::detail::Stop;

// ---------------------------------------------------------------- the schedule

/// The list algorithm simulate() used before StopSchedule (kept as the reference).
std::vector<Stop> reference_schedule(double t_end, double sample, const std::vector<double>& switching_times) {
  const double tolerance =
      std::max(1e-9 * std::min(sample, t_end), 64.0 * std::numeric_limits<double>::epsilon() * t_end);
  std::vector<Stop> points;
  for (long k = 0;; ++k) {
    const double t = static_cast<double>(k) * sample;
    if (t >= t_end - tolerance) break;
    points.push_back({t, true, false});
  }
  points.push_back({t_end, true, false});
  for (double s : switching_times) {
    if (s > tolerance && s < t_end - tolerance) points.push_back({s, false, true});
  }
  std::stable_sort(points.begin(), points.end(), [](const Stop& a, const Stop& b) { return a.t < b.t; });
  std::vector<Stop> stops;
  for (const Stop& p : points) {
    if (!stops.empty() && p.t - stops.back().t <= tolerance) {
      Stop& merged = stops.back();
      if (p.restart && !merged.restart) merged.t = p.t;
      merged.sample = merged.sample || p.sample;
      merged.restart = merged.restart || p.restart;
    } else {
      stops.push_back(p);
    }
  }
  return stops;
}

bool same_stops(const std::vector<Stop>& a, const std::vector<Stop>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].t != b[i].t || a[i].sample != b[i].sample || a[i].restart != b[i].restart) return false;
  }
  return true;
}

std::vector<Stop> all_stops(ipsim::detail::StopSchedule schedule) {
  std::vector<Stop> stops;
  while (const auto stop = schedule.next()) stops.push_back(*stop);
  return stops;
}

void check_schedule_stream() {
  std::mt19937_64 random(20261124);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int mismatches = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const double t_end = std::pow(10.0, 3.0 * unit(random) - 1.0);  // 0.1 .. 100
    const double sample = t_end / std::floor(1.0 + 300.0 * unit(random)) * (unit(random) < 0.2 ? 1.0 + 1e-10 : 1.0);
    std::vector<double> switching;
    const int count = static_cast<int>(5.0 * unit(random));
    for (int i = 0; i < count; ++i) {
      const double kind = unit(random);
      if (kind < 0.3) switching.push_back(sample * std::floor(t_end / sample * unit(random)));  // on a sample
      else if (kind < 0.45) switching.push_back(sample * std::floor(t_end / sample * unit(random)) + 1e-12 * t_end);
      else if (kind < 0.55) switching.push_back(kind < 0.5 ? -1.0 : t_end);  // outside: dropped
      else if (kind < 0.65 && !switching.empty()) switching.push_back(switching.back());  // repeated
      else switching.push_back(t_end * unit(random));
    }
    // The list, in any order (a pulse's edges, a step's time).
    if (!same_stops(all_stops({t_end, sample, switching}), reference_schedule(t_end, sample, switching))) ++mismatches;
    // A sampled input: every k·period below t_end, generated on the fly.
    const double period = unit(random) < 0.5 ? sample * std::floor(1.0 + 4.0 * unit(random)) : t_end * unit(random) / 7.0;
    std::vector<double> instants;
    for (long k = 1; static_cast<double>(k) * period < t_end; ++k) instants.push_back(static_cast<double>(k) * period);
    if (!same_stops(all_stops({t_end, sample, {}, period}), reference_schedule(t_end, sample, instants))) ++mismatches;
    const auto reference = reference_schedule(t_end, sample, switching);
    const long samples = std::count_if(reference.begin(), reference.end(), [](const Stop& s) { return s.sample; });
    if (ipsim::detail::StopSchedule(t_end, sample, switching).sample_count() != samples) ++mismatches;
  }
  CHECK(mismatches == 0);
  if (mismatches != 0) std::fprintf(stderr, "schedule mismatches: %d of 9000\n", mismatches);
}

// ---------------------------------------------------------------- CSV bytes

/// The CSV simulate_<model> wrote before streaming: header and rows from the complete Result.
std::string reference_csv(const ipsim::Result& result, const ipsim::ParamsOf<Model>& p, bool energy, bool u) {
  std::string text = "t";
  char cell[64];
  for (int i = 0; i < Model::kDof; ++i) text += ",theta" + std::to_string(i);
  for (int i = 0; i < Model::kDof; ++i) text += ",dtheta" + std::to_string(i);
  if (energy) text += ",kinetic,potential,input_work,dissipated";
  if (u) text += ",u";
  text += "\n";
  auto add = [&](const char* format, double value) {
    std::snprintf(cell, sizeof cell, format, value);
    text += cell;
  };
  for (std::size_t k = 0; k < result.times.size(); ++k) {
    const auto row = static_cast<Eigen::Index>(k);
    add("%.17g", result.times[k]);
    for (Eigen::Index j = 0; j < result.states.cols(); ++j) add(",%.17g", result.states(row, j));
    if (energy) {
      const ipsim::VectorOf<Model> q = result.states.row(row).head<Model::kDof>().transpose();
      const ipsim::VectorOf<Model> qd = result.states.row(row).segment<Model::kDof>(Model::kDof).transpose();
      add(",%.17g", Model::kinetic_energy<double>(q, qd, p));
      add(",%.17g", Model::potential_energy<double>(q, p));
      add(",%.17g", result.input_work[k]);
      add(",%.17g", result.dissipated_energy[k]);
    }
    if (u) add(",%.17g", result.inputs[k]);
    text += "\n";
  }
  return text;
}

/// The CSV CsvSink writes while the run proceeds, and the run's summary.
std::string streamed_csv(const ipsim::ParamsOf<Model>& p, const ipsim::Settings<Model>& s, bool energy, bool u,
                         ipsim::Result& summary) {
  std::FILE* file = std::tmpfile();
  if (file == nullptr) return "tmpfile failed";
  {
    ipsim::CsvSink<Model> sink(file, p, energy, u, "test.csv");
    summary = ipsim::simulate<Model>(p, s, sink);
    CHECK(sink.rows() == summary.samples);
  }
  std::fflush(file);
  std::rewind(file);
  std::string text;
  char buffer[65536];
  for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, file)) > 0;) text.append(buffer, n);
  std::fclose(file);
  return text;
}

ipsim::LinearFeedback upright_feedback(double period) {
  ipsim::LinearFeedback c;
  c.gain = Eigen::VectorXd(4);
  c.gain << -1.0, -21.6034, -2.28604, -3.56511;  // LQR, Q = I, R = 1 (ipgen.lqr), rounded
  c.equilibrium = Eigen::VectorXd::Zero(4);
  c.saturation = period > 0.0 ? 5.0 : INFINITY;
  c.period = period;
  return c;
}

void check_csv_bytes() {
  const ipsim::ParamsOf<Model> p{{0.5, 0.275}, {0.0, 0.5}, {0.3, 0.01}};
  struct Case {
    const char* name;
    ipsim::Input input;
    ipsim::Method method;
    bool energy, u;
  };
  const Case cases[] = {
      {"pulse, bdf, energy", ipsim::Input::pulse(0.4, 0.1, 0.5), ipsim::Method::bdf, true, false},
      {"step, rk4", ipsim::Input::step(-0.2, 0.33), ipsim::Method::rk4, false, false},
      {"sine, erk-dp5, energy", ipsim::Input::sine(0.3, 1.5, 0.2), ipsim::Method::erk_dp5, true, false},
      {"continuous feedback, adams, u", upright_feedback(0.0).input(), ipsim::Method::adams, false, true},
      {"sampled feedback, bdf, energy and u", upright_feedback(0.03).input(), ipsim::Method::bdf, true, true},
  };
  for (const Case& c : cases) {
    ipsim::Settings<Model> s;
    s.t_end = 2.0;
    s.sample = 0.007;
    s.step = 1e-3;
    s.method = c.method;
    s.input = c.input;
    s.theta << 0.0, 0.05;
    s.energy_ledger = c.energy;
    const ipsim::Result kept = ipsim::simulate<Model>(p, s);
    ipsim::Result summary;
    const std::string streamed = streamed_csv(p, s, c.energy, c.u, summary);
    const std::string expected = reference_csv(kept, p, c.energy, c.u);
    CHECK(expected.size() > 10000);  // a real trajectory (287 rows)
    if (streamed != expected) {
      ipsim_test::fail(__FILE__, __LINE__, std::string("streamed CSV differs from the in-memory one: ") + c.name);
    }
    // The summary is the same whether the samples are kept or streamed.
    CHECK(summary.samples == kept.times.size() && kept.samples == kept.times.size());
    CHECK(summary.times.empty() && summary.states.size() == 0 && !summary.stopped_early && !kept.stopped_early);
    CHECK(summary.max_abs_input == kept.max_abs_input);
    CHECK(summary.stats.steps == kept.stats.steps && summary.stats.rhs_evals == kept.stats.rhs_evals &&
          summary.stats.restarts == kept.stats.restarts);
  }
}

// ---------------------------------------------------------------- stopping a run

/// Stops after `limit` samples.
struct StopAfter : ipsim::SampleSink {
  explicit StopAfter(std::size_t limit) : limit(limit) {}
  bool record(const ipsim::Sample& sample) override {
    last_t = sample.t;
    return ++seen < limit;
  }
  std::size_t limit, seen = 0;
  double last_t = -1.0;
};

/// Records samples and nothing else, for DivergenceMonitor.
struct Count : ipsim::SampleSink {
  bool record(const ipsim::Sample&) override {
    ++seen;
    return true;
  }
  std::size_t seen = 0;
};

ipsim::Sample sample_at(double t, const Eigen::VectorXd& x) {
  ipsim::Sample s;
  s.t = t;
  s.state = x.data();
  s.state_size = static_cast<int>(x.size());
  return s;
}

void check_stopping() {
  const ipsim::ParamsOf<Model> p{{0.5, 0.275}, {0.0, 0.5}, {0.3, 0.01}};
  ipsim::Settings<Model> s;
  s.t_end = 1.0;
  s.sample = 0.01;
  StopAfter stop(25);
  const ipsim::Result r = ipsim::simulate<Model>(p, s, stop);
  CHECK(r.stopped_early && r.samples == 25 && stop.seen == 25);
  CHECK_NEAR(stop.last_t, 0.24, 1e-15);
  StopAfter never(1000);
  CHECK(!ipsim::simulate<Model>(p, s, never).stopped_early && never.seen == 101);

  // DivergenceMonitor on hand-made samples: x = [θ0, θ1, θ̇0, θ̇1], equilibrium hanging (θ1 = π).
  Eigen::VectorXd equilibrium = Eigen::VectorXd::Zero(4);
  equilibrium(1) = M_PI;
  auto state = [](double cart, double link) {
    Eigen::VectorXd x = Eigen::VectorXd::Zero(4);
    x << cart, link, 0.0, 0.0;
    return x;
  };
  {
    Count inner;
    ipsim::DivergenceMonitor monitor(inner, equilibrium, Model::kDof);
    CHECK(monitor.record(sample_at(0.0, state(0.0, M_PI + 0.1))));
    CHECK(monitor.record(sample_at(0.1, state(1e6, M_PI - 1.5))));  // the cart is not checked
    CHECK(!monitor.record(sample_at(0.2, state(0.0, M_PI + 1.6))));  // beyond π/2: stop
    CHECK(inner.seen == 3 && monitor.divergence().has_value());
    if (monitor.divergence()) {
      CHECK(monitor.divergence()->t == 0.2 && monitor.divergence()->link == 1);
      CHECK_NEAR(monitor.divergence()->deviation, 1.6, 1e-12);
    }
  }
  {
    Count inner;  // starts outside (upright, 3.1 rad from hanging): not stopped until it was inside
    ipsim::DivergenceMonitor monitor(inner, equilibrium, Model::kDof);
    CHECK(monitor.record(sample_at(0.0, state(0.0, 0.04))));
    CHECK(monitor.record(sample_at(0.1, state(0.0, 1.2))));
    CHECK(monitor.record(sample_at(0.2, state(0.0, 2.0))));  // inside from here on
    CHECK(!monitor.record(sample_at(0.3, state(0.0, 2.0 * M_PI))));  // a turn the other way: π away
    CHECK(!monitor.divergence() || monitor.divergence()->t == 0.3);
  }
  {
    Count inner;
    ipsim::DivergenceMonitor monitor(inner, equilibrium, Model::kDof, INFINITY);
    CHECK(monitor.record(sample_at(0.0, state(0.0, M_PI))) && monitor.record(sample_at(1.0, state(0.0, 100.0))));
    CHECK(!monitor.divergence());
  }

  // A run: positive feedback on the link makes it fall; the monitor stops the run (and its
  // MemorySink) at the first sample beyond π/2, the stabilising gain runs to t_end.
  s.t_end = 5.0;
  s.theta << 0.0, 0.05;
  for (const double sign : {1.0, -1.0}) {
    ipsim::LinearFeedback c = upright_feedback(0.0);
    c.gain *= sign;
    s.input = c.input();
    ipsim::Result kept;
    ipsim::MemorySink memory(kept);
    ipsim::DivergenceMonitor monitor(memory, c.equilibrium, Model::kDof);
    const ipsim::Result r = ipsim::simulate<Model>(p, s, monitor);
    memory.finish();
    const auto rows = kept.states.rows();
    if (sign > 0) {
      CHECK(!r.stopped_early && !monitor.divergence() && rows == 501);
      CHECK(rows > 0 && std::abs(kept.states(rows - 1, 1)) < 1e-3);
    } else {
      CHECK(r.stopped_early && monitor.divergence() && rows == static_cast<Eigen::Index>(r.samples));
      CHECK(rows > 1 && std::abs(kept.states(rows - 1, 1)) > M_PI / 2 && std::abs(kept.states(rows - 2, 1)) <= M_PI / 2);
      CHECK(!monitor.divergence() || monitor.divergence()->t == kept.times.back());
    }
  }
}

}  // namespace

/// Every check above; the exit status: 0 when all passed, 1 otherwise.
inline int run() {
  check_schedule_stream();
  check_csv_bytes();
  check_stopping();
  return ipsim_test::finish("ipsim streaming checks");
}

}  // namespace ipsim_test::streaming
