"""``rangefx guide``: chapter-6 guidance, the report's law and the avoiding law (SPEC §7, §13).

Flies the report's boundary conditions (initial [532, 590, 7] ft, [0, -38, 0] ft/s; final
[740, 0, 0] ft, [1, 0, 0] ft/s; ζ = 0.96, α = 0.5, μ = 0, β = 1e-6) through the obstacle
set chosen with ``--obstacles``:

* ``synthetic`` (default): the documented stand-in for the report's 293 range points on
  four parked vehicles (:func:`rangefx.guidance.obstacles.synthetic_runway_obstacles`);
* ``runway``: the ``runway`` scene ranged by the golden ``g4_consistent`` method;
* ``runway-p1``: end to end — the same scene through the bit-accurate P1 pipeline in
  motion mode (one stream, frame store, rotation on).

``--law avoid`` (default) keeps ``--clearance`` ft from every extracted obstacle extent
(:mod:`rangefx.guidance.avoid`); ``--law report`` flies the report's law (eqs 20-69).
With ``--law avoid`` the report's law is also flown on the same obstacles and its
figures are given under ``report_law``. ``--layout-sweep N`` flies the avoiding law over
the ±10 ft shift grid and ``N`` seeded random layouts of the synthetic set instead.

Writes Figs 4-10 look-alikes (extents, clearance and true vehicles drawn),
``trajectory.csv``, ``obstacles.csv``, ``extents.csv`` and ``summary.json`` to ``--out``
(default ``rangefx-out/guide``); ``--json`` prints the summary as one JSON object.
"""

from __future__ import annotations

import argparse
import io
import json
import math
import sys
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..report import atomic_output_dir, atomic_write_text, json_safe
from .options import out_path

__all__ = ["add_parser", "cmd_guide", "guide_into"]

_HEADLINE = (
    "flight_time_s",
    "min_true_obstacle_distance_ft",
    "min_obstacle_distance",
    "max_load_factor",
    "max_abs_theta_deg",
    "max_abs_phi_deg",
    "max_abs_phi_deg_excluding_final_0_5s",
)


def _csv(header: str, rows: np.ndarray) -> str:
    buf = io.StringIO()
    np.savetxt(buf, rows, delimiter=",", header=header, comments="", fmt="%.6f")
    return buf.getvalue()


def cmd_guide(args: argparse.Namespace) -> int:
    if not all(math.isfinite(v) for v in args.shift):
        raise UserError(f"--shift must be finite numbers, not {args.shift}")
    if not (math.isfinite(args.clearance) and args.clearance > 0):
        raise UserError(f"--clearance must be a positive number of feet, not {args.clearance}")
    out = Path(args.out)
    if args.layout_sweep is not None:
        if args.layout_sweep < 0:
            raise UserError(f"--layout-sweep must be >= 0, not {args.layout_sweep}")
        with atomic_output_dir(out) as tmp:
            summary = sweep_into(
                tmp, args.layout_sweep, args.clearance, args.guidance_interval,
                args.replan_interval,
            )  # fmt: skip
        s = summary["summary"]
        for row in s["infeasible"]:
            print(
                f"rangefx: warning: layout {row['layout']}: no trajectory keeps "
                f"{args.clearance:g} ft within the limits (touch-down point "
                f"{row['touchdown_extent_clearance_ft']:.1f} ft from an extent)",
                file=sys.stderr,
            )
        if args.json:
            print(json.dumps(json_safe(summary)))
        else:
            print(
                f"layout sweep: {s['layouts']} layouts, {s['feasible']} feasible, "
                f"{s['feasible_keeping_clearance']} of them keep {args.clearance:g} ft from the "
                f"true vehicles; worst true clearance {s['worst_true_clearance_ft']:.2f} ft "
                f"(feasible: {s['worst_true_clearance_feasible_ft']:.2f} ft); infeasible: "
                f"{', '.join(r['layout'] for r in s['infeasible']) or 'none'}"
            )
            print(f"results written to {out}/")
        return 0
    with atomic_output_dir(out) as tmp:
        summary, notes, metrics = guide_into(
            tmp,
            args.obstacles,
            law=args.law,
            clearance_ft=args.clearance,
            shift=tuple(args.shift),
            guidance_interval=args.guidance_interval,
            replan_interval=args.replan_interval,
        )
    for note in notes:
        print(f"rangefx: warning: {note}", file=sys.stderr)
    if args.json:
        print(json.dumps(json_safe(summary)))
    else:
        print(_line(f"guide ({args.obstacles}, law {args.law})", metrics))
        if "report_law" in summary:
            print(_line("  report law on the same obstacles", summary["report_law"]))
        print(f"results written to {out}/")
    return 0


