"""Error build-up of a pipeline along its scan: a simulation beside its golden (SPEC §6).

A recursive stage accumulates quantisation error where a per-signal min/max cannot show
it, so a study plots the RMS fixed-vs-golden error of the recursive stages' taps along
the direction of their recursion (:mod:`rangefx.tools.report.wlplots` draws them). Each
pipeline has its own profiles (:data:`BUILDUPS`):

* P1 (:func:`scan_profiles`): the row-filter taps of stream E2 against the column index
  (RMS over the rows) and its column-filter taps against the row index (RMS over the
  columns), each beside ``LSB / sqrt(12)`` of the tap's format (one rounding's RMS error);
* P2 (:func:`riccati_profiles`): along the backward Riccati sweep (position 0 is its
  first step, column ``n - 2``), the RMS relative range error over the rows (pixels valid
  in both) and the RMS error of ``e = G - G_hat`` against G5's, beside its
  ``LSB / sqrt(12)``;
* P3 (:func:`warp_profiles`): along the Gauss–Newton stages of level 0 (position 0 is
  the estimate expanded from the coarser levels, ``k + 1`` the one after warp ``k``), the
  RMS error of ``u`` against G6's at the same stage, beside its ``LSB / sqrt(12)``: the
  coarse levels' error arrives in the start, each warp adds its own and corrects some.

A profile is ``{"index": positions, "<curve>": values, "<curve>.lsb_rms": ...}``; the
profiles of one run are keyed by name (``row``, ``col``, ``riccati``), and
:data:`PROFILE_AXES` says what each index counts.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping

import numpy as np

from rangefx.rtl_model.config import WordLengthConfig
from rangefx.rtl_model.pipeline import Case, GoldenReference, Pipeline, PipelineResult, TapSpec

from .runner import golden_case, run_case
from .taps import tap_float, tap_specs

__all__ = [
    "BUILDUPS",
    "COL_TAPS",
    "PROFILE_AXES",
    "RICCATI_TAPS",
    "ROW_TAPS",
    "buildup_for",
    "riccati_profiles",
    "scan_profiles",
    "warp_profiles",
]

#: P1's row-filter taps (error against the column index) and column-filter taps (against
#: the row index), of stream E2.
ROW_TAPS: tuple[str, ...] = ("e2.row_state", "e2.row_r1", "e2.row_r2")
COL_TAPS: tuple[str, ...] = ("e2.col_state", "e2.col_s1", "e2.col_s2")
#: P2's forward-pass state scored along the backward sweep.
RICCATI_TAPS: tuple[str, ...] = ("e",)

#: Profile name -> what its index counts (the plot's x label).
PROFILE_AXES: Mapping[str, str] = {
    "row": "column index (along the line)",
    "col": "row index (down the columns)",
    "riccati": "position in the backward Riccati sweep (0: column n - 2)",
    "warps": "level-0 stage (0: the expanded coarse estimate, k + 1: after warp k)",
}

Profiles = dict[str, dict[str, np.ndarray]]


def _lsb_rms(spec: TapSpec, shape: tuple[int, ...]) -> np.ndarray:
    return np.full(shape, 2.0**-spec.fmt.frac / math.sqrt(12.0))


def scan_profiles(
    result: PipelineResult, golden: GoldenReference, specs: Mapping[str, TapSpec]
) -> Profiles:
    """P1: RMS |fixed - golden| per column of the row-filter taps (:data:`ROW_TAPS`) and
    per row of the column-filter taps (:data:`COL_TAPS`)."""
    out: Profiles = {}
    for kind, taps, axis in (("row", ROW_TAPS, 0), ("col", COL_TAPS, 1)):
        prof: dict[str, np.ndarray] = {}
        for tap in taps:
            if tap not in result.taps or tap not in golden.taps:
                continue
            err = tap_float(result, specs[tap]) - np.asarray(golden.taps[tap], dtype=np.float64)
            prof[tap] = np.sqrt(np.mean(err * err, axis=axis))
            prof[f"{tap}.lsb_rms"] = _lsb_rms(specs[tap], prof[tap].shape)
        if prof:
            length = next(iter(prof.values())).shape[0]
            out[kind] = {"index": np.arange(length), **prof}
    return out


def riccati_profiles(
    result: PipelineResult, golden: GoldenReference, specs: Mapping[str, TapSpec]
) -> Profiles:
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
        err = tap_float(result, specs[tap]) - np.asarray(golden.taps[tap], dtype=np.float64)
        prof[tap] = np.sqrt(np.mean(err[:, cols] ** 2, axis=0))
        prof[f"{tap}.lsb_rms"] = _lsb_rms(specs[tap], prof[tap].shape)
    return {"riccati": prof}


def warp_profiles(
    result: PipelineResult, golden: GoldenReference, specs: Mapping[str, TapSpec]
) -> Profiles:
    """P3 along the stages of level 0: RMS |u - u_G6| of ``u_start``, ``u0``, ``u1``, ...
    (every stage the golden traces), beside ``LSB / sqrt(12)`` of ``p3_u``."""
    stages = ["u_start"]
    while f"u{len(stages) - 1}" in result.taps:
        stages.append(f"u{len(stages) - 1}")
    stages = [t for t in stages if t in result.taps and t in golden.taps]
    if not stages:
        return {}
    rms = [
        math.sqrt(float(np.mean((tap_float(result, specs[t]) - golden.taps[t]) ** 2)))
        for t in stages
    ]
    lsb = _lsb_rms(specs[stages[0]], (len(stages),))
    return {"warps": {"index": np.arange(len(stages)), "u": np.array(rms), "u.lsb_rms": lsb}}


#: Pipeline name -> its build-up profiles (fixed result, golden with taps, tap table).
BUILDUPS: Mapping[
    str, Callable[[PipelineResult, GoldenReference, Mapping[str, TapSpec]], Profiles]
] = {"p1": scan_profiles, "p2": riccati_profiles, "p3": warp_profiles}


def buildup_for(
    pipeline: Pipeline, case: Case, config: WordLengthConfig, *, threads: int = 2
) -> Profiles:
    """The build-up profiles of ``config`` on ``case``: the pipeline runs with taps beside
    its golden with tap values. A pipeline without profiles in :data:`BUILDUPS` has none
    (an empty dict); a bad case or config is a :class:`~rangefx.tools.errors.UserError`."""
    profiles = BUILDUPS.get(pipeline.name)
    if profiles is None:
        return {}
    result = run_case(pipeline, case, config, taps=True, threads=threads)
    golden = golden_case(pipeline, case, config, taps=True)
    return profiles(result, golden, tap_specs(pipeline.tap_table(config, case.mode)))
