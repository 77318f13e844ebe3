"""Guidance cases end to end: obstacle points, extracted extents and true geometry, flown
by either law, with the figures of SPEC §13 (clearance to the true vehicles, extraction
scores, limits) and the layout sweep.

A :class:`GuidanceCase` holds what both laws need: the obstacle *points* (the report's
law, eqs 20-69, and the eq-20 cost of the avoiding law), the obstacle *extents*
extracted from them (:mod:`.extraction`; the avoiding law keeps its clearance from
these) and the *true* objects (scored against, never used by a law).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from .avoid import AvoidConfig, InfeasibleClearanceWarning, simulate_avoid
from .example import REPORT_BOUNDARY, REPORT_WEIGHTS
from .extraction import (
    ExtractionConfig,
    ExtractionResult,
    ObstacleBox,
    boxes_from_vehicles,
    extract_from_points,
    extract_obstacles,
    scene_truth_boxes,
    score_extraction,
)
from .law import BoundaryConditions, GuidanceWeights, NoTransversalityRootWarning, ObstacleField
from .model import VehicleParams
from .obstacles import (
    REPORT_VEHICLES,
    FrameMap,
    ParkedVehicle,
    RangeMapSource,
    obstacles_from_range,
    runway_range,
    synthetic_runway_obstacles,
)
from .simulate import SimulationConfig, SimulationResult, simulate, trajectory_metrics

__all__ = [
    "LAWS",
    "GuidanceCase",
    "GuidanceRun",
    "fly",
    "guidance_metrics",
    "layout_sweep",
    "random_layouts",
    "runway_case",
    "runway_scene_for",
    "shift_grid_layouts",
    "synthetic_case",
]

#: Selectable laws: the default that keeps the clearance, and the report's own.
LAWS: tuple[str, ...] = ("avoid", "report")

#: The synthetic set's camera (the example's start, 7 ft up).
SYNTHETIC_CAMERA = (532.0, 590.0, 7.0)


@dataclass
class GuidanceCase:
    """Obstacle points, extracted extents and true objects of one layout (guidance frame)."""

    name: str
    points: np.ndarray
    boxes: tuple[ObstacleBox, ...]
    truth: tuple[ObstacleBox, ...]
    extraction: ExtractionResult
    info: dict = field(default_factory=dict)
    scene: object = None
    frame_map: FrameMap | None = None

    @property
    def scores(self) -> dict:
        return score_extraction(self.boxes, self.truth)

    def shifted(self, shift: tuple[float, float, float]) -> GuidanceCase:
        """The whole layout (points, extents, truth) moved horizontally by ``shift``
        (points also vertically)."""
        d = np.asarray(shift, dtype=np.float64)
        if not np.any(d):
            return self

        def move(b: ObstacleBox) -> ObstacleBox:
            return replace(b, centre=(b.centre[0] + d[0], b.centre[1] + d[1]))

        return replace(
            self,
            points=self.points + d,
            boxes=tuple(move(b) for b in self.boxes),
            truth=tuple(move(b) for b in self.truth),
            info={**self.info, "shift_ft": d.tolist()},
        )


def synthetic_case(
    vehicles: tuple[ParkedVehicle, ...] = REPORT_VEHICLES,
    *,
    seed: int = 0,
    extraction: ExtractionConfig | None = None,
    name: str = "synthetic",
) -> GuidanceCase:
    """The synthetic stand-in (:func:`.obstacles.synthetic_runway_obstacles`): its points,
    the extents extracted from them (:func:`.extraction.extract_from_points`) and the
    parked vehicles' boxes as truth."""
    pts = synthetic_runway_obstacles(vehicles, seed=seed)
    ex = extract_from_points(pts, camera_position=SYNTHETIC_CAMERA, config=extraction)
    return GuidanceCase(name, pts, ex.obstacles, boxes_from_vehicles(vehicles), ex)


