"""P1's error build-up profiles along its filters' recursions.

Error build-up of a quantised recursion (SPEC §6): the row-filter taps of stream E2
against the column index (RMS over the rows) and its column-filter taps against the row
index (RMS over the columns), each beside ``LSB / sqrt(12)`` of the tap's format (one
rounding's RMS error).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..pipeline import GoldenReference, PipelineResult, TapSpec

__all__ = ["AXES", "COL_TAPS", "ROW_TAPS", "buildup_profiles"]

#: The row-filter taps (error against the column index) and column-filter taps (against
#: the row index), of stream E2.
ROW_TAPS: tuple[str, ...] = ("e2.row_state", "e2.row_r1", "e2.row_r2")
COL_TAPS: tuple[str, ...] = ("e2.col_state", "e2.col_s1", "e2.col_s2")
#: Profile name -> what its index counts.
AXES: dict[str, str] = {
    "row": "column index (along the line)",
    "col": "row index (down the columns)",
}


def buildup_profiles(
    result: PipelineResult, golden: GoldenReference, specs: Mapping[str, TapSpec]
) -> dict[str, dict[str, np.ndarray]]:
    """P1: RMS |fixed - golden| per column of the row-filter taps (:data:`ROW_TAPS`) and
    per row of the column-filter taps (:data:`COL_TAPS`)."""
    out: dict[str, dict[str, np.ndarray]] = {}
    for kind, taps, axis in (("row", ROW_TAPS, 0), ("col", COL_TAPS, 1)):
        prof: dict[str, np.ndarray] = {}
        for tap in taps:
            if tap not in result.taps or tap not in golden.taps:
                continue
            err = specs[tap].values(result) - np.asarray(golden.taps[tap], dtype=np.float64)
            prof[tap] = np.sqrt(np.mean(err * err, axis=axis))
            prof[f"{tap}.lsb_rms"] = np.full(prof[tap].shape, specs[tap].lsb_rms)
        if prof:
            length = next(iter(prof.values())).shape[0]
            out[kind] = {"index": np.arange(length), **prof}
    return out
