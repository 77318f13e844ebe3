"""A pipeline's word-length config for HLS and VHDL users (SPEC §11).

:func:`hls_header` writes one ``typedef ap_fixed<W,I,Q,O>`` (``ap_ufixed`` when unsigned)
per signal, the Vitis HLS meaning of every mode being the model's (docs/rounding.md);
:func:`vhdl_package` writes the matching IEEE 1076-2008 ``fixed_pkg`` subtypes,
``sfixed(I-1 downto -F)`` / ``ufixed``, with a rounding and an overflow style constant per
signal. ``fixed_pkg`` knows only ``fixed_truncate`` (= TRN) and ``fixed_round`` (ties to
even, = RND_CONV), ``fixed_wrap`` and ``fixed_saturate``: a signal in any other mode gets
the nearest style and a ``-- NOT EXACT`` comment naming the difference
(:func:`vhdl_inexact` lists them), so a VHDL design is never silently different.
"""

from __future__ import annotations

import re

from rangefx.rtl_model.config import WordLengthConfig
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant

__all__ = ["hls_header", "vhdl_inexact", "vhdl_package"]

#: Quantisation mode -> (fixed_pkg round style, exact?).
_VHDL_ROUND = {
    Quant.TRN: ("fixed_truncate", True),
    Quant.RND_CONV: ("fixed_round", True),
    Quant.TRN_ZERO: ("fixed_truncate", False),
    Quant.RND: ("fixed_round", False),
    Quant.RND_ZERO: ("fixed_round", False),
    Quant.RND_INF: ("fixed_round", False),
    Quant.RND_MIN_INF: ("fixed_round", False),
}
#: Overflow mode -> (fixed_pkg overflow style, exact?).
_VHDL_OVERFLOW = {
    Overflow.WRAP: ("fixed_wrap", True),
    Overflow.SAT: ("fixed_saturate", True),
    Overflow.SAT_ZERO: ("fixed_saturate", False),
    Overflow.SAT_SYM: ("fixed_saturate", False),
}


def _ident(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_]", "_", name)


def hls_header(config: WordLengthConfig) -> str:
    """C++ header: ``typedef ap_[u]fixed<W, I, AP_<quant>, AP_<overflow>> <signal>_t;``."""
    guard = f"RANGEFX_{config.PIPELINE.upper()}_{_ident(config.name).upper()}_TYPES_H"
    doc = config.signal_doc()
    lines = [
        f"// rangefx {config.PIPELINE.upper()} word-length config {config.name!r} "
        f"({config.DOC}): one type per signal",
        f"#ifndef {guard}",
        f"#define {guard}",
        "#include <ap_fixed.h>",
        "",
    ]
    for name in config.signals():
        f = config.formats[name]
        lines.append(f"typedef {f.describe()} {_ident(name)}_t;  // {f}: {doc[name]}")
    lines += ["", f"#endif  // {guard}", ""]
    return "\n".join(lines)


def _vhdl_range(f: FixedFormat) -> str:
    return f"({f.int_bits - 1} downto {-f.frac})"


def vhdl_inexact(config: WordLengthConfig) -> dict[str, str]:
    """Signals whose modes ``fixed_pkg`` cannot express exactly -> what differs."""
    out = {}
    for name in config.signals():
        f = config.formats[name]
        checks = ((f.quant, _VHDL_ROUND[f.quant][1]), (f.overflow, _VHDL_OVERFLOW[f.overflow][1]))
        bad = [mode.name for mode, exact in checks if not exact]
        if bad:
            out[name] = ", ".join(bad)
    return out


def vhdl_package(config: WordLengthConfig) -> str:
    """VHDL-2008 package: per signal a ``subtype <signal>_t is sfixed(I-1 downto -F)`` and
    the ``fixed_round_style_type`` / ``fixed_overflow_style_type`` constants to pass to
    ``resize``."""
    pkg = f"rangefx_{config.PIPELINE}_{_ident(config.name)}_types"
    doc = config.signal_doc()
    inexact = vhdl_inexact(config)
    lines = [
        f"-- rangefx {config.PIPELINE.upper()} word-length config {config.name!r} ({config.DOC})",
        "-- resize(x, <signal>_t'high, <signal>_t'low, <signal>_overflow, <signal>_round)",
        "library ieee;",
        "use ieee.fixed_pkg.all;",
        "use ieee.fixed_float_types.all;",
        "",
        f"package {pkg} is",
    ]
    for name in config.signals():
        f = config.formats[name]
        ident = _ident(name)
        kind = "sfixed" if f.signed else "ufixed"
        rnd, ovf = _VHDL_ROUND[f.quant][0], _VHDL_OVERFLOW[f.overflow][0]
        lines.append(f"  -- {name}: {f} {f.describe()}: {doc[name]}")
        if name in inexact:
            lines.append(
                f"  -- NOT EXACT: fixed_pkg has no {inexact[name]}; nearest style below, "
                "implement that mode by hand"
            )
        lines += [
            f"  subtype {ident}_t is {kind}{_vhdl_range(f)};",
            f"  constant {ident}_round : fixed_round_style_type := {rnd};",
            f"  constant {ident}_overflow : fixed_overflow_style_type := {ovf};",
        ]
    lines += [f"end package {pkg};", ""]
    return "\n".join(lines)
