"""Orchestration of the bit-accurate pipelines: run, compare with golden, benchmark.

``rangefx run --pipeline p1`` (this module's :func:`cmd_run_pipeline`), ``rangefx bench``
(:func:`cmd_bench`) and ``rangefx config`` (:func:`cmd_config`). The golden reference of
P1 is the float64 eq-28 method (``g4_<variant>``) with the same estimator settings, so
that "fixed vs golden" isolates the word lengths.
"""

from __future__ import annotations

import argparse
import difflib
import functools
import json
import os
import statistics
import subprocess
import sys
import time
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numba import njit

from rangefx.golden.estimator import EstimatorConfig
from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.methods import SCENE_RANGING, run_method
from rangefx.golden.ranging import RangeResult, RangingConfig
from rangefx.golden.realdata import load_motorcycle
from rangefx.golden.scenes import Scene, render_plane, render_scene
from rangefx.rtl_model.config import (
    P1_SIGNALS,
    SIGNAL_DOC,
    TimingConfig,
    WordLengthConfig,
    propose_config,
)
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant, cast_array
from rangefx.rtl_model.p1 import P1Result, run_p1

from . import report
from .errors import UserError
from .outdir import atomic_output_dir, atomic_write_text, check_output_file

__all__ = [
    "HELD_OUT_SCENES",
    "REAL_PAIRS",
    "P1Case",
    "compare_ranges",
    "golden_for",
    "held_out_case",
    "p1_case_from_scene",
    "real_pair_case",
    "run_case",
]

#: P1 mode of each scene preset: the lab pair is a stereo rig, the runway pair two frames.
SCENE_MODE = {"lab": "stereo", "runway": "motion"}


@dataclass(frozen=True)
class P1Case:
    """Everything one P1 run needs besides the word-length config."""

    image1: np.ndarray
    image2: np.ndarray
    camera: PinholeCamera
    motion: MotionIncrement
    ranging: RangingConfig
    mode: str
    scene: Scene | None = None
    #: Name for messages when there is no ``scene`` (a real pair: ``"motorcycle"``).
    label: str | None = None


def p1_case_from_scene(name: str, seed: int = 0) -> P1Case:
    try:
        scene = render_scene(name, seed=seed)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    return P1Case(
        scene.image1,
        scene.image2,
        scene.camera,
        scene.motion,
        SCENE_RANGING[name],
        SCENE_MODE[name],
        scene,
    )


#: Real stereo pairs with a P1 case (:func:`real_pair_case`).
REAL_PAIRS: tuple[str, ...] = ("motorcycle",)


@functools.cache
def real_pair_case(name: str = "motorcycle") -> P1Case:
    """P1 stereo case of a real pair: the Middlebury motorcycle pair as ``rangefx eval``
    loads it (:func:`rangefx.golden.realdata.load_motorcycle`, default factor: 26x39 px,
    median disparity 2 px, calibrated camera, stereo baseline along ``+y_c``).

    Why it differs from the pair as evaluated: P1 takes the sensor's integer grey
    levels, so the block means are rounded (the golden reference of :func:`golden_for`
    then runs on the same rounded pair); lengths are in metres, not the dataset's mm,
    because the translation register ``k_t_reg`` (default s28.20, +-128) would saturate
    at the 193 mm baseline and scale every range by 128/193 without an overflow count.
    Thresholds are the lab scene's (T_E = T_g = 2, as ``rangefx eval``), ``range_max``
    the dataset's (twice the largest known depth).
    """
    if name not in REAL_PAIRS:
        raise UserError(f"unknown real pair {name!r}; choose from {', '.join(REAL_PAIRS)}")
    data = load_motorcycle()
    metre = 1e-3  # the dataset's lengths are in mm
    image1, image2 = (
        np.clip(np.rint(im), 0, 255).astype(np.int64) for im in (data.image1, data.image2)
    )
    ranging = replace(SCENE_RANGING["lab"], range_max=data.range_max * metre)
    motion = MotionIncrement.stereo(data.motion.camera_displacement[1] * metre)
    return P1Case(image1, image2, data.camera, motion, ranging, "stereo", label=name)


