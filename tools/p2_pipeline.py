"""Orchestration of the P2 pipeline (Riccati sweep, issue 5): run, compare with golden
G5, benchmark, demo.

``rangefx run --pipeline p2`` dispatches to :func:`cmd_run_p2`; :func:`bench_p2` and
:func:`demo_p2` are the P2 parts of ``rangefx bench`` / ``rangefx demo``. The golden
reference of P2 is :func:`rangefx.golden.riccati.range_g5` with the same
:class:`RiccatiConfig` (the ``lq`` sweep, ``A`` at the pixel edge), so "fixed vs golden"
isolates the word lengths and the two bounding choices (γ clamp, κ floor).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from rangefx.golden.methods import SCENE_RICCATI
from rangefx.golden.ranging import RangeResult
from rangefx.golden.riccati import RiccatiConfig, range_g5
from rangefx.golden.scenes import Scene, render_scene
from rangefx.rtl_model.config import TimingConfig
from rangefx.rtl_model.p2 import P2Result, run_p2
from rangefx.rtl_model.p2_config import P2Config

from . import report
from .errors import UserError
from .outdir import atomic_output_dir, atomic_write_text
from .pipeline import P1Case, check_input_levels, compare_ranges, median_text, timing_from_args

__all__ = ["bench_p2", "cmd_run_p2", "demo_p2", "p2_figures", "riccati_for", "run_p2_case"]


def riccati_for(case: P1Case, args: argparse.Namespace | None = None) -> RiccatiConfig:
    """G5 settings of a case: the scene's (``SCENE_RICCATI``) or the defaults, with the
    command line's ``--threshold-e`` / ``--range-max`` applied."""
    name = case.scene.name if case.scene is not None else None
    cfg = SCENE_RICCATI.get(name, RiccatiConfig()) if name else RiccatiConfig()
    if args is not None:
        changes = {
            k: v
            for k, v in (
                ("threshold_e", getattr(args, "threshold_e", None)),
                ("range_max", getattr(args, "range_max", None)),
            )
            if v is not None
        }
        try:
            cfg = replace(cfg, **changes)
        except ValueError as exc:
            raise UserError(str(exc)) from None
    return cfg


def load_p2_config(path: str | None, divider: str | None) -> P2Config:
    try:
        config = P2Config.load(path) if path else P2Config.default()
        return config.with_(divider=divider) if divider else config
    except UnicodeDecodeError:
        raise UserError(f"{path}: not a text (UTF-8) P2 word-length config TOML") from None
    except ValueError as exc:
        message = str(exc)
        raise UserError(message if not path or path in message else f"{path}: {message}") from None


def run_p2_case(
    case: P1Case,
    config: P2Config,
    riccati: RiccatiConfig,
    timing: TimingConfig | None = None,
    *,
    taps: bool = False,
) -> P2Result:
    try:
        return run_p2(
            case.image1, case.image2, case.camera, case.motion, config, riccati,
            timing=timing, taps=taps,
        )  # fmt: skip
    except ValueError as exc:
        raise UserError(str(exc)) from None


def golden_g5(case: P1Case, riccati: RiccatiConfig) -> RangeResult:
    try:
        return range_g5(case.image1, case.image2, case.camera, case.motion, riccati)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def p2_figures(result: P2Result, golden: RangeResult, scene: Scene | None) -> dict:
    """The figures of one P2 run, with the keys of P1's (``pipeline.p1_figures``)."""
    figures: dict = {
        "pipeline": "p2",
        "mode": "stereo",
        "config": result.config.name,
        "divider": result.config.divider,
        "overflows": {"total": result.overflow_total, **result.overflows},
        **compare_ranges(result, golden),
        "valid_fraction": result.valid_fraction,
        "golden_valid_fraction": golden.valid_fraction,
        "latency_cycles": result.latency,
        "stage_latency": result.stage_latency,
        "schedule": result.schedule,
        "total_cycles": result.total_cycles,
        "line_buffer_bits": result.line_buffer_bits,
        "frame_store_bits": 0,
        "registers": {k: list(v) for k, v in result.registers.items()},
        "signal_minmax": {k: list(v) for k, v in result.minmax.items()},
    }
    if scene is not None:
        figures["scene"] = scene.name
        figures["unit"] = scene.unit
        figures["table"] = report.object_table(
            result.range, result.valid, scene.labels1, scene.objects, scene.depth1
        )
        figures["golden_table"] = report.object_table(
            golden.range, golden.valid, scene.labels1, scene.objects, scene.depth1
        )
    return figures


