"""A stress programme for the avoiding law: vehicles put on or near the nominal path
(SPEC §13, issue 39).

Why
---
The single flights and the layout sweep (:mod:`rangefx.guidance.cases`) do not put a vehicle
in the way:
on ``runway``/P1 no true vehicle is within 42 ft of even the report law's path, and the
sweep's vehicles stand beside the runway with perfect points. Here each layout moves a
whole ranged layout (the pipeline's range points, the extents extracted from them and
the true vehicles, rigidly, as ``rangefx guide --shift`` does) so that one true vehicle
stands on or near the *nominal path* — the report law's path on the unmoved layout — at
a seeded time along it. The obstacles therefore carry the pipeline's range errors
(extents long along the viewing rays), never perfect points, and every flight is scored
against the true geometry.

Each layout is flown by the avoiding law (:func:`rangefx.guidance.cases.fly`) and by the
report's law
(its flight time is the reference of the flight-time ratio; its true clearance shows
what the layout asks of a law that does not avoid).
"""

from __future__ import annotations

import math
import multiprocessing
import signal
import time
from dataclasses import dataclass, field, replace

import numpy as np

from .avoid import OUTCOMES, STOP_DISTANCE_FACTORS, AvoidConfig, stopping_distance
from .cases import GuidanceCase, fly
from .extraction import ObstacleBox
from .simulate import SimulationConfig

__all__ = [
    "StressLayout",
    "StressResult",
    "braking_segment",
    "stress_layouts",
    "stress_programme",
]


@dataclass(frozen=True)
class StressLayout:
    """One stress layout: the rigid shift of the ranged layout that puts ``vehicle`` at
    the nominal path's position at ``path_time_s``, ``offset_ft`` to its right (negative:
    left, horizontal and normal to the path)."""

    name: str
    shift_ft: tuple[float, float, float]
    vehicle: str
    path_time_s: float
    offset_ft: float

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "shift_ft": list(self.shift_ft),
            "vehicle": self.vehicle,
            "path_time_s": self.path_time_s,
            "offset_ft": self.offset_ft,
        }


def _min_distance(pos: np.ndarray, boxes: tuple[ObstacleBox, ...]) -> np.ndarray:
    if not boxes:
        return np.full(len(pos), math.inf)
    return np.min([b.signed_distance(pos) for b in boxes], axis=0)


def braking_segment(
    start: np.ndarray, velocity: np.ndarray, avoid: AvoidConfig | None = None, n: int = 33
) -> np.ndarray:
    """``n`` points from ``start`` along the horizontal part of ``velocity`` to where the
    law's braking stop (:func:`rangefx.guidance.avoid.plan_braking_stop`) holds: its
    first hold point, ``STOP_DISTANCE_FACTORS[0]`` × the :func:`stopping_distance` of the
    speed ahead (1.25 × 69 ft = 86 ft from the report's 38 ft/s). The stress layouts
    keep every true vehicle ``clearance`` from it."""
    start = np.asarray(start, dtype=np.float64)
    v = np.asarray(velocity, dtype=np.float64)
    speed = float(np.hypot(v[0], v[1]))
    if speed < 1e-9:
        return start[None].copy()
    d = np.array([v[0] / speed, v[1] / speed, 0.0])
    length = STOP_DISTANCE_FACTORS[0] * stopping_distance(speed, avoid)
    s = np.linspace(0.0, length, n)[:, None]
    return start[None] + s * d[None]


