"""P1-specific bit-exactness against the apytypes oracle (the mode x design x timing
matrix of every pipeline is ``tests/test_bitexact.py``): the pixel counters, cast once
per pixel, overflow per pixel whatever the model holds per line or band."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from bitexact_cases import assert_bit_exact, p1_case
from oracles import ORACLES

from rangefx.golden.geometry import PinholeCamera
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.p1.config import P1Config
from rangefx.rtl_model.registry import PIPELINES


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("overflow", [Overflow.WRAP, Overflow.SAT])
def test_pixel_counters_overflow_per_pixel(threads, overflow):
    """Counters narrowed to 3 bits overflow in both directions: ``xp`` and ``yp`` are cast
    once per pixel (docs/p1_datapath.md), whatever the model holds per line or band."""
    cfg = P1Config.default(variant="paper").with_formats(
        coord=FixedFormat(True, 3, 0, Quant.TRN, overflow)
    )
    case = p1_case(21, "random", "stereo")
    m, n = case.shape
    # principal point at the corner: counters 0..n-1 exceed the 3-bit range
    case = replace(case, camera=PinholeCamera(n, m, case.camera.f_px, cx=0.0, cy=0.0))
    ref = ORACLES["p1"].run(case, cfg)
    res = PIPELINES["p1"].run(case, cfg, threads=threads)
    assert (ref.taps["yp"] != np.arange(m)[:, None]).any()  # yp overflowed
    assert (ref.taps["xp"] != np.arange(n)[None, :]).any()  # so did xp
    assert_bit_exact(res, ref)