#: Synthetic scenes held out of tuning: ``rangefx optimise --verify`` only
#: (:func:`held_out_case`).
HELD_OUT_SCENES: tuple[str, ...] = ("plane",)


@functools.cache
def held_out_case(name: str = "plane", size: tuple[int, int] | None = None) -> P1Case:
    """P1 stereo case of a held-out synthetic scene, default 512x512 (``size``: any other
    ``(height, width)``, keeping the field of view as :func:`render_scene` does).

    ``plane``: :func:`rangefx.golden.scenes.render_plane` chosen unlike every tuning scene:
    a fronto-parallel plane at 5 m (lab: 19-60 in, runway: 230-610 ft, motorcycle: the
    real pair in metres at 26x39), 30 deg horizontal field of view (f = 955 px at 512
    wide; lab 45 deg, runway 35 deg), 5 mm baseline (disparity 0.96 px; lab about 2 px),
    scikit-image's ``coins`` texture (unused by lab, a small vehicle on runway) and noise
    seed 7 (the presets use 0). Thresholds T_E = T_g = 2 as lab, ``range_max`` twice
    the depth (as the real pair).
    """
    if name not in HELD_OUT_SCENES:
        raise UserError(
            f"unknown held-out scene {name!r}; choose from {', '.join(HELD_OUT_SCENES)}"
        )
    height, width = size if size else (512, 512)
    depth = 5.0
    try:
        f_px = PinholeCamera.from_fov(width, height, 30.0).f_px
        scene = render_plane(
            depth=depth, size=(height, width), f_px=f_px, baseline=0.005, seed=7,
            texture="coins", unit="m",
        )  # fmt: skip
    except ValueError as exc:
        raise UserError(f"{name}: {exc}") from None
    ranging = replace(SCENE_RANGING["lab"], range_max=2 * depth)
    return P1Case(scene.image1, scene.image2, scene.camera, scene.motion, ranging, "stereo", scene)


def golden_for(case: P1Case, config: WordLengthConfig) -> RangeResult:
    """The float64 reference of P1: eq 28 with the same estimator settings."""
    est = EstimatorConfig(pole=config.pole, bias=config.bias, init=config.init)
    return run_method(
        f"g4_{config.variant}",
        case.image1,
        case.image2,
        case.camera,
        case.motion,
        estimator=est,
        ranging=case.ranging,
    )


def compare_ranges(fixed: P1Result | RangeResult, golden: RangeResult) -> dict[str, float]:
    """Fixed vs golden on one pair: relative range difference on pixels valid in both
    (median and 95th percentile) and the fraction of pixels whose valid flags agree."""
    both = fixed.valid & golden.valid
    n_both = int(np.count_nonzero(both))
    rel = np.abs(fixed.range[both] - golden.range[both]) / golden.range[both]
    return {
        "median_rel_range_diff": float(np.median(rel)) if n_both else float("nan"),
        "p95_rel_range_diff": float(np.percentile(rel, 95)) if n_both else float("nan"),
        "valid_agreement": float(np.mean(fixed.valid == golden.valid)),
        "n_valid_both": n_both,
    }


def run_case(
    case: P1Case,
    config: WordLengthConfig,
    timing: TimingConfig | None = None,
    *,
    taps: bool = False,
) -> P1Result:
    try:
        return run_p1(
            case.image1,
            case.image2,
            case.camera,
            case.motion,
            config,
            case.ranging,
            timing=timing,
            mode=case.mode,
            taps=taps,
        )
    except ValueError as exc:
        raise UserError(str(exc)) from None


def _unknown_signal_hint(path: str) -> str | None:
    """For a config that misspells signals: "unknown signal 'row_stat' (did you mean
    'row_state'?)", or None when the file's ``[signals]`` names are all known."""
    try:
        table = tomllib.loads(Path(path).read_text(encoding="utf-8")).get("signals")
    except (OSError, ValueError):
        return None
    if not isinstance(table, dict):
        return None
    hints = []
    for name in (s for s in table if s not in SIGNAL_DOC):
        near = difflib.get_close_matches(name, list(SIGNAL_DOC), n=1)
        hints.append(f"{name!r}" + (f" (did you mean {near[0]!r}?)" if near else ""))
    return f"unknown signal {', '.join(hints)}" if hints else None