def stress_layouts(
    case: GuidanceCase,
    nominal_t: np.ndarray,
    nominal_pos: np.ndarray,
    count: int,
    *,
    seed: int = 0,
    max_offset_ft: float = 12.0,
    end_clearance_ft: float = 5.0,
    clearance_ft: float = 20.0,
    start_velocity: np.ndarray | None = None,
    avoid: AvoidConfig | None = None,
) -> list[StressLayout]:
    """``count`` seeded layouts of ``case``: layout ``k`` draws, with
    ``numpy.random.default_rng([seed, k])``, a true vehicle, a time uniform in the
    middle 70 % of the nominal path (``nominal_t``, ``nominal_pos``) and a lateral
    offset uniform in ``±max_offset_ft``, and shifts the layout horizontally so that the
    vehicle's centre lands there. Draws that put a true vehicle within
    ``end_clearance_ft`` of the start or the touch-down (no flight could start or end
    there) are redrawn, and so are those that put one within ``clearance_ft`` of the
    **braking segment** (:func:`braking_segment`: the start, and the straight line
    along the start's velocity ``start_velocity`` -- default the nominal path's first
    step -- to where the law's braking stop holds, 1.25 × the distance a deceleration
    within ``avoid``'s limits needs): such a vehicle is inside the stopping distance, or
    inside the clearance, of the start, and no law within the limits need keep the
    clearance from it. Every layout drawn therefore has a safe answer, the law's own
    braking stop."""
    if count < 0:
        raise ValueError(f"stress layout count must be >= 0, not {count!r}")
    if not case.truth:
        raise ValueError("stress layouts need true vehicles to put on the path")
    t_end = float(nominal_t[-1])
    ends = nominal_pos[[0, -1]]
    if start_velocity is None:
        start_velocity = (nominal_pos[1] - nominal_pos[0]) / (nominal_t[1] - nominal_t[0])
    braking = braking_segment(nominal_pos[0], start_velocity, avoid)
    out: list[StressLayout] = []
    for k in range(count):
        rng = np.random.default_rng([seed, k])
        for _ in range(1000):
            box = case.truth[int(rng.integers(len(case.truth)))]
            t = float(rng.uniform(0.15, 0.85) * t_end)
            off = float(rng.uniform(-max_offset_ft, max_offset_ft))
            p = np.array([np.interp(t, nominal_t, nominal_pos[:, i]) for i in range(2)])
            i = int(np.clip(np.searchsorted(nominal_t, t), 1, len(nominal_t) - 1))
            d = nominal_pos[i, :2] - nominal_pos[i - 1, :2]
            d = d / max(float(np.hypot(*d)), 1e-9)
            right = np.array([-d[1], d[0]])  # y lies to the right of x (guidance frame)
            target = p + off * right
            shift = (float(target[0] - box.centre[0]), float(target[1] - box.centre[1]), 0.0)
            moved = tuple(
                replace(b, centre=(b.centre[0] + shift[0], b.centre[1] + shift[1]))
                for b in case.truth
            )
            if (
                _min_distance(ends, moved).min() >= end_clearance_ft
                and _min_distance(braking, moved).min() >= clearance_ft
            ):
                break
        else:  # pragma: no cover - 1000 draws all blocked an end point
            raise ValueError(
                f"stress layout {k}: every draw puts a vehicle on an end point or on the "
                "braking segment"
            )
        out.append(StressLayout(f"stress{seed}-{k}", shift, box.name, t, off))
    return out


@dataclass
class StressResult:
    """Per-layout figures and the summary of a stress programme (:meth:`to_dict`)."""

    source: str
    clearance_ft: float
    seed: int
    rows: list[dict]
    nominal_flight_time_s: float
    extent_along_ray_ft: dict = field(default_factory=dict)
    runs: dict = field(default_factory=dict, repr=False)  # name -> (avoid, report) runs

    @property
    def summary(self) -> dict:
        rows = self.rows
        flown = [r for r in rows if r["outcome"] != "crash"]
        landed = [r for r in rows if r["outcome"] == "landing"]

        def rng(key, sel):
            vals = [r[key] for r in sel if math.isfinite(r[key])]
            return [min(vals), max(vals)] if vals else [math.nan, math.nan]

        return {
            "layouts": len(rows),
            "outcomes": {o: sum(r["outcome"] == o for r in rows) for o in OUTCOMES},
            "manoeuvres": {
                k: sum(r["manoeuvre"] == k for r in rows)
                for k in sorted({r["manoeuvre"] for r in rows if r["manoeuvre"]})
            },
            "landings_after_manoeuvre": sum(r["landed_after_manoeuvre"] for r in rows),
            "collisions": sum(r["collision"] for r in rows),
            "crashes": sum(r["outcome"] == "crash" for r in rows),
            "landings_keeping_clearance": sum(r["clearance_kept"] for r in landed),
            "min_true_distance_ft": min(
                (r["min_true_distance_ft"] for r in rows), default=math.nan
            ),
            "min_true_distance_landing_ft": min(
                (r["min_true_distance_ft"] for r in landed), default=math.nan
            ),
            "min_extent_distance_landing_ft": min(
                (r["min_extent_distance_ft"] for r in landed), default=math.nan
            ),
            "max_load_factor": max((r["max_load_factor"] for r in flown), default=math.nan),
            "max_abs_theta_deg": max((r["max_abs_theta_deg"] for r in flown), default=math.nan),
            "max_abs_phi_deg": max((r["max_abs_phi_deg"] for r in flown), default=math.nan),
            "flight_time_ratio_landing": rng("flight_time_ratio", landed),
            "flight_time_s": rng("flight_time_s", flown),
            "report_law_collisions": sum(r["report_law_collision"] for r in rows),
            "report_law_min_true_distance_ft": min(
                (r["report_law_min_true_distance_ft"] for r in rows), default=math.nan
            ),
        }

    def worst(self, k: int = 4) -> list[dict]:
        """The ``k`` layouts that came closest to a true vehicle."""
        return sorted(self.rows, key=lambda r: r["min_true_distance_ft"])[:k]

    def to_dict(self) -> dict:
        return {
            "source": self.source,
            "clearance_ft": self.clearance_ft,
            "seed": self.seed,
            "nominal_flight_time_s": self.nominal_flight_time_s,
            "extent_along_ray_ft": self.extent_along_ray_ft,
            "summary": self.summary,
            "layouts": self.rows,
        }


