"""G1 irradiance tracking (report ch. 2) and the G3 ranging polynomial of degree 1..4
(SPEC §3, §15): what ``rangefx track`` and ``rangefx degrees`` compute, as calls.

:func:`track_pixel` runs the irradiance-tracking navigation scheme on the ch. 2 scene at
one pixel (:mod:`rangefx.golden.tracking`); its :class:`TrackResult` writes the report's
Figs 3-7 look-alikes (scene section and trajectory, raw range, range after each low-pass
filter), the time series as CSV and ``summary.json``. :func:`degree_tables` ranges a scene
preset with the SPIE ranging polynomial of degree 1..4: once with the estimator order
equal to the degree, once with order 4 for every degree (the same derivatives, so only
the polynomial changes), or at one order; its :class:`DegreesResult` writes the tables.
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rangefx.golden.estimator import EstimatorConfig, estimate_derivatives
from rangefx.golden.methods import SCENE_RANGING
from rangefx.golden.polynomial import PolynomialConfig, range_g3_poly
from rangefx.golden.scenes import render_scene
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
from .runner import require_run_memory

__all__ = ["DEGREES", "DegreesResult", "TrackResult", "degree_tables", "track_pixel"]

#: Degrees of the ranging polynomial :func:`degree_tables` compares.
DEGREES = (1, 2, 3, 4)


def _json(data: Any) -> str:
    return json.dumps(json_safe(data), indent=2) + "\n"


@dataclass(frozen=True)
class TrackResult:
    """G1 at one pixel: the run (time series, truth, raw and filtered range), the ch. 2
    scene and the figures (``summary.json``: the sampling bound of eq 9, final and tail
    errors of the raw and the low-pass filtered range)."""

    run: TrackingRun = field(repr=False)
    scene: Any = field(repr=False)
    summary: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        """The figures as JSON-able values (``rangefx track --json``)."""
        return json_safe(self.summary)

    def write(self, out: str | Path) -> Path:
        """Write the Figs 3-7 look-alikes, ``tracking.csv`` and ``summary.json`` into
        directory ``out``, atomically."""
        run, scene = self.run, self.scene
        with atomic_output_dir(Path(out)) as tmp:
            _plot_scene(tmp / "fig3_4_scene.png", scene, run)
            _plot_range(
                tmp / "fig5_raw.png", run, run.range_raw, "Range estimate, navigation scheme",
                scene.unit,
            )  # fmt: skip
            for k, tau in enumerate(run.range_filtered):
                _plot_range(
                    tmp / f"fig{6 + k}_lowpass_tau{tau:g}.png", run, run.range_filtered[tau],
                    f"Range estimate with a low-pass filter, tau = {tau:g} s", scene.unit,
                )  # fmt: skip
            atomic_write_text(tmp / "tracking.csv", _track_csv(run))
            atomic_write_text(tmp / "summary.json", _json(self.summary))
        return Path(out)


def track_pixel(
    xp: float,
    zp: float,
    *,
    duration: float,
    taus: Sequence[float],
    fraction: float,
    threshold: float,
    noise: float = 0.0,
    seed: int = 0,
) -> TrackResult:
    """Track the pixel ``(xp, zp)`` of the ch. 2 scene for ``duration`` seconds, at the
    sampling interval ``fraction`` of the eq-9 bound, with low-pass filters of time
    constants ``taus`` (s), the irradiance test ``threshold`` and sensor noise ``noise``
    (grey levels, seeded)."""
    scene = chapter2_scene()
    if not (math.isfinite(duration) and duration > 0):
        raise UserError(f"--duration must be a positive number of seconds, not {duration}")
    try:
        taus = tuple(taus)
        config = chapter2_config(scene, xp, zp, fraction=fraction, threshold=threshold)
        steps = round(duration / config.h) + 1
        run = simulate_tracking(scene, xp, zp, config, steps, taus, noise_sigma=noise, seed=seed)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    depth0 = float(run.truth[0])
    bound = {
        form: float(sampling_interval_bound(xp, zp, depth0, scene.velocity, scene.f_px, form=form))
        for form in ("printed", "absolute")
    }
    bound["fraction_used"] = fraction
    summary = _track_summary(run, bound, window=1.0)
    summary["scene"] = {
        "unit": scene.unit,
        "f_px": scene.f_px,
        "velocity": [float(v) for v in scene.velocity],
        "section": scene.section.tolist(),
        "noise_sigma": noise,
    }
    return TrackResult(run, scene, summary)


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


@dataclass(frozen=True)
class DegreesResult:
    """The per-object tables of each degree of the ranging polynomial, per setting of
    the estimator order (``summary.json``: ``settings`` -> ``degree<d>`` -> figures)."""

    scene: Any = field(repr=False)
    variant: str
    summary: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        """The figures as JSON-able values (``rangefx degrees --json``)."""
        return json_safe(self.summary)

    def write(self, out: str | Path) -> Path:
        """Write ``table.md`` (every table) and ``summary.json`` into directory ``out``,
        atomically."""
        scene = self.scene
        with atomic_output_dir(Path(out)) as tmp:
            md = [f"# rangefx degrees: scene `{scene.name}`, variant `{self.variant}`\n"]
            for name, per_degree in self.summary["settings"].items():
                for key, v in per_degree.items():
                    md.append(report.table_markdown(v["table"], scene.unit, f"{name}: {key}"))
            atomic_write_text(tmp / "table.md", "\n".join(md))
            atomic_write_text(tmp / "summary.json", _json(self.summary))
        return Path(out)


# fmt: off
def degree_tables(
    scene: str = "lab", *, variant: str = "consistent", order: int | None = None,
    size: Sequence[int] | None = None, seed: int = 0,
) -> DegreesResult:
    """:func:`rangefx.api.degrees`: the scene preset ranged with the polynomial of every
    degree of :data:`DEGREES` (module docstring); ``order`` fixes the estimator order."""
    # fmt: on
    try:
        size = None if size is None else (size[0], size[1])
        if size is not None:
            require_run_memory(f"degrees --size {size[0]} {size[1]}", size[0] * size[1])
        rendered = render_scene(scene, seed=seed, size=size)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    settings = {}
    if order is None:
        settings["order_equals_degree"] = {d: d for d in DEGREES}
        settings["order4"] = {d: 4 for d in DEGREES}
    else:
        settings[f"order{order}"] = {d: order for d in DEGREES if d <= order}
    try:
        figures = {
            name: _degree_results(rendered, variant, orders, seed)
            for name, orders in settings.items()
        }
    except ValueError as exc:
        raise UserError(str(exc)) from None
    summary = {
        "scene": {"name": rendered.name, "unit": rendered.unit,
                  "size": list(rendered.image1.shape), "seed": rendered.seed},
        "variant": variant,
        "ranging": vars(SCENE_RANGING[rendered.name]),
        "settings": figures,
    }  # fmt: skip
    return DegreesResult(rendered, variant, summary)


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
