"""Attitude controllers: PD, LQR, analysis, tracking, slews, guidance, magnetic laws; imports ``attitude`` only.

The front door: ``from controllers import QuaternionPD, design_lqr, margins, plan_slew``.
"""

from controllers.analysis import (
    Margins,
    attitude_closed_loop,
    loop_gain,
    margins,
    plot_bode,
    plot_nichols,
    plot_step,
    sample_time_study,
    sampled_loop,
)
from controllers.diagnostics import Finding, mismatch_findings
from controllers.disk_margins import DiskMargins, LoopDiskMargins, disk_margins, loop_disk_margins
from controllers.filters import FilteredController, LowPassFilter, NotchFilter
from controllers.guidance import (
    GroundTarget,
    GroundTargetReference,
    GuidanceController,
    InertialReference,
    NadirReference,
    PointingReference,
    SunReference,
    VectorAlignmentReference,
    VectorTrack,
)
from controllers.integral import LQIController, QuaternionPID, design_lqi
from controllers.lqr import LQRController, LQRDesign, bryson_weights, design_lqr
from controllers.magnetic import BDotController, CrossProductUnloading, bdot_gain
from controllers.modes import After, Mode, ModeSequence, PointingWithin, RateBelow
from controllers.pd import QuaternionPD, RateLimitedPD
from controllers.pointing import NadirPointing
from controllers.slew import EigenaxisSlew, KeepOutCone, SlewPlan, eigenaxis_slew, plan_slew
from controllers.tracking import ReferenceTrajectory, TrackingController
from controllers.worst_case import UncertaintySet, WorstCase, worst_case_disk_margin, worst_case_step

__all__ = [
    "After",
    "BDotController",
    "CrossProductUnloading",
    "DiskMargins",
    "EigenaxisSlew",
    "FilteredController",
    "Finding",
    "GroundTarget",
    "GroundTargetReference",
    "GuidanceController",
    "InertialReference",
    "KeepOutCone",
    "LQIController",
    "LQRController",
    "LQRDesign",
    "LoopDiskMargins",
    "LowPassFilter",
    "Margins",
    "Mode",
    "ModeSequence",
    "NadirPointing",
    "NadirReference",
    "NotchFilter",
    "PointingReference",
    "PointingWithin",
    "QuaternionPD",
    "QuaternionPID",
    "RateBelow",
    "RateLimitedPD",
    "ReferenceTrajectory",
    "SlewPlan",
    "SunReference",
    "TrackingController",
    "UncertaintySet",
    "VectorAlignmentReference",
    "VectorTrack",
    "WorstCase",
    "attitude_closed_loop",
    "bdot_gain",
    "bryson_weights",
    "design_lqi",
    "design_lqr",
    "disk_margins",
    "eigenaxis_slew",
    "loop_disk_margins",
    "loop_gain",
    "margins",
    "mismatch_findings",
    "plan_slew",
    "plot_bode",
    "plot_nichols",
    "plot_step",
    "sample_time_study",
    "sampled_loop",
    "worst_case_disk_margin",
    "worst_case_step",
]
