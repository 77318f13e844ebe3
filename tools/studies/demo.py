"""``rangefx demo``'s work (SPEC §8, §15): the main job on the embedded ``lab`` scene.

:func:`demo_into` renders ``lab``, runs the golden methods of :data:`DEMO_METHODS`, every
registered fixed-point pipeline in each of its variants beside its golden
(:func:`demo_pipelines`) and the end-to-end chain (runway → P1 motion mode → obstacles →
guidance, :func:`rangefx.tools.studies.flights.guide_flight`), and writes range maps,
tables, plots and ``summary.json`` into a directory.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rangefx.golden.estimator import EstimatorConfig, estimate_derivatives
from rangefx.golden.methods import SCENE_RANGING, run_method
from rangefx.golden.ranging import RangeResult
from rangefx.golden.scenes import Scene, render_scene
from rangefx.rtl_model.pipeline import Case
from rangefx.rtl_model.registry import PIPELINES

from .. import report
from ..errors import UserError
from ..report import atomic_write_text, json_safe
from ..version import package_version
from .flights import guide_flight
from .runner import golden_case, load_config, pipeline_figures, run_case

__all__ = ["DEMO_METHODS", "DEMO_STEPS", "demo_into", "demo_pipelines", "package_version"]

#: The report's methods and G6 (beyond the report, SPEC §12): G6 adds about 0.2 s to the
#: demo's 20 s on ``lab`` (docs/multiscale.md, measured).
DEMO_METHODS = ("g3_paper", "g3_consistent", "g2_central", "g5_riccati", "g6_multiscale")
#: The steps :func:`demo_into` reports, in order.
DEMO_STEPS = ("render lab", *DEMO_METHODS, "fixed point", "end to end", "figures")


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
    case = Case.from_scene(scene)
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


def demo_into(
    tmp: Path,
    *,
    seed: int = 0,
    est: EstimatorConfig | None = None,
    design: dict[str, Any] | None = None,
    pipelines: Sequence[str] | None = None,
    step: Callable[[str], None] = lambda name: None,
) -> tuple[dict[str, Any], list[str]]:
    """Run the demo into the existing directory ``tmp``; return its summary
    (``summary.json``) and the end-to-end flight's warnings. ``step`` is called with each
    name of :data:`DEMO_STEPS` as it starts; ``design`` applies to the pipelines with the
    field, ``pipelines`` restricts them."""
    est = est or EstimatorConfig()
    step(DEMO_STEPS[0])
    scene = _render("lab", seed)
    ranging = SCENE_RANGING["lab"]
    results, summary_methods = {}, {}
    for m in DEMO_METHODS:
        step(m)
        results[m] = run_method(m, scene.image1, scene.image2, scene.camera, scene.motion,
                                estimator=est, ranging=ranging)  # fmt: skip
        summary_methods[m] = _method_figures(scene, results[m])
        step("fixed point")
    p1_summary = demo_pipelines(scene, tmp, design, pipelines)
    step("end to end")
    (tmp / "guide").mkdir()
    flight = guide_flight("runway-p1")
    flight.write_files(tmp / "guide")
    e2e, e2e_notes = flight.summary, flight.warnings
    step("figures")
    report.save_pair_png(tmp / "pair.png", scene.image1, scene.image2, ("left (E1)", "right (E2)"))
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
    return summary, e2e_notes
