"""Word-length and design configuration of the P1 pipeline (SPEC §4, §10).

Every named signal of the datapath (``docs/p1_datapath.md``) has one format in a
:class:`P1Config`, the P1 case of the one word-length config type
:class:`~rangefx.rtl_model.config.WordLengthConfig` (TOML, validation, int64 check).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import ClassVar

from ..config import Terms, WordLengthConfig, signed_bits
from ..fixedpoint import FixedFormat
from ..runtime import DIVIDERS

__all__ = [
    "DIVIDERS",
    "FILTER_FORMS",
    "HOST_REGISTERS",
    "INITS",
    "P1_SIGNALS",
    "VARIANTS",
    "P1Config",
]

#: (name, meaning) of every P1 signal and register, in datapath order.
_SIGNAL_TABLE: tuple[tuple[str, str], ...] = (
    ("pix_in", "input pixel (grey level)"),
    ("bias_reg", "register: input bias B (eq 19)"),
    ("pole_coef", "register: filter pole C per pixel"),
    ("bias_in", "biased input b = x + B"),
    ("row_state", "row filter state p (one register)"),
    ("row_r1", "row filter output r1 (smoothed)"),
    ("row_r2", "row filter output r2 = C (b - p) (x-difference)"),
    ("col_state", "column filter state q (line buffer LB1)"),
    ("col_s1", "column filter output s1 = E_hat (with bias)"),
    ("col_s2", "column filter output s2 = dE/dy"),
    ("col2_state", "consistent variant: state of the column filter on r2 (line buffer LB2)"),
    ("col2_out", "consistent variant: dE/dx, centred output of the column filter on r2"),
    ("div_quot", "paper variant: dE/dx = s1 r2 / r1 (divider quotient)"),
    ("c1", "c1 = E1_hat - E2_hat (eq 31, sign fixed)"),
    ("grad_a", "a1 = mean x-derivative (eq 29)"),
    ("grad_b", "b1 = mean y-derivative (eq 30)"),
    ("coord", "pixel coordinates xp, yp and registers cx, cy"),
    ("f_reg", "register: focal length f in pixels"),
    ("k_t_reg", "registers: k3, k4, k5 (translation terms)"),
    ("k_m_reg", "registers: rotation terms R_i0, R_i1/f, R_i2/f of k0..k2"),
    ("k_rot", "per-pixel k0, k1, k2"),
    ("geom_v", "vx = f k4 - xp k3, vy = f k5 - yp k3"),
    ("geom_w", "wx = f k1 - xp k0, wy = f k2 - yp k0, w0 = 1 + k0"),
    ("gv", "gv = a1 vx + b1 vy"),
    ("num", "numerator of eq 28: k3 c1 - gv"),
    ("den", "denominator of eq 28: a1 wx + b1 wy - c1 w0"),
    ("range", "range x_c = num / den (divider quotient) and range_max"),
    ("v_sq", "vx^2 + vy^2 (gradient threshold)"),
    ("tg2_reg", "register: T_g^2"),
    ("grad_sq", "gv^2 and T_g^2 (vx^2 + vy^2), compared for the gradient threshold"),
)
#: Per-frame registers written by the host (``pix_in`` is the pixel input, not one of
#: them). Their values are host constants (bias, filter pole, focal length, baseline and
#: motion terms, gradient threshold), so the formats they need follow the envelope of
#: the cameras and geometries the pipeline must serve, not image content: a word-length
#: optimiser tuned on a few scenes must not narrow them by default (``rangefx optimise
#: --tune-registers``).
HOST_REGISTERS: tuple[str, ...] = (
    "bias_reg", "pole_coef", "f_reg", "k_t_reg", "k_m_reg", "tg2_reg",
)  # fmt: skip

VARIANTS = ("paper", "consistent")
INITS = ("first", "zero")
#: How the row and column filters apply the pole C (SPIE eqs 13-21): ``"direct"`` multiplies
#: by the pole register (the report's form, any pole); ``"shift"`` takes C = 2^-k and shifts,
#: so the row filter's one-cycle loop holds no multiplier (hdl/p1_frontend.v).
FILTER_FORMS = ("direct", "shift")
_COUNTER = FixedFormat(True, 17, 0)  # pixel counters i, j: images up to 65535 wide
_ONE = FixedFormat(True, 2, 0)

#: Exact intermediate of each cast: a sum of products of operand signals (SPEC §4); the
#: second item is the extra fraction bit of a halving. Used to reject formats whose
#: exact values overflow int64.
_EXPRESSIONS: dict[str, tuple[tuple[tuple[str, ...], ...], int]] = {
    "bias_in": ((("pix_in",), ("bias_reg",)), 0),
    "row_state": ((("row_state",), ("pole_coef", "bias_in"), ("pole_coef", "row_state")), 0),
    "row_r2": ((("pole_coef", "bias_in"), ("pole_coef", "row_state")), 0),
    "row_r1": ((("row_state",), ("row_state",)), 1),
    "col_state": ((("col_state",), ("pole_coef", "row_r1"), ("pole_coef", "col_state")), 0),
    "col_s2": ((("pole_coef", "row_r1"), ("pole_coef", "col_state")), 0),
    "col_s1": ((("col_state",), ("col_state",)), 1),
    "col2_state": ((("col2_state",), ("pole_coef", "row_r2"), ("pole_coef", "col2_state")), 0),
    "col2_out": ((("col2_state",), ("col2_state",)), 1),
    "c1": ((("col_s1",), ("col_s1",)), 0),
    "grad_a": ((("div_quot",), ("div_quot",), ("col2_out",), ("col2_out",)), 1),
    "grad_b": ((("col_s2",), ("col_s2",)), 1),
    "coord": ((("@counter",), ("coord",)), 0),
    "k_rot": ((("k_m_reg",), ("k_m_reg", "coord"), ("k_m_reg", "coord")), 0),
    "geom_v": ((("f_reg", "k_t_reg"), ("coord", "k_t_reg")), 0),
    "geom_w": ((("f_reg", "k_rot"), ("coord", "k_rot"), ("@one",)), 0),
    "gv": ((("grad_a", "geom_v"), ("grad_b", "geom_v")), 0),
    "num": ((("k_t_reg", "c1"), ("gv",)), 0),
    "den": ((("grad_a", "geom_w"), ("grad_b", "geom_w"), ("c1", "geom_w")), 0),
    "v_sq": ((("geom_v", "geom_v"), ("geom_v", "geom_v")), 0),
    "grad_sq": ((("gv", "gv"), ("tg2_reg", "v_sq")), 0),
}


@dataclass(frozen=True, kw_only=True)
class P1Config(WordLengthConfig):
    """Formats of every P1 signal plus the design choices that shape the datapath.

    Attributes
    ----------
    formats
        One :class:`FixedFormat` per name in :data:`P1_SIGNALS`.
    variant
        Estimator variant (SPEC §3): ``"paper"`` (divider ``s1 r2 / r1``) or
        ``"consistent"`` (centred outputs, second column filter on ``r2``).
    divider
        Hardware divider model: ``"restoring"`` (radix-2, exact rounding from guard +
        sticky bits) or ``"reciprocal"`` (LUT + one Newton step).
    pole, bias
        Filter pole ``c`` and input bias ``b`` (float, quantised into ``pole_coef`` and
        ``bias_reg``).
    init
        Filter state at the start of a line/column: ``"first"`` input or ``"zero"``.
    recip_lut_bits, recip_bits
        Reciprocal divider: LUT index bits ``L`` and reciprocal fraction bits ``R``.
    filter_form
        How the filters apply the pole (:data:`FILTER_FORMS`): ``"shift"`` needs a pole
        ``2^-k`` and computes exactly what ``"direct"`` computes with that pole.
    """

    PIPELINE: ClassVar[str] = "p1"
    SIGNAL_TABLE: ClassVar[tuple[tuple[str, str], ...]] = _SIGNAL_TABLE
    HOST_REGISTERS: ClassVar[tuple[str, ...]] = HOST_REGISTERS
    DESIGN_REGISTERS: ClassVar[Mapping[str, str]] = MappingProxyType(
        {"bias": "bias_reg", "pole": "pole_coef"}
    )
    QUOTIENTS: ClassVar[tuple[str, ...]] = ("div_quot", "range")
    DOC: ClassVar[str] = "docs/p1_datapath.md"

    variant: str = "paper"
    divider: str = "reciprocal"
    pole: float = 0.5
    bias: float = 16.0
    init: str = "first"
    recip_lut_bits: int = 8
    recip_bits: int = 20
    filter_form: str = "shift"

    def validate_design(self) -> None:
        self.check_choice("variant", VARIANTS)
        self.check_choice("filter_form", FILTER_FORMS)
        self.check_choice("divider", DIVIDERS)
        self.check_choice("init", INITS)
        if not (isinstance(self.pole, int | float) and 0 < self.pole <= 1):
            raise ValueError(f"filter pole must be in (0, 1], not {self.pole!r}")
        if not (isinstance(self.bias, int | float) and math.isfinite(self.bias) and self.bias >= 0):
            raise ValueError(f"bias must be a finite non-negative number, not {self.bias!r}")
        self.check_reciprocal_fields()
        if self.filter_form == "shift" and math.frexp(self.pole)[0] != 0.5:
            raise ValueError(
                f"filter_form 'shift' needs a pole 2^-k (1, 0.5, 0.25, ...), not {self.pole}; "
                "choose filter_form 'direct' (--filter-form direct) for any other pole"
            )
        pole_raw = self.formats["pole_coef"].from_float(self.pole)
        if pole_raw <= 0:
            raise ValueError(
                f"signal 'pole_coef': pole {self.pole} quantises to {pole_raw} in "
                f"{self.formats['pole_coef']}; widen its fraction bits"
            )
        shift, frac = self.pole_shift, self.formats["pole_coef"].frac
        if shift is not None and (shift > frac or pole_raw != 1 << (frac - shift)):
            raise ValueError(
                f"signal 'pole_coef': filter_form 'shift' needs the pole {self.pole} exactly, "
                f"{self.formats['pole_coef']} holds {pole_raw}; widen its fraction bits"
            )

    def exact_intermediates(self) -> Iterable[tuple[str, Terms, int]]:
        def fmt(op: str) -> FixedFormat:
            return {"@counter": _COUNTER, "@one": _ONE}.get(op) or self.formats[op]

        for name, (terms, extra) in _EXPRESSIONS.items():
            yield name, tuple(tuple(fmt(o) for o in ops) for ops in terms), extra

    def divider_intermediates(self) -> Iterable[tuple[str, int, str]]:
        for name, num, den in (("div_quot", ("col_s1", "row_r2"), ("row_r1",)),
                               ("range", ("num",), ("den",))):  # fmt: skip
            f = self.formats
            n_bits = sum(signed_bits(f[o]) for o in num)
            n_frac = sum(f[o].frac for o in num)
            d_bits = sum(signed_bits(f[o]) for o in den)
            d_frac = sum(f[o].frac for o in den)
            out = f[name]
            if self.divider == "restoring":
                shift = out.frac + 1 + d_frac - n_frac
                need = max(n_bits + max(shift, 0), d_bits + max(-shift, 0), out.word + 3)
            else:
                need = max(n_bits + self.recip_bits + 2, 2 * (self.recip_bits + 2))
            yield name, need, f"{self.divider} divider"

    @property
    def pole_shift(self) -> int | None:
        """``k`` of the pole ``2^-k`` in the ``"shift"`` filter form, else ``None``."""
        if self.filter_form != "shift":
            return None
        return 1 - math.frexp(self.pole)[1]

    @property
    def ex_signal(self) -> str:
        """The signal that carries the x-derivative ``ex`` of this variant."""
        return "col2_out" if self.variant == "consistent" else "div_quot"


#: P1 signals in datapath order.
P1_SIGNALS: tuple[str, ...] = P1Config.signals()
