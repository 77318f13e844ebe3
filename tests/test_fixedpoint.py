"""Bit-exact tests of `rangefx.rtl_model.fixedpoint` (SPEC §4 "Fixed-point semantics").

References: exact `fractions.Fraction` arithmetic with the rounding and overflow rules written
out below, and apytypes (which has WRAP and SAT but no SAT_ZERO / SAT_SYM, so those two
overflow modes are checked against the Fraction reference only).
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction
from pathlib import Path

import apytypes
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numba import njit

from rangefx.rtl_model.fixedpoint import (
    ANY_MODES,
    PLAIN_MODES,
    PLAIN_OVERFLOWS,
    PLAIN_QUANTS,
    FixedFormat,
    Overflow,
    Quant,
    cast_array,
    cast_by_plan,
    cast_plan,
    cast_raw,
    overflow_raw,
    quantise_shift,
    rounding_doc_text,
    rounding_table,
    rounding_table_markdown,
)

DOC = Path(__file__).resolve().parent.parent / "docs" / "rounding.md"
MODE_PAIRS = list(itertools.product(Quant, Overflow))
APY_OVERFLOW = {Overflow.WRAP: apytypes.OverflowMode.WRAP, Overflow.SAT: apytypes.OverflowMode.SAT}
APY_QUANT = {q: getattr(apytypes.QuantizationMode, q.name) for q in Quant}
I64_MIN, I64_MAX = -(2**63), 2**63 - 1
BATCH = 256


def reference_round(x: Fraction, quant: Quant) -> int:
    floor = math.floor(x)
    rem = x - floor
    half = Fraction(1, 2)
    if quant is Quant.TRN:
        return floor
    if quant is Quant.TRN_ZERO:
        return floor if x >= 0 else math.ceil(x)
    if rem > half:
        return floor + 1
    if rem < half:
        return floor
    if quant is Quant.RND:
        return floor + 1
    if quant is Quant.RND_ZERO:
        return floor if x > 0 else floor + 1
    if quant is Quant.RND_INF:
        return floor + 1 if x > 0 else floor
    if quant is Quant.RND_MIN_INF:
        return floor
    if quant is Quant.RND_CONV:
        return floor if floor % 2 == 0 else floor + 1
    raise AssertionError(quant)


def reference_overflow(n: int, word: int, signed: bool, mode: Overflow) -> tuple[int, bool]:
    lo, hi = (-(2 ** (word - 1)), 2 ** (word - 1) - 1) if signed else (0, 2**word - 1)
    if mode is Overflow.SAT_SYM and signed and word > 1:  # W = 1: as SAT (the header)
        lo = -hi
    if lo <= n <= hi:
        return n, False
    if mode is Overflow.WRAP:
        base = -(2 ** (word - 1)) if signed else 0
        return (n - base) % 2**word + base, True
    if mode is Overflow.SAT_ZERO:
        return 0, True
    return (hi if n > hi else lo), True


def reference_cast(raw: int, frac_in: int, fmt: FixedFormat) -> tuple[int, bool]:
    exact = Fraction(raw) / Fraction(2) ** frac_in * Fraction(2) ** fmt.frac
    return reference_overflow(reference_round(exact, fmt.quant), fmt.word, fmt.signed, fmt.overflow)


def random_raws(seed: int, size: int, max_bits: int = 63) -> np.ndarray:
    """Signed values of uniformly random bit length (0..max_bits), plus int64 extremes."""
    rng = np.random.default_rng(seed)
    bits = rng.integers(0, max_bits + 1, size)
    mags = [
        int(rng.integers(0, 2 ** min(int(b), 62), dtype=np.int64)) << max(int(b) - 62, 0)
        for b in bits
    ]
    signs = rng.integers(0, 2, size)
    values = [-m if s else m for m, s in zip(mags, signs, strict=True)]
    values[:4] = [I64_MIN, I64_MAX, -1, 0] if max_bits == 63 else values[:4]
    return np.array(values, dtype=np.int64)


formats = st.builds(
    lambda signed, word, frac: (signed, word, frac),
    st.booleans(),
    st.integers(1, 62),
    st.integers(-80, 140),
)


def assert_cast_matches_reference(raws: np.ndarray, frac_in: int, fmt: FixedFormat) -> None:
    """The kernel's values and overflow count equal the Fraction reference, value by value."""
    out, count = cast_array(raws, frac_in, fmt)
    expected = [reference_cast(int(r), frac_in, fmt) for r in raws]
    assert out.tolist() == [value for value, _ in expected]
    assert count == sum(flag for _, flag in expected)


