"""P2's error build-up profile along its backward Riccati sweep.

Error build-up of a quantised recursion (SPEC §6): position 0 is the sweep's first step,
column ``n - 2``: the RMS relative range error over the rows (pixels valid in both) and
the RMS error of ``e = G - G_hat`` against G5's, beside its ``LSB / sqrt(12)``.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping

import numpy as np

from ..pipeline import GoldenReference, PipelineResult, TapSpec

__all__ = ["AXES", "RICCATI_TAPS", "buildup_profiles"]

#: The forward-pass state scored along the backward sweep.
RICCATI_TAPS: tuple[str, ...] = ("e",)
#: Profile name -> what its index counts.
AXES: dict[str, str] = {"riccati": "position in the backward Riccati sweep (0: column n - 2)"}


def buildup_profiles(
    result: PipelineResult, golden: GoldenReference, specs: Mapping[str, TapSpec]
) -> dict[str, dict[str, np.ndarray]]:
    """P2 along the backward sweep (columns ``n - 2`` down to 0): RMS relative range error
    over the rows on pixels valid in both (``range.rel``; NaN where no pixel of a column
    is), and RMS error of each tap of :data:`RICCATI_TAPS`."""
    n = result.range.shape[1]
    cols = np.arange(n - 2, -1, -1)  # backward sweep order
    gold = golden.result
    both = result.valid & gold.valid
    prof: dict[str, np.ndarray] = {"index": np.arange(cols.size)}
    with np.errstate(divide="ignore", invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns: no valid pixel
        rel = np.where(both, np.abs(result.range - gold.range) / gold.range, np.nan)
        prof["range.rel"] = np.sqrt(np.nanmean(rel[:, cols] ** 2, axis=0))
    for tap in RICCATI_TAPS:
        if tap not in result.taps or tap not in golden.taps:
            continue
        err = specs[tap].values(result) - np.asarray(golden.taps[tap], dtype=np.float64)
        prof[tap] = np.sqrt(np.mean(err[:, cols] ** 2, axis=0))
        prof[f"{tap}.lsb_rms"] = np.full(prof[tap].shape, specs[tap].lsb_rms)
    return {"riccati": prof}
