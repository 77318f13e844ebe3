"""Named golden ranging methods: estimator + ranging equation, applied to an image pair.

Method names are ``<algorithm>_<estimator variant>``: ``g3_paper``, ``g3_consistent``
(SPIE degree-1 polynomial, translation only) and ``g4_paper``, ``g4_consistent``
(obstacle paper eq 28, translation and rotation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .estimator import EstimatorConfig, estimate_derivatives
from .geometry import MotionIncrement, PinholeCamera
from .ranging import RangeResult, RangingConfig, range_g3, range_g4

__all__ = ["METHODS", "MethodSpec", "method_spec", "run_method"]


@dataclass(frozen=True)
class MethodSpec:
    name: str
    equation: str  # "g3" | "g4"
    variant: str  # estimator variant


METHODS: tuple[str, ...] = ("g3_paper", "g3_consistent", "g4_paper", "g4_consistent")


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
) -> RangeResult:
    """Run a named method on an image pair (E1 = ``image1``, E2 = ``image2``).

    ``estimator`` settings other than the variant are kept; the variant comes from the
    method name.
    """
    spec = method_spec(name)
    image1 = np.asarray(image1)
    image2 = np.asarray(image2)
    if image1.shape != image2.shape:
        raise ValueError(f"image pair shapes differ: {image1.shape} vs {image2.shape}")
    est = (estimator or EstimatorConfig()).with_(variant=spec.variant)
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
