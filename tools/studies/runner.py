"""The generic runner: any registered pipeline on any case, beside its golden (SPEC §10).

Every consumer (run, demo, bench, config, eval, sweeps, the optimiser) runs a pipeline
through these functions, which turn the model's ``ValueError`` into the command line's
:class:`UserError` and compute the figures every report shares.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from rangefx.golden.ranging import RangeResult
from rangefx.golden.scenes import Scene
from rangefx.rtl_model.config import TimingConfig, WordLengthConfig, propose_config
from rangefx.rtl_model.fixedpoint import FixedFormat, cast_array
from rangefx.rtl_model.pipeline import Case, GoldenReference, Pipeline, PipelineResult
from rangefx.rtl_model.registry import PIPELINES, get_pipeline

from .. import report
from ..errors import UserError, require_memory

__all__ = [
    "GOLDEN_BYTES_PER_PIXEL",
    "RUN_BASE_BYTES",
    "check_input_levels",
    "compare_ranges",
    "golden_case",
    "load_config",
    "pipeline_figures",
    "propose_from_cases",
    "range_source",
    "require_run_memory",
    "run_bytes_per_pixel",
    "run_case",
    "run_memory_bytes",
]


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


#: Peak resident memory of ``rangefx run`` (a pipeline beside its golden, or a golden
#: method alone): a base (the interpreter, numpy, numba and the loaded kernels) plus
#: bytes per pixel, each pipeline's its own :attr:`Pipeline.run_bytes_per_pixel`. Fitted
#: to ``/usr/bin/time -f %M rangefx run --pipeline P --left L.npy --right R.npy`` at
#: 512x512 and 2048x2048 (random 8-bit pair, AMD EPYC, warm kernel cache): base ~200 MB;
#: golden 195, P1 316, P2 176, P3 645 B a pixel; the figures are those with 15 % of
#: headroom, so the estimate is 13-21 % above the measured peak at both sizes
#: (docs/guarantees.md).
RUN_BASE_BYTES = 220 * 2**20
#: A golden method alone, bytes a pixel (``rangefx run --method``).
GOLDEN_BYTES_PER_PIXEL = 224


def run_bytes_per_pixel(pipeline: str | None = None) -> int:
    """Bytes a pixel of a run of ``pipeline`` (a registry name: its
    :attr:`~rangefx.rtl_model.pipeline.Pipeline.run_bytes_per_pixel`; ``"golden"``: a
    golden method alone). None, or a pipeline that declares no figure: the largest
    figure of the registry and golden."""
    if pipeline == "golden":
        return GOLDEN_BYTES_PER_PIXEL
    own = getattr(PIPELINES.get(pipeline or ""), "run_bytes_per_pixel", None)
    if own is not None:
        return own
    declared = (p.run_bytes_per_pixel for p in PIPELINES.values())
    return max(GOLDEN_BYTES_PER_PIXEL, *(b for b in declared if b is not None))


def run_memory_bytes(pixels: int, pipeline: str | None = None, runs: int = 1) -> int:
    """Estimated peak bytes of ``runs`` concurrent runs of ``pipeline`` (a registry name,
    ``"golden"`` for a golden method alone, None for the largest) on ``pixels`` pixels."""
    return RUN_BASE_BYTES + runs * pixels * run_bytes_per_pixel(pipeline)


def require_run_memory(what: str, pixels: int, runs: int = 1, pipeline: str | None = None) -> None:
    """Refuse, before rendering or running, ``runs`` concurrent runs of ``pixels`` pixels
    of ``pipeline`` (None: the largest) that would need more memory than this machine has
    (one line naming ``what``)."""
    require_memory(what, run_memory_bytes(pixels, pipeline, runs))


def load_config(pipeline: Pipeline, path: str | None = None, **design: Any) -> WordLengthConfig:
    """``path``'s config (or the pipeline's default) with design fields overridden; a
    config of another pipeline, a bad file or a bad value is one :class:`UserError`."""
    design = {k: v for k, v in design.items() if v is not None}
    try:
        config = pipeline.load_config(path) if path else pipeline.default_config()
        return config.with_(**design) if design else config
    except ValueError as exc:
        raise UserError(str(exc)) from None


def run_case(
    pipeline: Pipeline,
    case: Case,
    config: WordLengthConfig | None = None,
    timing: TimingConfig | None = None,
    *,
    taps: bool = False,
    threads: int = 2,
) -> PipelineResult:
    """:meth:`Pipeline.run` with the model's errors as :class:`UserError`."""
    try:
        return pipeline.run(case, config, timing, taps=taps, threads=threads)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def golden_case(
    pipeline: Pipeline, case: Case, config: WordLengthConfig | None = None, *, taps: bool = False
) -> GoldenReference:
    """:meth:`Pipeline.golden` with the model's errors as :class:`UserError`."""
    try:
        return pipeline.golden(case, config, taps=taps)
    except ValueError as exc:
        raise UserError(str(exc)) from None


