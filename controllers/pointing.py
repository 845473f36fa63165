"""Nadir (LVLH) hold: the guidance controller flying :class:`controllers.guidance.NadirReference`.

:class:`NadirPointing` holds the body at a fixed attitude ``q_BL`` in the
orbit's local-vertical local-horizontal frame L: the reference is

.. math::

    q_{RN}(t) = q_{LN}(t) \\otimes q_{BL}, \\qquad
    \\omega_{RN,R} = C(q_{BL})^T \\omega_{LN,L}, \\qquad
    \\dot\\omega_{RN,R} = C(q_{BL})^T \\dot\\omega_{LN,L}

(the one definition is :class:`controllers.guidance.NadirReference`) and the
law is the guidance controller's quaternion PD with the gyroscopic term
``omega x (I omega + h)`` and the reference's feedforward, both on by
default: in a steady hold the body turns at the orbit rate, and those terms
are the torque the turn needs (on an elliptic orbit including the
``e n^2`` angular acceleration of L). A steady body-fixed disturbance ``d``
then leaves the exact error ``q_e,v = K^-1 d`` (the rate error is zero when
the body turns with L).

Inertial pointing needs nothing new: it is :class:`controllers.pd.QuaternionPD`
with a constant ``q_ref`` (or :class:`controllers.guidance.InertialReference`).
"""

from __future__ import annotations

from typing import Any

from numpy.typing import ArrayLike

from attitude.rigid_body import RigidBody
from controllers.guidance.controller import GuidanceController
from controllers.guidance.nadir import NadirReference

__all__ = ["NadirPointing"]


class NadirPointing(GuidanceController):
    """Quaternion PD holding the body at ``q_BL`` in the orbit's LVLH frame (module docstring).

    With the identity ``q_BL`` the body axes are the LVLH axes: body z to
    nadir, body y along the negative orbit normal, body x along the velocity
    (on a circular orbit).

    Parameters
    ----------
    orbit : object
        Anything with ``q_LN(t) -> (..., 4)``, ``omega_LN_L`` (a ``(3,)``
        property or a method ``t -> (..., 3)``), ``position_N(t)`` and
        ``velocity_N(t)``, e.g. :class:`attitude.environment.CircularOrbit`;
        ``t`` in seconds of the simulation clock.
    body : RigidBody
        The spacecraft (its inertia [kg m^2] sets the gains and the
        gyroscopic term).
    wn : float or array_like (3,)
        Natural frequency per axis [rad/s].
    zeta : float or array_like (3,)
        Damping ratio per axis.
    period : float
        Controller sample time [s].
    q_BL : array_like (4,)
        Held attitude of the body relative to L (rotates body vectors into
        L); default identity.
    gyroscopic : bool
        Add ``omega x (I omega + h)`` (default True; see the module docstring).
    feedforward : bool
        Add the reference's acceleration ``I (C_BR omega_dot_r - omega x C_BR omega_r)`` (default True).

    Raises
    ------
    ValueError
        For an orbit without those members, a ``q_BL`` that is not a unit
        quaternion, or gains as :meth:`QuaternionPD.from_bandwidth`.
    """

    def __init__(
        self,
        orbit: Any,
        body: RigidBody,
        *,
        wn: ArrayLike,
        zeta: ArrayLike,
        period: float,
        q_BL: ArrayLike = (1.0, 0.0, 0.0, 0.0),
        gyroscopic: bool = True,
        feedforward: bool = True,
    ) -> None:
        nadir = NadirReference(orbit, q_BL)
        self.orbit = nadir.orbit
        self.q_BL = nadir.q_BL
        super().__init__(nadir, body, wn=wn, zeta=zeta, period=period, gyroscopic=gyroscopic, feedforward=feedforward)
