"""The multiplicative extended Kalman filter (MEKF): filter, batch, runner and steady state."""

from estimation.mekf.batch import MEKFBatch, VectorSamples
from estimation.mekf.filter import MEKF, initial_covariance, process_noise, transition_matrix
from estimation.mekf.runner import MEKFResult, run_mekf
from estimation.mekf.steady_state import steady_state_attitude_sigma, steady_state_covariance

__all__ = [
    "MEKF",
    "MEKFBatch",
    "MEKFResult",
    "VectorSamples",
    "initial_covariance",
    "process_noise",
    "run_mekf",
    "steady_state_attitude_sigma",
    "steady_state_covariance",
    "transition_matrix",
]
