// The paper's parameters for any link count and the work–energy balance of a run: shared by the
// tests (model_checks.hpp) and the stability drivers (cpp/stability), so it depends on ipsim and
// check.hpp's error measures only.
#pragma once

#include <cmath>
#include <cstddef>

#include "check.hpp"  // raise_to
#include "ipsim/ipsim.hpp"

namespace ipsim_test {

/// The paper's CDIP/RSIP parameters for any n (arm/cart 0.5 kg, links 0.275 kg and 0.5 m, arm
/// 0.6 m), damped as in the paper (δ0 = 0.3, δi = 0.1) or not at all.
template <class Model>
ipsim::ParamsOf<Model> paper_params(bool damped) {
  ipsim::ParamsOf<Model> p{};
  for (std::size_t i = 0; i < static_cast<std::size_t>(ipsim::dof_of<Model>()); ++i) {
    p.m[i] = i == 0 ? 0.5 : 0.275;
    p.l[i] = i == 0 ? 0.6 : 0.5;
    p.delta[i] = damped ? (i == 0 ? 0.3 : 0.1) : 0.0;
  }
  p.g = 9.81;
  return p;
}

/// max_k |E_k − (E_0 + W_in,k − E_diss,k)| [J] over the samples of a run with the energy ledger,
/// E = T + V: how far the ledger is from balancing the mechanical energy. NaN if any term is NaN
/// (a NaN sample must not pass as a small error), infinite if the ledger was not recorded.
template <class Model>
double work_energy_error(const ipsim::ParamsOf<Model>& params, const ipsim::Result& result) {
  const auto samples = static_cast<std::size_t>(result.states.rows());
  if (samples == 0 || result.input_work.size() != samples || result.dissipated_energy.size() != samples) {
    return INFINITY;
  }
  const double e0 = ipsim::mechanical_energy<Model>(params, result.states.row(0).transpose());
  double worst = 0.0;
  for (Eigen::Index k = 0; k < result.states.rows(); ++k) {
    const auto i = static_cast<std::size_t>(k);
    const double e = ipsim::mechanical_energy<Model>(params, result.states.row(k).transpose());
    const double error = std::abs(e - (e0 + result.input_work[i] - result.dissipated_energy[i]));
    raise_to(worst, error);
  }
  return worst;
}

}  // namespace ipsim_test