@pytest.mark.parametrize(("quant", "overflow"), MODE_PAIRS, ids=lambda m: m.name)
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    target=formats,
    shift=st.one_of(st.integers(-3, 3), st.integers(-70, 70)),
    seed=st.integers(0, 2**32 - 1),
    extra=st.lists(st.integers(I64_MIN, I64_MAX), max_size=8),
)
def test_cast_matches_fraction_reference(quant, overflow, target, shift, seed, extra):
    signed, word, frac = target
    fmt = FixedFormat(signed, word, frac, quant, overflow)
    frac_in = frac + shift
    raws = np.concatenate([random_raws(seed, BATCH), np.array(extra, dtype=np.int64)])
    assert_cast_matches_reference(raws, frac_in, fmt)


@pytest.mark.parametrize(("quant", "overflow"), MODE_PAIRS, ids=lambda m: m.name)
@settings(max_examples=15, deadline=None)
@given(
    word_in=st.integers(2, 62),
    frac_in=st.integers(-20, 80),
    word_out=st.integers(2, 62),
    frac_out=st.integers(-20, 80),
    seed=st.integers(0, 2**32 - 1),
)
def test_cast_in_format_ties_and_bounds(
    quant, overflow, word_in, frac_in, word_out, frac_out, seed
):
    rng = np.random.default_rng(seed)
    raws = random_raws(seed, BATCH, max_bits=word_in - 1)
    shift = frac_in - frac_out
    if 1 <= shift <= 62:
        base = rng.integers(-(2 ** (word_in - 2)), 2 ** (word_in - 2), 64) >> shift << shift
        raws = np.concatenate([raws, base + (1 << (shift - 1)), base - (1 << (shift - 1))])
    fmt = FixedFormat(True, word_out, frac_out, quant, overflow)
    assert_cast_matches_reference(raws, frac_in, fmt)


@pytest.mark.parametrize(("quant", "overflow"), MODE_PAIRS, ids=lambda m: m.name)
@pytest.mark.parametrize("signed", [True, False])
@pytest.mark.parametrize("shift", [0, 1, 5, 48])
def test_cast_row_in_range_and_overflowing_rows(quant, overflow, signed, shift):
    """``cast_row`` decides overflow on a row's quantised extremes and only then checks
    element by element: a row inside the format (ties included), the same row with one
    outlier at either end, and a row ending exactly on the format's bounds all equal the
    Fraction reference value by value, with the right overflow count."""
    word, frac = 12, 3
    fmt = FixedFormat(signed, word, frac, quant, overflow)
    frac_in = frac + shift
    rng = np.random.default_rng(shift * 97 + int(quant) * 7 + int(overflow))
    inside = rng.integers(fmt.raw_min + 1, fmt.raw_max - 1, 200, dtype=np.int64) << shift
    if shift:
        inside[:50] += 1 << (shift - 1)  # ties
    edges = np.array([fmt.raw_min << shift, fmt.raw_max << shift], dtype=np.int64)
    rows = {
        "inside": inside,
        "edges": np.concatenate([inside, edges]),
        "high": np.concatenate([inside, [(fmt.raw_max + 3) << shift]]),
        "low": np.concatenate([[(fmt.raw_min - 3) << shift], inside]),
    }
    for name, raws in rows.items():
        out, count = cast_array(raws, frac_in, fmt)
        expected = [reference_cast(int(r), frac_in, fmt) for r in raws]
        assert out.tolist() == [v for v, _ in expected], name
        assert count == sum(f for _, f in expected), name
    assert cast_array(rows["inside"], frac_in, fmt)[1] == 0
    assert cast_array(rows["high"], frac_in, fmt)[1] >= 1


@njit
def _cast_by_plan_array(raws, shift, word, signed, quant, overflow, modes):
    plan = cast_plan(shift, word, signed, quant, overflow)
    out = np.empty_like(raws)
    flags = np.empty(raws.shape[0], dtype=np.bool_)
    for i in range(raws.shape[0]):
        out[i], flags[i] = cast_by_plan(raws[i], plan, modes)
    return out, flags


#: Every mode pair through the body for any modes; the plain pairs also through the plain
#: body (PLAIN_MODES), which the kernels take when every cast of a config is plain.
PLAN_BODIES = [(q, o, ANY_MODES) for q, o in MODE_PAIRS] + [
    (q, o, PLAIN_MODES) for q, o in MODE_PAIRS if q in PLAIN_QUANTS and o in PLAIN_OVERFLOWS
]


