"""The float64 value of every pipeline tap that has an order-by-order counterpart.

The bit-accurate pipelines (``rtl_model``) expose taps: raw codes of datapath signals.
Their float references are computed here from the golden algorithms, so that a
word-length study scores each tap (SQNR, max error) against the float truth of the same
computation: P1 from the causal derivative estimator (SPIE eqs 13-21) and the eq-28
range algebra, P2 from the Riccati sweep G5 (ch. 5).
"""

from __future__ import annotations

import numpy as np

from .estimator import EstimatorConfig, estimate_derivatives
from .geometry import MotionIncrement, PinholeCamera, k_coefficients
from .ranging import RangeResult

__all__ = ["p1_golden_taps", "p2_golden_taps"]


def p1_golden_taps(
    image1: np.ndarray,
    image2: np.ndarray,
    camera: PinholeCamera,
    motion: MotionIncrement,
    est: EstimatorConfig,
) -> dict[str, np.ndarray]:
    """Float golden counterpart of every P1 tap that has one (tap name -> array).

    From :func:`estimate_derivatives` (``r1, r2, s1, s2`` / ``u00, u01, u10``) of each
    image and the golden eq-28 terms: the row state after a pixel is ``r1 + r2``
    (``paper``: ``r1`` is the state before, ``r2`` the step) or ``r1 + r2/2``
    (``consistent``: ``r1`` is the mean of the states before and after), likewise the
    column state; ``ex`` is the estimator's ``Ex``; the range-stage taps follow eq 28.
    ``col2_state`` has no order-1 float counterpart and is left out.
    """
    out: dict[str, np.ndarray] = {}
    half = 0.5 if est.variant == "consistent" else 1.0
    derivs = []
    for prefix, image in (("e1", image1), ("e2", image2)):
        d = estimate_derivatives(image, est)
        derivs.append(d)
        t = d.taps
        s1, s2 = (t["s1"], t["s2"]) if est.variant == "paper" else (t["u00"], t["u01"])
        out[f"{prefix}.bias_in"] = np.asarray(image, dtype=np.float64) + est.bias
        out[f"{prefix}.row_r1"] = t["r1"]
        out[f"{prefix}.row_r2"] = t["r2"]
        out[f"{prefix}.row_state"] = t["r1"] + half * t["r2"]
        out[f"{prefix}.col_s1"] = s1
        out[f"{prefix}.col_s2"] = s2
        out[f"{prefix}.col_state"] = s1 + half * s2
        out[f"{prefix}.ex"] = d.Ex
    d1, d2 = derivs
    xp, yp = camera.pixel_grid()
    f = camera.f_px
    (k0, k1, k2), (k3, k4, k5) = k_coefficients(motion, xp, yp, f)
    a1 = 0.5 * (d1.Ex + d2.Ex)
    b1 = 0.5 * (d1.Ey + d2.Ey)
    vx = f * k4 - xp * k3
    vy = f * k5 - yp * k3
    gv = a1 * vx + b1 * vy
    shape = a1.shape
    out.update(
        {
            "xp": np.asarray(xp, dtype=np.float64),
            "yp": np.asarray(yp, dtype=np.float64),
            "c1": d1.E - d2.E,
            "a1": a1,
            "b1": b1,
            "k0": np.broadcast_to(k0, shape),
            "k1": np.broadcast_to(k1, shape),
            "k2": np.broadcast_to(k2, shape),
            "vx": np.broadcast_to(vx, shape),
            "vy": np.broadcast_to(vy, shape),
            "wx": np.broadcast_to(f * k1 - xp * k0, shape),
            "wy": np.broadcast_to(f * k2 - yp * k0, shape),
            "w0": np.broadcast_to(1.0 + k0, shape),
            "gv": gv,
            "num": k3 * (d1.E - d2.E) - gv,
            "den": a1 * (f * k1 - xp * k0) + b1 * (f * k2 - yp * k0) - (d1.E - d2.E) * (1 + k0),
            "v_sq": np.broadcast_to(vx * vx + vy * vy, shape),
            "g_sq": gv * gv,
        }
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        out["range_q"] = out["num"] / out["den"]
    return out


def p2_golden_taps(g5: RangeResult) -> dict[str, np.ndarray]:
    """Float counterparts of P2's taps from a G5 result (:func:`range_g5` in the ``lq``
    form with ``A`` at the pixel edge, P2's discretisation): ``g_hat`` (E1 + E2), ``e``
    (G - G_hat) and ``z`` (the unthresholded range). The sweep's other taps are held
    in scaled units (``S~ = S / beta``, ``A`` per pixel) and are scored through the range."""
    t = g5.terms
    return {"g_hat": t["G_hat"], "e": t["e"], "z": t["raw_range"]}