def runway_case(
    source: RangeMapSource | None = None,
    *,
    scene=None,
    max_points: int = 300,
    extraction: ExtractionConfig | None = None,
    name: str = "runway",
) -> GuidanceCase:
    """The ``runway`` scene end to end: ``source`` ranges it (default golden
    ``g4_consistent``; the P1 pipeline plugs in), the valid points give the report's
    obstacle points (:func:`.obstacles.obstacles_from_range`, ≤ ``max_points`` by voxel
    clustering) and the extents (:func:`.extraction.extract_obstacles`; by default with
    the range-error model of the pair: motion, or stereo for a stereo pair); truth is
    the scene's vehicles."""
    r = runway_range(source, scene=scene)
    pts = obstacles_from_range(
        r.range_map, r.valid, r.scene.camera, r.scene.motion,
        max_points=max_points, max_range=r.max_range, frame_map=r.frame_map,
    )  # fmt: skip
    if extraction is None:  # the range-error model of the pair: stereo (P3) or motion
        kind = "stereo" if getattr(r.scene, "kind", "motion") == "stereo" else "motion"
        extraction = ExtractionConfig(error_model=kind)
    ex_cfg = replace(extraction, max_range=r.max_range)
    ex = extract_obstacles(
        r.range_map, r.valid, r.scene.camera, r.scene.motion,
        images=(r.scene.image1, r.scene.image2), frame_map=r.frame_map, config=ex_cfg,
    )  # fmt: skip
    truth = scene_truth_boxes(r.scene.name, r.frame_map)
    info = {"valid_pixels": int(np.count_nonzero(r.valid)), "obstacle_points": len(pts)}
    return GuidanceCase(name, pts, ex.obstacles, truth, ex, info, r.scene, r.frame_map)


def runway_scene_for(modes: tuple[str, ...], **render):
    """The rendering of the ``runway`` scene a pipeline with these ``modes`` ranges: the
    motion pair (:func:`rangefx.golden.scenes.render_scene`) when it models motion mode,
    else the stereo pair (:func:`rangefx.golden.scenes.render_runway_stereo`: same view
    1, a second camera beside it); ``render`` (size, seed, ...) goes to the renderer.
    ``ValueError`` when it models neither."""
    from rangefx.golden.scenes import render_runway_stereo, render_scene

    if "motion" in modes:
        return render_scene("runway", **render)
    if "stereo" in modes:
        return render_runway_stereo(**render)
    raise ValueError(f"the runway scene is a motion or a stereo pair; the pipeline models {modes}")


@dataclass
class GuidanceRun:
    """One flight: the law, its result and its figures."""

    law: str
    result: SimulationResult
    metrics: dict
    warnings: list[str]


def _min_box_distance(pos: np.ndarray, boxes: tuple[ObstacleBox, ...]) -> np.ndarray:
    if not boxes:
        return np.full(len(pos), math.inf)
    return np.min([b.signed_distance(pos) for b in boxes], axis=0)


def guidance_metrics(
    res: SimulationResult, case: GuidanceCase, law: str, clearance_ft: float
) -> dict:
    """Figures of a flight (SPEC §13), on the integrated (0.02 s) trajectory samples.

    Adds to :func:`.simulate.trajectory_metrics`: ``law``, ``clearance_ft``,
    ``min_true_obstacle_distance_ft`` (to the true objects), ``min_extent_distance_ft``
    (to the extracted extents), ``min_obstacle_point_distance_ft`` (to the points),
    ``min_obstacle_distance`` (to the obstacles that law uses: extents for ``avoid``,
    points for ``report``), ``clearance_kept`` (true distance >= clearance),
    ``max_abs_phi_deg_excluding_final_0_5s`` and the same for θ and the load factor,
    and for ``avoid`` ``feasible``, ``outcome`` (landing, hover, go-around, crash),
    ``manoeuvre`` (the safe manoeuvre taken, or ``None``), ``landing_blocked`` (why no
    landing, ``""`` if none) and the compute cost.
    """
    m = trajectory_metrics(res)
    pos = res.positions
    true_d = _min_box_distance(pos, case.truth)
    ext_d = _min_box_distance(pos, case.boxes)
    m["law"] = law
    m["clearance_ft"] = float(clearance_ft)
    m["min_obstacle_point_distance_ft"] = m["min_obstacle_distance"]
    m["min_extent_distance_ft"] = float(ext_d.min())
    m["min_true_obstacle_distance_ft"] = float(true_d.min())
    if law == "avoid":
        m["min_obstacle_distance"] = m["min_extent_distance_ft"]
    m["clearance_kept"] = bool(true_d.min() >= clearance_ft)
    early = res.t_cmd < res.flight_time - 0.5
    if early.any():
        m["max_abs_phi_deg_excluding_final_0_5s"] = float(np.degrees(np.abs(res.phi[early]).max()))
        m["max_abs_theta_deg_excluding_final_0_5s"] = float(
            np.degrees(np.abs(res.theta[early]).max())
        )
        m["max_load_factor_excluding_final_0_5s"] = float(
            res.thrust[early].max() / res.params.weight_lbf
        )
    if law == "avoid":
        ex = res.extras
        times = np.asarray(ex["solve_times_s"])
        m["feasible"] = ex["feasible"]
        m["outcome"] = ex["outcome"]
        m["manoeuvre"] = ex["manoeuvre"]
        m["landing_blocked"] = ex["landing_blocked"]
        m["crash_reason"] = ex["crash_reason"]
        m["compute"] = {
            "solves": int(ex["plans"]),
            "replan_failures": int(ex["replan_failures"]),
            "solve_time_mean_s": float(times.mean()),
            "solve_time_max_s": float(times.max()),
            "first_solve_time_s": float(times[0]),
            "solve_iterations_mean": float(np.mean(ex["solve_iterations"])),
            "solve_time_per_guidance_update_s": float(times.sum() / m["guidance_updates"]),
        }
        m["planned_min_clearance_ft"] = ex["planned_min_clearance_ft"]
        m["terminal_segment_skipped_s"] = ex["terminal_segment_skipped_s"]
        m["limited_updates"] = ex["limited_updates"]
    return m


