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

from .law import (
    BoundaryConditions,
    GuidanceWeights,
    ObstacleField,
    open_loop_solution,
    solve_time_to_go,
)
from .model import VehicleParams, inverse_controls
from .obstacles import synthetic_runway_obstacles
from .simulate import SimulationConfig, SimulationResult, simulate, trajectory_metrics

__all__ = [
    "REPORT_BOUNDARY",
    "REPORT_FIGURES",
    "REPORT_WEIGHTS",
    "ExampleRun",
    "extremal_figures",
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


def extremal_figures(
    field: ObstacleField,
    *,
    boundary: BoundaryConditions = REPORT_BOUNDARY,
    params: VehicleParams | None = None,
    t_go: float | None = None,
    samples: int = 400,
) -> dict[str, float]:
    """The report's figures on the open-loop extremal from the initial state (eqs 37-52
    at eq 55's time-to-go, or at ``t_go``): ``flight_time_s``, ``max_load_factor``,
    ``max_abs_theta_deg``, ``max_abs_phi_deg`` (by the inverse, eqs 12-19) and
    ``max_accel_ft_s2``.

    The closed loop follows this extremal within 1 ft (tested in ``test_guidance``), so
    these are the closed loop's figures without its guidance-interval effects; they
    depend on the obstacles only through their number and centroid (SPEC §9), which is
    what makes them cheap to scan over obstacle placements.
    """
    params = params or VehicleParams()
    t = solve_time_to_go(boundary.r0, boundary.v0, boundary, field).t_go if t_go is None else t_go
    sol = open_loop_solution(boundary.r0, boundary.v0, t, boundary, field)
    ts = np.linspace(0.0, t, samples)
    v, a = sol.derivative(ts, 1), sol.derivative(ts, 2)
    ctrl = [inverse_controls(vi, ai, params) for vi, ai in zip(v, a, strict=True)]
    return {
        "flight_time_s": float(t),
        "max_load_factor": max(c.load_factor(params) for c in ctrl),
        "max_abs_theta_deg": float(np.degrees(max(abs(c.theta) for c in ctrl))),
        "max_abs_phi_deg": float(np.degrees(max(abs(c.phi) for c in ctrl))),
        "max_accel_ft_s2": float(np.linalg.norm(a, axis=1).max()),
    }
