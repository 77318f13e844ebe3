"""``rangefx demo``: the main job on the embedded ``lab`` scene (SPEC §8).

Renders ``lab``, runs the golden methods of :data:`DEMO_METHODS`, every registered
fixed-point pipeline in each of its variants beside its golden and the end-to-end chain
(runway → P1 motion mode → obstacles → guidance), and writes range maps, tables, plots
and ``summary.json`` to ``--out`` (default ``./rangefx-out``): :func:`rangefx.api.demo`.
``--pole``/``--bias`` apply to the golden estimator and to P1's config alike.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from tqdm import tqdm

from .. import report
from ..report import atomic_output_dir, json_safe
from ..studies.demo import DEMO_METHODS, DEMO_STEPS, package_version
from .options import add_pipelines_arg, out_path

__all__ = ["DEMO_METHODS", "add_parser", "cmd_demo", "package_version"]


def cmd_demo(args: argparse.Namespace) -> int:
    from rangefx import api

    out = Path(args.out)
    bar = tqdm(
        total=len(DEMO_STEPS), desc="rangefx demo", disable=args.json or not sys.stderr.isatty()
    )
    started = []

    def step(name: str) -> None:
        if started:
            bar.update()
        started.append(name)
        bar.set_postfix_str(name)

    with atomic_output_dir(out) as tmp:  # refuses a directory rangefx did not write, now
        result = api.demo(
            seed=args.seed, pole=args.pole, bias=args.bias, pipelines=args.pipeline, step=step
        )
        result.write_into(tmp)
        bar.update()
    bar.close()
    summary, e2e_notes = result.summary, result.warnings
    e2e = summary["end_to_end"]
    if args.json:
        print(json.dumps(json_safe(summary)))
    else:
        print(
            report.format_side_by_side(
                {m: v["table"] for m, v in summary["methods"].items()}, summary["scene"]["unit"]
            )
        )
        for m, v in summary["methods"].items():
            print(
                f"{m}: valid-pixel fraction {v['valid_fraction']:.3f}, "
                f"median relative error vs truth {v['median_rel_error']:.3f}"
            )
        for m, v in summary["fixed_point"].items():
            print(
                f"{m} (fixed point, default config): overflows {v['overflows']['total']}, "
                f"median |fixed - golden| / golden {report.median_text(v)}, "
                f"valid agreement {v['valid_agreement']:.4f}"
            )
        rep = e2e["report_law"]
        print(
            "end to end (runway -> P1 motion mode -> obstacle extraction -> avoiding law): "
            f"{e2e['extraction']['n_obstacles']} obstacles "
            f"({e2e['extraction']['scores']['detected']} of "
            f"{e2e['extraction']['scores']['n_true']} vehicles detected, "
            f"{e2e['extraction']['scores']['false_obstacles']} false), "
            f"flight time {e2e['flight_time_s']:.2f} s, "
            f"min distance to the true vehicles {e2e['min_true_obstacle_distance_ft']:.2f} ft "
            f"(clearance {e2e['clearance_ft']:g} ft, feasible {e2e['feasible']}), "
            f"max load factor {e2e['max_load_factor']:.3f}, "
            f"max |theta| {e2e['max_abs_theta_deg']:.1f} deg, "
            f"max |phi| {e2e['max_abs_phi_deg']:.1f} deg; report law beside it: "
            f"{rep['flight_time_s']:.2f} s, {rep['min_true_obstacle_distance_ft']:.2f} ft to "
            f"the true vehicles, {rep['min_obstacle_distance']:.2f} ft to its points "
            "(figures in guide/)"
        )
        for note in e2e_notes:
            print(f"rangefx: warning: {note}", file=sys.stderr)
        print(f"results written to {out}/")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="the main job on the lab scene: golden, P1, P2, P3, guidance")
    p.add_argument(
        "--out",
        type=out_path,
        default="rangefx-out",
        help="output directory (default ./rangefx-out)",
    )
    p.add_argument("--pole", type=float, help="filter pole c per pixel (default 0.5)")
    p.add_argument("--bias", type=float, help="input bias B, eq 19 (default 16)")
    p.add_argument("--seed", type=int, default=0, help="scene noise seed")
    add_pipelines_arg(p)
    p.add_argument("--json", action="store_true", help="print one JSON object with the figures")
    p.set_defaults(func=cmd_demo)