def fly(
    case: GuidanceCase,
    law: str = "avoid",
    *,
    clearance_ft: float = 20.0,
    weights: GuidanceWeights = REPORT_WEIGHTS,
    boundary: BoundaryConditions = REPORT_BOUNDARY,
    params: VehicleParams | None = None,
    config: SimulationConfig | None = None,
    avoid: AvoidConfig | None = None,
) -> GuidanceRun:
    """Fly ``case`` with ``law`` (``"avoid"`` or ``"report"``), collecting its warnings."""
    if law not in LAWS:
        raise ValueError(f"unknown law {law!r}; choose from {', '.join(LAWS)}")
    field_ = ObstacleField(case.points, weights)
    av = replace(avoid or AvoidConfig(), clearance_ft=clearance_ft)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", NoTransversalityRootWarning)
        warnings.simplefilter("always", InfeasibleClearanceWarning)
        if law == "avoid":
            res = simulate_avoid(boundary, field_, case.boxes, params, config, av)
        else:
            res = simulate(boundary, field_, params, config)
    notes = [str(w.message) for w in caught if issubclass(w.category, Warning)]
    metrics = guidance_metrics(res, case, law, clearance_ft)
    metrics["obstacle_centroid"] = [float(c) for c in field_.centroid]
    return GuidanceRun(law, res, metrics, notes)


# --------------------------------------------------------------------------- layout sweep


def shift_grid_layouts(step: float = 10.0) -> list[tuple[str, tuple[ParkedVehicle, ...]]]:
    """The synthetic layout shifted by ``{-step, 0, +step}`` in x and y (9 layouts)."""
    out = []
    for dx in (-step, 0.0, step):
        for dy in (-step, 0.0, step):
            vs = tuple(
                replace(v, centre=(v.centre[0] + dx, v.centre[1] + dy)) for v in REPORT_VEHICLES
            )
            out.append((f"shift({dx:+g},{dy:+g})", vs))
    return out


def random_layouts(
    count: int = 20,
    *,
    seed: int = 0,
    n_vehicles: int = 4,
    y_range: tuple[float, float] = (-60, 450),
) -> list[tuple[str, tuple[ParkedVehicle, ...]]]:
    """``count`` seeded layouts of truck-sized boxes parked beside the runway.

    Each vehicle stands on either side of the runway (centre x = 714 or 766, ±3 ft, as in
    :data:`.obstacles.REPORT_VEHICLES`) at a uniform ``y`` in ``y_range``, drawn with
    ``numpy.random.default_rng(seed + k)`` for layout ``k``; overlapping boxes are
    redrawn.
    """
    out = []
    for k in range(count):
        rng = np.random.default_rng(seed + k)
        vs: list[ParkedVehicle] = []
        while len(vs) < n_vehicles:
            side = 714.0 if rng.random() < 0.5 else 766.0
            x = side + rng.uniform(-3.0, 3.0)
            y = rng.uniform(*y_range)
            if any(abs(x - v.centre[0]) < 9 and abs(y - v.centre[1]) < 21 for v in vs):
                continue
            vs.append(ParkedVehicle(f"Vehicle {len(vs) + 1}", (x, y), (8.0, 20.0, 8.0), 75))
        out.append((f"random{seed + k}", tuple(vs)))
    return out


