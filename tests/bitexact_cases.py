"""Helpers of the bit-exact tests (not a test module): the small random cases of P1 and
P3 that ``tests/test_bitexact.py`` and the pipelines' own test files run against the
oracles (``tests/oracles.py``), and the comparison itself (:func:`assert_bit_exact`).
Imported by name (``from bitexact_cases import ...``): ``tests/`` is on ``sys.path``
for every test module, as pytest puts a ``conftest.py``'s folder there (rootdir-less
``tests/``, pytest's default ``prepend`` import mode; ``tests/conftest.py``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.ranging import RangingConfig
from rangefx.golden.scenes import render_plane, render_scene
from rangefx.rtl_model.pipeline import Case

__all__ = ["P1_MOTION", "P1_RANGING", "assert_bit_exact", "lab_crop", "p1_case", "p3_case"]

P1_RANGING = RangingConfig(threshold_e=1.0, threshold_g=0.7, range_max=60.0, min_denominator=0.3)
P1_MOTION = MotionIncrement.from_attitudes(
    camera_angles=(0.0, -0.05, 0.0),
    camera_offset=(1.0, 0.0, 0.2),
    attitude1=(0.10, -0.03, 0.01),
    attitude2=(0.1014, -0.0290, 0.0121),
    position1=(0.0, 0.0, -3.0),
    position2=(0.6, -0.05, -2.98),
)

_SCENES: dict[str, Any] = {}


def _plane():
    if "plane" not in _SCENES:
        _SCENES["plane"] = render_plane(depth=4.0, size=(24, 24), seed=5, baseline=0.2)
    return _SCENES["plane"]


def p1_case(seed: int, kind: str, mode: str) -> Case:
    """A tiny random P1 case: a crop of a textured plane, or a random texture shifted by
    a fraction of a pixel plus noise; random principal point half the time."""
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
        shifted = 0.7 * im1.astype(float) + 0.3 * np.roll(im1, 1, axis=1)
        im2 = np.clip(np.rint(shifted + rng.normal(0, 3, (m, n))), 0, 255).astype(np.uint8)
        f_px = float(rng.uniform(12.0, 40.0))
    cx = float(rng.uniform(0, n - 1)) if rng.random() < 0.5 else None
    cy = float(rng.uniform(0, m - 1)) if rng.random() < 0.5 else None
    camera = PinholeCamera(n, m, f_px, cx=cx, cy=cy)
    motion = P1_MOTION if mode == "motion" else MotionIncrement.stereo(0.2)
    return Case(im1, im2, camera, motion, mode, settings={"ranging": P1_RANGING})


def lab_crop(
    rng: np.random.Generator, m: int, n: int
) -> tuple[np.ndarray, np.ndarray, PinholeCamera]:
    """A random ``m`` x ``n`` crop of the ``lab`` pair (rendered once) and its camera."""
    if "lab" not in _SCENES:
        _SCENES["lab"] = render_scene("lab")
    s = _SCENES["lab"]
    j0, i0 = int(rng.integers(100, 400)), int(rng.integers(100, 400))
    crop = (slice(j0, j0 + m), slice(i0, i0 + n))
    return s.image1[crop].copy(), s.image2[crop].copy(), PinholeCamera(n, m, s.camera.f_px)


def p3_case(seed: int, kind: str) -> Case:
    """A tiny random stereo case: a crop of ``lab``, or a smooth random texture whose
    second view is shifted by 0.5-3 px (E1(x) = E2(x - d)) plus noise."""
    rng = np.random.default_rng(seed)
    m, n = int(rng.integers(8, 13)), int(rng.integers(12, 19))
    if kind == "lab":
        im1, im2, camera = lab_crop(rng, m, n)
    else:
        base = rng.uniform(0, 255, (m, n + 8))
        base = (base + np.roll(base, 1, axis=1) + np.roll(base, -1, axis=1)) / 3
        cols = np.arange(n + 8, dtype=float)
        d = float(rng.uniform(0.5, 3.0))
        shifted = np.array([np.interp(cols + d, cols, row) for row in base])
        im1 = np.clip(np.rint(base[:, 4 : 4 + n]), 0, 255).astype(np.uint8)
        im2 = np.clip(np.rint(shifted[:, 4 : 4 + n] + rng.normal(0, 1, (m, n))), 0, 255)
        im2 = im2.astype(np.uint8)
        camera = PinholeCamera(n, m, float(rng.uniform(300, 600)))
    ranging = RangingConfig(range_max=100.0)
    return Case(im1, im2, camera, MotionIncrement.stereo(0.1), settings={"ranging": ranging})


def assert_bit_exact(res, ref) -> None:
    """Every tap (int64, equal), the outputs, every overflow count and every min/max."""
    assert set(res.taps) == set(ref.taps)
    bad = []
    for name, want in ref.taps.items():
        got = np.asarray(res.taps[name])
        if got.dtype != np.int64:
            bad.append(f"{name}: dtype {got.dtype}")
        if not np.array_equal(got.astype(np.int64), want):
            where = np.argwhere(got.astype(np.int64) != want)
            j, i = (int(v) for v in where[0]) if len(where) else (-1, -1)
            first = (got[j, i], want[j, i]) if j >= 0 else ("shape", got.shape)
            bad.append(f"{name}: {len(where)} pixels differ, first at (j={j}, i={i}): {first}")
    assert not bad, "taps differ from the oracle:\n" + "\n".join(bad)
    assert np.array_equal(res.range_raw, ref.range_raw)
    assert np.array_equal(res.valid, ref.valid)
    assert dict(res.overflows) == ref.overflows
    assert dict(res.minmax) == ref.minmax
