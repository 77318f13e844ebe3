"""Bit-exactness of the numba P1 model against the independent apytypes oracle.

Every tap, every overflow count and every pre-quantisation min/max of
``rangefx.rtl_model.p1.run_p1`` must equal ``tests/oracle_p1.py`` exactly, over random
small scenes x both estimator variants x both dividers x stereo and motion x configs that
put every signal into each quantisation mode and each overflow mode (narrowed so that
overflows happen), with and without blanking and input gaps (which must not change any
value).
"""

from __future__ import annotations

import itertools
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from oracle_p1 import oracle_p1

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.ranging import RangingConfig
from rangefx.golden.scenes import render_plane
from rangefx.rtl_model.config import HOST_REGISTERS, P1_SIGNALS, TimingConfig, WordLengthConfig
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.p1 import run_p1

DIVIDER_OUTPUTS = ("div_quot", "range")
REGISTERS = ("pix_in", *HOST_REGISTERS)  # the input and the host-written registers keep their width
TIMINGS = (
    TimingConfig(),
    TimingConfig(hblank=5, vblank=7),
    TimingConfig(hblank=3, vblank=2, gap_prob=0.4, seed=11),
)
MOTION = MotionIncrement.from_attitudes(
    camera_angles=(0.0, -0.05, 0.0),
    camera_offset=(1.0, 0.0, 0.2),
    attitude1=(0.10, -0.03, 0.01),
    attitude2=(0.1014, -0.0290, 0.0121),
    position1=(0.0, 0.0, -3.0),
    position2=(0.6, -0.05, -2.98),
)


def mode_config(
    variant: str,
    divider: str,
    quant: Quant,
    overflow: Overflow,
    narrow: bool,
    seed: int,
    **design,
) -> WordLengthConfig:
    """Default config with every signal in ``quant``/``overflow`` (divider outputs keep a
    saturating mode); ``narrow`` drops 1..5 integer bits and 0..3 fraction bits of every
    datapath signal (registers and the input keep their width) so that overflows happen.
    ``design``: other design fields (pole, bias, init, recip_lut_bits, recip_bits)."""
    base = WordLengthConfig.default(variant).with_(divider=divider, **design)
    rng = np.random.default_rng(seed)
    formats = {}
    for name in P1_SIGNALS:
        f = base.fmt(name)
        ovf = overflow
        if name in DIVIDER_OUTPUTS and overflow is Overflow.WRAP:
            ovf = Overflow.SAT
        word, frac = f.word, f.frac
        if narrow and name not in REGISTERS:
            d_int, d_frac = int(rng.integers(1, 6)), int(rng.integers(0, 4))
            word = max(2, word - d_int - d_frac)
            frac = frac - d_frac
        formats[name] = FixedFormat(f.signed, word, frac, quant, ovf)
    return base.with_(formats=formats)


_PLANE = {}


def _plane():
    if "scene" not in _PLANE:
        _PLANE["scene"] = render_plane(depth=4.0, size=(24, 24), seed=5, baseline=0.2)
    return _PLANE["scene"]


def make_scene(seed: int, kind: str, mode: str):
    """(image1, image2, camera, motion) of a tiny random scene."""
    rng = np.random.default_rng(seed)
    m, n = int(rng.integers(6, 11)), int(rng.integers(8, 12))
    if kind == "plane":
        scene = _plane()
        j0, i0 = int(rng.integers(0, 24 - m)), int(rng.integers(0, 24 - n))
        crop = (slice(j0, j0 + m), slice(i0, i0 + n))
        im1, im2 = scene.image1[crop].copy(), scene.image2[crop].copy()
        f_px = scene.camera.f_px
    else:
        im1 = rng.integers(0, 256, (m, n)).astype(np.uint8)
        # the second image: the first shifted by a fraction of a pixel, plus noise
        shifted = 0.7 * im1.astype(float) + 0.3 * np.roll(im1, 1, axis=1)
        im2 = np.clip(np.rint(shifted + rng.normal(0, 3, (m, n))), 0, 255).astype(np.uint8)
        f_px = float(rng.uniform(12.0, 40.0))
    cx = float(rng.uniform(0, n - 1)) if rng.random() < 0.5 else None
    cy = float(rng.uniform(0, m - 1)) if rng.random() < 0.5 else None
    camera = PinholeCamera(n, m, f_px, cx=cx, cy=cy)
    motion = MOTION if mode == "motion" else MotionIncrement.stereo(0.2)
    return im1, im2, camera, motion


DESIGNS = (
    {},
    {"pole": 0.3, "bias": 5.3, "init": "zero"},
    {"pole": 0.75, "recip_lut_bits": 5, "recip_bits": 13},
    {"pole": 0.61, "bias": 20.7, "recip_lut_bits": 3, "recip_bits": 8},
    {"init": "zero", "bias": 0.0},
)