def extent_along_ray_lengths(case: GuidanceCase, camera: np.ndarray) -> dict:
    """Length of each extent along the viewing ray from ``camera`` to its centre (ft):
    the range uncertainty the extraction carries (min, median, max and per extent)."""
    lengths = []
    for b in case.boxes:
        ray = np.asarray(b.centre) - camera[:2]
        ray = ray / max(float(np.hypot(*ray)), 1e-9)
        u, v = b.axes
        # extent of the box along the ray: the support of its footprint
        lengths.append(2.0 * (abs(ray @ u) * b.half_u + abs(ray @ v) * b.half_v))
    if not lengths:
        return {"n": 0}
    arr = np.array(lengths)
    return {
        "n": len(arr),
        "min_ft": float(arr.min()),
        "median_ft": float(np.median(arr)),
        "max_ft": float(arr.max()),
        "per_extent_ft": [float(x) for x in arr],
    }


def _worker_signals() -> None:
    """A worker's stop signals: the default action (a forked worker inherits the
    command's handler, which would let it fly on until its code returns to Python), and
    Ctrl-C left to the command, which ends its workers."""
    for name in ("SIGTERM", "SIGHUP"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _stress_row_indexed(job: tuple[int, tuple]) -> tuple[int, tuple[dict, tuple]]:
    """:func:`_stress_row` in a worker process, with the index of its layout."""
    index, args = job
    return index, _stress_row(*args)


def _stress_row(
    case: GuidanceCase,
    lay: StressLayout,
    nominal_positions: np.ndarray,
    clearance_ft: float,
    config: SimulationConfig | None,
    avoid: AvoidConfig | None,
) -> tuple[dict, tuple]:
    """One layout of :func:`stress_programme`: its row and ``(moved case, avoid run,
    report run)``."""
    cpu0, wall0 = time.process_time(), time.perf_counter()
    moved = case.shifted(lay.shift_ft)
    rep = fly(moved, "report", clearance_ft=clearance_ft, config=config, avoid=avoid)
    run = fly(moved, "avoid", clearance_ft=clearance_ft, config=config, avoid=avoid)
    m, ex = run.metrics, run.result.extras
    ends = np.stack([run.result.bc.r0, np.asarray(ex["touchdown"])])
    end_ext = _min_distance(ends, moved.boxes)
    path_d = _min_distance(nominal_positions, moved.truth)
    near = sum(
        bool(np.min(b.signed_distance(nominal_positions)) < clearance_ft) for b in moved.truth
    )
    t_rep = rep.metrics["flight_time_s"]
    row = {
        **lay.to_dict(),
        "vehicles_within_clearance_of_nominal_path": near,
        "nominal_path_true_distance_ft": float(path_d.min()),
        "outcome": ex["outcome"],
        "manoeuvre": (ex["manoeuvre"] or {}).get("kind", ""),
        "hold_point_ft": (ex["manoeuvre"] or {}).get("hold_point_ft"),
        "landed_after_manoeuvre": bool(
            ((ex["manoeuvre"] or {}).get("landing_after") or {}).get("landed", False)
        ),
        "manoeuvre_keeps_floor": (ex["manoeuvre"] or {}).get("keeps_clearance_floor"),
        "crash_reason": ex["crash_reason"],
        "feasible": m["feasible"],
        "collision": bool(m["min_true_obstacle_distance_ft"] < 0.0),
        "min_true_distance_ft": m["min_true_obstacle_distance_ft"],
        "min_extent_distance_ft": m["min_extent_distance_ft"],
        "clearance_kept": m["clearance_kept"],
        "start_extent_distance_ft": float(end_ext[0]),
        "touchdown_extent_distance_ft": float(end_ext[1]),
        "flight_time_s": m["flight_time_s"],
        "flight_time_ratio": m["flight_time_s"] / t_rep,
        "max_load_factor": m["max_load_factor"],
        "max_abs_theta_deg": m["max_abs_theta_deg"],
        "max_abs_phi_deg": m["max_abs_phi_deg"],
        "min_altitude_ft": float(run.result.positions[:, 2].min()),
        "limited_updates": m["limited_updates"],
        "solves": m["compute"]["solves"],
        "planner_wall_s": float(sum(ex["solve_times_s"])),
        "report_law_min_true_distance_ft": rep.metrics["min_true_obstacle_distance_ft"],
        "report_law_collision": bool(rep.metrics["min_true_obstacle_distance_ft"] < 0),
        "warnings": run.warnings,
        "cpu_s": time.process_time() - cpu0,  # both laws, this layout (its process)
        "wall_s": time.perf_counter() - wall0,
    }
    return row, (moved, run, rep)


def stress_programme(
    case: GuidanceCase,
    count: int,
    *,
    seed: int = 0,
    source: str = "",
    clearance_ft: float = 20.0,
    config: SimulationConfig | None = None,
    avoid: AvoidConfig | None = None,
    progress=None,
    indices: list[int] | None = None,
    jobs: int = 1,
    done: dict[str, dict] | None = None,
    on_row=None,
) -> StressResult:
    """Fly ``count`` stress layouts of ``case`` (:func:`stress_layouts`) with the avoiding
    law, and the report's law beside it, and score both against the true vehicles.

    Per layout: ``outcome`` (landing, hover, go-around, crash), ``manoeuvre``,
    ``collision`` (the avoiding law entered a true vehicle), the smallest distance to
    the true vehicles and to the extents, ``clearance_kept`` (true distance ≥ the
    clearance), flight time and its ratio to the report law's, peak load factor, |θ|,
    |φ|, the start's and touch-down's distances to the extents, the planner's time
    (``planner_wall_s``, the sum of its solves) and the report law's true distance and
    collision. ``indices`` flies only those of the ``count`` layouts (the layouts are
    drawn per index, so a programme can be split over processes); ``jobs`` > 1 flies
    them in that many worker processes (the same rows, in layout order).

    ``done`` maps layout names to rows flown before (a resumed run): those layouts are
    not flown again and their rows are taken as they are (``runs`` has no entry for
    them). ``on_row(row)`` is called with each newly flown row as soon as it is
    finished (in finishing order with ``jobs`` > 1), e.g. to append it to a journal."""
    if not isinstance(jobs, int) or jobs < 1:
        raise ValueError(f"stress jobs must be an integer >= 1, not {jobs!r}")
    nominal = fly(case, "report", clearance_ft=clearance_ft, config=config, avoid=avoid)
    nom = nominal.result
    runs: dict = {}
    layouts = stress_layouts(
        case, nom.t, nom.positions, count, seed=seed, clearance_ft=clearance_ft,
        start_velocity=nom.bc.v0, avoid=avoid,
    )  # fmt: skip
    todo = layouts if indices is None else [layouts[i] for i in indices]
    done = done or {}
    by_name = {lay.name: done[lay.name] for lay in todo if lay.name in done}
    fly_now = [lay for lay in todo if lay.name not in by_name]
    for name in by_name:
        if progress is not None:
            progress(name)
    args = (nom.positions, clearance_ft, config, avoid)

    def finished(lay: StressLayout, row: dict, flown) -> None:
        by_name[lay.name], runs[lay.name] = row, flown
        if on_row is not None:
            on_row(row)
        if progress is not None:
            progress(lay.name)

    if jobs > 1 and len(fly_now) > 1:
        # The rendered scene is not needed to fly: the workers get the case without it.
        light = replace(case, scene=None)
        work = [(i, (light, lay, *args)) for i, lay in enumerate(fly_now)]
        pool = multiprocessing.get_context().Pool(
            min(jobs, len(fly_now)), initializer=_worker_signals
        )
        try:
            for i, result in pool.imap_unordered(_stress_row_indexed, work):
                finished(fly_now[i], *result)
        except BaseException:
            # a stop signal or a failed layout ends the programme: its workers end with it
            # (joining them would fly every layout still running first)
            pool.terminate()
            raise
        else:
            pool.close()
        finally:
            pool.join()
    else:
        for lay in fly_now:
            finished(lay, *_stress_row(case, lay, *args))
    rows = [by_name[lay.name] for lay in todo]
    camera = np.asarray(nom.bc.r0)
    return StressResult(
        source, clearance_ft, seed, rows, nom.flight_time,
        extent_along_ray_lengths(case, camera), runs,
    )  # fmt: skip
