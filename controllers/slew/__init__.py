"""Optimal slew planning with casadi/IPOPT, eigenaxis references, keep-out cones and robust (unscented) slews."""

from controllers.slew.guess import MULTI_START, START_FAMILIES
from controllers.slew.keep_out import KeepOutCone
from controllers.slew.plan import SlewPlan
from controllers.slew.planner import plan_slew
from controllers.slew.problem import InfeasibleSlewError, SlewPlanningError, momentum_rate_max
from controllers.slew.reference import PUBLISHED_BILIMORIA_WIE, EigenaxisSlew, eigenaxis_slew
from controllers.slew.robust import RobustSlewPlan, plan_robust_slew, unscented_sigma_points
from controllers.slew.robust_comparison import RobustSlewComparison, compare_robust_slew
from controllers.slew.transcription import IPOPT_DEFAULTS

__all__ = [
    "IPOPT_DEFAULTS",
    "MULTI_START",
    "PUBLISHED_BILIMORIA_WIE",
    "START_FAMILIES",
    "EigenaxisSlew",
    "InfeasibleSlewError",
    "KeepOutCone",
    "RobustSlewComparison",
    "RobustSlewPlan",
    "SlewPlan",
    "SlewPlanningError",
    "compare_robust_slew",
    "eigenaxis_slew",
    "momentum_rate_max",
    "plan_robust_slew",
    "plan_slew",
    "unscented_sigma_points",
]
