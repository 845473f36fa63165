"""Attitude controllers (PD, LQR, optimal slews, tracking); imports ``attitude`` only."""
