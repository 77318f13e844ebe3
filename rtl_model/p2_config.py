"""Word-length and design configuration of the P2 pipeline (Riccati sweep, SPEC §4).

Kept apart from :mod:`rangefx.rtl_model.config` (P1) so that P1's
:class:`~rangefx.rtl_model.config.WordLengthConfig` is untouched: :class:`P2Config` holds
one :class:`~rangefx.rtl_model.fixedpoint.FixedFormat` per name of :data:`P2_SIGNALS`
(``docs/p2_datapath.md``) plus the design fields, loads/saves TOML in the same layout
(``[design]``, ``[signals]``) and rejects formats whose exact intermediates would not fit
the model's int64 arithmetic, naming the signal.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from types import MappingProxyType

from .config import _INT64_BITS, _SATURATING, _parse_format, _signed_bits, exact_bits
from .fixedpoint import FixedFormat

__all__ = ["P2_SIGNALS", "P2_SIGNAL_DOC", "P2Config", "loop_latency"]

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
P2_SIGNALS: tuple[str, ...] = tuple(name for name, _ in _SIGNAL_TABLE)
P2_SIGNAL_DOC: Mapping[str, str] = MappingProxyType(dict(_SIGNAL_TABLE))

DIVIDERS = ("restoring", "reciprocal")
_DESIGN_KEYS = ("divider", "recip_lut_bits", "recip_bits", "kappa_min", "lanes")
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


@dataclass(frozen=True)
class P2Config:
    """Formats of every P2 signal plus the design choices of the sweep.

    Attributes
    ----------
    formats
        One :class:`FixedFormat` per name in :data:`P2_SIGNALS`.
    divider
        The P1 divider models: ``"restoring"`` or ``"reciprocal"`` (LUT + Newton).
    recip_lut_bits, recip_bits
        Reciprocal divider: LUT index bits and reciprocal fraction bits.
    kappa_min
        Floor on ``kappa = alpha delta c = M A^2`` (dimensionless): bounds
        ``S <= alpha delta (1 + 1 / kappa_min)`` after the first step (docs/p2_datapath.md).
    lanes
        Lines interleaved by the sweep engine (the recurrence's loop latency is hidden
        by issuing one step of each lane in turn); 0 = the loop latency.
    """

    formats: Mapping[str, FixedFormat]
    divider: str = "reciprocal"
    recip_lut_bits: int = 8
    recip_bits: int = 20
    kappa_min: float = 2.0**-6
    lanes: int = 0
    name: str = field(default="custom", compare=False)

    def __post_init__(self) -> None:
        formats = dict(self.formats)
        missing = [s for s in P2_SIGNALS if s not in formats]
        if missing:
            raise ValueError(f"P2 word-length config lacks signals: {', '.join(missing)}")
        unknown = [s for s in formats if s not in P2_SIGNAL_DOC]
        if unknown:
            raise ValueError(f"P2 word-length config has unknown signals: {', '.join(unknown)}")
        for name, fmt in formats.items():
            if not isinstance(fmt, FixedFormat):
                raise ValueError(f"signal {name!r}: expected a FixedFormat, not {fmt!r}")
        object.__setattr__(self, "formats", MappingProxyType(formats))
        if self.divider not in DIVIDERS:
            raise ValueError(f"unknown divider {self.divider!r}; choose from {DIVIDERS}")
        for key, lo, hi in (("recip_lut_bits", 1, 16), ("recip_bits", 4, 28), ("lanes", 0, 256)):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
                raise ValueError(f"{key} must be an integer in {lo}..{hi}, not {v!r}")
        if self.recip_bits < self.recip_lut_bits + 2:
            raise ValueError("recip_bits must exceed recip_lut_bits by at least 2")
        k = self.kappa_min
        if isinstance(k, bool) or not isinstance(k, int | float) or not (0 < k < math.inf):
            raise ValueError(f"kappa_min must be a positive finite number, not {k!r}")
        if formats["p2_r"].overflow not in _SATURATING:
            raise ValueError(
                "signal 'p2_r': a divider quotient saturates; overflow mode must be SAT, "
                f"SAT_ZERO or SAT_SYM, not {formats['p2_r'].overflow.name}"
            )
        for name in ("p2_c", "p2_st", "p2_den", "p2_r", "p2_m_reg"):
            if formats[name].signed:
                raise ValueError(f"signal {name!r} must be unsigned (it is never negative)")
        self._check_int64(formats)

    def _check_int64(self, formats: Mapping[str, FixedFormat]) -> None:
        d, g = formats["p2_d"], formats["p2_ghat"]
        extra = {
            _D_SUM: FixedFormat(True, _signed_bits(d) + 1, d.frac),
            _DG: FixedFormat(True, _signed_bits(g) + 1, g.frac),
            "@one": _ONE,
        }
        for name, terms in _EXPRESSIONS.items():
            bits = exact_bits(tuple(tuple(extra.get(o) or formats[o] for o in t) for t in terms))
            if bits > _INT64_BITS:
                raise ValueError(
                    f"signal {name!r}: its exact pre-quantisation value needs {bits} bits, more "
                    f"than the model's int64 arithmetic holds ({_INT64_BITS}); narrow its "
                    "operands' formats"
                )
        den, out = formats["p2_den"], formats["p2_r"]
        if self.divider == "restoring":
            need = max(2 + out.frac + 1 + den.frac, _signed_bits(den), out.word + 3)
        else:
            need = max(2 + self.recip_bits + 2, 2 * (self.recip_bits + 2))
        if need > _INT64_BITS:
            raise ValueError(
                f"signal 'p2_r': the {self.divider} divider needs {need}-bit intermediates, "
                f"more than the model's int64 arithmetic holds ({_INT64_BITS})"
            )

    # -- access -----------------------------------------------------------------------
    def fmt(self, name: str) -> FixedFormat:
        try:
            return self.formats[name]
        except KeyError:
            raise ValueError(
                f"unknown signal {name!r}; P2 signals: {', '.join(P2_SIGNALS)}"
            ) from None

    def with_formats(self, **changes: FixedFormat) -> P2Config:
        for name in changes:
            self.fmt(name)
        return replace(self, formats={**self.formats, **changes})

    def with_(self, **changes) -> P2Config:
        return replace(self, **changes)

    def effective_lanes(self) -> int:
        return self.lanes or loop_latency(self)

    # -- TOML -------------------------------------------------------------------------
    @classmethod
    def from_mapping(cls, data: Mapping, name: str = "custom") -> P2Config:
        if not isinstance(data, Mapping):
            raise ValueError("P2 word-length config must be a table")
        design = dict(data.get("design", {}))
        unknown = set(design) - set(_DESIGN_KEYS)
        if unknown:
            raise ValueError(f"[design]: unknown keys {sorted(unknown)}")
        signals = data.get("signals")
        if not isinstance(signals, Mapping):
            raise ValueError("P2 word-length config needs a [signals] table")
        extra = set(data) - {"design", "signals"}
        if extra:
            raise ValueError(f"P2 word-length config: unknown tables {sorted(extra)}")
        formats = {str(k): _parse_format(str(k), v) for k, v in signals.items()}
        return cls(formats=formats, name=name, **design)

    @classmethod
    def from_toml(cls, text: str, name: str = "custom") -> P2Config:
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"P2 word-length config is not valid TOML: {exc}") from None
        return cls.from_mapping(data, name=name)

    @classmethod
    def load(cls, path: str | Path) -> P2Config:
        p = Path(path)
        try:
            text = p.read_text()
        except OSError as exc:
            raise ValueError(f"cannot read P2 config {str(p)!r}: {exc.strerror}") from None
        try:
            return cls.from_toml(text, name=p.stem)
        except ValueError as exc:
            raise ValueError(f"{p}: {exc}") from None

    @classmethod
    def default(cls) -> P2Config:
        """The shipped default (``rtl_model/p2_default.toml``)."""
        text = resources.files("rangefx.rtl_model").joinpath("p2_default.toml").read_text()
        return cls.from_toml(text, name="default")

    def to_toml(self) -> str:
        lines = [
            "# rangefx P2 word-length config (docs/p2_datapath.md)",
            "[design]",
            f'divider = "{self.divider}"',
            f"recip_lut_bits = {self.recip_lut_bits}",
            f"recip_bits = {self.recip_bits}",
            f"kappa_min = {float(self.kappa_min)!r}",
            f"lanes = {self.lanes}",
            "",
            "[signals]",
        ]
        for name in P2_SIGNALS:
            f = self.formats[name]
            lines.append(
                f'{name} = {{ format = "{f}", quant = "{f.quant.name}", '
                f'overflow = "{f.overflow.name}" }}  # {P2_SIGNAL_DOC[name]}'
            )
        return "\n".join(lines) + "\n"

    def save(self, path: str | Path) -> None:
        p = Path(path)
        tmp = p.with_name(f".{p.name}.tmp")
        tmp.write_text(self.to_toml())
        os.replace(tmp, p)


def divider_latency(config: P2Config) -> int:
    """Declared divider latency (the P1 models): restoring ``W + 4``, reciprocal 8."""
    return config.formats["p2_r"].word + 4 if config.divider == "restoring" else 8


def loop_latency(config: P2Config) -> int:
    """Cycles of the backward recurrence ``S~_k+1 -> S~_k``: product ``A^2 S~`` and cast
    (1), divider, product ``r S~`` plus ``M`` and cast (2)."""
    return 1 + divider_latency(config) + 2
