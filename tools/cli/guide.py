"""``rangefx guide``: the report's chapter-6 guidance example (SPEC §7).

Flies the example (initial [532, 590, 7] ft, [0, -38, 0] ft/s; final [740, 0, 0] ft,
[1, 0, 0] ft/s; ζ = 0.96, α = 0.5, μ = 0, β = 1e-6) through the obstacle set chosen with
``--obstacles``:

* ``synthetic`` (default): the documented stand-in for the report's 293 range points on
  four parked vehicles (:func:`rangefx.guidance.obstacles.synthetic_runway_obstacles`);
* ``runway``: the ``runway`` scene ranged by the golden ``g4_consistent`` method, valid
  points mapped to inertial coordinates (eq 33) and reduced to ≤ 300 points
  (:func:`rangefx.guidance.obstacles.runway_scene_obstacles`);
* ``runway-p1``: end to end — the same scene through the bit-accurate P1 pipeline in
  motion mode (one stream, frame store, rotation on), then the same reduction.

Writes Figs 4-10 look-alikes, ``trajectory.csv``, ``obstacles.csv`` and ``summary.json``
to ``--out`` (default ``rangefx-out/guide``); ``--json`` prints the summary as one JSON
object.
"""

from __future__ import annotations

import argparse
import io
import json
import math
import sys
import warnings
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..report import atomic_output_dir, atomic_write_text, json_safe

__all__ = ["add_parser", "cmd_guide"]


def _csv(header: str, rows: np.ndarray) -> str:
    buf = io.StringIO()
    np.savetxt(buf, rows, delimiter=",", header=header, comments="", fmt="%.6f")
    return buf.getvalue()


def cmd_guide(args: argparse.Namespace) -> int:
    if not all(math.isfinite(v) for v in args.shift):
        raise UserError(f"--shift must be finite numbers, not {args.shift}")
    out = Path(args.out)
    with atomic_output_dir(out) as tmp:
        summary, notes, metrics = guide_into(
            tmp, args.obstacles, shift=tuple(args.shift), guidance_interval=args.guidance_interval
        )
    for note in notes:
        print(f"rangefx: warning: {note}", file=sys.stderr)
    if args.json:
        print(json.dumps(json_safe(summary)))
    else:
        m = metrics
        print(
            f"guide ({args.obstacles}, {m['n_obstacles']} obstacle points): "
            f"flight time {m['flight_time_s']:.2f} s (report 20), "
            f"min obstacle distance {m['min_obstacle_distance']:.2f} ft (report ~8.25), "
            f"max load factor {m['max_load_factor']:.3f} (report <= 1.02), "
            f"max |theta| {m['max_abs_theta_deg']:.1f} deg (report < 12), "
            f"max |phi| {m['max_abs_phi_deg']:.1f} deg (report < 15)"
        )
        print(f"results written to {out}/")
    return 0


def guide_into(
    tmp: Path,
    obstacles: str,
    *,
    shift: tuple[float, float, float] = (0.0, 0.0, 0.0),
    guidance_interval: float = 0.1,
) -> tuple[dict, list[str], dict]:
    """Fly the example with the chosen obstacle set; write figures, CSVs and
    ``summary.json`` into the existing directory ``tmp``; return (summary, warnings,
    metrics)."""
    from rangefx.guidance.example import REPORT_FIGURES, run_example
    from rangefx.guidance.law import NoTransversalityRootWarning
    from rangefx.guidance.obstacles import runway_scene_obstacles, synthetic_runway_obstacles
    from rangefx.guidance.plots import FIGURES, save_figures
    from rangefx.guidance.simulate import SimulationConfig

    try:
        config = SimulationConfig(
            guidance_interval=guidance_interval,
            sample_interval=min(0.02, guidance_interval),
        )
    except ValueError as exc:
        raise UserError(f"--guidance-interval: {exc}") from None
    image = view = to_ned = None
    info: dict = {"source": obstacles}
    if obstacles in ("runway", "runway-p1"):
        from rangefx.rtl_model.p1 import P1Config

        from ..studies.runner import range_source

        consistent = P1Config.default(variant="consistent")
        source = range_source("p1", consistent) if obstacles == "runway-p1" else None
        try:
            pts, scene, fmap, extra = runway_scene_obstacles(source)
        except ValueError as exc:
            raise UserError(f"--obstacles {obstacles}: {exc}") from None
        method = (
            "P1 fixed point, motion mode, consistent, default config"
            if source
            else "golden g4_consistent"
        )
        info.update(extra, method=method, reduction="voxel")
        image, view, to_ned = scene.image1, (scene.camera, scene.motion), fmap.to_scene
    else:
        pts = synthetic_runway_obstacles()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", NoTransversalityRootWarning)
        try:
            run = run_example(pts, shift=tuple(shift), config=config)
        except (ValueError, RuntimeError) as exc:
            raise UserError(f"guidance example failed: {exc}") from None
    notes = [str(w.message) for w in caught if issubclass(w.category, Warning)]
    kw = {} if view is None else {"image": image, "view": view, "to_ned": to_ned}
    save_figures(run.result, tmp, title=f"rangefx guide ({obstacles})", **kw)
    res = run.result
    traj = np.column_stack(
        [
            res.t,
            res.states[:, :3],
            res.states[:, 3],
            np.degrees(res.states[:, 4]),
            np.degrees(res.states[:, 5]),
            res.closest_obstacle_distance(),
        ]
    )
    atomic_write_text(
        tmp / "trajectory.csv",
        _csv("t_s,x_ft,y_ft,z_ft,airspeed_ft_s,gamma_deg,chi_deg,closest_obstacle_ft", traj),
    )
    atomic_write_text(tmp / "obstacles.csv", _csv("x_ft,y_ft,z_ft", res.obstacles))
    summary = {
        **run.metrics,
        "obstacles": info,
        "shift_ft": list(shift),
        "guidance_interval_s": config.guidance_interval,
        "report": REPORT_FIGURES,
        "warnings": notes,
        "figures": sorted(FIGURES),
    }
    atomic_write_text(tmp / "summary.json", json.dumps(json_safe(summary), indent=2) + "\n")
    return summary, notes, run.metrics


def add_parser(sub) -> None:
    """Register ``guide`` on the ``rangefx`` subparsers."""
    p = sub.add_parser("guide", help="fly the report's ch. 6 obstacle-avoidance guidance example")
    p.add_argument(
        "--out", default="rangefx-out/guide", help="output directory (default ./rangefx-out/guide)"
    )
    p.add_argument(
        "--obstacles",
        choices=("synthetic", "runway", "runway-p1"),
        default="synthetic",
        help="obstacle set: documented synthetic stand-in, the runway scene ranged by "
        "golden g4_consistent, or (runway-p1, end to end) by the fixed-point P1 pipeline "
        "in motion mode (default synthetic)",
    )
    p.add_argument(
        "--shift",
        type=float,
        nargs=3,
        default=(0.0, 0.0, 0.0),
        metavar=("DX", "DY", "DZ"),
        help="move every obstacle point by this (ft)",
    )
    p.add_argument(
        "--guidance-interval",
        type=float,
        default=0.1,
        help="time between guidance updates, s (default 0.1)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object with the figures")
    p.set_defaults(func=cmd_guide)