def layout_sweep(
    layouts: list[tuple[str, tuple[ParkedVehicle, ...]]],
    *,
    clearance_ft: float = 20.0,
    config: SimulationConfig | None = None,
    avoid: AvoidConfig | None = None,
    progress=None,
) -> dict:
    """Fly the avoiding law over synthetic layouts and report per layout the clearance
    kept to the true vehicles, flight time, peak load factor and feasibility.

    Returns ``{"layouts": [...], "summary": {...}}``; the summary has the number of
    layouts, of feasible ones, the fraction of feasible layouts that keep the
    clearance, the worst true clearance and the names of the infeasible layouts (with
    the reason: which end point is inside the clearance, or none).
    """
    rows = []
    for name, vehicles in layouts:
        case = synthetic_case(vehicles, name=name)
        try:
            run = fly(case, "avoid", clearance_ft=clearance_ft, config=config, avoid=avoid)
        except RuntimeError as exc:  # the model left its domain: say so, do not drop it
            rows.append({"layout": name, "feasible": False, "failed": str(exc),
                         "vehicles": [list(v.centre) for v in vehicles]})  # fmt: skip
            continue
        m = run.metrics
        bc = REPORT_BOUNDARY
        ends = np.stack([bc.r0, bc.rf])
        end_clear = _min_box_distance(ends, case.boxes)
        rows.append(
            {
                "layout": name,
                "vehicles": [list(v.centre) for v in vehicles],
                "feasible": m["feasible"],
                "outcome": m["outcome"],
                "min_true_obstacle_distance_ft": m["min_true_obstacle_distance_ft"],
                "min_extent_distance_ft": m["min_extent_distance_ft"],
                "clearance_kept": m["clearance_kept"],
                "flight_time_s": m["flight_time_s"],
                "max_load_factor": m["max_load_factor"],
                "max_abs_theta_deg": m["max_abs_theta_deg"],
                "max_abs_phi_deg": m["max_abs_phi_deg"],
                "limited_updates": m["limited_updates"],
                "touchdown_extent_clearance_ft": float(end_clear[1]),
                "extraction_detected": case.scores["detected"],
                "extraction_false": case.scores["false_obstacles"],
                "solve_time_mean_s": m["compute"]["solve_time_mean_s"],
                "warnings": run.warnings,
            }
        )
        if progress is not None:
            progress(name)
    flown = [r for r in rows if "failed" not in r]
    feas = [r for r in flown if r["feasible"]]
    kept = [r for r in feas if r["clearance_kept"]]
    summary = {
        "layouts": len(rows),
        "feasible": len(feas),
        "feasible_keeping_clearance": len(kept),
        "fraction_feasible_keeping_clearance": len(kept) / len(feas) if feas else math.nan,
        "failed": [{"layout": r["layout"], "reason": r["failed"]} for r in rows if "failed" in r],
        "worst_true_clearance_ft": min(
            (r["min_true_obstacle_distance_ft"] for r in flown), default=math.nan
        ),
        "worst_true_clearance_feasible_ft": (
            min(r["min_true_obstacle_distance_ft"] for r in feas) if feas else math.nan
        ),
        "infeasible": [
            {
                "layout": r["layout"],
                "touchdown_extent_clearance_ft": r["touchdown_extent_clearance_ft"],
                "min_true_obstacle_distance_ft": r["min_true_obstacle_distance_ft"],
            }
            for r in flown
            if not r["feasible"]
        ],
        "max_load_factor": max((r["max_load_factor"] for r in flown), default=math.nan),
        "max_load_factor_feasible": max((r["max_load_factor"] for r in feas), default=math.nan),
        "flight_time_range_s": [
            min((r["flight_time_s"] for r in flown), default=math.nan),
            max((r["flight_time_s"] for r in flown), default=math.nan),
        ],
        "clearance_ft": clearance_ft,
    }
    return {"layouts": rows, "summary": summary}
