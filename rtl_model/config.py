"""Word-length, design and timing configuration of the P1 pipeline (SPEC §4).

Every named signal of the datapath (``docs/p1_datapath.md``) has one
:class:`~rangefx.rtl_model.fixedpoint.FixedFormat` (word, fraction bits, quantisation and
overflow modes) in a :class:`WordLengthConfig`, which loads and saves TOML. A format
whose exact intermediate values would not fit the int64 arithmetic of the model is
rejected when the config is built, with a message naming the signal.
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

from .fixedpoint import FixedFormat, Overflow, Quant

__all__ = [
    "HOST_REGISTERS",
    "P1_SIGNALS",
    "SIGNAL_DOC",
    "TimingConfig",
    "WordLengthConfig",
    "integer_bits_needed",
    "propose_config",
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
P1_SIGNALS: tuple[str, ...] = tuple(name for name, _ in _SIGNAL_TABLE)
#: Per-frame registers written by the host (``pix_in`` is the pixel input, not one of
#: them). Their values are host constants (bias, filter pole, focal length, baseline and
#: motion terms, gradient threshold), so the formats they need follow the envelope of
#: the cameras and geometries the pipeline must serve, not image content: a word-length
#: optimiser tuned on a few scenes must not narrow them by default (``rangefx optimise
#: --tune-registers``).
HOST_REGISTERS: tuple[str, ...] = (
    "bias_reg", "pole_coef", "f_reg", "k_t_reg", "k_m_reg", "tg2_reg",
)  # fmt: skip
SIGNAL_DOC: Mapping[str, str] = MappingProxyType(dict(_SIGNAL_TABLE))

VARIANTS = ("paper", "consistent")
DIVIDERS = ("restoring", "reciprocal")
INITS = ("first", "zero")
_DIVIDER_OUTPUTS = ("div_quot", "range")
_SATURATING = (Overflow.SAT, Overflow.SAT_ZERO, Overflow.SAT_SYM)
_INT64_BITS = 63  # magnitude bits an exact intermediate may use (one spare for the sign)
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


def _signed_bits(fmt: FixedFormat) -> int:
    """Bits of a two's complement integer that holds every raw code of ``fmt``."""
    return fmt.word if fmt.signed else fmt.word + 1


def exact_bits(terms: tuple[tuple[FixedFormat, ...], ...], extra_frac: int = 0) -> int:
    """Two's complement bits of the exact sum of products ``terms`` at a common LSB."""
    widths = []
    for ops in terms:
        bits = sum(_signed_bits(f) for f in ops)
        frac = sum(f.frac for f in ops)
        widths.append((bits, frac))
    top = max(frac for _, frac in widths) + extra_frac
    aligned = max(bits + top - frac for bits, frac in widths)
    return aligned + math.ceil(math.log2(len(terms)))


def _parse_format(name: str, entry: object) -> FixedFormat:
    if isinstance(entry, str):
        entry = {"format": entry}
    if not isinstance(entry, Mapping) or "format" not in entry:
        raise ValueError(f"signal {name!r}: expected a table with 'format', not {entry!r}")
    unknown = set(entry) - {"format", "quant", "overflow"}
    if unknown:
        raise ValueError(f"signal {name!r}: unknown keys {sorted(unknown)}")
    quant = entry.get("quant", "TRN")
    overflow = entry.get("overflow", "WRAP")
    try:
        q = Quant[quant]
    except (KeyError, TypeError):
        raise ValueError(
            f"signal {name!r}: unknown quantisation mode {quant!r}; "
            f"choose from {', '.join(m.name for m in Quant)}"
        ) from None
    try:
        o = Overflow[overflow]
    except (KeyError, TypeError):
        raise ValueError(
            f"signal {name!r}: unknown overflow mode {overflow!r}; "
            f"choose from {', '.join(m.name for m in Overflow)}"
        ) from None
    try:
        return FixedFormat.from_string(entry["format"], q, o)
    except ValueError as exc:
        raise ValueError(f"signal {name!r}: {exc}") from None


