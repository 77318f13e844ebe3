"""The real Vitis HLS ``ap_fixed`` headers as the reference of every cast (SPEC §4, §11).

A small C++ program, built with g++ against the ``ap_types`` headers that ship in the
hls4ml wheel (``hls4ml/templates/vivado/ap_types/``), casts raw codes into every target
format below under every quantisation x overflow mode pair and prints the result and its
overflow flag; :func:`cast_raw` and :func:`cast_array` must agree bit for bit.

The overflow flag of the header side is "the result differs from the exactly quantised
value" (the quantised value held in a format wide enough for it): what rangefx counts as
an overflow. The headers are found in ``$RANGEFX_AP_TYPES`` or in an installed hls4ml;
without them or without g++ the test skips (``RANGEFX_REQUIRE_AP_TYPES=1``, as CI sets
it, turns that skip into a failure). To get them: ``pip download --no-deps hls4ml`` and
unzip ``hls4ml/templates/vivado/ap_types/`` from the wheel.
"""

from __future__ import annotations

import hashlib
import itertools
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from ap_types import ap_types_dir, skip_or_fail

from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant, cast_array, cast_raw

I64_MIN, I64_MAX = -(2**63), 2**63 - 1
MODE_PAIRS = list(itertools.product(Quant, Overflow))
#: (signed, W, F, frac_in): W 1..62, F -30..70, shift = frac_in - F from -78 to +93, and
#: the 1-bit and 2-bit signed formats where SAT_SYM's clamp is a corner.
TARGETS: tuple[tuple[bool, int, int, int], ...] = (
    (True, 1, 0, 0),
    (True, 1, 0, 3),
    (True, 1, 2, -5),
    (False, 1, 0, 2),
    (True, 2, 0, 1),
    (True, 2, 1, 8),
    (True, 3, 0, 2),
    (False, 3, 1, 4),
    (True, 8, 4, 12),
    (False, 8, 0, 8),
    (True, 12, -3, 0),
    (True, 16, 4, 20),
    (False, 16, 16, 30),
    (True, 20, 10, -8),
    (True, 24, 70, 40),
    (True, 30, -30, 63),
    (False, 31, 12, 0),
    (True, 32, 16, 48),
    (True, 40, 20, 60),
    (True, 48, 0, -30),
    (False, 50, 10, 72),
    (True, 55, 5, 98),
    (True, 61, 30, 0),
    (True, 62, 0, 62),
    (True, 62, 61, 0),
    (False, 62, 8, 40),
    (True, 62, 70, -8),
    (True, 10, -8, 85),
)
N_RANDOM = 160


def _raws(frac_in: int, word: int, frac: int, seed: int) -> np.ndarray:
    """Boundary values of the target (its codes, codes +-1, ties, half LSBs, at the
    input's scale where representable), int64 extremes and random values of every size."""
    rng = np.random.default_rng(seed)
    shift = frac_in - frac
    edges: set[int] = {0, 1, -1, 2, -2, I64_MIN, I64_MAX, I64_MIN + 1, I64_MAX - 1}
    for code in (0, 1, -1, 2**word, 2 ** (word - 1), -(2 ** (word - 1)), 2**word - 1):
        for d in (-1, 0, 1):
            for extra in (0, 1, -1) if shift > 0 else (0,):
                c = code + d
                v = c << shift if shift >= 0 else c >> -shift
                if shift > 0:  # the tie below and above the code
                    v += extra * (1 << (shift - 1))
                if I64_MIN <= v <= I64_MAX:
                    edges.add(v)
    bits = rng.integers(1, 64, N_RANDOM)
    rand = [int(rng.integers(-(2 ** int(b - 1)), 2 ** int(b - 1))) for b in bits]
    return np.array(sorted(edges) + rand, dtype=np.int64)


_RUN = [
    "#include <ap_fixed.h>",
    "#include <cstdio>",
    "template <bool S, int W, int I, ap_q_mode Q, ap_o_mode O> struct TM {",
    "  typedef ap_fixed<W, I, Q, O> t; };",
    "template <int W, int I, ap_q_mode Q, ap_o_mode O> struct TM<false, W, I, Q, O> {",
    "  typedef ap_ufixed<W, I, Q, O> t; };",
    "template <int FIN, int WIN, bool S, int W, int F, ap_q_mode Q, ap_o_mode O, int IQ>",
    "void run(long long raw) {",
    # the raw, sign-extended to WIN >= 66 bits: the header asserts ("read bit beyond MSB")
    # when a cast drops more bits than its source holds
    "  ap_fixed<WIN, WIN - FIN> x;",
    "  x.range(WIN - 1, 0) = ap_int<WIN>(raw);",
    "  typename TM<S, W, W - F, Q, O>::t y = x;",
    "  ap_fixed<IQ + F, IQ, Q, AP_WRAP> q = x;  // exactly quantised",
    "  ap_fixed<IQ + F, IQ> yw = y;",
    "  unsigned long long u = y.range(W - 1, 0).to_uint64();",
    "  long long v = (long long)u;",
    "  if (S && ((u >> (W - 1)) & 1ULL)) v = (long long)(u - (1ULL << W));",
    '  std::printf("%lld %d\\n", v, (int)(yw != q));',
    "}",
]