#: Pixels a band of :func:`compare_ranges` takes at once.
_COMPARE_CHUNK_PIXELS = 1 << 20


def compare_ranges(fixed: PipelineResult | RangeResult, golden: RangeResult) -> dict[str, float]:
    """Fixed vs golden on one pair: relative range difference on pixels valid in both
    (median and 95th percentile; NaN when no pixel is valid in both) and the fraction of
    pixels whose valid flags agree."""
    # in bands of rows, into one array of the differences: a whole-frame expression held
    # five frame-sized temporaries at once (a banded 8192x8192 run's peak); the values,
    # their order and so the figures are the whole-frame expression's, bit for bit
    m = fixed.valid.shape[0]
    step = max(1, _COMPARE_CHUNK_PIXELS // max(1, fixed.valid[:1].size))
    agree = 0
    counts = []
    for j in range(0, m, step):
        both = fixed.valid[j : j + step] & golden.valid[j : j + step]
        counts.append(int(np.count_nonzero(both)))
        agree += int(np.count_nonzero(fixed.valid[j : j + step] == golden.valid[j : j + step]))
    n_both = sum(counts)
    rel = np.empty(n_both)
    k = 0
    for j, count in zip(range(0, m, step), counts, strict=True):
        both = fixed.valid[j : j + step] & golden.valid[j : j + step]
        ref = golden.range[j : j + step][both]
        rel[k : k + count] = np.abs(fixed.range[j : j + step][both] - ref) / ref
        k += count
    # in place (no copy of the frame's differences): the median and the percentile depend
    # only on the values, which the partial sort of the first leaves as they were
    median = float(np.median(rel, overwrite_input=True)) if n_both else float("nan")
    p95 = float(np.percentile(rel, 95, overwrite_input=True)) if n_both else float("nan")
    return {
        "median_rel_range_diff": median,
        "p95_rel_range_diff": p95,
        "valid_agreement": agree / fixed.valid.size,
        "n_valid_both": n_both,
    }


def pipeline_figures(
    result: PipelineResult, golden: RangeResult, scene: Scene | None
) -> dict[str, Any]:
    """The figures of one run, with the same keys for every pipeline: the config and its
    design fields, overflows, fixed vs golden, valid fractions, latency, buffers,
    registers, the schedule, per-signal min/max and (on a scene) both object tables."""
    config = result.config
    figures: dict[str, Any] = {
        "pipeline": result.pipeline,
        "mode": result.mode,
        "config": config.name,
        **config.design(),
        "overflows": {"total": result.overflow_total, **result.overflows},
        **compare_ranges(result, golden),
        "valid_fraction": result.valid_fraction,
        "golden_valid_fraction": golden.valid_fraction,
        "latency_cycles": result.latency,
        "stage_latency": result.stage_latency,
        "schedule": result.schedule,
        "total_cycles": result.total_cycles,
        "line_buffer_bits": result.line_buffer_bits,
        "frame_store_bits": result.frame_store_bits,
        "sweep_buffer_bits": result.sweep_buffer_bits,
        "registers": {k: list(v) for k, v in result.registers.items()},
        "saturated_registers": list(result.saturated_registers),
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


def propose_from_cases(
    pipeline: Pipeline,
    config: WordLengthConfig,
    cases: Sequence[Case],
    *,
    guard_bits: int = 1,
    rounds: int = 4,
) -> tuple[WordLengthConfig, dict[str, tuple[float, float]], int]:
    """Integer bits of every cast signal from the ranges logged on ``cases``, iterated to
    a fixpoint (a clipped signal hides its consumers' ranges). Returns the proposed
    config, the merged ranges of its last round, and that round's overflow count."""
    proposed = config
    minmax: dict[str, tuple[float, float]] = {}
    overflows = 0
    for _ in range(rounds):
        minmax, overflows = {}, 0
        for case in cases:
            result = run_case(pipeline, case, proposed)
            overflows += result.overflow_total
            for sig, (lo, hi) in result.minmax.items():
                old = minmax.get(sig, (lo, hi))
                minmax[sig] = (min(old[0], lo), max(old[1], hi))
        try:
            step = propose_config(proposed, minmax, guard_bits=guard_bits)
        except ValueError as exc:
            raise UserError(str(exc)) from None
        if step == proposed and overflows == 0:
            break
        proposed = step
    return proposed, minmax, overflows


def range_source(
    pipeline: Pipeline | str = "p1",
    config: WordLengthConfig | None = None,
    cases: Callable[[Scene], Case] | None = None,
) -> Callable[[Scene], tuple[np.ndarray, np.ndarray]]:
    """A range-map source for :func:`rangefx.guidance.obstacles.runway_scene_obstacles`:
    the fixed-point pipeline on the scene (in the scene's mode: motion for ``runway``)."""
    pipe = get_pipeline(pipeline) if isinstance(pipeline, str) else pipeline
    make = cases or Case.from_scene

    def source(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
        result = run_case(pipe, make(scene), config)
        return result.range, result.valid

    return source