@dataclass(frozen=True)
class WordLengthConfig:
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
    """

    formats: Mapping[str, FixedFormat]
    variant: str = "paper"
    divider: str = "reciprocal"
    pole: float = 0.5
    bias: float = 16.0
    init: str = "first"
    recip_lut_bits: int = 8
    recip_bits: int = 20
    name: str = field(default="custom", compare=False)

    def __post_init__(self) -> None:
        formats = dict(self.formats)
        missing = [s for s in P1_SIGNALS if s not in formats]
        if missing:
            raise ValueError(f"word-length config lacks signals: {', '.join(missing)}")
        unknown = [s for s in formats if s not in SIGNAL_DOC]
        if unknown:
            raise ValueError(f"word-length config has unknown signals: {', '.join(unknown)}")
        for name, fmt in formats.items():
            if not isinstance(fmt, FixedFormat):
                raise ValueError(f"signal {name!r}: expected a FixedFormat, not {fmt!r}")
        object.__setattr__(self, "formats", MappingProxyType(formats))
        if self.variant not in VARIANTS:
            raise ValueError(f"unknown estimator variant {self.variant!r}; choose from {VARIANTS}")
        if self.divider not in DIVIDERS:
            raise ValueError(f"unknown divider {self.divider!r}; choose from {DIVIDERS}")
        if self.init not in INITS:
            raise ValueError(f"unknown filter init {self.init!r}; choose from {INITS}")
        if not (isinstance(self.pole, int | float) and 0 < self.pole <= 1):
            raise ValueError(f"filter pole must be in (0, 1], not {self.pole!r}")
        if not (isinstance(self.bias, int | float) and math.isfinite(self.bias) and self.bias >= 0):
            raise ValueError(f"bias must be a finite non-negative number, not {self.bias!r}")
        for key, lo, hi in (("recip_lut_bits", 1, 16), ("recip_bits", 4, 28)):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
                raise ValueError(f"{key} must be an integer in {lo}..{hi}, not {v!r}")
        if self.recip_bits < self.recip_lut_bits + 2:
            raise ValueError(
                f"recip_bits ({self.recip_bits}) must exceed recip_lut_bits "
                f"({self.recip_lut_bits}) by at least 2"
            )
        for name in _DIVIDER_OUTPUTS:
            if formats[name].overflow not in _SATURATING:
                raise ValueError(
                    f"signal {name!r}: a divider quotient saturates; overflow mode must be "
                    f"SAT, SAT_ZERO or SAT_SYM, not {formats[name].overflow.name}"
                )
        pole_raw = formats["pole_coef"].from_float(self.pole)
        if pole_raw <= 0:
            raise ValueError(
                f"signal 'pole_coef': pole {self.pole} quantises to {pole_raw} in "
                f"{formats['pole_coef']}; widen its fraction bits"
            )
        self._check_int64(formats)

    def _check_int64(self, formats: Mapping[str, FixedFormat]) -> None:
        def fmt(op: str) -> FixedFormat:
            return {"@counter": _COUNTER, "@one": _ONE}.get(op) or formats[op]

        for name, (terms, extra) in _EXPRESSIONS.items():
            bits = exact_bits(tuple(tuple(fmt(o) for o in ops) for ops in terms), extra)
            if bits > _INT64_BITS:
                raise ValueError(
                    f"signal {name!r}: its exact pre-quantisation value needs {bits} bits, more "
                    f"than the model's int64 arithmetic holds ({_INT64_BITS}); narrow its "
                    "operands' formats"
                )
        self._check_divider("div_quot", formats, ("col_s1", "row_r2"), ("row_r1",))
        self._check_divider("range", formats, ("num",), ("den",))

    def _check_divider(
        self,
        name: str,
        formats: Mapping[str, FixedFormat],
        num: tuple[str, ...],
        den: tuple[str, ...],
    ) -> None:
        n_bits = sum(_signed_bits(formats[o]) for o in num)
        n_frac = sum(formats[o].frac for o in num)
        d_bits = sum(_signed_bits(formats[o]) for o in den)
        d_frac = sum(formats[o].frac for o in den)
        out = formats[name]
        if self.divider == "restoring":
            shift = out.frac + 1 + d_frac - n_frac
            need = max(n_bits + max(shift, 0), d_bits + max(-shift, 0), out.word + 3)
        else:
            need = max(n_bits + self.recip_bits + 2, 2 * (self.recip_bits + 2))
        if need > _INT64_BITS:
            raise ValueError(
                f"signal {name!r}: the {self.divider} divider needs {need}-bit intermediates "
                f"for these formats, more than the model's int64 arithmetic holds "
                f"({_INT64_BITS}); narrow its operands or fraction bits"
            )

    # -- access -----------------------------------------------------------------------
    def fmt(self, name: str) -> FixedFormat:
        try:
            return self.formats[name]
        except KeyError:
            raise ValueError(
                f"unknown signal {name!r}; P1 signals: {', '.join(P1_SIGNALS)}"
            ) from None

    def with_formats(self, **changes: FixedFormat) -> WordLengthConfig:
        """Copy with some signals' formats replaced (validated again)."""
        for name in changes:
            self.fmt(name)
        return replace(self, formats={**self.formats, **changes})

    def with_(self, **changes) -> WordLengthConfig:
        return replace(self, **changes)

    def register_bits(self) -> int:
        """Sum of the word lengths of all signals (a crude register-count proxy)."""
        return sum(f.word for f in self.formats.values())

    # -- TOML -------------------------------------------------------------------------
    @classmethod
    def from_mapping(cls, data: Mapping, name: str = "custom") -> WordLengthConfig:
        if not isinstance(data, Mapping):
            raise ValueError("word-length config must be a table")
        design = dict(data.get("design", {}))
        unknown = set(design) - {
            "variant",
            "divider",
            "pole",
            "bias",
            "init",
            "recip_lut_bits",
            "recip_bits",
        }
        if unknown:
            raise ValueError(f"[design]: unknown keys {sorted(unknown)}")
        signals = data.get("signals")
        if not isinstance(signals, Mapping):
            raise ValueError("word-length config needs a [signals] table")
        formats = {str(k): _parse_format(str(k), v) for k, v in signals.items()}
        extra = set(data) - {"design", "signals"}
        if extra:
            raise ValueError(f"word-length config: unknown tables {sorted(extra)}")
        return cls(formats=formats, name=name, **design)

    @classmethod
    def from_toml(cls, text: str, name: str = "custom") -> WordLengthConfig:
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"word-length config is not valid TOML: {exc}") from None
        return cls.from_mapping(data, name=name)

    @classmethod
    def load(cls, path: str | Path) -> WordLengthConfig:
        p = Path(path)
        try:
            text = p.read_text()
        except OSError as exc:
            raise ValueError(f"cannot read word-length config {str(p)!r}: {exc.strerror}") from None
        try:
            return cls.from_toml(text, name=p.stem)
        except ValueError as exc:
            raise ValueError(f"{p}: {exc}") from None

    @classmethod
    def default(cls, variant: str = "paper") -> WordLengthConfig:
        """The shipped default (``rtl_model/p1_default.toml``), chosen from measured ranges."""
        text = resources.files("rangefx.rtl_model").joinpath("p1_default.toml").read_text()
        return cls.from_toml(text, name="default").with_(variant=variant)

    def to_toml(self) -> str:
        lines = [
            "# rangefx P1 word-length config (docs/p1_datapath.md)",
            "[design]",
            f'variant = "{self.variant}"',
            f'divider = "{self.divider}"',
            f"pole = {float(self.pole)!r}",
            f"bias = {float(self.bias)!r}",
            f'init = "{self.init}"',
            f"recip_lut_bits = {self.recip_lut_bits}",
            f"recip_bits = {self.recip_bits}",
            "",
            "[signals]",
        ]
        for name in P1_SIGNALS:
            f = self.formats[name]
            lines.append(
                f'{name} = {{ format = "{f}", quant = "{f.quant.name}", '
                f'overflow = "{f.overflow.name}" }}  # {SIGNAL_DOC[name]}'
            )
        return "\n".join(lines) + "\n"

    def save(self, path: str | Path) -> None:
        """Write the TOML atomically (temporary sibling, then rename)."""
        p = Path(path)
        tmp = p.with_name(f".{p.name}.tmp")
        tmp.write_text(self.to_toml())
        os.replace(tmp, p)


