"""The ``rangefx`` command line (SPEC §8).

Subcommands: ``demo`` (the main job on the embedded ``lab`` scene) and ``run`` (one
method on a scene preset or on a user's image pair). Every command that reports figures
takes ``--json`` and then prints one JSON object on stdout. User mistakes print one
``rangefx: error: ...`` line and exit with status 2; no output directory is left
looking complete after a failure.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
from tqdm import tqdm

from rangefx.golden.estimator import EstimatorConfig, estimate_derivatives, validate_image
from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.methods import METHODS, SCENE_RANGING, run_method
from rangefx.golden.ranging import RangeResult, RangingConfig
from rangefx.golden.scenes import SCENE_NAMES, Scene, render_scene

from . import cmd_eval, cmd_guide, cmd_sweep, cmd_track, cmd_vectors, p2_pipeline, pipeline, report
from .errors import UserError
from .outdir import atomic_output_dir, atomic_write_text
from .report import json_safe

DEMO_METHODS = ("g3_paper", "g3_consistent", "g2_central", "g5_riccati")


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("rangefx")
    except PackageNotFoundError:  # running from a source tree without install
        return "0+unknown"


def _render(name: str, seed: int) -> Scene:
    try:
        return render_scene(name, seed=seed)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def _method_figures(scene: Scene, result: RangeResult) -> dict:
    rows = report.object_table(
        result.range, result.valid, scene.labels1, scene.objects, scene.depth1
    )
    overall = report.overall_metrics(result.range, result.valid, scene.depth1)
    return {"table": rows, **overall}


def _paper_diagnostics(scene: Scene, est: EstimatorConfig, valid: np.ndarray) -> dict:
    """Measure why the ``paper`` estimator errs (SPEC §3), on the pixels it ranges.

    ``s1_over_r1``: the divider's factor, which the bias pushes towards 1;
    ``ex_rel_diff``: median |Ex_paper - Ex_consistent| / |Ex_consistent|, i.e. how far
    the paper's x-derivative is from the x-derivative of the smoothed image it pairs
    with; ``offset_px``: the sub-pixel shift between the paper's Ex and E_hat measured
    as the x-shift minimising the mismatch of Ex with the derivative of E_hat.
    """
    dp = estimate_derivatives(scene.image1, est.with_(variant="paper"))
    dc = estimate_derivatives(scene.image1, est.with_(variant="consistent"))
    ratio = dp.taps["s1"] / dp.taps["r1"]
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.abs(dp.Ex - dc.Ex) / np.abs(dc.Ex)
    grad_e = np.gradient(dp.E, axis=1)  # central difference of the paper's own E_hat
    shifts = np.linspace(-1.5, 1.5, 61)
    errs = []
    for s in shifts:  # Ex(x) ≈ grad_e(x + s): find s by linear interpolation
        lo = np.floor(s)
        w = s - lo
        g = (1 - w) * np.roll(grad_e, -int(lo), axis=1) + w * np.roll(grad_e, -int(lo) - 1, axis=1)
        errs.append(float(np.mean(((dp.Ex - g)[:, 8:-8][valid[:, 8:-8]]) ** 2)))
    return {
        "s1_over_r1_median": float(np.median(ratio[valid])),
        "s1_over_r1_p10_p90": [float(v) for v in np.percentile(ratio[valid], [10, 90])],
        "ex_rel_diff_median": float(np.nanmedian(rel[valid])),
        "ex_offset_px": float(shifts[int(np.argmin(errs))]),
    }


def _estimator(args: argparse.Namespace) -> EstimatorConfig:
    try:
        return EstimatorConfig(pole=args.pole, bias=args.bias)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def cmd_demo(args: argparse.Namespace) -> int:
    out = Path(args.out)
    est = _estimator(args)
    steps = ["render lab", *DEMO_METHODS, "p1/p2 fixed point", "end to end", "figures"]
    bar = tqdm(total=len(steps), desc="rangefx demo", disable=args.json or not sys.stderr.isatty())
    with atomic_output_dir(out) as tmp:
        bar.set_postfix_str(steps[0])
        scene = _render("lab", args.seed)
        bar.update()
        ranging = SCENE_RANGING["lab"]
        results, summary_methods = {}, {}
        for m in DEMO_METHODS:
            bar.set_postfix_str(m)
            results[m] = run_method(
                m,
                scene.image1,
                scene.image2,
                scene.camera,
                scene.motion,
                estimator=est,
                ranging=ranging,
            )
            summary_methods[m] = _method_figures(scene, results[m])
            bar.update()
        bar.set_postfix_str("p1/p2 fixed point")
        p1_summary = pipeline.demo_p1(scene, tmp, json_safe)
        p1_summary.update(p2_pipeline.demo_p2(scene, tmp, json_safe))
        bar.update()
        bar.set_postfix_str("end to end")
        (tmp / "guide").mkdir()
        e2e, e2e_notes, _ = cmd_guide.guide_into(tmp / "guide", "runway-p1")
        bar.update()
        bar.set_postfix_str("figures")
        report.save_pair_png(
            tmp / "pair.png", scene.image1, scene.image2, ("left (E1)", "right (E2)")
        )
        xp, yp = scene.camera.pixel_grid()
        md = [f"# rangefx demo: scene `lab` ({scene.unit})\n"]
        for m, r in results.items():
            report.save_range_map_png(
                tmp / f"range_{m}.png",
                r.range,
                r.valid,
                ranging.range_max,
                f"{m} range",
                unit=scene.unit,
            )
            report.save_points_3d_png(
                tmp / f"points3d_{m}.png",
                r.range,
                r.valid,
                xp,
                yp,
                scene.camera.f_px,
                m,
                unit=scene.unit,
            )
            rows = summary_methods[m]["table"]
            md.append(report.table_markdown(rows, scene.unit, title=m))
            atomic_write_text(tmp / f"table_{m}.csv", report.table_csv(rows))
        for m, v in p1_summary.items():
            md.append(report.table_markdown(v["table"], scene.unit, title=f"{m} (fixed point)"))
        atomic_write_text(tmp / "table.md", "\n".join(md))
        summary = {
            "rangefx_version": _version(),
            "scene": {
                "name": scene.name,
                "unit": scene.unit,
                "seed": scene.seed,
                "size": list(scene.image1.shape),
                "f_px": scene.camera.f_px,
                "description": scene.description,
            },
            "estimator": {"pole": est.pole, "order": est.order, "bias": est.bias, "init": est.init},
            "ranging": vars(ranging),
            "methods": summary_methods,
            "fixed_point": p1_summary,
            "end_to_end": e2e,
            "paper_diagnostics": _paper_diagnostics(scene, est, results["g3_paper"].valid),
        }
        atomic_write_text(tmp / "summary.json", json.dumps(json_safe(summary), indent=2) + "\n")
        bar.update()
    bar.close()
    if args.json:
        print(json.dumps(json_safe(summary)))
    else:
        print(
            report.format_side_by_side(
                {m: v["table"] for m, v in summary_methods.items()}, scene.unit
            )
        )
        for m, v in summary_methods.items():
            print(
                f"{m}: valid-pixel fraction {v['valid_fraction']:.3f}, "
                f"median relative error vs truth {v['median_rel_error']:.3f}"
            )
        for m, v in p1_summary.items():
            print(
                f"{m} (fixed point, default config): overflows {v['overflows']['total']}, "
                f"median |fixed - golden| / golden {v['median_rel_range_diff']:.2e}, "
                f"valid agreement {v['valid_agreement']:.4f}"
            )
        rep = e2e["report_law"]
        print(
            "end to end (runway -> P1 motion mode -> obstacle extraction -> avoiding law): "
            f"{e2e['extraction']['n_obstacles']} obstacles "
            f"({e2e['extraction']['scores']['detected']} of "
            f"{e2e['extraction']['scores']['n_true']} vehicles detected), "
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


def _load_image(path: str) -> np.ndarray:
    p = Path(path)
    if not p.is_file():
        raise UserError(f"image file not found: {path}")
    try:
        if p.suffix == ".npy":
            arr = np.load(p, allow_pickle=False)
        else:
            from skimage.io import imread

            arr = imread(p)
    except Exception as exc:  # any decoder failure is the user's file
        raise UserError(f"cannot read image {path}: {exc}") from None
    try:
        return validate_image(arr, name=f"image {path}")
    except ValueError as exc:
        raise UserError(str(exc)) from None


def cmd_run(args: argparse.Namespace) -> int:
    if args.left or args.right:
        if not (args.left and args.right):
            raise UserError("--left and --right must be given together")
        e1, e2 = _load_image(args.left), _load_image(args.right)
        if e1.shape != e2.shape:
            raise UserError(
                f"image pair shapes differ: {args.left} {e1.shape} vs {args.right} {e2.shape}"
            )
        if args.f_px is None or args.baseline is None:
            raise UserError("an image pair needs --f-px and --baseline")
        try:
            camera = PinholeCamera(e1.shape[1], e1.shape[0], args.f_px)
            motion = MotionIncrement.stereo(args.baseline)
        except ValueError as exc:
            raise UserError(str(exc)) from None
        scene, ranging = None, RangingConfig()
    else:
        scene = _render(args.scene, args.seed)
        e1, e2, camera, motion = scene.image1, scene.image2, scene.camera, scene.motion
        ranging = SCENE_RANGING[scene.name]
    try:
        overrides = {
            "threshold_e": args.threshold_e,
            "threshold_g": args.threshold_g,
            "range_max": args.range_max,
        }
        ranging = replace(ranging, **{k: v for k, v in overrides.items() if v is not None})
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if args.pipeline == "p2":
        case = pipeline.P1Case(e1, e2, camera, motion, ranging, "stereo", scene)
        return p2_pipeline.cmd_run_p2(args, case, json_safe)
    if args.pipeline == "p1":
        mode = pipeline.SCENE_MODE[scene.name] if scene is not None else "stereo"
        case = pipeline.P1Case(e1, e2, camera, motion, ranging, mode, scene)
        return pipeline.cmd_run_pipeline(args, case, json_safe)
    try:
        est = _estimator(args)
        result = run_method(args.method, e1, e2, camera, motion, estimator=est, ranging=ranging)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    figures: dict = {"method": args.method, "valid_fraction": result.valid_fraction}
    if scene is not None:
        figures.update(scene=scene.name, unit=scene.unit, **_method_figures(scene, result))
    if args.out:
        with atomic_output_dir(Path(args.out)) as tmp:
            np.save(tmp / "range.npy", result.range)
            np.save(tmp / "valid.npy", result.valid)
            report.save_range_map_png(
                tmp / "range.png", result.range, result.valid, ranging.range_max, args.method
            )
            atomic_write_text(tmp / "summary.json", json.dumps(json_safe(figures), indent=2) + "\n")
    if args.json:
        print(json.dumps(json_safe(figures)))
    else:
        if scene is not None:
            print(
                report.table_markdown(
                    figures["table"], scene.unit, title=f"{scene.name}: {args.method}"
                )
            )
        print(f"valid-pixel fraction {result.valid_fraction:.3f}")
    return 0


def _add_p1_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("fixed-point pipeline (--pipeline p1)")
    g.add_argument("--config", help="word-length config TOML (default: the shipped default)")
    g.add_argument("--variant", choices=("paper", "consistent"), help="estimator variant")
    g.add_argument("--divider", choices=("restoring", "reciprocal"), help="divider model")
    g.add_argument("--hblank", type=int, default=0, help="horizontal blanking, cycles")
    g.add_argument("--vblank", type=int, default=0, help="vertical blanking, cycles")
    g.add_argument("--gap-prob", type=float, default=0.0, help="input gap probability")
    g.add_argument("--gap-seed", type=int, default=0, help="input gap seed")


def _add_estimator_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--pole", type=float, default=0.5, help="filter pole c per pixel (default 0.5)")
    p.add_argument("--bias", type=float, default=EstimatorConfig.bias, help="input bias (eq 19)")
    p.add_argument("--seed", type=int, default=0, help="scene noise seed")
    p.add_argument("--json", action="store_true", help="print one JSON object with the figures")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="rangefx", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"rangefx {_version()}")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("demo", help="render the lab scene, range it with G3 (paper, consistent)")
    p.add_argument("--out", default="rangefx-out", help="output directory (default ./rangefx-out)")
    _add_estimator_args(p)
    p.set_defaults(func=cmd_demo)
    p = sub.add_parser("run", help="run one golden method on a scene or an image pair")
    p.add_argument("--scene", default="lab", help=f"scene preset: {', '.join(SCENE_NAMES)}")
    p.add_argument("--method", default="g3_consistent", choices=METHODS)
    p.add_argument("--left", help="E1 image (.npy or image file)")
    p.add_argument("--right", help="E2 image, second camera to the right")
    p.add_argument("--f-px", type=float, help="focal length in pixels (image pair)")
    p.add_argument("--baseline", type=float, help="stereo baseline (image pair)")
    p.add_argument("--threshold-e", type=float, help="T_E, grey levels")
    p.add_argument("--threshold-g", type=float, help="T_g, grey levels per pixel")
    p.add_argument("--range-max", type=float, help="maximum scene depth")
    p.add_argument("--out", help="write range.npy, valid.npy, range.png, summary.json here")
    p.add_argument(
        "--pipeline",
        choices=("golden", "p1", "p2"),
        default="golden",
        help="golden (float64 method), p1 or p2 (bit-accurate fixed-point pipelines)",
    )
    _add_p1_args(p)
    _add_estimator_args(p)
    p.set_defaults(func=cmd_run)
    p = sub.add_parser("bench", help="P1 throughput (Mpixel/s) beside the float64 golden")
    p.add_argument("--repeats", type=int, default=5, help="timed runs per figure (median)")
    p.add_argument("--size", type=int, default=512, help="image side in pixels (default 512)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=lambda a: pipeline.cmd_bench(a, json_safe))
    p = sub.add_parser("config", help="P1 word-length config: show the default, or propose")
    p.add_argument("action", choices=("show", "propose"))
    p.add_argument("--config", help="start from this TOML (default: the shipped default)")
    p.add_argument("--variant", choices=("paper", "consistent"))
    p.add_argument("--scene", nargs="+", default=["lab", "runway"], help="scenes to log")
    p.add_argument("--guard-bits", type=int, default=1, help="extra integer bits (propose)")
    p.add_argument("--out", help="write the TOML here")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=lambda a: pipeline.cmd_config(a, json_safe))
    cmd_eval.add_parser(sub)
    cmd_track.add_parser(sub)
    cmd_guide.add_parser(sub)
    cmd_vectors.add_parser(sub)
    cmd_sweep.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except UserError as exc:
        print(f"rangefx: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
