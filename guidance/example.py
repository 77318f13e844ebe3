"""The report's example (chapter 6, "Algorithm Implementation and Evaluation").

Initial position [532, 590, 7] ft and velocity [0, -38, 0] ft/s; final position
[740, 0, 0] ft and velocity [1, 0, 0] ft/s; ζ = 0.96, α = 0.5, μ = 0, β = 1e-6; about
300 range points on four vehicles parked beside a runway. The report gives a flight
time of 20 s, a minimum obstacle distance of about 8.25 ft, a load factor within 1.02,
``|θ|`` below about 12° and ``|φ|`` well within 15°.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .law import BoundaryConditions, GuidanceWeights, ObstacleField
from .model import VehicleParams
from .obstacles import synthetic_runway_obstacles
from .simulate import SimulationConfig, SimulationResult, simulate, trajectory_metrics

__all__ = [
    "REPORT_BOUNDARY",
    "REPORT_FIGURES",
    "REPORT_WEIGHTS",
    "ExampleRun",
    "run_example",
]

REPORT_BOUNDARY = BoundaryConditions(
    r0=[532.0, 590.0, 7.0], v0=[0.0, -38.0, 0.0], rf=[740.0, 0.0, 0.0], vf=[1.0, 0.0, 0.0]
)
REPORT_WEIGHTS = GuidanceWeights(zeta=0.96, alpha=0.5, mu=0.0, beta=1e-6)

#: The figures the report quotes for its example (bounds as worded there).
REPORT_FIGURES: dict[str, str] = {
    "flight_time_s": "20",
    "min_obstacle_distance": "about 8.25",
    "max_load_factor": "within 1.02",
    "max_abs_theta_deg": "less than about 12",
    "max_abs_phi_deg": "well within 15",
}


@dataclass
class ExampleRun:
    """A run of the example: the simulation, its metrics and the obstacle field."""

    result: SimulationResult
    metrics: dict
    field: ObstacleField


def run_example(
    obstacles: np.ndarray | None = None,
    *,
    shift: tuple[float, float, float] = (0.0, 0.0, 0.0),
    weights: GuidanceWeights = REPORT_WEIGHTS,
    boundary: BoundaryConditions = REPORT_BOUNDARY,
    params: VehicleParams | None = None,
    config: SimulationConfig | None = None,
) -> ExampleRun:
    """Fly the report's example.

    Parameters
    ----------
    obstacles
        ``(n, 3)`` guidance-frame points; ``None`` uses
        :func:`~rangefx.guidance.obstacles.synthetic_runway_obstacles`.
    shift
        Added to every obstacle point (placement-sensitivity studies).
    weights, boundary, params, config
        Overrides of the report's settings and of the simulation defaults.
    """
    pts = synthetic_runway_obstacles() if obstacles is None else np.asarray(obstacles, float)
    if pts.ndim == 2 and pts.shape[-1] == 3:
        pts = pts + np.asarray(shift, dtype=np.float64)
    field = ObstacleField(pts, weights)
    res = simulate(boundary, field, params, config)
    metrics = trajectory_metrics(res)
    metrics["obstacle_centroid"] = [float(c) for c in field.centroid]
    return ExampleRun(res, metrics, field)
