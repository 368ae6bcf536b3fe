"""Estimation and control stage: what a rig's controller knows of the state.

A rig measures some angles (quantised by encoders, with noise) at every sample and never the
rates; the controller then acts on an estimate x̂_k. This package computes that estimate as a
rig would (the shared spec of issue 32, docs/estimation.md):

- `covariance`: the default noise covariances Rn (from the encoders' resolution and the noise)
  and Qn (from the input's uncertainty and a rate random walk);
- `kalman`: the steady-state discrete Kalman filter on the ZOH-discretised exact linearisation
  (`ipgen.kalman`, python-control's `dlqe` convention, scipy's discrete Riccati solver);
- `estimators`: the estimators as objects with one `step(y, u)` per sample (backward difference,
  first-order derivative filter, steady-state Kalman, extended Kalman), which the bench, a
  notebook or a test runs on a recording (`replay`).

The pendulum is described as `ipgen.linearize` takes it (a mapping of its keyword arguments) or
as an `ipgen.control.linear.VectorField`; `pendulum.as_model` resolves either.
"""

from ipgen.estimation.design import EstimatorDesign, design
from ipgen.estimation.estimators import (
    DerivativeFilter,
    Difference,
    Estimator,
    ExtendedKalman,
    SteadyStateKalman,
)
from ipgen.estimation.kalman import Kalman, default_covariances, discretize, kalman
from ipgen.estimation.measurement import Sensors
from ipgen.estimation.pendulum import EstimationError, as_model
from ipgen.estimation.replay import Replay, replay

__all__ = [
    "DerivativeFilter",
    "Difference",
    "EstimationError",
    "Estimator",
    "EstimatorDesign",
    "ExtendedKalman",
    "Kalman",
    "Replay",
    "Sensors",
    "SteadyStateKalman",
    "as_model",
    "default_covariances",
    "design",
    "discretize",
    "kalman",
    "replay",
]
