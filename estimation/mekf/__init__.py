"""The multiplicative extended Kalman filter (MEKF): filter, batch, runner and steady state."""

from estimation.mekf.filter import (
    GATE_PROBABILITY,
    MEKF,
    MEKFBatch,
    MEKFResult,
    initial_covariance,
    process_noise,
    run_mekf,
    steady_state_attitude_sigma,
    steady_state_covariance,
    transition_matrix,
)

__all__ = [
    "GATE_PROBABILITY",
    "MEKF",
    "MEKFBatch",
    "MEKFResult",
    "initial_covariance",
    "process_noise",
    "run_mekf",
    "steady_state_attitude_sigma",
    "steady_state_covariance",
    "transition_matrix",
]
