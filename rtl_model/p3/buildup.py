"""P3's error build-up profile along the Gauss-Newton stages of level 0.

Error build-up of a quantised recursion (SPEC §6): position 0 is the estimate expanded
from the coarser levels, ``k + 1`` the one after warp ``k``; the RMS error of ``u``
against G6's at the same stage, beside its ``LSB / sqrt(12)``: the coarse levels' error
arrives in the start, each warp adds its own and corrects some.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ..pipeline import GoldenReference, PipelineResult, TapSpec

__all__ = ["AXES", "buildup_profiles"]

#: Profile name -> what its index counts.
AXES: dict[str, str] = {
    "warps": "level-0 stage (0: the expanded coarse estimate, k + 1: after warp k)"
}


def buildup_profiles(
    result: PipelineResult, golden: GoldenReference, specs: Mapping[str, TapSpec]
) -> dict[str, dict[str, np.ndarray]]:
    """P3 along the stages of level 0: RMS |u - u_G6| of ``u_start``, ``u0``, ``u1``, ...
    (every stage the golden traces), beside ``LSB / sqrt(12)`` of ``p3_u``."""
    stages = ["u_start"]
    while f"u{len(stages) - 1}" in result.taps:
        stages.append(f"u{len(stages) - 1}")
    stages = [t for t in stages if t in result.taps and t in golden.taps]
    if not stages:
        return {}
    rms = [
        math.sqrt(float(np.mean((specs[t].values(result) - golden.taps[t]) ** 2))) for t in stages
    ]
    lsb = np.full((len(stages),), specs[stages[0]].lsb_rms)
    return {"warps": {"index": np.arange(len(stages)), "u": np.array(rms), "u.lsb_rms": lsb}}
