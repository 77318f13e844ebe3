"""``rangefx guide``: chapter-6 guidance, the report's law and the avoiding law (SPEC §7, §13).

Flies the report's boundary conditions (initial [532, 590, 7] ft, [0, -38, 0] ft/s; final
[740, 0, 0] ft, [1, 0, 0] ft/s; ζ = 0.96, α = 0.5, μ = 0, β = 1e-6) through the obstacle
set chosen with ``--obstacles``:

* ``synthetic`` (default): the documented stand-in for the report's 293 range points on
  four parked vehicles (:func:`rangefx.guidance.obstacles.synthetic_runway_obstacles`);
* ``runway``: the ``runway`` scene ranged by the golden ``g4_consistent`` method;
* ``runway-p1``: end to end — the same scene through the bit-accurate P1 pipeline in
  motion mode (one stream, frame store, rotation on);
* ``runway-p3``: end to end through P3 on the runway's stereo pair.

``--law avoid`` (default) keeps ``--clearance`` ft from every extracted obstacle extent
(:mod:`rangefx.guidance.avoid`); ``--law report`` flies the report's law (eqs 20-69).
With ``--law avoid`` the report's law is also flown on the same obstacles and its
figures are given under ``report_law``. ``--layout-sweep N`` flies the avoiding law over
the ±10 ft shift grid and ``N`` seeded random layouts of the synthetic set instead.
``--stress N [--pipeline NAME] [--seed S]`` flies both laws over ``N`` seeded layouts of
the ``runway`` scene ranged by the pipeline (default P3: it flew them better than P1),
each moved so that a true vehicle stands on or near the nominal path
(:mod:`rangefx.guidance.stress`), and writes ``stress.json``
and ``stress_worst.png``; each finished layout is appended to ``stress_layouts.jsonl`` in
``--out`` at once, and a re-run of the same command flies only the layouts not yet
there. When no path to the touch-down keeps the clearance the
avoiding law takes a safe manoeuvre (hover and hold, climb over, turn away; brake to a
stop when none keeps its floor) and says so.

One call of :func:`rangefx.api.guide` (:mod:`rangefx.tools.studies.flights`). Writes
Figs 4-10 look-alikes (extents, clearance and true vehicles drawn),
``trajectory.csv``, ``obstacles.csv``, ``extents.csv`` and ``summary.json`` to ``--out``
(default ``rangefx-out/guide``); ``--json`` prints the summary as one JSON object.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

from rangefx.rtl_model.registry import PIPELINES

from ..studies.flights import DEFAULT_PIPELINE, stress_table
from .options import out_path

__all__ = ["add_parser", "cmd_guide"]


def cmd_guide(args: argparse.Namespace) -> int:
    from rangefx import api

    result = api.guide(
        args.obstacles, law=args.law, clearance_ft=args.clearance, shift=tuple(args.shift),
        guidance_interval=args.guidance_interval, replan_interval=args.replan_interval,
        layout_sweep=args.layout_sweep, stress=args.stress, pipeline=args.pipeline,
        seed=args.seed, jobs=args.jobs, out=args.out if args.stress is not None else None,
    )  # fmt: skip
    out = result.write(args.out)
    if result.programme == "stress":
        print(json.dumps(result.to_dict()) if args.json else stress_table(result.summary))
    elif result.programme == "layout-sweep":
        s = result.summary["summary"]
        for row in s["infeasible"]:
            print(
                f"rangefx: warning: layout {row['layout']}: no trajectory keeps "
                f"{args.clearance:g} ft within the limits (touch-down point "
                f"{row['touchdown_extent_clearance_ft']:.1f} ft from an extent)",
                file=sys.stderr,
            )
        if args.json:
            print(json.dumps(result.to_dict()))
        else:
            print(
                f"layout sweep: {s['layouts']} layouts, {s['feasible']} feasible, "
                f"{s['feasible_keeping_clearance']} of them keep {args.clearance:g} ft from the "
                f"true vehicles; worst true clearance {s['worst_true_clearance_ft']:.2f} ft "
                f"(feasible: {s['worst_true_clearance_feasible_ft']:.2f} ft); infeasible: "
                f"{', '.join(r['layout'] for r in s['infeasible']) or 'none'}"
            )
    else:
        for note in result.warnings:
            print(f"rangefx: warning: {note}", file=sys.stderr)
        if args.json:
            print(json.dumps(result.to_dict()))
        else:
            print(_line(f"guide ({args.obstacles}, law {args.law})", result.metrics))
            if "report_law" in result.summary:
                print(_line("  report law on the same obstacles", result.summary["report_law"]))
    if not args.json:
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
        choices=("synthetic", "runway", *(f"runway-{name}" for name in PIPELINES)),
        default="synthetic",
        help="obstacle set: documented synthetic stand-in, the runway scene ranged by "
        "golden g4_consistent, or (runway-p1, runway-p3, ... end to end) by that fixed-point "
        "pipeline: P1 on the motion pair, a stereo-only pipeline on the runway's stereo "
        "pair (default synthetic)",
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
    p.add_argument(
        "--stress",
        type=int,
        default=None,
        metavar="N",
        help="stress programme: N seeded layouts of the runway scene ranged by --pipeline, "
        "each moved so that a true vehicle stands on or near the nominal path; the avoiding "
        "law and the report's flown on each (writes stress.json, stress_worst.png, and "
        "stress_layouts.jsonl as each layout ends: a re-run resumes)",
    )
    p.add_argument(
        "--pipeline",
        choices=tuple(PIPELINES),
        default=DEFAULT_PIPELINE,
        help="--stress: the bit-accurate pipeline that ranges the runway scene (default "
        f"{DEFAULT_PIPELINE}: it flew the stress programme better than p1)",
    )
    p.add_argument("--seed", type=int, default=0, help="--stress: layout seed (default 0)")
    p.add_argument(
        "--jobs",
        type=int,
        default=1,
        metavar="N",
        help="--stress: fly the layouts in N worker processes (default 1; same rows)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object with the figures")
    p.set_defaults(func=cmd_guide)