def _cpp_sources(cases: list[tuple[int, bool, int, int, int]], parts: int) -> list[str]:
    """``parts`` translation units (built in parallel), each one function per (target,
    mode pair) that casts a raw and prints value and flag, plus the main that reads
    ``case raw`` lines and dispatches."""
    q_names = {q: f"AP_{q.name}" for q in Quant}
    o_names = {o: f"AP_{o.name}" for o in Overflow}
    units = []
    for part in range(parts):
        lines = [*_RUN, f"bool dispatch{part}(int fn, long long raw) {{", "  switch (fn) {"]
        for k, (frac_in, signed, word, frac, pair) in enumerate(cases):
            if k % parts != part:
                continue
            quant, overflow = MODE_PAIRS[pair]
            # integer bits that hold the exactly quantised value (the input's, or one
            # LSB's) and every result of the target, with a spare bit
            win = max(66, frac_in - frac + 4)
            iq = max(win - frac_in, 2 - frac, word - frac) + 2
            lines.append(
                f"    case {k}: run<{frac_in}, {win}, {str(signed).lower()}, {word}, {frac}, "
                f"{q_names[quant]}, {o_names[overflow]}, {iq}>(raw); return true;"
            )
        units.append("\n".join([*lines, "  }", "  return false;", "}"]) + "\n")
    calls = " || ".join(f"dispatch{p}(fn, raw)" for p in range(parts))
    main = [
        "#include <cstdio>",
        *(f"bool dispatch{p}(int fn, long long raw);" for p in range(parts)),
        "int main() {",
        "  long long raw; int fn;",
        '  while (std::scanf("%d %lld", &fn, &raw) == 2) {',
        f"    if (!({calls})) return 1;",
        "  }",
        "  return 0;",
        "}",
    ]
    return [*units, "\n".join(main) + "\n"]


@pytest.fixture(scope="module")
def header_binary(tmp_path_factory) -> Path:
    gxx = shutil.which("g++")
    if gxx is None:
        skip_or_fail("g++ is not installed")
    ap_types = ap_types_dir()
    if ap_types is None or not (ap_types / "ap_fixed.h").is_file():
        skip_or_fail("the ap_types headers are not found ($RANGEFX_AP_TYPES or hls4ml)")
    cases = [
        (frac_in, signed, word, frac, pair)
        for signed, word, frac, frac_in in TARGETS
        for pair in range(len(MODE_PAIRS))
    ]
    sources = _cpp_sources(cases, parts=max(1, min(4, os.cpu_count() or 1)))
    # the build takes a minute: keep the binary between runs, keyed by sources + headers
    blob = "".join(sources[:-1]).encode() + str(ap_types.resolve()).encode()
    cache = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "rangefx"
    binary = cache / f"ap_fixed_ref-{hashlib.sha256(blob).hexdigest()[:16]}"
    if not binary.is_file():
        work = tmp_path_factory.mktemp("apfixed")
        builds = []
        for k, text in enumerate(sources):  # -O0: builds in about 2/3 of -O1's time
            (work / f"u{k}.cpp").write_text(text)
            builds.append(subprocess.Popen(
                [gxx, "-O0", "-std=c++14", "-w", f"-I{ap_types}", "-c", f"u{k}.cpp"],
                cwd=work, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            ))  # fmt: skip
        for b in builds:
            _, err = b.communicate()
            assert b.returncode == 0, err[-3000:]
        objects = [f"u{k}.o" for k in range(len(sources))]
        built = subprocess.run(
            [gxx, *objects, "-o", "ref"], cwd=work, capture_output=True, text=True, check=False
        )
        assert built.returncode == 0, built.stderr[-3000:]
        try:
            cache.mkdir(parents=True, exist_ok=True)
            os.replace(work / "ref", binary)
        except OSError:
            binary = work / "ref"
    return binary


def test_casts_match_the_ap_fixed_header(header_binary: Path):
    raws_of = [_raws(frac_in, word, frac, seed=t) for t, (_, word, frac, frac_in) in
               enumerate(TARGETS)]  # fmt: skip
    requests = [
        f"{t * len(MODE_PAIRS) + pair} {int(r)}"
        for t, raws in enumerate(raws_of)
        for pair in range(len(MODE_PAIRS))
        for r in raws
    ]
    out = subprocess.run(
        [str(header_binary)], input="\n".join(requests) + "\n",
        capture_output=True, text=True, check=True,
    ).stdout.split("\n")  # fmt: skip
    header = np.array([line.split() for line in out if line], dtype=np.int64)
    assert header.shape == (len(requests), 2)
    mismatches: dict[str, int] = {}
    checked = 0
    row = 0
    for (signed, word, frac, frac_in), raws in zip(TARGETS, raws_of, strict=True):
        for quant, overflow in MODE_PAIRS:
            ref = header[row : row + raws.size]
            row += raws.size
            fmt = FixedFormat(signed, word, frac, quant, overflow)
            scalar = np.array(
                [cast_raw(r, frac_in, word, frac, signed, int(quant), int(overflow)) for r in raws],
                dtype=np.int64,
            )
            array, count = cast_array(raws, frac_in, fmt)
            bad = (scalar[:, 0] != ref[:, 0]) | (scalar[:, 1] != ref[:, 1])
            bad |= array != ref[:, 0]
            if count != int(ref[:, 1].sum()):
                bad[0] = True
            checked += raws.size
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                mismatches[f"{fmt.describe()} from frac {frac_in}"] = int(bad.sum())
                mismatches[f"{fmt.describe()} first: raw {int(raws[i])}"] = int(ref[i, 0])
    assert checked == len(requests)
    assert not mismatches, mismatches


@pytest.mark.parametrize(
    ("raw", "frac_in", "expected"),
    [(-1, 0, (-1, False)), (-5, 0, (-1, True)), (-1, 3, (-1, False)), (3, 0, (0, True))],
)
def test_signed_one_bit_sat_sym_follows_the_header(raw, frac_in, expected):
    """For W = 1 the header's symmetric clamp leaves the sign bit set: SAT_SYM acts as SAT."""
    value, flag = cast_raw(raw, frac_in, 1, 0, True, int(Quant.TRN), int(Overflow.SAT_SYM))
    assert (int(value), bool(flag)) == expected