def test_plain_bodies_cover_the_plain_modes():
    plain = [(q.name, o.name) for q, o, m in PLAN_BODIES if m is PLAIN_MODES]
    assert sorted(plain) == sorted(
        (q, o) for q in ("TRN", "RND", "RND_MIN_INF") for o in ("SAT", "SAT_SYM")
    )


@pytest.mark.parametrize(
    ("quant", "overflow", "modes"),
    PLAN_BODIES,
    ids=lambda m: "plain" if m is None else ("any" if m is True else m.name),
)
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    target=formats,
    shift=st.one_of(st.integers(-3, 3), st.integers(-62, 62)),
    seed=st.integers(0, 2**32 - 1),
    extra=st.lists(st.integers(I64_MIN, I64_MAX), max_size=8),
)
def test_cast_by_plan_matches_fraction_reference(
    quant, overflow, modes, target, shift, seed, extra
):
    """The fused kernels' branch-free cast (either sign of the shift, left shifts that
    leave int64 included), in both bodies, equals the Fraction reference element by
    element."""
    signed, word, frac = target
    fmt = FixedFormat(signed, word, frac, quant, overflow)
    raws = np.concatenate([random_raws(seed, BATCH), np.array(extra, dtype=np.int64)])
    out, flags = _cast_by_plan_array(raws, shift, word, signed, int(quant), int(overflow), modes)
    expected = [reference_cast(int(r), frac + shift, fmt) for r in raws]
    assert out.tolist() == [value for value, _ in expected]
    assert flags.tolist() == [flag for _, flag in expected]


def to_signed(bits: int, word: int) -> int:
    return bits - (1 << word) if bits >= 1 << (word - 1) else bits


APY_PAIRS = [(q, o) for q, o in MODE_PAIRS if o in APY_OVERFLOW]


@pytest.mark.parametrize(("quant", "overflow"), APY_PAIRS, ids=lambda m: m.name)
@settings(max_examples=30, deadline=None)
@given(
    word_in=st.integers(1, 62),
    frac_in=st.integers(-40, 100),
    word_out=st.integers(1, 62),
    left=st.integers(-100, 62),
    seed=st.integers(0, 2**32 - 1),
)
def test_cast_matches_apytypes(quant, overflow, word_in, frac_in, word_out, left, seed):
    """apytypes 0.5.1 mis-saturates when the source, shifted left, needs more than 64 bits
    (e.g. s2.0 value 1 cast to s1.63 with SAT gives raw -1), so the left shift is capped."""
    frac_out = frac_in + min(left, 64 - word_in)
    rng = np.random.default_rng(seed)
    raws = [to_signed(int(b), word_in) for b in rng.integers(0, 2**word_in, BATCH, dtype=np.uint64)]
    raws[:2] = [-(2 ** (word_in - 1)), 2 ** (word_in - 1) - 1]
    source = apytypes.APyFixedArray([r % 2**word_in for r in raws], bits=word_in, frac_bits=frac_in)
    cast = source.cast(
        bits=word_out,
        frac_bits=frac_out,
        quantization=APY_QUANT[quant],
        overflow=APY_OVERFLOW[overflow],
    )
    expected = [to_signed(int(b), word_out) for b in cast.to_bits()]
    fmt = FixedFormat(True, word_out, frac_out, quant, overflow)
    out, _ = cast_array(np.array(raws, dtype=np.int64), frac_in, fmt)
    assert out.tolist() == expected


@pytest.mark.parametrize("quant", list(Quant), ids=lambda m: m.name)
def test_apytypes_ties_agree(quant):
    ties = apytypes.APyFixedArray([(-5) % 16, -3 % 16, -1 % 16, 1, 3, 5], bits=4, frac_bits=1)
    cast = ties.cast(bits=4, frac_bits=0, quantization=APY_QUANT[quant])
    row = next(r for r in rounding_table() if r["mode"] == quant.name)
    assert [to_signed(int(b), 4) for b in cast.to_bits()] == [row[k] for k in TIE_KEYS]


