"""Attitude and rate estimators (rate EKF, MEKF), static attitude determination and consistency tests.

Imports ``attitude`` only. The front door:
``from estimation import MEKF, run_mekf, RateEKF, average_nees, quest, q_method, triad``.
"""

from estimation.consistency import average_nees, average_nis, chi2_band, nees, nis, plot_errors_with_bounds, plot_nees
from estimation.determination import AttitudeSolution
from estimation.determination.q_method import q_method
from estimation.determination.quest import quest
from estimation.determination.triad import triad
from estimation.mekf import MEKF, MEKFResult, initial_covariance, run_mekf, steady_state_attitude_sigma
from estimation.rate_ekf import RateEKF, RateEKFResult, run_rate_ekf

__all__ = [
    "MEKF",
    "AttitudeSolution",
    "MEKFResult",
    "RateEKF",
    "RateEKFResult",
    "average_nees",
    "average_nis",
    "chi2_band",
    "initial_covariance",
    "nees",
    "nis",
    "plot_errors_with_bounds",
    "plot_nees",
    "q_method",
    "quest",
    "run_mekf",
    "run_rate_ekf",
    "steady_state_attitude_sigma",
    "triad",
]