@dataclass(frozen=True)
class TimingConfig:
    """Input stream timing (SPEC §4 "Cycle faithfulness").

    Attributes
    ----------
    hblank, vblank
        Idle cycles (``valid`` low) after each line and after each frame.
    gap_prob
        Probability, per cycle, that the source stalls before a pixel (input gaps):
        the number of idle cycles before each pixel is geometric with this parameter.
    seed
        Seed of the gap generator (numpy PCG64).
    """

    hblank: int = 0
    vblank: int = 0
    gap_prob: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        for key in ("hblank", "vblank", "seed"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                raise ValueError(f"timing {key} must be a non-negative integer, not {v!r}")
        p = self.gap_prob
        if isinstance(p, bool) or not isinstance(p, int | float) or not 0 <= p < 1:
            raise ValueError(f"timing gap_prob must be in [0, 1), not {p!r}")


def integer_bits_needed(lo: float, hi: float, signed: bool) -> int:
    """Fewest integer bits ``I = W - F`` (sign included) whose range covers ``[lo, hi]``.

    Unsigned: ``hi < 2**I``; signed: ``-2**(I-1) <= lo`` and ``hi < 2**(I-1)``. ``I`` may
    be negative for small values; an all-zero range needs 1.
    """
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
        raise ValueError(f"range [{lo}, {hi}] is not a finite interval")
    if not signed and lo < 0:
        raise ValueError(f"an unsigned format cannot hold the negative value {lo}")
    if lo == 0 and hi == 0:
        return 1
    bits = -1100
    if hi > 0:  # smallest b with hi < 2**b
        bits = math.floor(math.log2(hi)) + 1
    if signed:
        bits += 1
        if lo < 0:  # smallest b with -2**(b-1) <= lo, i.e. 2**(b-1) >= -lo
            bits = max(bits, math.ceil(math.log2(-lo)) + 1)
    return bits


def propose_config(
    config: WordLengthConfig,
    minmax: Mapping[str, tuple[float, float]],
    *,
    guard_bits: int = 1,
) -> WordLengthConfig:
    """Integer bits from observed pre-quantisation ranges (MATLAB's "propose word lengths").

    For each signal with a logged range, the word length becomes the integer bits that
    hold it plus ``guard_bits``, fraction bits and modes unchanged. Registers and signals
    never cast keep their format. The result is validated like any config.
    """
    if isinstance(guard_bits, bool) or not isinstance(guard_bits, int) or guard_bits < 0:
        raise ValueError(f"guard_bits must be a non-negative integer, not {guard_bits!r}")
    changes = {}
    for name, (lo, hi) in minmax.items():
        fmt = config.fmt(name)
        ib = integer_bits_needed(lo, hi, fmt.signed) + guard_bits
        word = max(1, ib + fmt.frac)
        if word > 62:
            raise ValueError(
                f"signal {name!r}: range [{lo}, {hi}] needs {word} bits at {fmt.frac} fraction "
                "bits, more than 62"
            )
        changes[name] = replace(fmt, word=word)
    name = config.name if config.name.endswith("-proposed") else f"{config.name}-proposed"
    return config.with_formats(**changes).with_(name=name)
