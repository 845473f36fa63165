"""Optimal slew planning with casadi/IPOPT, eigenaxis references and keep-out cones."""

from controllers.slew.guess import MULTI_START, START_FAMILIES
from controllers.slew.keep_out import KeepOutCone
from controllers.slew.plan import SlewPlan
from controllers.slew.planner import plan_slew
from controllers.slew.problem import InfeasibleSlewError, SlewPlanningError, momentum_rate_max
from controllers.slew.reference import PUBLISHED_BILIMORIA_WIE, EigenaxisSlew, eigenaxis_slew
from controllers.slew.transcription import IPOPT_DEFAULTS

__all__ = [
    "IPOPT_DEFAULTS",
    "MULTI_START",
    "PUBLISHED_BILIMORIA_WIE",
    "START_FAMILIES",
    "EigenaxisSlew",
    "InfeasibleSlewError",
    "KeepOutCone",
    "SlewPlan",
    "SlewPlanningError",
    "eigenaxis_slew",
    "momentum_rate_max",
    "plan_slew",
]
