"""Which word-length signal, stage and cycle each P2 tap belongs to (docs/p2_datapath.md).

P2's samples do not leave at a fixed latency after their input beat: a line's backward
sweep starts when the line (and its lane group) is in the line buffer, and its forward
pass after the sweep. The cycle of each sample therefore comes from the schedule
(:func:`rangefx.rtl_model.p2.model.p2_schedule`):

* ``e1.pix_in``, ``e2.pix_in``: the input beat; ``d``, ``g_hat``: the beat plus
  ``IN_LATENCY`` (cast and adder, written to the line buffer);
* backward-sweep taps of column ``k`` (``a``, ``c``, ``den``, ``r``, ``s``, ``h``, ``q``):
  the sweep engine's write-back register of the slot of column ``k``, read from the line
  buffer at ``sweep_start + (n - 1 - k) P_b`` (``P_b`` the sweep's period per column),
  plus ``SWEEP_READ + T_b`` (``T_b`` its loop latency); column ``n - 1``'s slot is the
  lane's first: it writes back the start values ``S~_end``, ``Q~ = 0`` (the other taps 0);
* forward-pass taps of column ``k``, whose slot reads the sweep buffer at
  ``forward_start + k P_f``: ``e`` (``e_k``, the e operand register: ``e_0 = 0``) at
  ``+ FWD_READ``, ``w``, ``lam``, ``z`` at ``+ W_OFFSET``, ``LAM_OFFSET``, ``Z_OFFSET``
  (each the register after its cast); ``valid`` and
  ``range`` (the output register) at ``+ OUT_LATENCY``, the output cycle. Column
  ``n - 1``'s slot reads a zero entry (``w = lam = z = 0``, invalid, ``range_max``).

Every tap is one register's output, one sample per cycle (docs/p2_datapath.md, Hardware).
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

import numpy as np

from ..pipeline import VALID_FORMAT, TapSpec
from .config import P2Config, loop_latency
from .model import (
    FWD_READ,
    IN_LATENCY,
    LAM_OFFSET,
    OUT_LATENCY,
    P2_TAPS,
    SWEEP_READ,
    W_OFFSET,
    Z_OFFSET,
)

__all__ = ["TAP_SIGNALS", "TAP_STAGE", "tap_cycles", "tap_names", "tap_table"]

#: Tap -> signal whose format it carries.
TAP_SIGNALS: Mapping[str, str] = MappingProxyType(
    {
        "pix_in": "p2_pix",
        "d": "p2_d",
        "g_hat": "p2_ghat",
        "a": "p2_a",
        "c": "p2_c",
        "den": "p2_den",
        "r": "p2_r",
        "s": "p2_st",
        "h": "p2_h",
        "q": "p2_q",
        "w": "p2_w",
        "lam": "p2_lam",
        "z": "p2_z",
        "e": "p2_e",
        "valid": "valid",
        "range": "p2_z",
    }
)
_BACKWARD = ("a", "c", "den", "r", "s", "h", "q")
#: Tap -> stage of docs/p2_datapath.md whose output it is.
TAP_STAGE: Mapping[str, str | None] = MappingProxyType(
    {
        "pix_in": None,
        "d": "input",
        "g_hat": "input",
        **dict.fromkeys(_BACKWARD, "backward_loop"),
        **dict.fromkeys(("w", "lam", "z", "e"), "forward_loop"),
        "valid": "output",
        "range": "output",
    }
)
#: Cycles after the forward step's start at which each forward tap leaves.
_FORWARD_OFFSET = {
    "e": FWD_READ,
    "w": W_OFFSET,
    "lam": LAM_OFFSET,
    "z": Z_OFFSET,
    "valid": OUT_LATENCY,
    "range": OUT_LATENCY,
}


def tap_names() -> tuple[str, ...]:
    """Every tap of a run with taps, in pipeline order."""
    return ("e1.pix_in", "e2.pix_in", *P2_TAPS)


def tap_table(config: P2Config) -> tuple[TapSpec, ...]:
    """The :class:`~rangefx.rtl_model.pipeline.TapSpec` of every tap; only the inputs
    and the input stage have a fixed latency (the rest follow the schedule)."""
    out = []
    for tap in tap_names():
        stream, _, base = tap.rpartition(".")
        signal = TAP_SIGNALS[base]
        fmt = VALID_FORMAT if signal == "valid" else config.formats[signal]
        latency = {"pix_in": 0, "d": IN_LATENCY, "g_hat": IN_LATENCY}.get(base)
        out.append(TapSpec(tap, signal, fmt, TAP_STAGE[base], latency, stream or None))
    return tuple(out)


def tap_cycles(
    tap: str,
    config: P2Config,
    in_cycles: np.ndarray,
    rows: Mapping[str, np.ndarray],
    info: Mapping[str, int],
) -> np.ndarray:
    """Cycle of every sample of ``tap`` (shape (m, n)) from the schedule ``rows``
    (``sweep_start``, ``forward_start`` per line) and ``info`` (periods)."""
    base = tap.rpartition(".")[2]
    n = in_cycles.shape[1]
    if base == "pix_in":
        return in_cycles.copy()
    if base in ("d", "g_hat"):
        return in_cycles + IN_LATENCY
    k = np.arange(n, dtype=np.int64)
    if base in _BACKWARD:
        steps = (n - 1 - k) * info["backward_period"] + SWEEP_READ + loop_latency(config)
        return rows["sweep_start"][:, None] + steps[None, :]
    if base in _FORWARD_OFFSET:
        return (
            rows["forward_start"][:, None]
            + (k * info["forward_period"])[None, :]
            + (_FORWARD_OFFSET[base])
        )
    raise ValueError(f"unknown P2 tap {tap!r}; taps: {', '.join(tap_names())}")
