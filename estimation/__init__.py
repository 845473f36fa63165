"""Attitude and rate estimators (EKF, MEKF) and consistency tests; imports ``attitude`` only."""