def _cases():
    cases = []
    for i, (quant, overflow) in enumerate(itertools.product(Quant, Overflow)):
        cases.append(
            pytest.param(
                dict(
                    quant=quant,
                    overflow=overflow,
                    variant=("paper", "consistent")[i % 2],
                    divider=("restoring", "reciprocal")[(i // 2) % 2],
                    mode=("stereo", "motion")[(i // 4) % 2],
                    narrow=i % 5 != 2,
                    timing=TIMINGS[(i // 3) % 3],
                    kind="plane" if i % 5 == 0 else "random",
                    seed=1000 + i,
                    design=DESIGNS[i % len(DESIGNS)],
                ),
                id=f"{i}-{quant.name}-{overflow.name}",
            )
        )
    return cases


def assert_bit_exact(res, ref) -> None:
    assert set(res.taps) == set(ref.taps)
    bad = []
    for name, want in ref.taps.items():
        got = np.asarray(res.taps[name])
        if got.dtype != np.int64 and name != "valid":
            bad.append(f"{name}: dtype {got.dtype}")
        if not np.array_equal(got.astype(np.int64), want):
            where = np.argwhere(got.astype(np.int64) != want)
            j, i = (int(v) for v in where[0]) if len(where) else (-1, -1)
            first = (got[j, i], want[j, i]) if j >= 0 else ("shape", got.shape)
            bad.append(f"{name}: {len(where)} pixels differ, first at (j={j}, i={i}): {first}")
    assert not bad, "taps differ from the oracle:\n" + "\n".join(bad)
    assert dict(res.overflows) == ref.overflows
    assert dict(res.minmax) == ref.minmax


@pytest.mark.parametrize("case", _cases())
def test_p1_bit_exact(case):
    cfg = mode_config(
        case["variant"],
        case["divider"],
        case["quant"],
        case["overflow"],
        case["narrow"],
        case["seed"],
        **case["design"],
    )
    im1, im2, camera, motion = make_scene(case["seed"], case["kind"], case["mode"])
    ranging = RangingConfig(threshold_e=1.0, threshold_g=0.7, range_max=60.0, min_denominator=0.3)
    ref = oracle_p1(im1, im2, camera, motion, cfg, ranging, mode=case["mode"])
    res = run_p1(
        im1, im2, camera, motion, cfg, ranging, timing=case["timing"], mode=case["mode"], taps=True
    )
    assert_bit_exact(res, ref)
    if case["narrow"]:
        # not vacuous: the overflow mode under test acted on some non-divider signal
        acted = sum(
            n for s, n in ref.overflows.items() if s not in DIVIDER_OUTPUTS and s not in REGISTERS
        )
        assert acted > 0


@pytest.mark.parametrize("variant", ["paper", "consistent"])
@pytest.mark.parametrize("mode", ["stereo", "motion"])
def test_default_config_bit_exact_on_plane_crops(variant, mode):
    """The shipped config (no overflow in the datapath expected) on a textured plane, with
    the same input under three timings: gaps and blanking change no value."""
    cfg = WordLengthConfig.default(variant)
    im1, im2, camera, motion = make_scene(7 if mode == "stereo" else 8, "plane", mode)
    ranging = RangingConfig(threshold_e=1.0, threshold_g=0.7, range_max=60.0, min_denominator=0.3)
    ref = oracle_p1(im1, im2, camera, motion, cfg, ranging, mode=mode)
    for timing in TIMINGS:
        res = run_p1(im1, im2, camera, motion, cfg, ranging, timing=timing, mode=mode)
        assert_bit_exact(res, ref)
    assert ref.taps["valid"].any()


def test_cases_cover_every_mode():
    cases = [p.values[0] for p in _cases()]
    assert {c["quant"] for c in cases} == set(Quant)
    assert {c["overflow"] for c in cases} == set(Overflow)
    for key, values in (
        ("variant", {"paper", "consistent"}),
        ("divider", {"restoring", "reciprocal"}),
        ("mode", {"stereo", "motion"}),
        ("narrow", {True, False}),
        ("kind", {"plane", "random"}),
    ):
        assert {c[key] for c in cases} == values
    assert {c["design"].get("init", "first") for c in cases} == {"first", "zero"}
    assert {c["timing"] for c in cases} == set(TIMINGS)
    # every overflow mode is exercised with narrow formats, every quant mode too
    assert {c["overflow"] for c in cases if c["narrow"]} == set(Overflow)
    assert {c["quant"] for c in cases if c["narrow"]} == set(Quant)


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("overflow", [Overflow.WRAP, Overflow.SAT])
def test_pixel_counters_overflow_per_pixel(threads, overflow):
    """Counters narrowed to 3 bits overflow in both directions: ``xp`` and ``yp`` are cast
    once per pixel (docs/p1_datapath.md), whatever the model holds per line or band."""
    cfg = WordLengthConfig.default("paper").with_formats(
        coord=FixedFormat(True, 3, 0, Quant.TRN, overflow)
    )
    im1, im2, camera, motion = make_scene(21, "random", "stereo")
    m, n = im1.shape
    camera = PinholeCamera(n, m, camera.f_px, cx=0.0, cy=0.0)  # counters 0..n-1 > 3
    ranging = RangingConfig(threshold_e=1.0, threshold_g=0.7, range_max=60.0, min_denominator=0.3)
    ref = oracle_p1(im1, im2, camera, motion, cfg, ranging)
    res = run_p1(im1, im2, camera, motion, cfg, ranging, threads=threads)
    assert (ref.taps["yp"] != np.arange(m)[:, None]).any()  # yp overflowed
    assert (ref.taps["xp"] != np.arange(n)[None, :]).any()  # so did xp
    assert_bit_exact(res, ref)
