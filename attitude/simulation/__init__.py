"""The closed-loop simulation engine, its batch (vectorised) and compiled variants and their code generation."""

from attitude.simulation.batch import (
    BATCH_CHUNK,
    BatchResult,
    closed_loop_metrics,
    simulate_batch,
)
from attitude.simulation.batch_estimated import (
    simulate_batch_estimated,
)
from attitude.simulation.direction_sensors import MagnetometerDirection, SunDirection
from attitude.simulation.engine import SimulationDivergedError, SimulationResult, settling_time_after, simulate
from attitude.simulation.protocols import (
    BatchEstimator,
    CompiledController,
    Controller,
    Estimate,
    Estimator,
    Sensor,
    Truth,
    VectorMeasurement,
)

__all__ = [
    "BATCH_CHUNK",
    "BatchEstimator",
    "BatchResult",
    "CompiledController",
    "Controller",
    "Estimate",
    "Estimator",
    "MagnetometerDirection",
    "Sensor",
    "SimulationDivergedError",
    "SimulationResult",
    "SunDirection",
    "Truth",
    "VectorMeasurement",
    "closed_loop_metrics",
    "settling_time_after",
    "simulate",
    "simulate_batch",
    "simulate_batch_estimated",
]
