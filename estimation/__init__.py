"""Attitude and rate estimators (rate EKF, MEKF) and their consistency tests; imports ``attitude`` only.

The front door: ``from estimation import MEKF, run_mekf, RateEKF, average_nees``.
"""

from estimation.consistency import average_nees, average_nis, chi2_band, nees, nis, plot_errors_with_bounds, plot_nees
from estimation.mekf import MEKF, MEKFResult, initial_covariance, run_mekf, steady_state_attitude_sigma
from estimation.rate_ekf import RateEKF, RateEKFResult, run_rate_ekf

__all__ = [
    "MEKF",
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
    "run_mekf",
    "run_rate_ekf",
    "steady_state_attitude_sigma",
]
