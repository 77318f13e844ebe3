"""P1-specific bit-exactness against the apytypes oracle (the mode x design x timing
matrix of every pipeline is ``tests/test_bitexact.py``): the pixel counters, cast once
per pixel, overflow per pixel whatever the model holds per line or band."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from oracles import ORACLES
from test_bitexact import assert_bit_exact

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.ranging import RangingConfig
from rangefx.golden.scenes import render_plane
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.p1 import run_p1
from rangefx.rtl_model.p1.config import P1Config
from rangefx.rtl_model.pipeline import Case

MOTION = MotionIncrement.from_attitudes(
    camera_angles=(0.0, -0.05, 0.0),
    camera_offset=(1.0, 0.0, 0.2),
    attitude1=(0.10, -0.03, 0.01),
    attitude2=(0.1014, -0.0290, 0.0121),
    position1=(0.0, 0.0, -3.0),
    position2=(0.6, -0.05, -2.98),
)


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


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("overflow", [Overflow.WRAP, Overflow.SAT])
def test_pixel_counters_overflow_per_pixel(threads, overflow):
    """Counters narrowed to 3 bits overflow in both directions: ``xp`` and ``yp`` are cast
    once per pixel (docs/p1_datapath.md), whatever the model holds per line or band."""
    cfg = P1Config.default(variant="paper").with_formats(
        coord=FixedFormat(True, 3, 0, Quant.TRN, overflow)
    )
    im1, im2, camera, motion = make_scene(21, "random", "stereo")
    m, n = im1.shape
    camera = PinholeCamera(n, m, camera.f_px, cx=0.0, cy=0.0)  # counters 0..n-1 > 3
    ranging = RangingConfig(threshold_e=1.0, threshold_g=0.7, range_max=60.0, min_denominator=0.3)
    ref = ORACLES["p1"].run(Case(im1, im2, camera, motion, "stereo", ranging), cfg)
    res = run_p1(im1, im2, camera, motion, cfg, ranging, threads=threads)
    assert (ref.taps["yp"] != np.arange(m)[:, None]).any()  # yp overflowed
    assert (ref.taps["xp"] != np.arange(n)[None, :]).any()  # so did xp
    assert_bit_exact(res, ref)