def load_config(path: str | None, variant: str | None, divider: str | None) -> WordLengthConfig:
    try:
        config = WordLengthConfig.load(path) if path else WordLengthConfig.default()
        changes = {k: v for k, v in (("variant", variant), ("divider", divider)) if v}
        return config.with_(**changes) if changes else config
    except UnicodeDecodeError:
        raise UserError(f"{path}: not a text (UTF-8) word-length config TOML") from None
    except ValueError as exc:
        message = str(exc)
        hint = _unknown_signal_hint(path) if path else None
        if hint is not None:
            message = f"{path}: {hint}"
        elif path and str(path) not in message:
            message = f"{path}: {message}"
        raise UserError(message) from None


def _integer_image(image: np.ndarray, name: str) -> np.ndarray:
    if not np.array_equal(image, np.round(image)):
        raise UserError(f"{name} must hold integer grey levels for the fixed-point pipeline")
    return image.astype(np.int64)


def check_input_levels(
    images: dict[str, np.ndarray], fmt: FixedFormat, signal: str, *, allow: bool
) -> int:
    """Count the grey levels of ``images`` (name -> integer image) that the input format
    ``fmt`` cannot hold, which the pipeline would saturate (a 16-bit PNG, 300, -300 for
    ``u8.0``). Any is an error unless ``allow``; then a one-line warning says how many.

    Returns
    -------
    int
        The number of such pixels over all images.

    Raises
    ------
    UserError
        Some pixels are outside ``fmt`` and ``allow`` is False.
    """
    total, parts = 0, []
    for name, image in images.items():
        _, count = cast_array(np.asarray(image, dtype=np.int64), 0, fmt)
        if count:
            total += count
            parts.append(f"{name} {count} (levels {int(image.min())}..{int(image.max())})")
    if total:
        what = (
            f"{total} input pixels outside {signal} ({fmt}: "
            f"{fmt.to_float(fmt.raw_min):g}..{fmt.to_float(fmt.raw_max):g}): {'; '.join(parts)}"
        )
        if not allow:
            raise UserError(
                f"{what}; the pipeline would saturate them: rescale the images or pass "
                "--allow-saturated-input"
            )
        print(f"rangefx: warning: {what}, saturated (--allow-saturated-input)", file=sys.stderr)
    return total


def timing_from_args(args: argparse.Namespace) -> TimingConfig:
    try:
        return TimingConfig(
            hblank=args.hblank, vblank=args.vblank, gap_prob=args.gap_prob, seed=args.gap_seed
        )
    except ValueError as exc:
        raise UserError(str(exc)) from None


