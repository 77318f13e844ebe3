"""The one word-length config type of every pipeline, and the stream timing (SPEC §4, §10).

Every named signal of a pipeline's datapath has one
:class:`~rangefx.rtl_model.fixedpoint.FixedFormat` (word, fraction bits, quantisation and
overflow modes) in a :class:`WordLengthConfig`. Each pipeline subclasses it once, with
its signal table (names and meanings, in datapath order), its design fields (dataclass
fields with defaults) and the exact intermediates of its casts; everything else — TOML
load/save, validation, the int64 check naming the signal, ``propose`` — lives here, once.
A format whose exact intermediate values would not fit the int64 arithmetic of the
models is rejected when the config is built, with a message naming the signal.
"""

from __future__ import annotations

import difflib
import json
import math
import os
import tempfile
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, fields, replace
from importlib import resources
from pathlib import Path
from types import MappingProxyType
from typing import Any, ClassVar, Self, TypeVar

from .fixedpoint import FixedFormat, Overflow, Quant

__all__ = [
    "INT64_BITS",
    "MAX_NESTING",
    "SATURATING",
    "TimingConfig",
    "WordLengthConfig",
    "exact_bits",
    "integer_bits_needed",
    "loads_json",
    "loads_toml",
    "near_hint",
    "parse_format",
    "propose_config",
    "signed_bits",
]

#: Magnitude bits an exact intermediate may use in the models' int64 arithmetic (one
#: spare for the sign).
INT64_BITS = 63
#: Overflow modes that saturate (a divider quotient must use one of them).
SATURATING = (Overflow.SAT, Overflow.SAT_ZERO, Overflow.SAT_SYM)

#: An exact intermediate: a sum of products of operand formats, at a common LSB, plus
#: the extra fraction bits of a halving.
Terms = tuple[tuple[FixedFormat, ...], ...]


#: Levels of nested tables/arrays a user's TOML or JSON file (config, sweep definition,
#: manifest) may have; rangefx's own files use at most 5.
MAX_NESTING = 32


def _check_nesting(data: object) -> object:
    """``data`` if no container in it lies deeper than :data:`MAX_NESTING` (walked
    without recursion: a deep file must not exhaust the stack here either)."""
    stack = [(data, 1)]
    while stack:
        item, depth = stack.pop()
        children = (
            item.values() if isinstance(item, dict) else item if isinstance(item, list) else ()
        )
        if children and depth > MAX_NESTING:
            raise ValueError(f"nested more than {MAX_NESTING} levels deep")
        stack.extend((c, depth + 1) for c in children)
    return data


def loads_toml(text: str) -> dict:
    """``tomllib.loads`` for a user's file: ``tomllib.TOMLDecodeError`` as it is, a file
    nested deeper than :data:`MAX_NESTING` a ``ValueError`` (not a ``RecursionError``)."""
    try:
        data = tomllib.loads(text)
    except RecursionError:
        raise ValueError(f"nested more than {MAX_NESTING} levels deep") from None
    return _check_nesting(data)


def loads_json(text: str | bytes) -> Any:
    """``json.loads`` for a user's file: ``json.JSONDecodeError`` as it is, a file nested
    deeper than :data:`MAX_NESTING` a ``ValueError`` (not a ``RecursionError``)."""
    try:
        data = json.loads(text)
    except RecursionError:
        raise ValueError(f"nested more than {MAX_NESTING} levels deep") from None
    return _check_nesting(data)


def signed_bits(fmt: FixedFormat) -> int:
    """Bits of a two's complement integer that holds every raw code of ``fmt``."""
    return fmt.word if fmt.signed else fmt.word + 1


def exact_bits(terms: Terms, extra_frac: int = 0) -> int:
    """Two's complement bits of the exact sum of products ``terms`` at a common LSB."""
    widths = []
    for ops in terms:
        bits = sum(signed_bits(f) for f in ops)
        frac = sum(f.frac for f in ops)
        widths.append((bits, frac))
    top = max(frac for _, frac in widths) + extra_frac
    aligned = max(bits + top - frac for bits, frac in widths)
    return aligned + math.ceil(math.log2(len(terms)))


def parse_format(name: str, entry: object) -> FixedFormat:
    """One ``[signals]`` entry: ``"s16.8"`` or ``{format, quant, overflow}``."""
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
    if not isinstance(entry["format"], str):
        raise ValueError(f"signal {name!r}: format must be a string such as 's16.8'")
    try:
        return FixedFormat.from_string(entry["format"], q, o)
    except ValueError as exc:
        raise ValueError(f"signal {name!r}: {exc}") from None