def _line(prefix: str, m: dict) -> str:
    return (
        f"{prefix}: flight time {m['flight_time_s']:.2f} s, "
        f"min distance to true vehicles {m['min_true_obstacle_distance_ft']:.2f} ft, "
        f"to its obstacles {m['min_obstacle_distance']:.2f} ft, "
        f"max load factor {m['max_load_factor']:.3f}, "
        f"max |theta| {m['max_abs_theta_deg']:.1f} deg, "
        f"max |phi| {m['max_abs_phi_deg']:.1f} deg "
        f"({m.get('max_abs_phi_deg_excluding_final_0_5s', math.nan):.1f} before the last 0.5 s)"
        + ("" if m.get("feasible", True) else " -- INFEASIBLE clearance")
    )


def _case(obstacles: str):
    from rangefx.guidance.cases import runway_case, synthetic_case

    if obstacles in ("runway", "runway-p1"):
        from rangefx.rtl_model.p1 import P1Config

        from ..studies.runner import range_source

        consistent = P1Config.default(variant="consistent")
        source = range_source("p1", consistent) if obstacles == "runway-p1" else None
        try:
            case = runway_case(source)
        except ValueError as exc:
            raise UserError(f"--obstacles {obstacles}: {exc}") from None
        case.info["method"] = (
            "P1 fixed point, motion mode, consistent, default config"
            if source
            else "golden g4_consistent"
        )
        case.info["reduction"] = "voxel"
        return case
    return synthetic_case()


def guide_into(
    tmp: Path,
    obstacles: str,
    *,
    law: str = "avoid",
    clearance_ft: float = 20.0,
    shift: tuple[float, float, float] = (0.0, 0.0, 0.0),
    guidance_interval: float = 0.1,
    replan_interval: float = 0.5,
) -> tuple[dict, list[str], dict]:
    """Fly the chosen law on the chosen obstacle set; write figures, CSVs and
    ``summary.json`` into the existing directory ``tmp``; return (summary, warnings,
    metrics). With ``law="avoid"`` the report's law is flown beside it."""
    from rangefx.guidance.avoid import AvoidConfig
    from rangefx.guidance.cases import fly
    from rangefx.guidance.example import REPORT_FIGURES
    from rangefx.guidance.plots import FIGURES, save_figures
    from rangefx.guidance.simulate import SimulationConfig

    try:
        config = SimulationConfig(
            guidance_interval=guidance_interval,
            sample_interval=min(0.02, guidance_interval),
        )
    except ValueError as exc:
        raise UserError(f"--guidance-interval: {exc}") from None
    try:
        avoid = AvoidConfig(clearance_ft=clearance_ft, replan_interval=replan_interval)
    except ValueError as exc:
        raise UserError(f"--clearance / --replan-interval: {exc}") from None
    case = _case(obstacles).shifted(shift)
    runs = {}
    for which in (law, "report") if law == "avoid" else (law,):
        try:
            runs[which] = fly(case, which, clearance_ft=clearance_ft, config=config, avoid=avoid)
        except (ValueError, RuntimeError) as exc:
            raise UserError(f"guidance ({which} law) failed: {exc}") from None
    run = runs[law]
    notes = list(run.warnings)
    kw = {}
    if case.scene is not None:
        kw = {
            "image": case.scene.image1,
            "view": (case.scene.camera, case.scene.motion),
            "to_ned": case.frame_map.to_scene,
        }
    compare = runs["report"].result if law == "avoid" else None
    save_figures(
        run.result, tmp, title=f"rangefx guide ({obstacles}, {law})", extents=case.boxes,
        truth=case.truth, clearance_ft=clearance_ft, compare=compare,
        labels=(f"{law} law", "report law"), **kw,
    )  # fmt: skip
    res = run.result
    d_true = np.min([b.signed_distance(res.positions) for b in case.truth], axis=0)
    traj = np.column_stack(
        [
            res.t,
            res.states[:, :3],
            res.states[:, 3],
            np.degrees(res.states[:, 4]),
            np.degrees(res.states[:, 5]),
            res.closest_obstacle_distance(),
            d_true,
        ]
    )
    atomic_write_text(
        tmp / "trajectory.csv",
        _csv(
            "t_s,x_ft,y_ft,z_ft,airspeed_ft_s,gamma_deg,chi_deg,closest_obstacle_ft,"
            "closest_true_vehicle_ft",
            traj,
        ),
    )
    atomic_write_text(tmp / "obstacles.csv", _csv("x_ft,y_ft,z_ft", res.obstacles))
    ext = np.array(
        [
            [*b.centre, math.degrees(b.heading), 2 * b.half_u, 2 * b.half_v, b.top]
            for b in case.boxes
        ]
    ).reshape(-1, 6)
    atomic_write_text(
        tmp / "extents.csv", _csv("x_ft,y_ft,heading_deg,length_ft,width_ft,height_ft", ext)
    )
    summary = {
        **run.metrics,
        "obstacles": {"source": obstacles, **case.info},
        "extraction": {**case.extraction.as_dict(), "scores": case.scores},
        "shift_ft": list(shift),
        "guidance_interval_s": config.guidance_interval,
        "replan_interval_s": replan_interval,
        "report": REPORT_FIGURES,
        "warnings": notes,
        "figures": sorted(FIGURES),
    }
    if law == "avoid":
        rep = runs["report"]
        summary["report_law"] = {**rep.metrics, "warnings": rep.warnings}
        t_rep = rep.metrics["flight_time_s"]
        summary["flight_time_ratio_to_report_law"] = run.metrics["flight_time_s"] / t_rep
    atomic_write_text(tmp / "summary.json", json.dumps(json_safe(summary), indent=2) + "\n")
    return summary, notes, run.metrics