def p1_figures(result: P1Result, golden: RangeResult, scene: Scene | None) -> dict:
    figures: dict = {
        "pipeline": "p1",
        "mode": result.mode,
        "config": result.config.name,
        "variant": result.config.variant,
        "divider": result.config.divider,
        "overflows": {"total": result.overflow_total, **result.overflows},
        **compare_ranges(result, golden),
        "valid_fraction": result.valid_fraction,
        "golden_valid_fraction": golden.valid_fraction,
        "latency_cycles": result.latency,
        "stage_latency": result.stage_latency,
        "total_cycles": result.total_cycles,
        "line_buffer_bits": result.line_buffer_bits,
        "frame_store_bits": result.frame_store_bits,
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


def median_text(figures: dict) -> str:
    """The median relative range difference for a report line; with no pixel valid in
    both results there is no median, and the line says so instead of printing nan."""
    if not figures.get("n_valid_both"):
        return "n/a (no pixel valid in both fixed and golden)"
    return f"{figures['median_rel_range_diff']:.2e}"


def cmd_run_pipeline(
    args: argparse.Namespace, case: P1Case, clean, write_outputs: bool = True
) -> int:
    """``rangefx run --pipeline p1``: range map + taps + report (SPEC §8)."""
    if case.scene is None:
        case = P1Case(
            _integer_image(case.image1, args.left),
            _integer_image(case.image2, args.right),
            case.camera,
            case.motion,
            case.ranging,
            "stereo",
        )
    config = load_config(args.config, args.variant, args.divider)
    check_input_levels(
        {args.left or "image1": case.image1, args.right or "image2": case.image2},
        config.fmt("pix_in"), "pix_in", allow=args.allow_saturated_input,
    )  # fmt: skip
    timing = timing_from_args(args)
    result = run_case(case, config, timing, taps=bool(args.out))
    golden = golden_for(case, config)
    figures = p1_figures(result, golden, case.scene)
    if args.out and write_outputs:
        with atomic_output_dir(Path(args.out)) as tmp:
            np.save(tmp / "range.npy", result.range)
            np.save(tmp / "valid.npy", result.valid)
            np.savez_compressed(tmp / "taps.npz", **result.taps)
            report.save_range_map_png(
                tmp / "range.png", result.range, result.valid, case.ranging.range_max, "P1 range"
            )
            atomic_write_text(tmp / "config.toml", config.to_toml())
            atomic_write_text(tmp / "summary.json", json.dumps(clean(figures), indent=2) + "\n")
    if args.json:
        print(json.dumps(clean(figures)))
        return 0
    if case.scene is not None:
        print(
            report.format_side_by_side(
                {"golden g4": figures["golden_table"], "p1 fixed": figures["table"]},
                case.scene.unit,
            )
        )
    print(
        f"P1 {result.mode} ({config.variant}, {config.divider} divider): "
        f"overflows {result.overflow_total}, median |fixed-golden|/golden "
        f"{median_text(figures)}, valid agreement "
        f"{figures['valid_agreement']:.4f}, latency {result.latency} cycles, "
        f"line buffers {result.line_buffer_bits} bits, frame store {result.frame_store_bits} bits"
    )
    return 0


# -- benchmark -------------------------------------------------------------------------
def _median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def bench_figures(repeats: int = 5, size: int = 512) -> dict:
    """Mpixel/s of P1 (stereo, 512x512) vs the float64 golden on the same pair."""
    scene = render_scene("lab", size=(size, size)) if size != 512 else render_scene("lab")
    case = P1Case(
        scene.image1, scene.image2, scene.camera, scene.motion, SCENE_RANGING["lab"], "stereo"
    )
    out = {"size": [size, size], "repeats": repeats, "cpu_count": os.cpu_count()}
    pixels = size * size
    for variant in ("paper", "consistent"):
        config = WordLengthConfig.default(variant)
        run_case(case, config)  # JIT warm-up
        cpu: list[dict[str, float]] = []
        t = _median_time(lambda c=config, k=cpu: k.append(run_case(case, c).kernel_cpu_s), repeats)
        out[f"p1_stereo_{variant}_mpix_s"] = pixels / t / 1e6
        # where the time goes: CPU ns per pixel of each kernel (both streams / all bands)
        for kernel in ("front_end", "range"):
            ns = statistics.median(c[kernel] for c in cpu) / pixels * 1e9
            out[f"p1_{variant}_{kernel}_cpu_ns_px"] = ns
        t = _median_time(
            lambda c=config: run_p1(case.image1, case.image2, case.camera, case.motion, c,
                                    case.ranging, taps=False, threads=1),
            repeats,
        )  # fmt: skip
        # one thread, for the second core's share
        out[f"p1_stereo_{variant}_1thread_mpix_s"] = pixels / t / 1e6
        t = _median_time(lambda c=config: run_case(case, c, taps=True), repeats)
        out[f"p1_stereo_{variant}_taps_mpix_s"] = pixels / t / 1e6
        t = _median_time(lambda c=config: golden_for(case, c), repeats)
        out[f"golden_p1_{variant}_mpix_s"] = pixels / t / 1e6
    out["p1_stereo_mpix_s"] = out["p1_stereo_paper_mpix_s"]
    out["golden_p1_mpix_s"] = out["golden_p1_paper_mpix_s"]
    out["cast_ns"], out["cast_overflowing_row_ns"] = _cast_ns()
    out["log_floor_ns"] = _floor_ns(_minmax_loop)
    out["constant_cast_floor_ns"] = _floor_ns(_constant_cast_loop)
    from .p2_pipeline import bench_p2  # local: p2_pipeline imports this module

    out.update(bench_p2(repeats, size))
    code = (
        "import time; t=time.perf_counter(); import numpy as np;"
        "from rangefx.tools.pipeline import _cold_run; _cold_run();"
        "print(time.perf_counter()-t)"
    )
    t = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
    out["cold_process_s"] = time.perf_counter() - t
    return out


def _cast_ns(size: int = 1 << 16, repeats: int = 21) -> tuple[float, float]:
    """CPU ns per element of one cast (``cast_array``, s16.4 RND/SAT from 8 more fraction
    bits): the unit cost the pipeline pays ~41 times per stereo pixel. Two figures: a
    row inside the format (the common case: overflow is decided on the row's extremes)
    and the same row with one element out of range (a second, element-wise pass)."""
    raw = np.random.default_rng(0).integers(-(2**22), 2**22, size)
    fmt = FixedFormat.from_string("s16.4", Quant.RND, Overflow.SAT)
    figures = []
    for row in (raw, np.concatenate([raw[:-1], [2**40]])):
        cast_array(row, 12, fmt)  # JIT warm-up
        times = []
        for _ in range(repeats):
            t = time.thread_time()
            cast_array(row, 12, fmt)
            times.append(time.thread_time() - t)
        figures.append(statistics.median(times) / size * 1e9)
    return figures[0], figures[1]


@njit(cache=True, nogil=True)
def _minmax_loop(raw, out, reps):
    """Only the min/max log of an int64 row, ``reps`` times (a calibration: see below)."""
    lo, hi = raw[0], raw[0]
    for _ in range(reps):
        for i in range(raw.shape[0]):
            lo = min(lo, raw[i])
            hi = max(hi, raw[i])
    return lo, hi, 0


@njit(cache=True, nogil=True)
def _constant_cast_loop(raw, out, reps):
    """A cast with its format folded in as constants (s16.4 RND/SAT from 8 more fraction
    bits), saturated element by element, logged and counted, ``reps`` times: what a kernel
    specialised on one config pays without the row-extremes overflow check of cast_row."""
    lo, hi, count = raw[0], raw[0], 0
    for _ in range(reps):
        for i in range(raw.shape[0]):
            r = raw[i]
            lo = min(lo, r)
            hi = max(hi, r)
            q = (r + 128) >> 8
            value = min(max(q, -32768), 32767)
            out[i] = value
            count += value != q
    return lo, hi, count


def _floor_ns(loop, size: int = 512, reps: int = 4000, repeats: int = 7) -> float:
    """CPU ns per element of a calibration ``loop`` over a 512-element int64 row (min of
    ``repeats``): floors for one logged cast on this CPU (AVX2 has no 64-bit vector
    min/max), to set beside ``cast_ns``."""
    raw = np.random.default_rng(1).integers(-(2**22), 2**22, size)
    out = np.empty_like(raw)
    loop(raw, out, 1)
    times = []
    for _ in range(repeats):
        t = time.thread_time()
        loop(raw, out, reps)
        times.append(time.thread_time() - t)
    return min(times) / (size * reps) * 1e9


def _cold_run() -> None:
    """A second process's first P1 run on a 64x64 pair (numba cache warm)."""
    rng = np.random.default_rng(0)
    a = rng.integers(0, 256, (64, 64))
    cam = PinholeCamera(64, 64, 100.0)
    run_p1(a, np.roll(a, 1, axis=1), cam, MotionIncrement.stereo(0.1), taps=False)


def cmd_bench(args: argparse.Namespace, clean) -> int:
    if args.repeats < 1 or args.size < 16:
        raise UserError("bench needs --repeats >= 1 and --size >= 16")
    figures = bench_figures(repeats=args.repeats, size=args.size)
    if args.json:
        print(json.dumps(clean(figures)))
    else:
        for k, v in figures.items():
            print(f"{k}: {v:.3f}" if isinstance(v, float) else f"{k}: {v}")
    return 0


# -- word-length config ------------------------------------------------------------------
#: First bytes of every config TOML rangefx writes: ``config --out`` replaces only such a file.
CONFIG_HEADER = b"# rangefx "


def _write_output_file(path: Path, text: str) -> None:
    try:
        atomic_write_text(path, text)
    except OSError as exc:
        raise UserError(f"cannot write --out {str(path)!r}: {exc.strerror}") from None


def cmd_config(args: argparse.Namespace, clean) -> int:
    """``rangefx config show|propose``: the default TOML, or integer bits from ranges."""
    config = load_config(args.config, args.variant, None)
    out = check_output_file(args.out, CONFIG_HEADER) if args.out else None
    if args.action == "show":
        text = config.to_toml()
        if out is not None:
            _write_output_file(out, text)
        else:
            sys.stdout.write(text)
        return 0
    cases = [p1_case_from_scene(name) for name in args.scene]
    proposed = config
    for _ in range(4):  # a clipped signal hides its consumers' ranges: iterate to a fixpoint
        minmax: dict[str, tuple[float, float]] = {}
        overflows = 0
        for case in cases:
            result = run_case(case, proposed)
            overflows += result.overflow_total
            for sig, (lo, hi) in result.minmax.items():
                old = minmax.get(sig, (lo, hi))
                minmax[sig] = (min(old[0], lo), max(old[1], hi))
        try:
            step = propose_config(proposed, minmax, guard_bits=args.guard_bits)
        except ValueError as exc:
            raise UserError(str(exc)) from None
        if step == proposed and overflows == 0:
            break
        proposed = step
    if out is not None:
        _write_output_file(out, proposed.to_toml())
    rows = {
        sig: {
            "min": minmax.get(sig, (None, None))[0],
            "max": minmax.get(sig, (None, None))[1],
            "current": str(config.formats[sig]),
            "proposed": str(proposed.formats[sig]),
        }
        for sig in P1_SIGNALS
    }
    if args.json:
        print(json.dumps(clean(rows)))
    else:
        for sig, r in rows.items():
            lo, hi = r["min"], r["max"]
            print(f"{sig:12s} {r['current']:>8s} -> {r['proposed']:>8s}  range [{lo}, {hi}]")
    return 0


def demo_p1(scene: Scene, out_dir: Path, clean) -> dict:
    """The fixed-point P1 (stereo, default config, both variants) beside golden, for
    ``rangefx demo``: range maps, Table-1 tables, error histograms; returns the figures."""
    case = P1Case(
        scene.image1, scene.image2, scene.camera, scene.motion, SCENE_RANGING[scene.name],
        SCENE_MODE[scene.name], scene,
    )  # fmt: skip
    summary = {}
    for variant in ("paper", "consistent"):
        config = WordLengthConfig.default(variant)
        result = run_case(case, config)
        golden = golden_for(case, config)
        figures = p1_figures(result, golden, scene)
        figures.pop("signal_minmax")
        name = f"p1_{variant}"
        report.save_range_map_png(
            out_dir / f"range_{name}.png",
            result.range,
            result.valid,
            case.ranging.range_max,
            f"P1 fixed point ({variant})",
            unit=scene.unit,
        )
        both = result.valid & golden.valid
        rel = np.abs(result.range[both] - golden.range[both]) / golden.range[both]
        report.save_error_histogram_png(
            out_dir / f"hist_{name}.png", rel, f"P1 {variant}: fixed vs golden g4_{variant}"
        )
        atomic_write_text(out_dir / f"table_{name}.csv", report.table_csv(figures["table"]))
        summary[name] = figures
    return clean(summary)


def p1_range_source(variant: str = "consistent", config: WordLengthConfig | None = None):
    """A range-map source for :func:`rangefx.guidance.obstacles.runway_scene_obstacles`:
    the fixed-point P1 pipeline (the scene's mode: motion for ``runway``)."""
    config = config or WordLengthConfig.default(variant)

    def source(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
        case = P1Case(
            scene.image1, scene.image2, scene.camera, scene.motion, SCENE_RANGING[scene.name],
            SCENE_MODE[scene.name], scene,
        )  # fmt: skip
        result = run_case(case, config)
        return result.range, result.valid

    return source
