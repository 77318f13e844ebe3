"""Which word-length signal, and which pipeline stage, each P1 tap belongs to.

The one place that maps the names of :data:`rangefx.rtl_model.p1.FRONTEND_TAPS`
(prefixed ``e1.`` / ``e2.``) and :data:`rangefx.rtl_model.p1.RANGE_TAPS` to the signal
of the :class:`~rangefx.rtl_model.p1.config.P1Config` whose format they carry
(``docs/p1_datapath.md``), and to the stage after which they leave the pipeline, so
that every sample of a tap gets a cycle stamp (``docs/vectors.md``).
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from ..fixedpoint import FixedFormat
from ..pipeline import VALID_FORMAT, TapSpec
from .config import P1Config
from .model import FRONTEND_TAPS, RANGE_TAPS

__all__ = [
    "INPUT_TAP",
    "STAGE_ORDER",
    "TAP_SIGNALS",
    "TAP_STAGE",
    "split_tap",
    "tap_format",
    "tap_latency",
    "tap_signal",
    "tap_table",
]

#: Input pixels of a stream (``e1.pix_in``, ``e2.pix_in``): the beats' data.
INPUT_TAP = "pix_in"

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


def tap_signal(tap: str, config: P1Config) -> str:
    """Word-length signal carried by ``tap`` (``"valid"`` for the 1-bit flag)."""
    _, base = split_tap(tap)
    if base == "ex":
        return config.ex_signal
    return TAP_SIGNALS[base]


def tap_format(tap: str, config: P1Config) -> FixedFormat:
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


def tap_names(config: P1Config) -> tuple[str, ...]:
    """Every tap of a run with taps, in pipeline order: both streams' inputs, their
    front-end taps (``col2_state`` in the consistent variant only), the range stage."""
    names = [f"{s}.{INPUT_TAP}" for s in ("e1", "e2")]
    for s in ("e1", "e2"):
        names += [
            f"{s}.{t}" for t in FRONTEND_TAPS if t != "col2_state" or config.variant == "consistent"
        ]
    return (*names, *RANGE_TAPS)


def tap_table(config: P1Config, stage_latency: Mapping[str, int]) -> tuple[TapSpec, ...]:
    """The :class:`~rangefx.rtl_model.pipeline.TapSpec` of every tap (:func:`tap_names`)."""
    out = []
    for tap in tap_names(config):
        stream, base = split_tap(tap)
        out.append(
            TapSpec(
                name=tap,
                signal=tap_signal(tap, config),
                fmt=tap_format(tap, config),
                stage=TAP_STAGE[base],
                latency=tap_latency(tap, stage_latency),
                stream=stream,
            )
        )
    return tuple(out)
