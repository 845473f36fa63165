"""Optimal slew planning with casadi/IPOPT, eigenaxis references and keep-out cones."""

from controllers.slew.planner import (
    IPOPT_DEFAULTS,
    PUBLISHED_BILIMORIA_WIE,
    EigenaxisSlew,
    InfeasibleSlewError,
    KeepOutCone,
    SlewPlan,
    SlewPlanningError,
    eigenaxis_slew,
    momentum_rate_limit,
    plan_slew,
)

__all__ = [
    "IPOPT_DEFAULTS",
    "PUBLISHED_BILIMORIA_WIE",
    "EigenaxisSlew",
    "InfeasibleSlewError",
    "KeepOutCone",
    "SlewPlan",
    "SlewPlanningError",
    "eigenaxis_slew",
    "momentum_rate_limit",
    "plan_slew",
]
