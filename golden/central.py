"""G2: the optical ranging equation with central differences (ch. 3 paper, float64).

Ch. 3 ("Image Based Range Determination", AIAA GNC 1990) expands the correspondence
hypothesis to first order both ways (eqs 11-12) and adds / subtracts the two:

* eq 13, the **optical ranging equation**:
  ``E1 - E2 = ½ [(E1x + E2x)(xp Δz0 - f Δx0) + (E1y + E2y)(yp Δz0 - f Δy0)] / (z - z0 - Δz0)``
* eq 14, the **range-error equation**: the same bracket with the *difference* of the
  gradients, ``0 = ½ [(E1x - E2x)(...) + (E1y - E2y)(...)] / (z - z0 - Δz0)``. It is zero
  only where the irradiance is locally linear; its right-hand side evaluated at the
  estimated inverse depth is the first-order model's residual in grey levels.
* eq 15 solves eq 13 for the depth, ``z - z0 = Δz0 + ½ [...] / (E1 - E2)``; eqs 16-17
  give the lateral coordinates (``x = xp z / f`` in camera 1 once ``z`` is known).
* eqs 18-19, the derivatives: central differences ``(E(i+1) - E(i-1)) / 2δx`` on the raw
  images, no smoothing (the paper: "rather crude, and do not exhibit any noise
  attenuating characteristics at all"). Pixel units, so ``δx = δy = 1``.

Points whose irradiance difference is below a threshold are not ranged and carry the
maximum scene depth (the paper: "smaller than 15 levels of gray", its Fig. 2 text).

Axes are those of :func:`rangefx.golden.ranging.range_g3` (``Δx0`` right, ``Δy0`` down,
``Δz0`` forward, from :attr:`MotionIncrement.camera_displacement`); eq 15 is G3's
degree-1 equation with different derivatives, so the two share conventions and
:class:`~rangefx.golden.ranging.RangeResult`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .estimator import validate_image
from .geometry import MotionIncrement, PinholeCamera
from .ranging import RangeResult

__all__ = ["CentralConfig", "central_differences", "range_error_ratio", "range_g2"]


@dataclass(frozen=True)
class CentralConfig:
    """Thresholds of G2.

    Attributes
    ----------
    threshold_e
        Minimum ``|E1 - E2|`` in grey levels (the paper used 15 on its 8-bit camera).
    threshold_g
        Minimum ``|½ (g1 + g2) · u|`` in grey levels per pixel, ``u`` the unit disparity
        direction at the pixel (0 disables).
    max_error_ratio
        Maximum ``|eq 14 residual| / |E1 - E2|`` = ``|(g1 - g2)·v| / |(g1 + g2)·v|``;
        ``inf`` disables. Rejects pixels where the two images' gradients disagree, i.e.
        where the linear model behind eq 13 fails (the use of eq 14 the paper suggests).
    range_max
        Maximum scene depth; value of invalid pixels.
    """

    threshold_e: float = 15.0
    threshold_g: float = 0.0
    max_error_ratio: float = math.inf
    range_max: float = 100.0

    def __post_init__(self) -> None:
        for name in ("threshold_e", "threshold_g"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, not {v!r}")
        r = self.max_error_ratio
        if not (isinstance(r, (int, float)) and r > 0) or math.isnan(r):
            raise ValueError(f"max_error_ratio must be > 0 (inf disables it), not {r!r}")
        if not (math.isfinite(self.range_max) and self.range_max > 0):
            raise ValueError(f"range_max must be a positive finite length, not {self.range_max!r}")


def central_differences(image: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(E, dE/dx, dE/dy)`` by central differences, eqs 18-19 with ``δx = δy = 1``.

    The outermost rows/columns have no central difference: they are NaN (and hence never
    valid downstream).
    """
    e = validate_image(image).astype(np.float64)
    ex = np.full_like(e, np.nan)
    ey = np.full_like(e, np.nan)
    ex[:, 1:-1] = 0.5 * (e[:, 2:] - e[:, :-2])  # eq 18
    ey[1:-1, :] = 0.5 * (e[2:, :] - e[:-2, :])  # eq 19
    return e, ex, ey


def range_error_ratio(terms: dict[str, np.ndarray]) -> np.ndarray:
    """``|eq 14| / |eq 13|`` from the ``terms`` of :func:`range_g2`.

    Both equations share the factor ``1 / (z - z0 - Δz0)``, so the ratio needs no range:
    ``|(g1 - g2)·v| / |(g1 + g2)·v|``. Near 0 the first-order model holds; near or
    above 1 the two images' gradients disagree and eq 15 is unreliable.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.abs(terms["b1"]) / np.abs(terms["a1"])


def range_g2(
    image1: np.ndarray,
    image2: np.ndarray,
    camera: PinholeCamera,
    motion: MotionIncrement,
    config: CentralConfig | None = None,
) -> RangeResult:
    """Depth from the optical ranging equation (eq 15) with central differences (18-19).

    ``E1 = image1``, ``E2 = image2``; the second view is displaced by
    ``motion.camera_displacement`` (translation only, as in the paper). Returns the depth
    along the camera-1 optical axis, ``z - z0`` of eq 15.

    ``terms``: ``c1 = E1 - E2``, ``a1 = ½ (g1 + g2)·v`` (eq 13's bracket), ``b1 = ½
    (g1 - g2)·v`` (eq 14's bracket), ``error = b1 δ`` (eq 14's right-hand side at the
    estimated inverse depth ``δ = c1 / a1``, grey levels), ``grad`` and ``raw_range``.
    """
    config = config or CentralConfig()
    e1, e1x, e1y = central_differences(image1)
    e2, e2x, e2y = central_differences(image2)
    if e1.shape != e2.shape:
        raise ValueError(f"image pair shapes differ: {e1.shape} vs {e2.shape}")
    if e1.shape != (camera.height, camera.width):
        raise ValueError(f"images are {e1.shape} but the camera is {camera.height}x{camera.width}")
    fwd, right, down = motion.camera_displacement
    if math.hypot(fwd, right, down) == 0:
        raise ValueError("camera displacement between the two views is zero: no parallax")
    xp, yp = camera.pixel_grid()
    f = camera.f_px
    vx = xp * fwd - f * right  # [xp Δz0 - f Δx0], eqs 9 and 13
    vy = yp * fwd - f * down  # [yp Δz0 - f Δy0]
    a1 = 0.5 * ((e1x + e2x) * vx + (e1y + e2y) * vy)  # eq 13 bracket
    b1 = 0.5 * ((e1x - e2x) * vx + (e1y - e2y) * vy)  # eq 14 bracket
    c1 = e1 - e2
    with np.errstate(divide="ignore", invalid="ignore"):
        grad = np.abs(a1) / np.hypot(vx, vy)
        inv = c1 / a1  # 1 / (z - z0 - Δz0), eq 13
        raw = a1 / c1 + fwd  # eq 15
        error = b1 * inv  # eq 14 right-hand side, grey levels
        ok = (np.abs(c1) >= config.threshold_e) & (grad >= config.threshold_g)
        if math.isfinite(config.max_error_ratio):
            ok &= np.abs(b1) <= config.max_error_ratio * np.abs(a1)
        valid = ok & np.isfinite(raw) & (raw > 0) & (raw <= config.range_max)
    rng = np.where(valid, raw, config.range_max)
    terms = {"c1": c1, "a1": a1, "b1": b1, "error": error, "grad": grad, "raw_range": raw}
    return RangeResult(range=rng, valid=valid, terms=terms)