def sweep_into(
    tmp: Path, n_random: int, clearance_ft: float, guidance_interval: float,
    replan_interval: float = 0.5,
) -> dict:  # fmt: skip
    """The layout sweep (:func:`rangefx.guidance.cases.layout_sweep`) into ``tmp``."""
    from tqdm import tqdm

    from rangefx.guidance.cases import layout_sweep, random_layouts, shift_grid_layouts
    from rangefx.guidance.simulate import SimulationConfig

    try:
        config = SimulationConfig(
            guidance_interval=guidance_interval, sample_interval=min(0.02, guidance_interval)
        )
    except ValueError as exc:
        raise UserError(f"--guidance-interval: {exc}") from None
    from rangefx.guidance.avoid import AvoidConfig

    try:
        # The same programme as a single flight: the sweep measures what `guide` flies.
        avoid = AvoidConfig(clearance_ft=clearance_ft, replan_interval=replan_interval)
    except ValueError as exc:
        raise UserError(f"--clearance / --replan-interval: {exc}") from None
    layouts = shift_grid_layouts() + random_layouts(n_random)
    bar = tqdm(total=len(layouts), desc="layout sweep", disable=not sys.stderr.isatty())
    try:
        out = layout_sweep(
            layouts,
            clearance_ft=clearance_ft,
            config=config,
            avoid=avoid,
            progress=lambda _n: bar.update(),
        )
    finally:
        bar.close()
    atomic_write_text(tmp / "sweep.json", json.dumps(json_safe(out), indent=2) + "\n")
    return out


def add_parser(sub) -> None:
    """Register ``guide`` on the ``rangefx`` subparsers."""
    p = sub.add_parser(
        "guide", help="fly the ch. 6 guidance: the avoiding law (default) or the report's"
    )
    p.add_argument(
        "--out",
        type=out_path,
        default="rangefx-out/guide",
        help="output directory (default ./rangefx-out/guide)",
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
        "--law",
        choices=("avoid", "report"),
        default="avoid",
        help="avoid: keep --clearance from every obstacle extent (receding-horizon optimal "
        "control, limits as constraints); report: the report's law, eqs 20-69 (default avoid)",
    )
    p.add_argument(
        "--clearance",
        type=float,
        default=20.0,
        metavar="FT",
        help="required clearance from every obstacle extent, ft (default 20)",
    )
    p.add_argument(
        "--shift",
        type=float,
        nargs=3,
        default=(0.0, 0.0, 0.0),
        metavar=("DX", "DY", "DZ"),
        help="move every obstacle (points, extents, true vehicles) by this (ft)",
    )
    p.add_argument(
        "--guidance-interval",
        type=float,
        default=0.1,
        help="time between guidance updates, s (default 0.1)",
    )
    p.add_argument(
        "--replan-interval",
        type=float,
        default=0.5,
        metavar="S",
        help="avoid law: time between re-solves of its programme, s (default 0.5)",
    )
    p.add_argument(
        "--layout-sweep",
        type=int,
        default=None,
        metavar="N",
        help="fly the avoiding law over the +-10 ft shift grid and N seeded random layouts "
        "of the synthetic set (writes sweep.json)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object with the figures")
    p.set_defaults(func=cmd_guide)
