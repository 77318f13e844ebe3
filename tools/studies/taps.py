"""Fixed-point taps against their float golden, for any pipeline of the registry.

A tap's raw codes become float values through the format its
:class:`~rangefx.rtl_model.pipeline.TapSpec` declares (:meth:`Pipeline.tap_table`), and
are scored against the float value of the same computation
(:attr:`~rangefx.rtl_model.pipeline.GoldenReference.taps`). No pipeline's tap names are
known here: the tap table says which format each tap carries.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from rangefx.rtl_model.pipeline import GoldenReference, PipelineResult, TapSpec

__all__ = ["RANGE_TAP", "signal_of_taps", "tap_errors", "tap_float", "tap_specs"]

#: The tap every pipeline's table has for its thresholded output.
RANGE_TAP = "range"


def tap_specs(table: Sequence[TapSpec]) -> dict[str, TapSpec]:
    """A pipeline's tap table by tap name."""
    return {spec.name: spec for spec in table}


def tap_float(result: PipelineResult, spec: TapSpec) -> np.ndarray:
    """The raw codes of tap ``spec`` in ``result`` as float values (raw times 2^-F)."""
    return spec.values(result)


def tap_errors(
    result: PipelineResult, golden: GoldenReference, table: Sequence[TapSpec]
) -> dict[str, dict[str, float | None]]:
    """Per tap with a float counterpart: SQNR in dB (``None``: exact) and max
    |fixed - golden|.

    A tap in the format of the range output (P1's quotient ``range_q``, P2's ``z``) is
    scored on the pixels valid in both (elsewhere the golden quotient may be unbounded);
    every other tap on all pixels.
    """
    specs = tap_specs(table)
    range_signal = specs[RANGE_TAP].signal if RANGE_TAP in specs else None
    valid_both = result.valid & golden.result.valid
    out: dict[str, dict[str, float | None]] = {}
    for tap, gold in golden.taps.items():
        if tap not in result.taps or tap not in specs:
            continue
        fixed, ref = tap_float(result, specs[tap]), np.asarray(gold, dtype=np.float64)
        if specs[tap].signal == range_signal:
            fixed, ref = fixed[valid_both], ref[valid_both]
        err = fixed - ref
        if err.size == 0:
            continue
        noise = float(np.sum(err * err))
        power = float(np.sum(np.square(ref)))
        sqnr = None if noise == 0 else (10 * math.log10(power / noise) if power > 0 else -math.inf)
        out[tap] = {"sqnr_db": sqnr, "max_abs_err": float(np.max(np.abs(err)))}
    return out


def signal_of_taps(table: Sequence[TapSpec]) -> Mapping[str, str]:
    """Tap name -> the config signal whose format it carries."""
    return {spec.name: spec.signal for spec in table}
