"""Monte Carlo campaigns: the campaign, dispersions, executors, results, statistics and plots."""

from attitude.montecarlo.campaign import Campaign, run_campaign, usable_cpus
from attitude.montecarlo.dispersions import (
    AttitudeDispersion,
    Dispersion,
    InertiaDispersion,
    Misalignment,
    Normal,
    RandomAttitude,
    RelativeScale,
    Uniform,
    dispersions_from_config,
    draw_parameters,
    flatten_parameters,
    parameter_columns,
    run_seed_sequence,
    scenario_generator,
    scenario_spawn_key,
)
from attitude.montecarlo.executors import RunOutput
from attitude.montecarlo.results import CampaignResult, Requirement, RunReplay
from attitude.montecarlo.statistics import (
    DEFAULT_PERCENTILES,
    percentiles,
    runs_for_zero_failures,
    success_lower_bound,
    success_statement,
    zero_failure_bound,
)

__all__ = [
    "DEFAULT_PERCENTILES",
    "AttitudeDispersion",
    "Campaign",
    "CampaignResult",
    "Dispersion",
    "InertiaDispersion",
    "Misalignment",
    "Normal",
    "RandomAttitude",
    "RelativeScale",
    "Requirement",
    "RunOutput",
    "RunReplay",
    "Uniform",
    "dispersions_from_config",
    "draw_parameters",
    "flatten_parameters",
    "parameter_columns",
    "percentiles",
    "run_campaign",
    "run_seed_sequence",
    "runs_for_zero_failures",
    "scenario_generator",
    "scenario_spawn_key",
    "success_lower_bound",
    "success_statement",
    "usable_cpus",
    "zero_failure_bound",
]
