"""Bit-exactness of the numba P2 model against the independent apytypes oracle.

Every tap, every overflow count and every pre-quantisation min/max of
``rangefx.rtl_model.p2.run_p2`` must equal ``tests/oracle_p2.py`` exactly, over random
small scenes (crops of ``lab`` and random shifted textures) x both dividers x G5 weights x
configs putting every signal into each quantisation mode and each overflow mode (narrowed
so that overflows happen), under three timings (which must not change any value).
"""

from __future__ import annotations

import itertools
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from oracle_p2 import oracle_p2

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.riccati import PAPER_PIXEL_PITCH_IN, RiccatiConfig
from rangefx.golden.scenes import render_scene
from rangefx.rtl_model.config import TimingConfig
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.p2 import run_p2
from rangefx.rtl_model.p2_config import P2_SIGNALS, P2Config

REGISTERS = ("p2_pix", "p2_ka_reg", "p2_m_reg")
TIMINGS = (
    TimingConfig(),
    TimingConfig(hblank=5, vblank=7),
    TimingConfig(hblank=3, vblank=2, gap_prob=0.4, seed=11),
)
RICCATI = (
    RiccatiConfig(threshold_e=2.0, range_max=100.0),
    RiccatiConfig(alpha=2.0, beta=4e-3, gamma=1e3, threshold_e=1.5, range_max=60.0),
    RiccatiConfig(alpha=1.0, beta=1e-3, gamma=1e6, pixel_pitch=1.0, threshold_e=0.5),
    RiccatiConfig(alpha=0.5, beta=2e-3, gamma=1e8, pixel_pitch=PAPER_PIXEL_PITCH_IN * 2),
)
DESIGNS = (
    {},
    {"kappa_min": 0.1, "recip_lut_bits": 5, "recip_bits": 13},
    {"kappa_min": 2.0**-9, "lanes": 40},
    {"recip_lut_bits": 3, "recip_bits": 8},
)


def mode_config(divider: str, quant: Quant, overflow: Overflow, narrow: bool, seed: int,
                **design) -> P2Config:  # fmt: skip
    """Default config with every signal in ``quant``/``overflow`` (the divider output keeps
    a saturating mode); ``narrow`` drops 2..12 integer and 0..3 fraction bits of every
    datapath signal (registers and the input keep their width)."""
    base = P2Config.default().with_(divider=divider, **design)
    rng = np.random.default_rng(seed)
    formats = {}
    for name in P2_SIGNALS:
        f = base.fmt(name)
        ovf = Overflow.SAT if name == "p2_r" and overflow is Overflow.WRAP else overflow
        word, frac = f.word, f.frac
        if narrow and name not in REGISTERS:
            d_int, d_frac = int(rng.integers(2, 13)), int(rng.integers(0, 4))
            word = max(2, word - d_int - d_frac)
            frac -= d_frac
        formats[name] = FixedFormat(f.signed, word, frac, quant, ovf)
    return base.with_(formats=formats)


_LAB = {}


def make_scene(seed: int, kind: str):
    rng = np.random.default_rng(seed)
    m, n = int(rng.integers(2, 5)), int(rng.integers(8, 14))
    if kind == "lab":
        if "lab" not in _LAB:
            _LAB["lab"] = render_scene("lab")
        s = _LAB["lab"]
        j0, i0 = int(rng.integers(100, 400)), int(rng.integers(100, 400))
        crop = (slice(j0, j0 + m), slice(i0, i0 + n))
        return s.image1[crop].copy(), s.image2[crop].copy(), PinholeCamera(n, m, s.camera.f_px), 0.1
    im1 = rng.integers(0, 256, (m, n)).astype(np.uint8)
    shifted = 0.6 * im1.astype(float) + 0.4 * np.roll(im1, -1, axis=1)
    im2 = np.clip(np.rint(shifted + rng.normal(0, 2, (m, n))), 0, 255).astype(np.uint8)
    im2[:, : n // 3] = im1[:, : n // 3]  # a flat run (E1 = E2: A = 0, the c floor acts)
    return im1, im2, PinholeCamera(n, m, float(rng.uniform(400, 800))), 0.1


def _cases():
    cases = []
    for i, (quant, overflow) in enumerate(itertools.product(Quant, Overflow)):
        cases.append(
            pytest.param(
                dict(
                    quant=quant,
                    overflow=overflow,
                    divider=("restoring", "reciprocal")[i % 2],
                    narrow=i % 5 != 2,
                    timing=TIMINGS[(i // 2) % 3],
                    kind="lab" if i % 3 == 0 else "random",
                    seed=2000 + i,
                    design=DESIGNS[i % len(DESIGNS)],
                    riccati=RICCATI[(i // 3) % len(RICCATI)],
                ),
                id=f"{i}-{quant.name}-{overflow.name}",
            )
        )
    return cases


def assert_bit_exact(res, ref) -> None:
    assert set(res.taps) == set(ref.taps)
    bad = []
    for name, want in ref.taps.items():
        got = np.asarray(res.taps[name]).astype(np.int64)
        if not np.array_equal(got, want):
            where = np.argwhere(got != want)
            j, i = (int(v) for v in where[0])
            bad.append(f"{name}: {len(where)} differ, first (j={j}, i={i}): {got[j, i]} vs "
                       f"{want[j, i]}")  # fmt: skip
    assert not bad, "taps differ from the oracle:\n" + "\n".join(bad)
    assert np.array_equal(res.range_raw, ref.taps["range"])
    assert np.array_equal(res.valid, ref.taps["valid"].astype(bool))
    assert dict(res.overflows) == ref.overflows
    assert dict(res.minmax) == ref.minmax


@pytest.mark.parametrize("case", _cases())
def test_p2_bit_exact(case):
    cfg = mode_config(case["divider"], case["quant"], case["overflow"], case["narrow"],
                      case["seed"], **case["design"])  # fmt: skip
    im1, im2, camera, b = make_scene(case["seed"], case["kind"])
    motion = MotionIncrement.stereo(b)
    ref = oracle_p2(im1, im2, camera, motion, cfg, case["riccati"])
    res = run_p2(im1, im2, camera, motion, cfg, case["riccati"], timing=case["timing"])
    assert_bit_exact(res, ref)
    if case["narrow"]:
        assert sum(v for k, v in ref.overflows.items() if k != "p2_r") > 0


def test_default_config_bit_exact_on_lab_crop_any_timing():
    cfg = P2Config.default()
    im1, im2, camera, b = make_scene(3, "lab")
    riccati = RiccatiConfig(threshold_e=2.0, range_max=100.0)
    ref = oracle_p2(im1, im2, camera, MotionIncrement.stereo(b), cfg, riccati)
    assert sum(ref.overflows.values()) == 0
    assert ref.taps["valid"].any()
    for timing in TIMINGS:
        res = run_p2(im1, im2, camera, MotionIncrement.stereo(b), cfg, riccati, timing=timing)
        assert_bit_exact(res, ref)


def test_cases_cover_every_mode():
    cases = [p.values[0] for p in _cases()]
    assert {c["quant"] for c in cases if c["narrow"]} == set(Quant)
    assert {c["overflow"] for c in cases if c["narrow"]} == set(Overflow)
    assert {c["divider"] for c in cases} == {"restoring", "reciprocal"}
    assert {c["kind"] for c in cases} == {"lab", "random"}
    assert {c["timing"] for c in cases} == set(TIMINGS)
