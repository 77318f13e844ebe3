"""Word-length and design configuration of the P2 pipeline (Riccati sweep, SPEC §4, §10).

:class:`P2Config` is the P2 case of the one word-length config type
:class:`~rangefx.rtl_model.config.WordLengthConfig`: one format per name of
:data:`P2_SIGNALS` (``docs/p2_datapath.md``) plus the design fields; TOML, validation and
the int64 check naming the signal are shared.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import ClassVar

from ..config import Terms, WordLengthConfig, signed_bits
from ..fixedpoint import FixedFormat
from ..runtime import DIVIDERS, divider_latency

__all__ = [
    "ADD_LATENCY",
    "BRAM_READ",
    "CAST_LATENCY",
    "DEN_LATENCY",
    "DIVIDER_PIPELINING",
    "FWD_LOOP",
    "MUL_LATENCY",
    "OPERAND_LATENCY",
    "P2_SIGNALS",
    "QUOTIENT_LATENCY",
    "ROUND_LATENCY",
    "STATE_CAST_LATENCY",
    "STATE_LATENCY",
    "SWEEP_READ",
    "P2Config",
    "backward_loop_latency",
    "default_lanes",
    "divider_latency_p2",
    "loop_latency",
]

#: (name, meaning) of every P2 signal and register, in datapath order.
_SIGNAL_TABLE: tuple[tuple[str, str], ...] = (
    ("p2_pix", "input pixels E1, E2 (grey levels)"),
    ("p2_d", "d = E1 - E2 (line buffer)"),
    ("p2_ghat", "G_hat = E1 + E2 (eq 34, line buffer)"),
    ("p2_ka_reg", "register: KA = 1 / (f dx) in pixel units (eq 33 with the factor 2 in D)"),
    ("p2_a", "A at the pixel edge, KA (d_k + d_k+1) (eq 33)"),
    ("p2_c", "c beta = A^2 (pixel units) and the floor register c_min"),
    ("p2_m_reg", "register: M = alpha / beta"),
    ("p2_st", "S~ = S / beta (Riccati variable, eq 27) and gamma_eff"),
    ("p2_den", "1 + A^2 S~_k+1 = 1 + c S (divider denominator)"),
    ("p2_r", "r = 1 / (1 + c S) (divider quotient)"),
    ("p2_h", "h = Q~_k+1 - S~_k+1 dG_k"),
    ("p2_q", "Q~ = (K + S G_hat) / beta"),
    ("p2_w", "w = S~_k+1 u + Q~_k+1"),
    ("p2_lam", "lambda / beta = r w (eq 19, 23)"),
    ("p2_z", "range z = -A lambda / beta (eq 38) and range_max"),
    ("p2_e", "e = G - G_hat: e_k+1 = u + A z, u = e_k - dG_k (eq 37)"),
)

_D_SUM = "@dsum"  # d_k + d_k+1: one bit wider than p2_d
_DG = "@dg"  # G_hat_k+1 - G_hat_k: one bit wider than p2_ghat, signed
_ONE = FixedFormat(True, 2, 0)

#: Exact intermediate of each cast (sums of products of operand signals); used to
#: reject formats whose exact values overflow int64.
_EXPRESSIONS: dict[str, tuple[tuple[str, ...], ...]] = {
    "p2_d": (("p2_pix",), ("p2_pix",)),
    "p2_ghat": (("p2_pix",), ("p2_pix",)),
    "p2_a": (("p2_ka_reg", _D_SUM),),
    "p2_c": (("p2_a", "p2_a"),),
    "p2_den": (("@one",), ("p2_c", "p2_st")),
    "p2_st": (("p2_m_reg",), ("p2_r", "p2_st")),
    "p2_h": (("p2_q",), ("p2_st", _DG)),
    "p2_q": (("p2_r", "p2_h"),),
    "p2_w": (("p2_st", "p2_e"), ("p2_st", _DG), ("p2_q",)),
    "p2_lam": (("p2_r", "p2_w"),),
    "p2_e": (("p2_e",), (_DG,), ("p2_a", "p2_z")),
    "p2_z": (("p2_a", "p2_lam"),),
}


@dataclass(frozen=True, kw_only=True)
class P2Config(WordLengthConfig):
    """Formats of every P2 signal plus the design choices of the sweep.

    Attributes
    ----------
    formats
        One :class:`FixedFormat` per name in :data:`P2_SIGNALS`.
    divider
        The shared divider models: ``"restoring"`` or ``"reciprocal"`` (LUT + Newton).
    recip_lut_bits, recip_bits
        Reciprocal divider: LUT index bits and reciprocal fraction bits.
    kappa_min
        Floor on ``kappa = alpha delta c = M A^2`` (dimensionless): bounds
        ``S <= alpha delta (1 + 1 / kappa_min)`` after the first step (docs/p2_datapath.md).
    lanes
        Lines interleaved by the sweep engine (the recurrence's loop latency is hidden
        by issuing one step of each lane in turn); 0 = the loop latency.
    """

    PIPELINE: ClassVar[str] = "p2"
    SIGNAL_TABLE: ClassVar[tuple[tuple[str, str], ...]] = _SIGNAL_TABLE
    HOST_REGISTERS: ClassVar[tuple[str, ...]] = ("p2_ka_reg", "p2_m_reg")
    QUOTIENTS: ClassVar[tuple[str, ...]] = ("p2_r",)
    DOC: ClassVar[str] = "docs/p2_datapath.md"

    divider: str = "reciprocal"
    recip_lut_bits: int = 8
    recip_bits: int = 20
    kappa_min: float = 2.0**-6
    lanes: int = 0

    def validate_design(self) -> None:
        self.check_choice("divider", DIVIDERS)
        self.check_reciprocal_fields()
        self.check_int_field("lanes", 0, 256)
        k = self.kappa_min
        if isinstance(k, bool) or not isinstance(k, int | float) or not (0 < k < math.inf):
            raise ValueError(f"kappa_min must be a positive finite number, not {k!r}")
        for name in ("p2_c", "p2_st", "p2_den", "p2_r", "p2_m_reg"):
            if self.formats[name].signed:
                raise ValueError(f"signal {name!r} must be unsigned (it is never negative)")

    def exact_intermediates(self) -> Iterable[tuple[str, Terms, int]]:
        formats = self.formats
        d, g = formats["p2_d"], formats["p2_ghat"]
        extra = {
            _D_SUM: FixedFormat(True, signed_bits(d) + 1, d.frac),
            _DG: FixedFormat(True, signed_bits(g) + 1, g.frac),
            "@one": _ONE,
        }
        for name, terms in _EXPRESSIONS.items():
            yield name, tuple(tuple(extra.get(o) or formats[o] for o in t) for t in terms), 0

    def divider_intermediates(self) -> Iterable[tuple[str, int, str]]:
        den, out = self.formats["p2_den"], self.formats["p2_r"]
        if self.divider == "restoring":
            need = max(2 + out.frac + 1 + den.frac, signed_bits(den), out.word + 3)
        else:
            need = max(2 + self.recip_bits + 2, 2 * (self.recip_bits + 2))
        yield "p2_r", need, f"{self.divider} divider"

    def effective_lanes(self) -> int:
        """Lanes of the sweep engine (``lanes``, or :func:`default_lanes` when 0)."""
        return self.lanes or default_lanes(self.divider, self.formats["p2_r"].word)


#: P2 signals in datapath order.
P2_SIGNALS: tuple[str, ...] = P2Config.signals()


#: Declared latencies (cycles) of P2's hardware units (docs/p2_datapath.md, "Hardware"):
#: every unit does one multiply, one carry chain or one cast per cycle.
#: Every P2 product (``KA D``, ``a^2``; the backward loop's ``c S~``, ``S~ dG``, ``r S~``,
#: ``r h``; the forward ``KA D``, ``S~ u``, ``r w``, ``(-a) lam``, ``a z``): hdl/fx_pipe.v
#: ``fx_mul_pipe`` with ``IREG = 1``: the operands in the MULT18X18D's input registers,
#: the 18x18 partial products, their pair sums, the final sum.
MUL_LATENCY = 4
ADD_LATENCY = 1  # one carry chain (an add, a subtract or a compare), registered
CAST_LATENCY = 1  # fx_cast_sized: the rounding carry and the overflow mode, registered
#: fx_cast_reg: a cast's rounded value registered before its overflow mode (the forward
#: ``lam`` and ``z`` casts: each rounding carry alone in the cycle after its product)
ROUND_LATENCY = 1
#: A block RAM read (hdl/p2_top.v p2_ram): the address registered, the blocks' read
#: ports (zero but the one holding the address), their words registered, ORed in fours,
#: then all.
BRAM_READ = 5
OPERAND_LATENCY = 1  # a lane's loop state (LUT RAM) read into the loop's operand register
#: Cycles from a sweep slot's line-buffer read to its loop entry (c at the loop's
#: multiplier): read, D = d_k + d_k+1, KA D, cast a, a^2, cast, max(., C_MIN).
SWEEP_READ = (
    BRAM_READ + ADD_LATENCY + MUL_LATENCY + CAST_LATENCY + MUL_LATENCY + CAST_LATENCY + ADD_LATENCY
)
#: Cycles from the loop entry to the divider's operand ``den``: the operand register,
#: ``c S~``, ``+ 1``, the cast.
DEN_LATENCY = OPERAND_LATENCY + MUL_LATENCY + ADD_LATENCY + CAST_LATENCY
#: The divider's quotient ``r`` (its output cast's rounding carry) registered before the
#: ``r S~``, ``r h`` products' operands.
QUOTIENT_LATENCY = 1
#: The casts of ``S~_k``, ``Q~_k`` and ``e_k+1`` (their rounding carries) registered
#: before the lane's state write.
STATE_CAST_LATENCY = 1
#: Cycles from the divider's ``r`` to ``S~_k`` in the lane's state: ``r`` registered,
#: ``r S~``, ``+ M``, the cast, registered.
STATE_LATENCY = QUOTIENT_LATENCY + MUL_LATENCY + ADD_LATENCY + CAST_LATENCY + STATE_CAST_LATENCY
#: The forward recurrence ``e_k -> e_k+1``: ``u = e - dG``; ``S~ u``, ``+ Q~``, cast ``w``;
#: ``r w``, cast ``lam``; ``(-a) lam``, cast ``z`` (each with its rounded value
#: registered first, ``ROUND_LATENCY``); ``a z``, ``+ u``, cast ``e``, registered into
#: the lane's state (``STATE_CAST_LATENCY``); the e operand register.
FWD_LOOP = (
    ADD_LATENCY
    + (MUL_LATENCY + ADD_LATENCY + CAST_LATENCY)
    + 2 * (MUL_LATENCY + ROUND_LATENCY + CAST_LATENCY)
    + (MUL_LATENCY + ADD_LATENCY + CAST_LATENCY + STATE_CAST_LATENCY)
    + OPERAND_LATENCY
)


#: Cycles P2's divider ``r = 1 / den`` adds to :func:`~rangefx.rtl_model.runtime.divider_latency`
#: (``hdl/fx_divide.v``): the reciprocal one runs with ``PIPE = 2`` (the leading one, the
#: normalising shift, the products (4 stages each, their operands in the MULT18X18D's
#: input registers), the cast's shift and its rounded value each in their own stages:
#: + 14), ``UNIT = 1`` (numerator 1, ``den >= 0``: no magnitude stage, no ``|N| y1``
#: product nor its ``y1`` register: - 6) and ``NORM = 1`` (``den`` registered again
#: before its leading one, the normalising shift in two stages: + 2); the restoring one
#: as declared (``W + 4``).
DIVIDER_PIPELINING = {"reciprocal": 14 - 6 + 2, "restoring": 0}


def divider_latency_p2(divider: str, quotient_word: int) -> int:
    """Cycles of P2's divider ``r = 1 / den`` (reciprocal 19, restoring ``W + 4``)."""
    return divider_latency(divider, quotient_word) + DIVIDER_PIPELINING[divider]


def backward_loop_latency(divider: str, quotient_word: int) -> int:
    """Cycles of the backward recurrence ``S~_k+1 -> S~_k`` with a divider and its
    quotient word: ``DEN_LATENCY`` + the divider + ``STATE_LATENCY``."""
    return DEN_LATENCY + divider_latency_p2(divider, quotient_word) + STATE_LATENCY


def default_lanes(divider: str, quotient_word: int) -> int:
    """Lanes when the config says 0: the longer loop latency (backward or forward), the
    fewest lanes that sustain one pixel per clock without blanking."""
    return max(backward_loop_latency(divider, quotient_word), FWD_LOOP)


def loop_latency(config: P2Config) -> int:
    """Cycles of the backward recurrence ``S~_k+1 -> S~_k`` of ``config``
    (:func:`backward_loop_latency`)."""
    return backward_loop_latency(config.divider, config.formats["p2_r"].word)
