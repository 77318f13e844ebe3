"""Which word-length signal, stage and cycle each P3 tap belongs to (docs/multiscale.md).

Every tap is a level-0 signal (one sample per full-scale pixel); the coarser levels are
checked through their overflow counts and pre-quantisation ranges. A sample of line
``y`` leaves a fixed number of lines and cycles after its input beat
(:func:`rangefx.rtl_model.p3.model.tap_offsets`): the lines are the coarse-to-fine delay
and ``radius`` per warp stage, so the cycle comes from the schedule, not a fixed
latency; only the inputs have one.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from ..pipeline import VALID_FORMAT, TapSpec
from .config import P3Config
from .model import BOX_TAPS, VERTICAL_TAPS, WARP_TAPS, tap_names

__all__ = ["TAP_SIGNALS", "TAP_STAGE", "tap_table"]

#: Tap base name (the warp index stripped) -> signal whose format it carries.
TAP_SIGNALS: Mapping[str, str] = MappingProxyType(
    {
        "pix_in": "p3_pix",
        "norm": "p3_norm",
        "ax": "p3_grad",
        "u_start": "p3_u",
        "warp": "p3_warp",
        "wx": "p3_grad",
        "g": "p3_g",
        "err": "p3_e",
        "rgg": "p3_rgg",
        "rge": "p3_rge",
        "ree": "p3_ree",
        "sgg": "p3_sgg",
        "sge": "p3_sge",
        "see": "p3_see",
        "ay": "p3_grad",
        "wy": "p3_grad",
        "gy": "p3_gy",
        "ryy": "p3_ryy",
        "rgy": "p3_rgy",
        "rye": "p3_rye",
        "syy": "p3_syy",
        "sgy": "p3_sgy",
        "sye": "p3_sye",
        "det": "p3_det",
        "nu": "p3_nu",
        "nv": "p3_nv",
        "bgg": "p3_bgg",
        "bge": "p3_bge",
        "byy": "p3_byy",
        "bgy": "p3_bgy",
        "bye": "p3_bye",
        "bdet": "p3_bdet",
        "bnv": "p3_bnv",
        "v": "p3_v",
        "ev": "p3_ev",
        "du": "p3_du",
        "u": "p3_u",
        "res": "p3_res",
        "rthr": "p3_res",
        "valid": "valid",
        "range": "p3_range",
    }
)
#: Tap base name -> stage whose output it is.
TAP_STAGE: Mapping[str, str | None] = MappingProxyType(
    {
        "pix_in": None,
        "norm": "normalise",
        "ax": "derivative",
        "u_start": "expand",
        "warp": "warp",
        "wx": "derivative",
        "g": "derivative",
        "err": "warp",
        "ay": "derivative",
        "wy": "derivative",
        "gy": "derivative",
        **dict.fromkeys(("rgg", "rge", "ree", "ryy", "rgy", "rye"), "window_row"),
        **dict.fromkeys(("sgg", "sge", "see", "syy", "sgy", "sye"), "window_column"),
        "det": "normal_equations",
        "nu": "normal_equations",
        "nv": "normal_equations",
        **dict.fromkeys(("bgg", "bge", "byy", "bgy", "bye"), "box_column"),
        "bdet": "normal_equations",
        "bnv": "normal_equations",
        "v": "v_divider",
        "ev": "correction",
        "du": "du_divider",
        "u": "update",
        "res": "residual",
        "rthr": "residual",
        "valid": "output",
        "range": "output",
    }
)


def base_name(tap: str) -> str:
    """``warp1`` -> ``warp``; ``e1.pix_in`` -> ``pix_in``; others unchanged."""
    tap = tap.rpartition(".")[2]
    stem = tap.rstrip("0123456789")
    return stem if stem in WARP_TAPS or stem in VERTICAL_TAPS or stem in BOX_TAPS else tap


def tap_table(config: P3Config) -> tuple[TapSpec, ...]:
    """The :class:`~rangefx.rtl_model.pipeline.TapSpec` of every tap; only the inputs
    have a fixed latency (the rest follow the schedule)."""
    out = [
        TapSpec(f"{s}.pix_in", "p3_pix", config.formats["p3_pix"], None, 0, s) for s in ("e1", "e2")
    ]
    if config.normalise != "none":  # each camera's normalised level 0
        fmt = config.formats["p3_norm"]
        out += [TapSpec(f"{s}.norm", "p3_norm", fmt, "normalise", None, s) for s in ("e1", "e2")]
    for tap in tap_names(config):
        base = base_name(tap)
        signal = TAP_SIGNALS[base]
        fmt = VALID_FORMAT if signal == "valid" else config.formats[signal]
        out.append(TapSpec(tap, signal, fmt, TAP_STAGE[base], None, None))
    return tuple(out)
