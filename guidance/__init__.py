"""Chapter 6: vision-based optimal obstacle-avoidance guidance for rotorcraft.

Modules: :mod:`.model` (point-mass model, eqs 1-19), :mod:`.law` (gains, Hamiltonian,
time-to-go, eqs 20-69), :mod:`.simulate` (closed loop), :mod:`.obstacles` (synthetic
set and range map → obstacle points, eqs 32-33 of ch. 4), :mod:`.example` (the report's
example), :mod:`.plots` (Figs 4-10; imports matplotlib, so not imported here).
"""

from .example import REPORT_BOUNDARY, REPORT_FIGURES, REPORT_WEIGHTS, run_example
from .law import (
    BoundaryConditions,
    GuidanceWeights,
    NoTransversalityRootWarning,
    ObstacleField,
    command_acceleration,
    feedback_gains,
    solve_time_to_go,
)
from .model import Controls, VehicleParams, inverse_controls, point_mass_rhs
from .obstacles import obstacles_from_range, runway_scene_obstacles, synthetic_runway_obstacles
from .simulate import SimulationConfig, SimulationResult, simulate, trajectory_metrics

__all__ = [
    "REPORT_BOUNDARY",
    "REPORT_FIGURES",
    "REPORT_WEIGHTS",
    "BoundaryConditions",
    "Controls",
    "GuidanceWeights",
    "NoTransversalityRootWarning",
    "ObstacleField",
    "SimulationConfig",
    "SimulationResult",
    "VehicleParams",
    "command_acceleration",
    "feedback_gains",
    "inverse_controls",
    "obstacles_from_range",
    "point_mass_rhs",
    "run_example",
    "runway_scene_obstacles",
    "simulate",
    "solve_time_to_go",
    "synthetic_runway_obstacles",
    "trajectory_metrics",
]