TIE_KEYS = ["-2.5", "-1.5", "-0.5", "0.5", "1.5", "2.5"]
EXPECTED_TIES = {
    "TRN": [-3, -2, -1, 0, 1, 2],
    "TRN_ZERO": [-2, -1, 0, 0, 1, 2],
    "RND": [-2, -1, 0, 1, 2, 3],
    "RND_ZERO": [-2, -1, 0, 0, 1, 2],
    "RND_INF": [-3, -2, -1, 1, 2, 3],
    "RND_MIN_INF": [-3, -2, -1, 0, 1, 2],
    "RND_CONV": [-2, -2, 0, 0, 2, 2],
}
EXPECTED_EQUIVALENTS = {
    "TRN": ("Floor", "fixed_truncate"),
    "TRN_ZERO": ("Zero", "none"),
    "RND": ("Nearest", "none"),
    "RND_ZERO": ("none", "none"),
    "RND_INF": ("Round", "none"),
    "RND_MIN_INF": ("none", "none"),
    "RND_CONV": ("Convergent", "fixed_round"),
}


def test_rounding_table_by_hand():
    table = rounding_table()
    assert [row["mode"] for row in table] == list(EXPECTED_TIES)
    for row in table:
        assert [row[k] for k in TIE_KEYS] == EXPECTED_TIES[row["mode"]]
        assert (row["matlab"], row["vhdl"]) == EXPECTED_EQUIVALENTS[row["mode"]]
        assert row["ap_fixed"] == "AP_" + row["mode"]


def test_rounding_table_markdown_rows():
    lines = rounding_table_markdown().splitlines()
    assert len(lines) == 2 + len(Quant)
    assert lines[-1] == "| `AP_RND_CONV` | -2 | -2 | 0 | 0 | 2 | 2 | Convergent | fixed_round |"


def test_rounding_doc_is_current():
    assert DOC.read_text(encoding="utf-8") == rounding_doc_text()


@pytest.mark.parametrize(
    ("raw", "shift", "quant", "expected"),
    [
        (7, 2, Quant.TRN, 1),
        (-7, 2, Quant.TRN, -2),
        (-7, 2, Quant.TRN_ZERO, -1),
        (-6, 2, Quant.RND, -1),
        (-6, 2, Quant.RND_ZERO, -1),
        (-6, 2, Quant.RND_INF, -2),
        (-6, 2, Quant.RND_MIN_INF, -2),
        (-6, 2, Quant.RND_CONV, -2),
        (-10, 2, Quant.RND_CONV, -2),
        (3, -4, Quant.RND, 48),
        (I64_MIN, 63, Quant.TRN, -1),
        (I64_MIN, 64, Quant.RND, 0),
        (I64_MIN, 64, Quant.RND_MIN_INF, -1),
        (I64_MIN, 65, Quant.RND_INF, 0),
        (I64_MAX, 200, Quant.TRN, 0),
        (-1, 200, Quant.TRN, -1),
        (-1, 200, Quant.TRN_ZERO, 0),
    ],
)
def test_quantise_shift_known_answers(raw, shift, quant, expected):
    assert quantise_shift(np.int64(raw), shift, int(quant)) == expected


@pytest.mark.parametrize(
    ("raw", "word", "signed", "mode", "expected"),
    [
        (8, 4, True, Overflow.WRAP, (-8, True)),
        (-9, 4, True, Overflow.WRAP, (7, True)),
        (16, 4, False, Overflow.WRAP, (0, True)),
        (-1, 4, False, Overflow.WRAP, (15, True)),
        (100, 4, True, Overflow.SAT, (7, True)),
        (-100, 4, False, Overflow.SAT, (0, True)),
        (100, 4, True, Overflow.SAT_ZERO, (0, True)),
        (-8, 4, True, Overflow.SAT_SYM, (-7, True)),
        (-7, 4, True, Overflow.SAT_SYM, (-7, False)),
        (-8, 4, True, Overflow.SAT, (-8, False)),
        (20, 4, False, Overflow.SAT_SYM, (15, True)),
        (0, 1, True, Overflow.SAT_SYM, (0, False)),
        (-1, 1, True, Overflow.SAT_SYM, (-1, False)),
        (-2, 1, True, Overflow.SAT_SYM, (-1, True)),
    ],
)
def test_overflow_raw_known_answers(raw, word, signed, mode, expected):
    value, flag = overflow_raw(np.int64(raw), word, signed, int(mode))
    assert (int(value), bool(flag)) == expected


@njit(cache=False)
def _double_cast(raw, frac_in):
    first, flag1 = cast_raw(raw, frac_in, 20, 4, True, 6, 1)
    second, flag2 = cast_raw(first, 4, 8, 0, False, 2, 0)
    return second, flag1 or flag2