def cmd_run_p2(args: argparse.Namespace, case: P1Case, clean) -> int:
    """``rangefx run --pipeline p2``: range map + taps + report, P2 beside golden G5."""
    for name, im in (("left", case.image1), ("right", case.image2)):
        if not np.array_equal(im, np.round(im)):
            raise UserError(f"{name} image must hold integer grey levels for the P2 pipeline")
    case = replace(case, image1=case.image1.astype(np.int64), image2=case.image2.astype(np.int64))
    config = load_p2_config(getattr(args, "config", None), getattr(args, "divider", None))
    check_input_levels(
        {args.left or "image1": case.image1, args.right or "image2": case.image2},
        config.formats["p2_pix"], "p2_pix", allow=args.allow_saturated_input,
    )  # fmt: skip
    riccati = riccati_for(case, args)
    timing = timing_from_args(args)
    result = run_p2_case(case, config, riccati, timing, taps=bool(args.out))
    golden = golden_g5(case, riccati)
    figures = p2_figures(result, golden, case.scene)
    if args.out:
        with atomic_output_dir(Path(args.out)) as tmp:
            np.save(tmp / "range.npy", result.range)
            np.save(tmp / "valid.npy", result.valid)
            np.savez_compressed(tmp / "taps.npz", **result.taps)
            report.save_range_map_png(
                tmp / "range.png", result.range, result.valid, riccati.range_max, "P2 range"
            )
            atomic_write_text(tmp / "config.toml", config.to_toml())
            atomic_write_text(tmp / "summary.json", json.dumps(clean(figures), indent=2) + "\n")
    if args.json:
        print(json.dumps(clean(figures)))
        return 0
    if case.scene is not None:
        print(
            report.format_side_by_side(
                {"golden g5": figures["golden_table"], "p2 fixed": figures["table"]},
                case.scene.unit,
            )
        )
    print(
        f"P2 stereo ({config.divider} divider, {result.schedule['lanes']} lanes): overflows "
        f"{result.overflow_total}, median |fixed-golden|/golden "
        f"{median_text(figures)}, valid agreement "
        f"{figures['valid_agreement']:.4f}, latency {result.latency} cycles, "
        f"line buffers {result.line_buffer_bits} bits"
    )
    return 0


def _lab_case(size: int = 512, seed: int = 0) -> P1Case:
    scene = render_scene("lab", size=(size, size), seed=seed) if size != 512 else (
        render_scene("lab", seed=seed)
    )  # fmt: skip
    return P1Case(scene.image1, scene.image2, scene.camera, scene.motion, None, "stereo", scene)


def bench_p2(repeats: int = 5, size: int = 512) -> dict:
    """Mpixel/s of P2 (stereo, ``size``², default config, no taps; and with taps) and of
    golden G5 on the same pair; median of ``repeats`` runs after a warm-up."""
    case = _lab_case(size)
    config, riccati = P2Config.default(), SCENE_RICCATI["lab"]
    pixels = size * size

    def med(fn) -> float:
        fn()
        times = []
        for _ in range(repeats):
            t = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t)
        return statistics.median(times)

    return {
        "p2_stereo_mpix_s": pixels / med(lambda: run_p2_case(case, config, riccati)) / 1e6,
        "p2_stereo_taps_mpix_s": pixels
        / med(lambda: run_p2_case(case, config, riccati, taps=True))
        / 1e6,
        "golden_g5_mpix_s": pixels / med(lambda: golden_g5(case, riccati)) / 1e6,
    }


def demo_p2(scene: Scene, out_dir: Path, clean) -> dict:
    """P2 (default config) beside golden G5 for ``rangefx demo``: range map and error
    histogram PNGs, Table-1 CSV and the figures (without the per-signal ranges), as
    ``{"p2": figures}`` with the keys of ``pipeline.demo_p1``'s entries."""
    case = P1Case(scene.image1, scene.image2, scene.camera, scene.motion, None, "stereo", scene)
    riccati = riccati_for(case)
    result = run_p2_case(case, P2Config.default(), riccati)
    golden = golden_g5(case, riccati)
    figures = p2_figures(result, golden, scene)
    figures.pop("signal_minmax")
    report.save_range_map_png(
        out_dir / "range_p2.png", result.range, result.valid, riccati.range_max,
        "P2 fixed point (Riccati sweep)", unit=scene.unit,
    )  # fmt: skip
    both = result.valid & golden.valid
    rel = np.abs(result.range[both] - golden.range[both]) / golden.range[both]
    report.save_error_histogram_png(out_dir / "hist_p2.png", rel, "P2: fixed vs golden G5")
    atomic_write_text(out_dir / "table_p2.csv", report.table_csv(figures["table"]))
    return clean({"p2": figures})
