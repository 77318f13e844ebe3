"""``rangefx demo``: the main job on the embedded ``lab`` scene (SPEC §8).

Renders ``lab``, runs the golden methods of :data:`DEMO_METHODS`, every registered
fixed-point pipeline in each of its variants beside its golden (:func:`demo_pipelines`),
and the end-to-end chain (runway → P1 motion mode → obstacles → guidance); writes range
maps, tables, plots and ``summary.json`` to ``--out`` (default ``./rangefx-out``).
``--pole``/``--bias`` apply to the golden estimator and to P1's config alike.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from rangefx.golden.estimator import EstimatorConfig, estimate_derivatives
from rangefx.golden.methods import SCENE_RANGING, run_method
from rangefx.golden.ranging import RangeResult
from rangefx.golden.scenes import Scene, render_scene
from rangefx.rtl_model.registry import PIPELINES

from .. import report
from ..errors import UserError
from ..report import atomic_output_dir, atomic_write_text, json_safe
from ..studies.cases import case_from_scene
from ..studies.runner import golden_case, load_config, pipeline_figures, run_case
from . import guide
from .main import package_version
from .options import add_pipelines_arg, design_from_args, out_path
from .run import estimator_from_args

__all__ = ["DEMO_METHODS", "add_parser", "cmd_demo", "demo_pipelines", "package_version"]

#: The report's methods and G6 (beyond the report, SPEC §12): G6 adds about 0.2 s to the
#: demo's 20 s on ``lab`` (docs/multiscale.md, measured).
DEMO_METHODS = ("g3_paper", "g3_consistent", "g2_central", "g5_riccati", "g6_multiscale")


def _render(name: str, seed: int) -> Scene:
    try:
        return render_scene(name, seed=seed)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def demo_pipelines(
    scene: Scene,
    out_dir: Path,
    design: dict[str, Any] | None = None,
    names: Sequence[str] | None = None,
) -> dict[str, dict[str, Any]]:
    """Every registered pipeline, in each of its variants (default config, ``design``
    applied where the pipeline has the field), beside its golden on ``scene``: range
    map and error histogram PNGs, Table-1 CSV and the figures (without the per-signal
    ranges), keyed ``<pipeline>_<variant>`` (``<pipeline>`` for a single variant);
    ``names`` restricts the pipelines (default: all)."""
    case = case_from_scene(scene)
    summary = {}
    for pipeline in (PIPELINES[n] for n in names or PIPELINES):
        if case.mode not in pipeline.modes:
            continue
        own = {k: v for k, v in (design or {}).items() if k in pipeline.options}
        for variant, fields in pipeline.variants.items():
            config = load_config(pipeline, None, **{**fields, **own})
            result = run_case(pipeline, case, config)
            golden = golden_case(pipeline, case, config).result
            figures = pipeline_figures(result, golden, scene)
            figures.pop("signal_minmax")
            label = f"{pipeline.name}_{variant}" if variant else pipeline.name
            title = f"{pipeline.name.upper()} fixed point" + (f" ({variant})" if variant else "")
            report.save_range_map_png(
                out_dir / f"range_{label}.png", result.range, result.valid,
                pipeline.range_max(case), title, unit=scene.unit,
            )  # fmt: skip
            both = result.valid & golden.valid
            rel = np.abs(result.range[both] - golden.range[both]) / golden.range[both]
            report.save_error_histogram_png(
                out_dir / f"hist_{label}.png", rel,
                f"{label}: fixed vs golden {pipeline.golden_label(config)}",
            )  # fmt: skip
            atomic_write_text(out_dir / f"table_{label}.csv", report.table_csv(figures["table"]))
            summary[label] = figures
    return json_safe(summary)


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


def cmd_demo(args: argparse.Namespace) -> int:
    out = Path(args.out)
    est = estimator_from_args(args)
    steps = ["render lab", *DEMO_METHODS, "fixed point", "end to end", "figures"]
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
        bar.set_postfix_str("fixed point")
        design = design_from_args(PIPELINES["p1"], args)
        p1_summary = demo_pipelines(scene, tmp, design, args.pipeline)
        bar.update()
        bar.set_postfix_str("end to end")
        (tmp / "guide").mkdir()
        e2e, e2e_notes, _ = guide.guide_into(tmp / "guide", "runway-p1")
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
            "rangefx_version": package_version(),
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