def test_kernels_callable_from_njit():
    assert _double_cast(np.int64(1000), 6) == (16, False)
    assert _double_cast(np.int64(-1000), 6) == (240, True)


def test_cast_array_shape_and_validation():
    fmt = FixedFormat(True, 8, 2, Quant.RND, Overflow.SAT)
    out, count = cast_array(np.arange(-6, 6, dtype=np.int32).reshape(3, 4), 3, fmt)
    assert out.shape == (3, 4)
    assert out.dtype == np.int64
    assert out.ravel().tolist() == [-3, -2, -2, -1, -1, 0, 0, 1, 1, 2, 2, 3]
    assert count == 0
    with pytest.raises(ValueError, match="float64"):
        cast_array(np.zeros(3), 0, fmt)
    with pytest.raises(ValueError, match=r"1\.5"):
        cast_array(np.zeros(3, dtype=np.int64), 1.5, fmt)
    with pytest.raises(ValueError, match=str(2**64 - 1)):
        cast_array(np.array([2**64 - 1], dtype=np.uint64), 0, fmt)
    with pytest.raises(ValueError, match=r"'s8\.2'"):
        cast_array(np.zeros(3, dtype=np.int64), 0, "s8.2")


def test_format_properties():
    fmt = FixedFormat(True, 16, 8, Quant.RND, Overflow.SAT)
    assert fmt.describe() == "ap_fixed<16,8,AP_RND,AP_SAT>"
    assert (fmt.int_bits, fmt.raw_min, fmt.raw_max, fmt.lsb) == (8, -32768, 32767, 2**-8)
    ufmt = FixedFormat(False, 12, -2, Quant.RND_CONV, Overflow.SAT_SYM)
    assert ufmt.describe() == "ap_ufixed<12,14,AP_RND_CONV,AP_SAT_SYM>"
    assert (ufmt.raw_min, ufmt.raw_max, ufmt.lsb) == (0, 4095, 4.0)
    assert FixedFormat.from_string("u12.-2", Quant.RND_CONV, Overflow.SAT_SYM) == ufmt
    assert str(ufmt) == "u12.-2"
    assert FixedFormat(True, 4, 0, 2, 1).quant is Quant.RND


def test_from_float_and_to_float():
    fmt = FixedFormat(True, 16, 8, Quant.RND_CONV, Overflow.SAT)
    assert fmt.from_float(1.5 / 256) == 2
    assert fmt.from_float(2.5 / 256) == 2
    assert fmt.from_float(-2.5 / 256) == -2
    assert fmt.from_float(1e300) == 32767
    assert fmt.from_float(-5e-324) == 0
    assert fmt.from_float(0.1) == 26
    assert fmt.to_float(-384) == -1.5
    assert fmt.to_float(np.array([1, -2])).tolist() == [2**-8, -(2**-7)]
    trn = FixedFormat(True, 8, 0)
    assert trn.from_float(-5e-324) == -1
    assert trn.from_float(130.0) == -126
    with pytest.raises(ValueError, match="nan"):
        fmt.from_float(float("nan"))


@pytest.mark.parametrize(("quant", "overflow"), MODE_PAIRS, ids=lambda m: m.name)
@settings(max_examples=20, deadline=None)
@given(
    x=st.floats(allow_nan=False, allow_infinity=False),
    target=formats,
)
def test_from_float_matches_fraction_reference(quant, overflow, x, target):
    fmt = FixedFormat(*target, quant, overflow)
    n = reference_round(Fraction(x) * Fraction(2) ** fmt.frac, quant)
    assert fmt.from_float(x) == reference_overflow(n, fmt.word, fmt.signed, overflow)[0]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"word": 0}, "not 0"),
        ({"word": 63}, "not 63"),
        ({"word": 16.0}, "not 16.0"),
        ({"frac": 2000}, "not 2000"),
        ({"quant": 7}, "Quant, not 7"),
        ({"quant": "RND"}, "Quant, not 'RND'"),
        ({"overflow": 4}, "Overflow, not 4"),
        ({"overflow": Quant.RND}, "Overflow, not <Quant.RND: 2>"),
        ({"signed": 1}, "bool, not 1"),
    ],
)
def test_format_validation(kwargs, match):
    args = {"signed": True, "word": 16, "frac": 8} | kwargs
    with pytest.raises(ValueError, match=match):
        FixedFormat(**args)


def test_from_string_rejects_garbage():
    with pytest.raises(ValueError, match=r"'x16\.8'"):
        FixedFormat.from_string("x16.8")
