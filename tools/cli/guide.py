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
``--stress N [--pipeline NAME] [--seed S]`` flies both laws over ``N`` seeded layouts of
the ``runway`` scene ranged by the pipeline, each moved so that a true vehicle stands on
or near the nominal path (:mod:`rangefx.guidance.stress`), and writes ``stress.json``
and ``stress_worst.png``. When no path to the touch-down keeps the clearance the
avoiding law takes a safe manoeuvre (hover and hold, climb over, turn away) and says so.

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

from rangefx.rtl_model.registry import PIPELINES

from ..errors import UserError
from ..report import atomic_output_dir, atomic_write_text, json_safe
from .options import out_path

__all__ = ["add_parser", "cmd_guide", "guide_into", "stress_into", "stress_table"]

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
    if args.stress is not None:
        return _cmd_stress(args, out)
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


def _cmd_stress(args: argparse.Namespace, out: Path) -> int:
    if args.stress < 0:
        raise UserError(f"--stress must be >= 0, not {args.stress}")
    if args.layout_sweep is not None:
        raise UserError("--stress and --layout-sweep are separate programmes: give one")
    if args.jobs < 1:
        raise UserError(f"--jobs must be >= 1, not {args.jobs}")
    with atomic_output_dir(out) as tmp:
        res = stress_into(
            tmp, args.stress, args.pipeline, seed=args.seed, clearance_ft=args.clearance,
            guidance_interval=args.guidance_interval, replan_interval=args.replan_interval,
            jobs=args.jobs,
        )  # fmt: skip
    data = res.to_dict()
    if args.json:
        print(json.dumps(json_safe(data)))
    else:
        print(stress_table(data))
        print(f"results written to {out}/")
    return 0


def stress_table(data: dict) -> str:
    """The stress programme's per-layout table and summary as text."""
    head = (
        f"{'layout':<12} {'vehicle':<10} {'t (s)':>6} {'off':>6} {'outcome':<10} "
        f"{'manoeuvre':<10} {'true':>7} {'extent':>7} {'time':>6} {'n':>6} {'|θ|':>5} "
        f"{'|φ|':>5} {'report':>7}"
    )
    lines = [head]
    for r in data["layouts"]:
        lines.append(
            f"{r['name']:<12} {r['vehicle']:<10} {r['path_time_s']:6.1f} {r['offset_ft']:+6.1f} "
            f"{r['outcome']:<10} {r['manoeuvre'] or '-':<10} {r['min_true_distance_ft']:7.2f} "
            f"{r['min_extent_distance_ft']:7.2f} {r['flight_time_ratio']:6.3f} "
            f"{r['max_load_factor']:6.3f} {r['max_abs_theta_deg']:5.1f} "
            f"{r['max_abs_phi_deg']:5.1f} {r['report_law_min_true_distance_ft']:7.2f}"
        )
    s = data["summary"]
    lines.append(
        f"stress ({data['source']}, {s['layouts']} layouts, clearance {data['clearance_ft']:g} "
        f"ft): outcomes {s['outcomes']}, collisions {s['collisions']} (report law "
        f"{s['report_law_collisions']}), crashes {s['crashes']}, landings keeping the "
        f"clearance {s['landings_keeping_clearance']} of {s['outcomes']['landing']}, min true "
        f"distance {s['min_true_distance_ft']:.2f} ft, max load factor "
        f"{s['max_load_factor']:.3f}"
    )
    return "\n".join(lines)


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
    from rangefx.guidance.cases import synthetic_case

    if obstacles == "runway":
        return _runway_case(None)
    if obstacles.startswith("runway-"):
        return _runway_case(obstacles.removeprefix("runway-"))
    return synthetic_case()


def _runway_case(pipeline: str | None):
    """The ``runway`` scene end to end, ranged by golden ``g4_consistent`` (``None``) or
    by the bit-accurate ``pipeline``: the motion pair if it models motion mode, else the
    stereo pair (:func:`rangefx.guidance.cases.runway_scene_for`)."""
    from rangefx.guidance.cases import runway_case, runway_scene_for
    from rangefx.rtl_model.registry import get_pipeline

    from ..studies.runner import range_source

    source, scene = None, None
    label = f"--pipeline {pipeline}" if pipeline else "--obstacles runway"
    if pipeline is not None:
        pipe = get_pipeline(pipeline)
        if pipeline == "p1":  # the consistent variant, as the documented figures
            from rangefx.rtl_model.p1 import P1Config

            config = P1Config.default(variant="consistent")
        else:
            config = pipe.default_config()
        source = range_source(pipe, config)
        try:
            scene = runway_scene_for(pipe.modes)
        except ValueError as exc:
            raise UserError(f"{label}: {exc}") from None
    try:
        case = runway_case(source, scene=scene)
    except ValueError as exc:
        raise UserError(f"{label}: {exc}") from None
    mode = "motion" if scene is None else scene.kind
    case.info["method"] = (
        f"{pipeline.upper()} fixed point, {mode} mode, default config"
        + (", consistent" if pipeline == "p1" else "")
        if pipeline
        else "golden g4_consistent"
    )
    case.info["reduction"] = "voxel"
    return case


def stress_into(
    tmp: Path,
    count: int,
    pipeline: str,
    *,
    seed: int = 0,
    clearance_ft: float = 20.0,
    guidance_interval: float = 0.1,
    replan_interval: float = 0.5,
    jobs: int = 1,
):
    """The stress programme (:func:`rangefx.guidance.stress.stress_programme`) on the
    ``runway`` scene ranged by ``pipeline``, into ``tmp``: ``stress.json`` and
    ``stress_worst.png`` (the closest layouts). Returns the
    :class:`~rangefx.guidance.stress.StressResult`."""
    from tqdm import tqdm

    from rangefx.guidance.avoid import AvoidConfig
    from rangefx.guidance.plots import save_stress_figure
    from rangefx.guidance.simulate import SimulationConfig
    from rangefx.guidance.stress import stress_programme

    try:
        config = SimulationConfig(
            guidance_interval=guidance_interval, sample_interval=min(0.02, guidance_interval)
        )
    except ValueError as exc:
        raise UserError(f"--guidance-interval: {exc}") from None
    try:
        avoid = AvoidConfig(clearance_ft=clearance_ft, replan_interval=replan_interval)
    except ValueError as exc:
        raise UserError(f"--clearance / --replan-interval: {exc}") from None
    case = _runway_case(pipeline)
    bar = tqdm(total=count, desc="stress", disable=not sys.stderr.isatty())
    try:
        res = stress_programme(
            case, count, seed=seed, source=f"runway-{pipeline}", clearance_ft=clearance_ft,
            config=config, avoid=avoid, progress=lambda _n: bar.update(), jobs=jobs,
        )  # fmt: skip
    finally:
        bar.close()
    atomic_write_text(tmp / "stress.json", json.dumps(json_safe(res.to_dict()), indent=2) + "\n")
    if res.rows:
        save_stress_figure(res, tmp / "stress_worst.png")
    return res


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
        "law and the report's flown on each (writes stress.json, stress_worst.png)",
    )
    p.add_argument(
        "--pipeline",
        choices=tuple(PIPELINES),
        default="p1",
        help="--stress: the bit-accurate pipeline that ranges the runway scene (default p1)",
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
