"""Named golden ranging methods: estimator + ranging equation, applied to an image pair.

Method names are ``<algorithm>_<estimator variant>``: ``g3_paper``, ``g3_consistent``
(SPIE degree-1 polynomial, translation only) and ``g4_paper``, ``g4_consistent``
(obstacle paper eq 28, translation and rotation); ``g2_central`` (ch. 3: eq 15 with the
central differences of eqs 18-19, no estimator) and ``g5_riccati`` (ch. 5: derivative-free
Riccati sweep, stereo pairs only); ``g6_multiscale`` (beyond the report, SPEC §12: the
degree-1 normal equations over a window, coarse to fine with warping, stereo pairs only,
:mod:`rangefx.golden.multiscale`). ``g3d<n>_<variant>`` (n = 2..4) is the SPIE ranging
polynomial of degree n (eq 10, :func:`rangefx.golden.polynomial.range_g3_poly`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .central import CentralConfig, range_g2
from .estimator import EstimatorConfig, estimate_derivatives
from .geometry import MotionIncrement, PinholeCamera
from .multiscale import MultiscaleConfig, range_g6
from .polynomial import PolynomialConfig, range_g3_poly
from .ranging import RangeResult, RangingConfig, range_g3, range_g4
from .riccati import RiccatiConfig, range_g5

__all__ = ["METHODS", "MethodSpec", "method_spec", "run_method"]


@dataclass(frozen=True)
class MethodSpec:
    name: str
    equation: str  # "g3" | "g4"
    variant: str  # estimator variant


METHODS: tuple[str, ...] = ("g3_paper", "g3_consistent", "g4_paper", "g4_consistent")

#: SPIE ranging polynomial of degree 2..4 (:mod:`rangefx.golden.polynomial`), named
#: ``g3d<degree>_<variant>``; the estimator runs with order >= degree.
G3_POLY_METHODS: tuple[str, ...] = tuple(
    f"g3d{n}_{v}" for n in (2, 3, 4) for v in ("paper", "consistent")
)
METHODS += G3_POLY_METHODS

#: Methods without the derivative estimator: ch. 3 central differences and ch. 5 sweep.
G2_G5_METHODS: tuple[str, ...] = ("g2_central", "g5_riccati")
METHODS += G2_G5_METHODS

#: Beyond the report (SPEC §12): the multi-scale windowed degree-1 method.
G6_METHODS: tuple[str, ...] = ("g6_multiscale",)
METHODS += G6_METHODS


def method_spec(name: str) -> MethodSpec:
    """Parse a method name; unknown names raise ``ValueError`` listing the valid ones."""
    if name not in METHODS:
        raise ValueError(f"unknown method {name!r}; choose from {', '.join(METHODS)}")
    equation, variant = name.split("_", 1)
    return MethodSpec(name, equation, variant)


def run_method(
    name: str,
    image1: np.ndarray,
    image2: np.ndarray,
    camera: PinholeCamera,
    motion: MotionIncrement,
    *,
    estimator: EstimatorConfig | None = None,
    ranging: RangingConfig | None = None,
    central: CentralConfig | None = None,
    riccati: RiccatiConfig | None = None,
    multiscale: MultiscaleConfig | None = None,
) -> RangeResult:
    """Run a named method on an image pair (E1 = ``image1``, E2 = ``image2``).

    ``estimator`` settings other than the variant are kept; the variant comes from the
    method name. ``g2_central`` and ``g5_riccati`` ignore ``estimator``; without their
    own ``central`` / ``riccati`` config they take ``threshold_e`` (and ``threshold_g``
    for G2) and ``range_max`` from ``ranging``. ``g6_multiscale`` takes its settings
    from ``multiscale`` and only ``range_max`` from ``ranging``.
    """
    spec = method_spec(name)
    image1 = np.asarray(image1)
    image2 = np.asarray(image2)
    if image1.shape != image2.shape:
        raise ValueError(f"image pair shapes differ: {image1.shape} vs {image2.shape}")
    if spec.name == "g2_central":
        if central is None and ranging is not None:
            central = CentralConfig(
                threshold_e=ranging.threshold_e,
                threshold_g=ranging.threshold_g,
                range_max=ranging.range_max,
            )
        return range_g2(image1, image2, camera, motion, central)
    if spec.name == "g6_multiscale":
        return range_g6(image1, image2, camera, motion, multiscale, ranging)
    if spec.name == "g5_riccati":
        if riccati is None and ranging is not None:
            riccati = RiccatiConfig(threshold_e=ranging.threshold_e, range_max=ranging.range_max)
        return range_g5(image1, image2, camera, motion, riccati)
    est = (estimator or EstimatorConfig()).with_(variant=spec.variant)
    if spec.name in G3_POLY_METHODS:  # degree n needs derivatives up to order n
        degree = int(spec.equation[3:])
        est = est.with_(order=max(est.order, degree))
        d1, d2 = estimate_derivatives(image1, est), estimate_derivatives(image2, est)
        return range_g3_poly(d1, d2, camera, motion, ranging, PolynomialConfig(degree=degree))
    d1 = estimate_derivatives(image1, est)
    d2 = estimate_derivatives(image2, est)
    solve = range_g3 if spec.equation == "g3" else range_g4
    return solve(d1, d2, camera, motion, ranging)


#: Ranging thresholds per scene preset, chosen by measurement (README, "Measured"):
#: the lab pair has 1-3 px disparity and 0.5 grey-level noise; the runway pair's
#: larger thresholds reject the near-focus-of-expansion ground where parallax vanishes.
SCENE_RANGING: dict[str, RangingConfig] = {
    "lab": RangingConfig(threshold_e=2.0, threshold_g=2.0, range_max=100.0),
    "runway": RangingConfig(threshold_e=4.0, threshold_g=4.0, range_max=2000.0),
}


#: G2 / G5 settings per scene (docs/golden_g2_g5.md, "Measured"). Lab: G2's thresholds
#: are G3's (the paper's 15 grey levels keep the pixels where the first-order model is
#: worst: median error 0.45 vs 0.33); G5 keeps the paper's weights (inches, rescaled by
#: the pixel pitch) with T_E = 2. G5 needs a stereo pair, so ``runway`` has none.
SCENE_CENTRAL: dict[str, CentralConfig] = {
    "lab": CentralConfig(threshold_e=2.0, threshold_g=2.0, range_max=100.0),
}
SCENE_RICCATI: dict[str, RiccatiConfig] = {
    "lab": RiccatiConfig(threshold_e=2.0, range_max=100.0),
}
