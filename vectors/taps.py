"""Which word-length signal, and which pipeline stage, each P1 tap belongs to.

The one place that maps the names of :data:`rangefx.rtl_model.p1.FRONTEND_TAPS`
(prefixed ``e1.`` / ``e2.``) and :data:`rangefx.rtl_model.p1.RANGE_TAPS` to the signal
of the :class:`~rangefx.rtl_model.config.WordLengthConfig` whose format they carry
(``docs/p1_datapath.md``), and to the stage after which they leave the pipeline, so
that every sample of a tap gets a cycle stamp (``docs/vectors.md``).
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from rangefx.rtl_model.config import WordLengthConfig
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant

__all__ = [
    "INPUT_TAP",
    "STAGE_ORDER",
    "TAP_SIGNALS",
    "TAP_STAGE",
    "VALID_FORMAT",
    "split_tap",
    "tap_format",
    "tap_latency",
    "tap_signal",
]

#: Input pixels of a stream (``e1.pix_in``, ``e2.pix_in``): the beats' data.
INPUT_TAP = "pix_in"

#: The 1-bit flag ``valid``: unsigned, one bit, no fraction.
VALID_FORMAT = FixedFormat(False, 1, 0, Quant.TRN, Overflow.WRAP)

#: Tap name (without the ``e1.``/``e2.`` prefix) -> word-length signal. ``ex`` depends on
#: the variant and is resolved by :func:`tap_signal`; ``valid`` has :data:`VALID_FORMAT`.
TAP_SIGNALS: Mapping[str, str] = MappingProxyType(
    {
        "pix_in": "pix_in",
        # per stream (FRONTEND_TAPS)
        "bias_in": "bias_in",
        "row_r1": "row_r1",
        "row_r2": "row_r2",
        "row_state": "row_state",
        "col_s1": "col_s1",
        "col_s2": "col_s2",
        "col_state": "col_state",
        "ex": "div_quot|col2_out",
        "col2_state": "col2_state",
        # range stage (RANGE_TAPS)
        "xp": "coord",
        "yp": "coord",
        "c1": "c1",
        "a1": "grad_a",
        "b1": "grad_b",
        "k0": "k_rot",
        "k1": "k_rot",
        "k2": "k_rot",
        "vx": "geom_v",
        "vy": "geom_v",
        "wx": "geom_w",
        "wy": "geom_w",
        "w0": "geom_w",
        "gv": "gv",
        "num": "num",
        "den": "den",
        "range_q": "range",
        "v_sq": "v_sq",
        "g_sq": "grad_sq",
        "g_thr": "grad_sq",
        "valid": "valid",
        "range": "range",
    }
)

#: Stages of :func:`rangefx.rtl_model.p1.stage_latencies`, in pipeline order.
STAGE_ORDER: tuple[str, ...] = (
    "input",
    "bias",
    "row_filter",
    "column_filter",
    "x_derivative",
    "range_coords",
    "range_products",
    "range_divider",
    "threshold",
)

#: Tap -> the stage whose output it is; a sample leaves at its pixel's input cycle plus
#: the latencies of the stages up to and including this one (``pix_in``: the input beat).
TAP_STAGE: Mapping[str, str | None] = MappingProxyType(
    {
        "pix_in": None,
        "bias_in": "bias",
        "row_r1": "row_filter",
        "row_r2": "row_filter",
        "row_state": "row_filter",
        "col_s1": "column_filter",
        "col_s2": "column_filter",
        "col_state": "column_filter",
        "ex": "x_derivative",
        "col2_state": "x_derivative",
        **dict.fromkeys(
            ("xp", "yp", "c1", "a1", "b1", "k0", "k1", "k2", "vx", "vy", "wx", "wy", "w0"),
            "range_coords",
        ),
        **dict.fromkeys(("gv", "num", "den", "v_sq", "g_sq", "g_thr"), "range_products"),
        "range_q": "range_divider",
        "valid": "threshold",
        "range": "threshold",
    }
)


def split_tap(tap: str) -> tuple[str | None, str]:
    """``"e1.row_r1"`` -> ``("e1", "row_r1")``; ``"range"`` -> ``(None, "range")``.

    Raises
    ------
    ValueError
        The tap name is unknown.
    """
    stream, _, base = tap.rpartition(".")
    if stream not in ("", "e1", "e2") or base not in TAP_SIGNALS:
        known = ", ".join(TAP_SIGNALS)
        raise ValueError(f"unknown tap {tap!r}; taps are e1./e2.<stream tap> or: {known}")
    return (stream or None), base


def tap_signal(tap: str, config: WordLengthConfig) -> str:
    """Word-length signal carried by ``tap`` (``"valid"`` for the 1-bit flag)."""
    _, base = split_tap(tap)
    if base == "ex":
        return "col2_out" if config.variant == "consistent" else "div_quot"
    return TAP_SIGNALS[base]


def tap_format(tap: str, config: WordLengthConfig) -> FixedFormat:
    """Format (word, fraction bits, sign, modes) of the raw codes of ``tap``."""
    signal = tap_signal(tap, config)
    return VALID_FORMAT if signal == "valid" else config.fmt(signal)


def tap_latency(tap: str, stage_latency: Mapping[str, int]) -> int:
    """Cycles from a pixel's input beat to the cycle its ``tap`` sample leaves its stage."""
    _, base = split_tap(tap)
    stage = TAP_STAGE[base]
    if stage is None:
        return 0
    upto = STAGE_ORDER[: STAGE_ORDER.index(stage) + 1]
    return int(sum(stage_latency[s] for s in upto))
