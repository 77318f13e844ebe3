"""``rangefx track`` (G1, report ch. 2) and ``rangefx degrees`` (G3 degree 1..4 table).

``track`` runs the irradiance-tracking navigation scheme on the ch. 2 scene at one
pixel and writes the report's Figs 3-7 look-alikes (scene section and trajectory, raw
range, range after a fast and a slow low-pass filter), the time series as CSV and a
``summary.json``. ``degrees`` ranges a scene preset with the SPIE ranging polynomial of
degree 1..4 and prints the per-object table of each degree: once with the estimator
order equal to the degree, once with order 4 for every degree (the same derivatives, so
only the polynomial changes).
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
import sys
from pathlib import Path

import numpy as np

from rangefx.golden.estimator import EstimatorConfig, estimate_derivatives
from rangefx.golden.methods import SCENE_RANGING
from rangefx.golden.polynomial import PolynomialConfig, range_g3_poly
from rangefx.golden.scenes import SCENE_NAMES, render_scene
from rangefx.golden.tracking import (
    TrackingRun,
    chapter2_config,
    chapter2_scene,
    sampling_interval_bound,
    simulate_tracking,
)

from .. import report
from ..errors import UserError
from ..report import atomic_output_dir, atomic_write_text, json_safe
from ..studies.runner import require_run_memory
from .options import int_at_least, out_path

__all__ = ["add_parser", "cmd_degrees", "cmd_track"]

DEGREES = (1, 2, 3, 4)


# --------------------------------------------------------------------------- track


def _last_valid(a: np.ndarray) -> float:
    idx = np.flatnonzero(np.isfinite(a))
    return float(a[idx[-1]]) if idx.size else math.nan


def _track_summary(run: TrackingRun, bound: dict, window: float) -> dict:
    truth = run.truth
    tail = run.t >= run.t[-1] - window
    final_truth = float(truth[-1])
    out = {
        "pixel": {"xp": float(run.xp), "zp": float(run.zp)},
        "h": run.config.h,
        "steps": len(run.t),
        "duration": float(run.t[-1]),
        "tracking": {
            "a": run.config.a,
            "a_h": run.config.a * run.config.h,
            "b": run.config.b,
            "c": run.config.c,
            "temporal": run.config.temporal,
            "threshold": run.config.threshold,
        },
        "sampling_bound": bound,
        "valid_fraction": float(np.mean(run.valid)),
        "final_truth": final_truth,
        "final_raw": _last_valid(run.range_raw),
        "raw_median_rel_error": float(
            np.nanmedian(np.abs(run.range_raw - truth) / truth) if run.valid.any() else math.nan
        ),
        "tail_window": window,
        "filtered": {},
    }
    for tau, f in run.range_filtered.items():
        rel = np.abs(f[tail] - truth[tail]) / truth[tail]
        out["filtered"][f"{tau:g}"] = {
            "tau": tau,
            "final": float(f[-1]),
            "final_rel_error": float((f[-1] - final_truth) / final_truth),
            "tail_max_rel_error": float(np.max(rel)),
        }
    return out


def _track_csv(run: TrackingRun) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    taus = list(run.range_filtered)
    w.writerow(
        ["t", "truth", "irradiance", "model", "range_raw", "valid"]
        + [f"range_lowpass_tau{tau:g}" for tau in taus]
    )
    for i in range(len(run.t)):
        w.writerow(
            [repr(float(run.t[i])), repr(float(run.truth[i])), repr(float(run.irradiance[i])),
             repr(float(run.model[i])), repr(float(run.range_raw[i])), int(run.valid[i])]
            + [repr(float(run.range_filtered[tau][i])) for tau in taus]
        )  # fmt: skip
    return buf.getvalue()


def _plot_range(path: Path, run: TrackingRun, series: np.ndarray, title: str, unit: str) -> None:
    fig = report.new_figure((7.0, 4.0))
    ax = fig.add_subplot(1, 1, 1)
    ax.plot(run.t, run.truth, "k-", lw=1.5, label="actual depth")
    ax.plot(run.t, series, "r-", lw=0.8, label="estimate")
    top = 2.0 * float(np.nanmax(run.truth))
    ax.set_ylim(0.0, top)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"depth y - y0 ({unit})")
    ax.set_title(title)
    ax.legend(loc="upper right")
    fig.tight_layout()
    report.save_png(fig, path)


def _plot_scene(path: Path, scene, run: TrackingRun) -> None:
    fig = report.new_figure((10.0, 4.0))
    ax = fig.add_subplot(1, 2, 1)
    ax.plot(scene.section[:, 0], scene.section[:, 1], "k-", lw=2, label="scene section")
    cam = scene.camera_position(run.t)
    ax.plot(cam[:, 0], cam[:, 1], "b-", label="camera trajectory")
    hit_y = cam[:, 1] + run.truth
    hit_x = cam[:, 0] + run.truth * float(run.xp) / scene.f_px
    ax.plot(hit_x, hit_y, "r.", ms=1, label="point seen by the pixel")
    ax.set_xlabel(f"X ({scene.unit})")
    ax.set_ylabel(f"Y, forward ({scene.unit})")
    ax.set_title("Horizontal section (Fig. 3) and trajectory")
    ax.legend(loc="lower right", fontsize=8)
    ax2 = fig.add_subplot(1, 2, 2)
    xs = np.linspace(-60.0, 60.0, 481)
    e = scene.irradiance(xs, 0.0, 0.0)
    ax2.plot(xs, e, "k-")
    ax2.set_xlabel("x_p (pixels), z_p = 0, t = 0")
    ax2.set_ylabel("irradiance (grey levels)")
    ax2.set_title("Irradiance across the image (Fig. 4)")
    fig.tight_layout()
    report.save_png(fig, path)


def cmd_track(args: argparse.Namespace) -> int:
    scene = chapter2_scene()
    if not (math.isfinite(args.duration) and args.duration > 0):
        raise UserError(f"--duration must be a positive number of seconds, not {args.duration}")
    try:
        taus = tuple(args.tau)
        config = chapter2_config(
            scene, args.xp, args.zp, fraction=args.fraction, threshold=args.threshold
        )
        steps = round(args.duration / config.h) + 1
        run = simulate_tracking(
            scene, args.xp, args.zp, config, steps, taus,
            noise_sigma=args.noise, seed=args.seed,
        )  # fmt: skip
    except ValueError as exc:
        raise UserError(str(exc)) from None
    depth0 = float(run.truth[0])
    bound = {
        form: float(
            sampling_interval_bound(args.xp, args.zp, depth0, scene.velocity, scene.f_px, form=form)
        )
        for form in ("printed", "absolute")
    }
    bound["fraction_used"] = args.fraction
    summary = _track_summary(run, bound, window=1.0)
    summary["scene"] = {
        "unit": scene.unit,
        "f_px": scene.f_px,
        "velocity": [float(v) for v in scene.velocity],
        "section": scene.section.tolist(),
        "noise_sigma": args.noise,
    }
    out = Path(args.out)
    with atomic_output_dir(out) as tmp:
        _plot_scene(tmp / "fig3_4_scene.png", scene, run)
        _plot_range(
            tmp / "fig5_raw.png", run, run.range_raw, "Range estimate, navigation scheme",
            scene.unit,
        )  # fmt: skip
        for k, tau in enumerate(taus):
            _plot_range(
                tmp / f"fig{6 + k}_lowpass_tau{tau:g}.png", run, run.range_filtered[tau],
                f"Range estimate with a low-pass filter, tau = {tau:g} s", scene.unit,
            )  # fmt: skip
        atomic_write_text(tmp / "tracking.csv", _track_csv(run))
        atomic_write_text(tmp / "summary.json", json.dumps(json_safe(summary), indent=2) + "\n")
    if args.json:
        print(json.dumps(json_safe(summary)))
    else:
        print(
            f"G1 at pixel ({args.xp:g}, {args.zp:g}): h = {config.h:.4g} s "
            f"({args.fraction:g} x eq-9 bound {bound['absolute']:.4g} s), {steps} frames"
        )
        print(
            f"final depth {summary['final_truth']:.2f} {scene.unit}; "
            f"last valid raw {summary['final_raw']:.2f}; "
            f"raw median relative error {summary['raw_median_rel_error']:.3f}"
        )
        for key, v in summary["filtered"].items():
            print(
                f"low-pass tau {key} s: final {v['final']:.2f} "
                f"({100 * v['final_rel_error']:+.1f}%), max error over the last "
                f"{summary['tail_window']:g} s {100 * v['tail_max_rel_error']:.1f}%"
            )
        print(f"results written to {out}/")
    return 0


# --------------------------------------------------------------------------- degrees


def _degree_results(scene, variant: str, orders: dict[int, int], seed: int) -> dict:
    """Range the scene with degree d at estimator order ``orders[d]``; figures per degree."""
    ranging = SCENE_RANGING[scene.name]
    cache: dict[int, tuple] = {}
    results = {}
    for d, order in orders.items():
        if order not in cache:
            est = EstimatorConfig(order=order, variant=variant)
            cache[order] = (estimate_derivatives(scene.image1, est),
                            estimate_derivatives(scene.image2, est))  # fmt: skip
        d1, d2 = cache[order]
        results[d] = range_g3_poly(
            d1, d2, scene.camera, scene.motion, ranging, PolynomialConfig(degree=d)
        )
    common = np.logical_and.reduce([r.valid for r in results.values()])
    figures = {}
    for d, r in results.items():
        rows = report.object_table(r.range, r.valid, scene.labels1, scene.objects, scene.depth1)
        overall = report.overall_metrics(r.range, r.valid, scene.depth1)
        on_common = report.overall_metrics(r.range, common, scene.depth1)
        figures[f"degree{d}"] = {
            "degree": d,
            "estimator_order": orders[d],
            "table": rows,
            **overall,
            "common_pixels": on_common["n_scored"],
            "common_median_rel_error": on_common["median_rel_error"],
            "common_within_5pct": on_common["within_5pct"],
        }
    return figures


def cmd_degrees(args: argparse.Namespace) -> int:
    try:
        size = None if args.size is None else (args.size[0], args.size[1])
        if size is not None:
            require_run_memory(f"degrees --size {size[0]} {size[1]}", size[0] * size[1])
        scene = render_scene(args.scene, seed=args.seed, size=size)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    settings = {}
    if args.order is None:
        settings["order_equals_degree"] = {d: d for d in DEGREES}
        settings["order4"] = {d: 4 for d in DEGREES}
    else:
        settings[f"order{args.order}"] = {d: args.order for d in DEGREES if d <= args.order}
    try:
        figures = {
            name: _degree_results(scene, args.variant, orders, args.seed)
            for name, orders in settings.items()
        }
    except ValueError as exc:
        raise UserError(str(exc)) from None
    summary = {
        "scene": {"name": scene.name, "unit": scene.unit, "size": list(scene.image1.shape),
                  "seed": scene.seed},
        "variant": args.variant,
        "ranging": vars(SCENE_RANGING[scene.name]),
        "settings": figures,
    }  # fmt: skip
    if args.out:
        with atomic_output_dir(Path(args.out)) as tmp:
            md = [f"# rangefx degrees: scene `{scene.name}`, variant `{args.variant}`\n"]
            for name, per_degree in figures.items():
                for key, v in per_degree.items():
                    md.append(report.table_markdown(v["table"], scene.unit, f"{name}: {key}"))
            atomic_write_text(tmp / "table.md", "\n".join(md))
            atomic_write_text(tmp / "summary.json", json.dumps(json_safe(summary), indent=2) + "\n")
    if args.json:
        print(json.dumps(json_safe(summary)))
        return 0
    for name, per_degree in figures.items():
        print(f"## {scene.name}, {args.variant} estimator, {name}")
        print(
            report.format_side_by_side(
                {f"degree {v['degree']} (order {v['estimator_order']})": v["table"]
                 for v in per_degree.values()},
                scene.unit,
            )
        )  # fmt: skip
        for v in per_degree.values():
            print(
                f"degree {v['degree']}: valid fraction {v['valid_fraction']:.3f}, median "
                f"relative error {v['median_rel_error']:.4f} (on the {v['common_pixels']} "
                f"pixels valid for every degree: {v['common_median_rel_error']:.4f})"
            )
        print()
    return 0


# --------------------------------------------------------------------------- parser


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``track`` and ``degrees`` on the ``rangefx`` subparsers."""
    p = sub.add_parser("track", help="G1: range by irradiance tracking on the ch. 2 scene")
    p.add_argument("--out", type=out_path, default="rangefx-track", help="output directory")
    p.add_argument("--xp", type=float, default=40.0, help="pixel x_p from the centre (right)")
    p.add_argument("--zp", type=float, default=30.0, help="pixel z_p from the centre (up)")
    p.add_argument("--duration", type=float, default=5.0, help="simulated time, s")
    p.add_argument(
        "--fraction", type=float, default=0.1, help="frame interval / eq-9 bound (default 0.1)"
    )
    p.add_argument(
        "--tau", type=float, nargs="+", default=[0.1, 0.4], help="low-pass time constants, s"
    )
    p.add_argument(
        "--threshold", type=float, default=0.1, help="min |h dE_M/dt|, grey levels per frame"
    )
    p.add_argument("--noise", type=float, default=0.0, help="sensor noise sigma, grey levels")
    p.add_argument("--seed", type=int, default=0, help="noise seed")
    p.add_argument("--json", action="store_true", help="print one JSON object with the figures")
    p.set_defaults(func=cmd_track)

    p = sub.add_parser("degrees", help="G3 ranging polynomial of degree 1..4 on a scene")
    p.add_argument("--scene", default="lab", choices=SCENE_NAMES, help="scene preset")
    p.add_argument("--variant", default="consistent", choices=("paper", "consistent"))
    p.add_argument(
        "--order",
        type=int,
        choices=(1, 2, 3, 4),
        help="estimator order for every degree (default: both order = degree and order 4)",
    )
    p.add_argument(
        "--size",
        type=int_at_least(8, "image size"),
        nargs=2,
        metavar=("H", "W"),
        help="render size",
    )
    p.add_argument("--seed", type=int, default=0, help="scene noise seed")
    p.add_argument("--out", type=out_path, help="also write table.md and summary.json here")
    p.add_argument("--json", action="store_true", help="print one JSON object with the figures")
    p.set_defaults(func=cmd_degrees)


if __name__ == "__main__":  # pragma: no cover
    sys.exit("use `rangefx track` or `rangefx degrees`")
