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
from rangefx.rtl_model.registry import get_pipeline

from .. import report
from ..errors import UserError, require_memory

__all__ = [
    "RUN_BASE_BYTES",
    "RUN_BYTES_PER_PIXEL",
    "check_input_levels",
    "compare_ranges",
    "golden_case",
    "load_config",
    "pipeline_figures",
    "propose_from_cases",
    "range_source",
    "require_run_memory",
    "run_case",
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


#: Peak resident memory of ``rangefx run`` (golden beside a pipeline): a base (the
#: interpreter, numpy, numba and the compiled kernels; 230-380 MB measured at 512x512)
#: plus bytes per pixel (measured 2048x2048 minus 512x512: golden 190, P1 309, P2 146,
#: P3 272; AMD EPYC, ``/usr/bin/time -f %M rangefx run --pipeline P``). The estimate
#: takes the largest with a third of headroom.
RUN_BASE_BYTES = 400 * 2**20
RUN_BYTES_PER_PIXEL = 400


def require_run_memory(what: str, pixels: int, runs: int = 1) -> None:
    """Refuse, before rendering or running, ``runs`` concurrent runs of ``pixels`` pixels
    that would need more memory than this machine has (one line naming ``what``)."""
    require_memory(what, RUN_BASE_BYTES + runs * pixels * RUN_BYTES_PER_PIXEL)


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


def compare_ranges(fixed: PipelineResult | RangeResult, golden: RangeResult) -> dict[str, float]:
    """Fixed vs golden on one pair: relative range difference on pixels valid in both
    (median and 95th percentile; NaN when no pixel is valid in both) and the fraction of
    pixels whose valid flags agree."""
    both = fixed.valid & golden.valid
    n_both = int(np.count_nonzero(both))
    rel = np.abs(fixed.range[both] - golden.range[both]) / golden.range[both]
    return {
        "median_rel_range_diff": float(np.median(rel)) if n_both else float("nan"),
        "p95_rel_range_diff": float(np.percentile(rel, 95)) if n_both else float("nan"),
        "valid_agreement": float(np.mean(fixed.valid == golden.valid)),
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
