"""Derivative-based ranging equations (float64 golden model).

G3 (SPIE paper of ch. 4): the optical ranging polynomial (eq 10) of degree 1 for a
translating camera. With the disparity ``r = δ [xp Δz0 - f Δx0, yp Δz0 - f Δy0]``
(eq 9, ``δ`` = inverse depth in the second view) and the first-order Taylor form of
eq 6, ``E1 - E2 = a1 δ`` with ``a1 = ½ (g1 + g2) · [xp Δz0 - f Δx0, yp Δz0 - f Δy0]``.
The depth in the first view is ``1/δ + Δz0`` (from eq 12).

G4 (obstacle paper of ch. 4): translation and rotation, eq 28 with k0..k5 of eqs 23-24
(:func:`rangefx.golden.geometry.k_coefficients`). The print's eq 31 reads
``c1 = E2 - E1``; with eqs 27-28 that flips every range (``x_c = 2 Δx_v - depth`` for a
forward translation): the sign consistent with eq 27 is ``c1 = E1 - E2`` (SPEC §9), and
with it eq 28 reduces to G3 degree 1 to rounding error when the rotations vanish. The
printed sign stays selectable (``c1_sign="printed"``) so the error can be shown.

Validity (SPEC §3): a pixel carries a range only where ``|E1_hat - E2_hat| >= T_E``,
the image gradient along the disparity direction is at least ``T_g`` (grey levels per
pixel), the denominator is not near zero, and ``0 < range <= range_max``. Every other
pixel carries ``range_max`` ("a pre-defined maximum scene depth", SPIE §3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .estimator import Derivatives
from .geometry import MotionIncrement, PinholeCamera, k_coefficients

__all__ = ["RangeResult", "RangingConfig", "range_g3", "range_g4"]


@dataclass(frozen=True)
class RangingConfig:
    """Thresholds of the ranging stage.

    Attributes
    ----------
    threshold_e
        ``T_E``: minimum ``|E1_hat - E2_hat|`` in grey levels.
    threshold_g
        ``T_g``: minimum ``|½ (g1 + g2) · u|`` in grey levels per pixel, ``u`` the unit
        disparity direction at the pixel.
    range_max
        Maximum scene depth, in the scene's length unit; also the value of invalid pixels.
    min_denominator
        Minimum ``|denominator|`` of eq 28 (grey levels); G3's denominator is ``E1 - E2``
        itself, so this only binds with rotations. Keep it ``<= threshold_e`` for G4 to
        reduce to G3.
    """

    threshold_e: float = 2.0
    threshold_g: float = 2.0
    range_max: float = 100.0
    min_denominator: float = 1.0

    def __post_init__(self) -> None:
        for name in ("threshold_e", "threshold_g", "min_denominator"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, not {v!r}")
        if not (math.isfinite(self.range_max) and self.range_max > 0):
            raise ValueError(f"range_max must be a positive finite length, not {self.range_max!r}")


@dataclass(frozen=True)
class RangeResult:
    """Range map and validity flag, shape (m, n).

    ``range`` is the range along the optical axis of camera 1 (``x_c`` of the obstacle
    paper = depth ``z`` of the SPIE paper); invalid pixels carry ``range_max``. ``terms``
    holds the per-pixel intermediate signals (``c1 = E1 - E2``, gradient term,
    numerator, denominator, raw range) for inspection and bit-accuracy comparisons.
    """

    range: np.ndarray
    valid: np.ndarray
    terms: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def valid_fraction(self) -> float:
        return float(np.count_nonzero(self.valid)) / self.valid.size


def _check_pair(d1: Derivatives, d2: Derivatives, camera: PinholeCamera) -> None:
    if d1.E.shape != d2.E.shape:
        raise ValueError(f"image pair shapes differ: {d1.E.shape} vs {d2.E.shape}")
    if d1.E.shape != (camera.height, camera.width):
        raise ValueError(
            f"images are {d1.E.shape} but the camera is {camera.height}x{camera.width}"
        )


def _finish(
    raw: np.ndarray, ok: np.ndarray, config: RangingConfig, terms: dict[str, np.ndarray]
) -> RangeResult:
    with np.errstate(invalid="ignore"):
        valid = ok & np.isfinite(raw) & (raw > 0) & (raw <= config.range_max)
    rng = np.where(valid, raw, config.range_max)
    terms["raw_range"] = raw
    return RangeResult(range=rng, valid=valid, terms=terms)


def range_g3(
    d1: Derivatives,
    d2: Derivatives,
    camera: PinholeCamera,
    motion: MotionIncrement,
    config: RangingConfig | None = None,
) -> RangeResult:
    """Degree-1 optical ranging polynomial (SPIE eqs 9-10) for a translating camera.

    Only the translation of ``motion`` is used (the SPIE paper assumes no rotation); the
    camera displacement in the camera frame maps to the SPIE axes as ``Δx0`` = right,
    ``Δy0`` = down, ``Δz0`` = forward.
    """
    config = config or RangingConfig()
    _check_pair(d1, d2, camera)
    fwd, right, down = motion.camera_displacement
    if math.hypot(fwd, right, down) == 0:
        raise ValueError("camera displacement between the two views is zero: no parallax")
    xp, yp = camera.pixel_grid()
    f = camera.f_px
    vx = xp * fwd - f * right  # disparity per unit inverse depth (eq 9)
    vy = yp * fwd - f * down
    gx = 0.5 * (d1.Ex + d2.Ex)  # eq 6, first-order term
    gy = 0.5 * (d1.Ey + d2.Ey)
    a1 = gx * vx + gy * vy  # eq 10, degree-1 coefficient
    c1 = d1.E - d2.E
    norm = np.hypot(vx, vy)
    with np.errstate(divide="ignore", invalid="ignore"):
        grad = np.abs(a1) / norm
        raw = a1 / c1 + fwd  # depth in view 1 = 1/δ + Δz0, δ = (E1 - E2) / a1
    ok = (np.abs(c1) >= config.threshold_e) & (grad >= config.threshold_g)
    return _finish(raw, ok, config, {"c1": c1, "a1": a1, "grad": grad})


def range_g4(
    d1: Derivatives,
    d2: Derivatives,
    camera: PinholeCamera,
    motion: MotionIncrement,
    config: RangingConfig | None = None,
    *,
    c1_sign: str = "fixed",
) -> RangeResult:
    """Range ``x_c`` with translation and rotation, obstacle paper eq 28.

    ``x_c = (k3 c1 - a1 (f k4 - xp k3) - b1 (f k5 - yp k3)) /
    (a1 (f k1 - xp k0) + b1 (f k2 - yp k0) - c1 (1 + k0))`` with ``a1``, ``b1`` the
    mean x and y derivatives of the two images (eqs 29-30) and ``c1 = E1 - E2``
    (``c1_sign="fixed"``, SPEC §9) or the printed ``E2 - E1`` (``c1_sign="printed"``).
    """
    if c1_sign not in ("fixed", "printed"):
        raise ValueError(f"c1_sign must be 'fixed' or 'printed', not {c1_sign!r}")
    config = config or RangingConfig()
    _check_pair(d1, d2, camera)
    xp, yp = camera.pixel_grid()
    f = camera.f_px
    (k0, k1, k2), (k3, k4, k5) = k_coefficients(motion, xp, yp, f)
    if max(abs(k3), abs(k4), abs(k5)) == 0:
        raise ValueError("camera translation between the two views is zero: no parallax")
    a1 = 0.5 * (d1.Ex + d2.Ex)  # eq 29
    b1 = 0.5 * (d1.Ey + d2.Ey)  # eq 30
    c1 = d1.E - d2.E if c1_sign == "fixed" else d2.E - d1.E  # eq 31, sign fixed
    vx = f * k4 - xp * k3  # translation part of the disparity, per 1/x_c (eqs 25-26)
    vy = f * k5 - yp * k3
    num = k3 * c1 - a1 * vx - b1 * vy
    den = a1 * (f * k1 - xp * k0) + b1 * (f * k2 - yp * k0) - c1 * (1.0 + k0)
    with np.errstate(divide="ignore", invalid="ignore"):
        grad = np.abs(a1 * vx + b1 * vy) / np.hypot(vx, vy)
        raw = num / den
    ok = (
        (np.abs(c1) >= config.threshold_e)
        & (grad >= config.threshold_g)
        & (np.abs(den) >= config.min_denominator)
    )
    return _finish(raw, ok, config, {"c1": c1, "grad": grad, "numerator": num, "denominator": den})