def near_hint(name: str, known: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` naming the closest of ``known`` to ``name``, or ``""``."""
    close = difflib.get_close_matches(name, list(known), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _toml_value(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, float):
        return repr(float(value))
    return str(value)


@dataclass(frozen=True, kw_only=True)
class WordLengthConfig:
    """Formats of every signal of one pipeline plus its design choices (SPEC §10).

    A pipeline subclasses this once: class attributes :attr:`PIPELINE` (registry name),
    :attr:`SIGNAL_TABLE` ((name, meaning) in datapath order; the first is the input
    pixel), :attr:`HOST_REGISTERS` (signals whose values the host writes per frame),
    :attr:`QUOTIENTS` (divider outputs, which must saturate) and :attr:`DOC` (its
    datapath page); its design fields as dataclass fields with defaults; :meth:`validate_design`
    and :meth:`exact_intermediates` for its rules. The shipped default lives beside the
    subclass's module as ``default.toml``.

    Attributes
    ----------
    formats
        One :class:`FixedFormat` per signal of :attr:`SIGNAL_TABLE`.
    name
        Label for reports (the TOML file's stem); not compared.
    """

    PIPELINE: ClassVar[str] = ""
    SIGNAL_TABLE: ClassVar[tuple[tuple[str, str], ...]] = ()
    HOST_REGISTERS: ClassVar[tuple[str, ...]] = ()
    QUOTIENTS: ClassVar[tuple[str, ...]] = ()
    #: Design fields the host writes into a register: field -> the signal holding it. A
    #: value outside that format is refused when the config is built (it would only
    #: saturate at run time).
    DESIGN_REGISTERS: ClassVar[Mapping[str, str]] = MappingProxyType({})
    DOC: ClassVar[str] = ""

    formats: Mapping[str, FixedFormat]
    name: str = field(default="custom", compare=False)

    # -- the signal table -------------------------------------------------------------
    @classmethod
    def signals(cls) -> tuple[str, ...]:
        """Signal names in datapath order."""
        return tuple(name for name, _ in cls.SIGNAL_TABLE)

    @classmethod
    def signal_doc(cls) -> Mapping[str, str]:
        """Signal name -> meaning."""
        return MappingProxyType(dict(cls.SIGNAL_TABLE))

    @classmethod
    def design_fields(cls) -> tuple[str, ...]:
        """Names of the design fields (every dataclass field but ``formats`` and ``name``)."""
        return tuple(f.name for f in fields(cls) if f.name not in ("formats", "name"))

    # -- validation -------------------------------------------------------------------
    def __post_init__(self) -> None:
        if not self.SIGNAL_TABLE:
            raise TypeError("WordLengthConfig is the base type; use a pipeline's config")
        formats = dict(self.formats)
        doc = self.signal_doc()
        label = f"{self.PIPELINE.upper()} word-length config"
        unknown = [s for s in formats if s not in doc]
        if unknown:
            hints = "; ".join(f"{s!r}{near_hint(s, doc)}" for s in unknown)
            raise ValueError(f"{label} has unknown signals: {hints}")
        missing = [s for s in self.signals() if s not in formats]
        if missing:
            raise ValueError(f"{label} lacks signals: {', '.join(missing)}")
        for name, fmt in formats.items():
            if not isinstance(fmt, FixedFormat):
                raise ValueError(f"signal {name!r}: expected a FixedFormat, not {fmt!r}")
        object.__setattr__(self, "formats", MappingProxyType(formats))
        for name, fmt in formats.items():  # every pipeline alike, before its own checks
            if abs(fmt.frac) >= INT64_BITS:
                raise ValueError(
                    f"signal {name!r}: {fmt} has {fmt.frac} fraction bits; the model's int64 "
                    f"arithmetic scales by 2**frac, so they must lie in "
                    f"-{INT64_BITS - 1}..{INT64_BITS - 1}"
                )
        self.check_saturating(*self.QUOTIENTS)
        self.validate_design()
        self.check_design_registers()
        for name, terms, extra in self.exact_intermediates():
            bits = exact_bits(terms, extra)
            if bits > INT64_BITS:
                raise ValueError(
                    f"signal {name!r}: its exact pre-quantisation value needs {bits} bits, more "
                    f"than the model's int64 arithmetic holds ({INT64_BITS}); narrow its "
                    "operands' formats"
                )
        for name, need, what in self.divider_intermediates():
            if need > INT64_BITS:
                raise ValueError(
                    f"signal {name!r}: the {what} needs {need}-bit intermediates for these "
                    f"formats, more than the model's int64 arithmetic holds ({INT64_BITS}); "
                    "narrow its operands or fraction bits"
                )

    def validate_design(self) -> None:
        """Check the design fields and per-signal rules; raise ``ValueError``."""

    def exact_intermediates(self) -> Iterable[tuple[str, Terms, int]]:
        """(signal, terms, extra fraction bits) of every cast's exact intermediate."""
        return ()

    def divider_intermediates(self) -> Iterable[tuple[str, int, str]]:
        """(quotient signal, bits its divider's intermediates need, what) per divider."""
        return ()

    def check_int_field(self, key: str, lo: int, hi: int) -> None:
        """A design field that must be an integer in ``lo..hi``."""
        v = getattr(self, key)
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise ValueError(f"{key} must be an integer in {lo}..{hi}, not {v!r}")

    def check_choice(self, key: str, choices: tuple[str, ...]) -> None:
        """A design field that must be one of ``choices``."""
        v = getattr(self, key)
        if v not in choices:
            raise ValueError(f"unknown {key} {v!r}; choose from {', '.join(choices)}")

    def check_reciprocal_fields(self) -> None:
        """The reciprocal divider's design fields (``recip_lut_bits`` L in 1..16,
        ``recip_bits`` R in 4..28, R >= L + 2: the ROM and Newton step of
        :func:`rangefx.rtl_model.runtime.reciprocal_lut`), for configs that have them."""
        self.check_int_field("recip_lut_bits", 1, 16)
        self.check_int_field("recip_bits", 4, 28)
        if self.recip_bits < self.recip_lut_bits + 2:
            raise ValueError(
                f"recip_bits ({self.recip_bits}) must exceed recip_lut_bits "
                f"({self.recip_lut_bits}) by at least 2"
            )

    def design_register_values(self) -> Iterable[tuple[str, str, float, str]]:
        """(design field, how it is shown, value, register signal) of every value the host
        writes into a register from the design fields alone: those of
        :attr:`DESIGN_REGISTERS` as they are; a pipeline adds those it derives (P3's
        ``T_g^2``). Registers that also depend on the case (camera, scene weights) are
        checked at run time, where a value outside its format is a warning."""
        for key, signal in self.DESIGN_REGISTERS.items():
            v = getattr(self, key)
            yield key, f"{key} = {v!r}", v, signal

    def check_design_registers(self) -> None:
        """Every value of :meth:`design_register_values` lies in its register's range."""
        for key, shown, v, signal in self.design_register_values():
            fmt = self.formats[signal]
            lo, hi = fmt.to_float(fmt.raw_min), fmt.to_float(fmt.raw_max)
            if not lo <= v <= hi:
                raise ValueError(
                    f"{shown} does not fit its register {signal!r} ({fmt}: {lo:g}..{hi:g}); "
                    f"choose another {key} or widen {signal!r}"
                )

    def check_saturating(self, *names: str) -> None:
        """Divider quotients saturate: their overflow mode must be SAT, SAT_ZERO or SAT_SYM."""
        for name in names:
            mode = self.formats[name].overflow
            if mode not in SATURATING:
                raise ValueError(
                    f"signal {name!r}: a divider quotient saturates; overflow mode must be "
                    f"SAT, SAT_ZERO or SAT_SYM, not {mode.name}"
                )

    # -- access -----------------------------------------------------------------------
    def fmt(self, name: str) -> FixedFormat:
        """Format of one signal; ``ValueError`` naming the pipeline's signals otherwise."""
        try:
            return self.formats[name]
        except KeyError:
            raise ValueError(
                f"unknown {self.PIPELINE.upper()} signal {name!r}{near_hint(name, self.formats)}; "
                f"signals: {', '.join(self.signals())}"
            ) from None

    def with_formats(self, **changes: FixedFormat) -> Self:
        """Copy with some signals' formats replaced (validated again)."""
        for name in changes:
            self.fmt(name)
        return replace(self, formats={**self.formats, **changes})

    def with_(self, **changes: Any) -> Self:
        """Copy with some design fields (or ``name``) replaced (validated again)."""
        allowed = {*self.design_fields(), "name", "formats"}
        unknown = sorted(set(changes) - allowed)
        if unknown:
            raise ValueError(
                f"{self.PIPELINE.upper()} has no design field {unknown[0]!r}; "
                f"fields: {', '.join(self.design_fields())}"
            )
        return replace(self, **changes)

    def design(self) -> dict[str, Any]:
        """The design fields and their values."""
        return {k: getattr(self, k) for k in self.design_fields()}

    def register_bits(self) -> int:
        """Sum of the word lengths of all signals (a crude register-count proxy)."""
        return sum(f.word for f in self.formats.values())

    # -- TOML -------------------------------------------------------------------------
    @classmethod
    def from_mapping(cls, data: Mapping, name: str = "custom") -> Self:
        label = f"{cls.PIPELINE.upper()} word-length config"
        if not isinstance(data, Mapping):
            raise ValueError(f"{label} must be a table")
        design = data.get("design", {})
        if not isinstance(design, Mapping):
            raise ValueError("[design] must be a table")
        unknown = sorted(set(design) - set(cls.design_fields()))
        if unknown:
            hints = ", ".join(f"{k!r}{near_hint(k, cls.design_fields())}" for k in unknown)
            raise ValueError(f"[design]: unknown keys {hints}")
        signals = data.get("signals")
        if not isinstance(signals, Mapping):
            raise ValueError(f"{label} needs a [signals] table")
        extra = set(data) - {"design", "signals"}
        if extra:
            raise ValueError(f"{label}: unknown tables {sorted(extra)}")
        formats = {str(k): parse_format(str(k), v) for k, v in signals.items()}
        try:
            return cls(formats=formats, name=name, **design)
        except TypeError as exc:  # a design value of the wrong kind for a comparison
            raise ValueError(f"{label}: {exc}") from None

    @classmethod
    def from_toml(cls, text: str, name: str = "custom") -> Self:
        try:
            data = loads_toml(text)
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(
                f"{cls.PIPELINE.upper()} word-length config is not valid TOML: {exc}"
            ) from None
        except ValueError as exc:
            raise ValueError(f"{cls.PIPELINE.upper()} word-length config is {exc}") from None
        return cls.from_mapping(data, name=name)

    @classmethod
    def load(cls, path: str | Path) -> Self:
        p = Path(path)
        try:
            text = p.read_bytes().decode("utf-8")
        except UnicodeDecodeError:
            raise ValueError(f"{p}: word-length config is not UTF-8 text") from None
        except OSError as exc:
            raise ValueError(f"cannot read word-length config {str(p)!r}: {exc.strerror}") from None
        try:
            return cls.from_toml(text, name=p.stem)
        except ValueError as exc:
            raise ValueError(f"{p}: {exc}") from None

    @classmethod
    def default(cls, **design: Any) -> Self:
        """The shipped default (``default.toml`` beside the pipeline's config module),
        chosen from measured ranges; ``design`` overrides design fields."""
        package = cls.__module__.rpartition(".")[0]
        text = resources.files(package).joinpath("default.toml").read_text()
        config = cls.from_toml(text, name="default")
        return config.with_(**design) if design else config

    def to_toml(self) -> str:
        lines = [
            f"# rangefx {self.PIPELINE.upper()} word-length config ({self.DOC})",
            "[design]",
        ]
        lines += [f"{k} = {_toml_value(v)}" for k, v in self.design().items()]
        lines += ["", "[signals]"]
        doc = self.signal_doc()
        for name in self.signals():
            f = self.formats[name]
            lines.append(
                f'{name} = {{ format = "{f}", quant = "{f.quant.name}", '
                f'overflow = "{f.overflow.name}" }}  # {doc[name]}'
            )
        return "\n".join(lines) + "\n"

    def save(self, path: str | Path) -> None:
        """Write the TOML atomically: a uniquely named, fsynced temporary sibling, then a
        rename; the temporary is removed if anything fails. ``ValueError`` if ``path``
        is a directory or cannot be written."""
        p = Path(path)
        if p.is_dir():
            raise ValueError(f"{p} is a directory; give a file name for the config")
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent or ".")
        except OSError as exc:
            raise ValueError(f"cannot write {p}: {exc.strerror}") from None
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(self.to_toml())
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, p)
        except OSError as exc:
            Path(tmp).unlink(missing_ok=True)
            raise ValueError(f"cannot write {p}: {exc.strerror}") from None
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise


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


C = TypeVar("C", bound=WordLengthConfig)


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
    config: C,
    minmax: Mapping[str, tuple[float, float]],
    *,
    guard_bits: int = 1,
) -> C:
    """Integer bits from observed pre-quantisation ranges (MATLAB's "propose word lengths").

    For each signal with a logged range, the word length becomes the integer bits that
    hold it plus ``guard_bits``, fraction bits and modes unchanged. Registers and signals
    never cast keep their format. The result is validated like any config, of the same
    pipeline as ``config``.
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
