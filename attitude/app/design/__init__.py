"""The design computation: body, linear, slew and estimation studies and their requirement verdicts."""

from attitude.app.design.run import (
    GAIN_MARGIN_GUIDELINE_DB,
    PHASE_MARGIN_GUIDELINE_DEG,
    DesignOptions,
    DesignResult,
    plan_verdicts,
    requirement_verdicts,
    run_design,
)

__all__ = [
    "GAIN_MARGIN_GUIDELINE_DB",
    "PHASE_MARGIN_GUIDELINE_DEG",
    "DesignOptions",
    "DesignResult",
    "plan_verdicts",
    "requirement_verdicts",
    "run_design",
]
