"""G5: derivative-free stereo ranging as an optimal-control problem (ch. 5, float64).

Padé constraint (eqs 1-11)
--------------------------
A registered pair obeys ``E1(xp) = E2(xp + Δxp)`` along each line (eq 1). The
first-order Padé form of the shift, ``e^{-sΔ/2} E1 = e^{sΔ/2} E2`` (eqs 2-4), gives

    2 (E1 - E2) / Δxp = d(E1 + E2)/dxp                                        (eq 5)

and the disparity ``Δxp = f Δx / z`` (eq 8) turns it into ``Ġ = A z`` (eqs 9-11) with
``G = E1 + E2`` and ``A = 2 (E1 - E2) / (f Δx)`` (eq 10).

**Sign (SPEC §9).** Eqs 6-8 put the point at ``x + Δx`` in the second camera, i.e. the
second camera sits at ``-Δx``. In this project camera 2 sits ``b`` to the *right*
(:meth:`MotionIncrement.stereo`), so image 2 shows at ``xp - f b / z`` what image 1
shows at ``xp``: eq 8 holds with ``Δx = -b``, hence ``A = -2 (E1 - E2) / (f b)``.

Cost and weights (eqs 12-16)
----------------------------
Per line, minimise ``γ/2 (G - Ĝ)²|_r + ∫ [α/2 (G - Ĝ)² + β/2 z²] dxp`` subject to
``Ġ = A z``, ``G(l) = Ĝ(l)`` (eqs 12-13). Bryson's rule (eqs 14-16):
``α = 1 / (L G_M)``, ``β = 1 / (L z_M)``, ``γ = 1 / G_M`` with ``L`` the line length,
``G_M`` / ``z_M`` the largest acceptable ``(G - Ĝ)²`` / ``z²`` (:func:`bryson_weights`).

**Units.** ``α`` and ``β`` weight an integral over ``dxp``: with image-plane lengths in
pixel-pitch units ``s`` (the paper used inches, ``s ≈ 3.8e-4 in``, eq 32 with
``f ≈ 0.236 in``, 45°, 512 px) the same cost in pixel units has ``α_px = s α``,
``β_px = s β``, ``γ_px = γ`` (:func:`weights_in_pixels`); the minimiser is then
identical (tested). Changing the *scene* length unit (inches to mm) scales ``z`` and
so ``β`` by ``1/25.4²``; keeping the numbers fixed instead biases the range (SPEC §9).
The paper's α = 1, β = 1e-3, γ = 1e6 are Bryson's rule with ``(G - Ĝ)`` up to
≈ 2.3 grey levels and ``z`` up to ≈ 72 in over a 0.195 in line: sensible in inches.

Backward sweep (eqs 17-29, 35-38)
---------------------------------
The Hamiltonian (17) gives ``λ̇ = -α (G - Ĝ)`` (18), ``z = -λ A / β`` (19) and with
``λ = S G + K`` (23) the Riccati equation ``Ṡ = S² A²/β - α`` (27), ``K̇ = S A²/β K +
α Ĝ`` (28), ``S(r) = γ``, ``K(r) = -γ Ĝ(r)`` (24), and ``z = -(S G + K) A / β`` (29).

``form="literal"``: eqs 35-37 exactly as printed, stepped from the right edge to the
left with the printed right-hand sides (``S ← S + S² A² δ/β - α δ``, ``K ← K + S A²
δ/β K + α Ĝ δ``), then eq 37 forward and eq 38 (printed as a second "(33)", SPEC §9).
As printed, eq 35 computes ``S_{j+1}`` from ``S_j`` while ``j`` runs *down*; read
either way the explicit step multiplies by ``S² A² δ / β``, which from ``S = γ = 1e6``
is ~1e12 times a number of order ``A²δ/β`` — the recurrence explodes at the first step
(shown in the tests; it is also the wrong sign for a backward Euler step).

``form="lq"`` (default): the exact minimiser of the *discretised* cost::

    J = γ/2 (G_{n-1} - Ĝ_{n-1})² + Σ_{k=0}^{n-2} [αδ/2 (G_k - Ĝ_k)² + βδ/2 z_k²],
    G_{k+1} = G_k + δ A_k z_k,   G_0 = Ĝ_0.

Dynamic programming with ``V_k(G) = ½ S_k G² + K_k G + const``: substituting
``z = (G⁺ - G) / (δ A_k)`` the step cost is ``(G⁺ - G)² / (2 c_k)`` with
``c_k = δ A_k² / β``, and minimising ``(G⁺ - G)²/(2c) + ½ S G⁺² + K G⁺`` over ``G⁺``
(an infimal convolution of two quadratics: curvatures combine harmonically) gives::

    r_k = 1 / (1 + c_k S_{k+1})                 (the one division per pixel)
    S_k = α δ + r_k S_{k+1}                     (→ eq 27 as δ → 0)
    K_k = -α δ Ĝ_k + r_k K_{k+1}                (→ eq 28)
    z_k = -(A_k / β) r_k (S_{k+1} G_k + K_{k+1}) = -(A_k / β)(S_{k+1} G_{k+1} + K_{k+1})
    G_{k+1} = r_k (G_k - c_k K_{k+1})           (→ eq 37)

i.e. eq 38 with ``S, K, G`` taken at ``k+1``. Every factor is bounded: ``S_k`` lies in
``[αδ, αδ + S_{k+1}]``, ``0 < r_k <= 1``, so the sweep is stable for *any* positive
weights and any ``A`` (``A = 0`` is harmless: ``r = 1``; the paper's "replace A by a
small value" is not needed).

**Cancellation.** ``S G + K`` is the difference of two numbers of size ``S Ĝ``
(``S`` up to γ, ``Ĝ`` up to 510). The sweep therefore carries ``Q_k = K_k + S_k Ĝ_k``
and ``e_k = G_k - Ĝ_k`` instead of ``K`` and ``G``; from the recurrences above::

    Q_{n-1} = 0,   Q_k = r_k (Q_{k+1} - S_{k+1} ΔĜ_k),     ΔĜ_k = Ĝ_{k+1} - Ĝ_k
    e_0 = 0,       e_{k+1} = r_k (e_k - ΔĜ_k - c_k Q_{k+1})
    z_k = -(A_k / β) r_k (S_{k+1} (e_k - ΔĜ_k) + Q_{k+1})

which involves only small, differenced signals (what a fixed-point datapath wants).

Where ``A`` is sampled
----------------------
``z_k`` drives the step from pixel centre ``k`` to ``k+1``; the data it must explain is
``ΔĜ_k``, centred at the pixel *edge* ``k + ½``. ``a_sampling="edge"`` (default) uses
``A_{k+½} = (A_k + A_{k+1}) / 2`` there; ``"centre"`` uses ``A_k`` as eq 37 prints it,
half a pixel off the difference it multiplies (measured in docs/golden_g2_g5.md). The
range of step ``k`` is reported at pixel ``k`` (the last column carries none).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from .estimator import validate_image
from .geometry import MotionIncrement, PinholeCamera
from .ranging import RangeResult

if TYPE_CHECKING:
    from .scenes import Scene

__all__ = [
    "PAPER_PIXEL_PITCH_IN",
    "PAPER_WEIGHTS",
    "RiccatiConfig",
    "RiccatiLines",
    "bryson_config",
    "bryson_weights",
    "range_g5",
    "riccati_signal_ranges",
    "riccati_sweep",
    "stereo_baseline",
    "weights_in_pixels",
]

#: The paper's weights (ch. 5, "Results and Discussions"), for image-plane lengths in inches.
PAPER_WEIGHTS: tuple[float, float, float] = (1.0, 1e-3, 1e6)

#: Pixel pitch of the paper's camera by eq 32: ``2 f tan(ψ/2) / n`` with f = 6 mm, ψ = 45°,
#: n = 512, in inches.
PAPER_PIXEL_PITCH_IN: float = 2 * (6.0 / 25.4) * math.tan(math.radians(22.5)) / 512

_FORMS = ("lq", "literal")
_SAMPLINGS = ("edge", "centre")


def weights_in_pixels(
    alpha: float, beta: float, gamma: float, pixel_pitch: float
) -> tuple[float, float, float]:
    """Rescale weights given for image-plane lengths in units of ``pixel_pitch`` per pixel
    to pixel units: ``(α s, β s, γ)`` (the integral of eq 12 is over ``dxp = s du``)."""
    if not (math.isfinite(pixel_pitch) and pixel_pitch > 0):
        raise ValueError(f"pixel_pitch must be a positive finite length, not {pixel_pitch!r}")
    return alpha * pixel_pitch, beta * pixel_pitch, gamma


def bryson_weights(
    line_length: float, g_max_sq: float, z_max_sq: float, g_edge_max_sq: float | None = None
) -> tuple[float, float, float]:
    """Bryson's rule, eqs 14-16: ``α = 1/(L G_M)``, ``β = 1/(L z_M)``, ``γ = 1/G_M(r)``.

    ``line_length`` is ``x_p(r) - x_p(l)`` (pixels for pixel units), ``g_max_sq`` the
    largest acceptable ``(G - Ĝ)²``, ``z_max_sq`` the largest acceptable ``z²`` and
    ``g_edge_max_sq`` that of ``(G - Ĝ)²`` at the right edge (default ``g_max_sq``).
    """
    g_edge = g_max_sq if g_edge_max_sq is None else g_edge_max_sq
    for name, v in (
        ("line_length", line_length),
        ("g_max_sq", g_max_sq),
        ("z_max_sq", z_max_sq),
        ("g_edge_max_sq", g_edge),
    ):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a positive finite number, not {v!r}")
    return 1.0 / (line_length * g_max_sq), 1.0 / (line_length * z_max_sq), 1.0 / g_edge


@dataclass(frozen=True)
class RiccatiConfig:
    """Settings of G5.

    Attributes
    ----------
    alpha, beta, gamma
        Weights of eq 12 for image-plane lengths in units of ``pixel_pitch`` per pixel.
        The default is the paper's (1, 1e-3, 1e6) in the paper's inches.
    pixel_pitch
        Image-plane length of one pixel in the unit the weights assume (eq 32's ``δ``);
        1.0 means the weights are in pixel units.
    form
        ``"lq"`` (exact discrete minimiser, default) or ``"literal"`` (eqs 35-37 as printed).
    a_sampling
        ``"edge"`` (``A`` at the pixel edge between the two samples of a step, default)
        or ``"centre"`` (``A_k`` at the step's left pixel, as eq 37 prints it).
    threshold_e
        Minimum ``|E1 - E2|`` (grey levels, at the sample of ``A``) for a valid range;
        the paper drops "points of small irradiance differences".
    range_max
        Maximum scene depth; value of invalid pixels.
    """

    alpha: float = PAPER_WEIGHTS[0]
    beta: float = PAPER_WEIGHTS[1]
    gamma: float = PAPER_WEIGHTS[2]
    pixel_pitch: float = PAPER_PIXEL_PITCH_IN
    form: str = "lq"
    a_sampling: str = "edge"
    threshold_e: float = 2.0
    range_max: float = 100.0

    def __post_init__(self) -> None:
        for name in ("alpha", "beta", "gamma", "pixel_pitch", "range_max"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"{name} must be a positive finite number, not {v!r}")
            if v <= 0:
                raise ValueError(f"{name} must be a positive finite number, not {v!r}")
        if self.form not in _FORMS:
            raise ValueError(f"form must be one of {', '.join(_FORMS)}, not {self.form!r}")
        if self.a_sampling not in _SAMPLINGS:
            raise ValueError(
                f"a_sampling must be one of {', '.join(_SAMPLINGS)}, not {self.a_sampling!r}"
            )
        t = self.threshold_e
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not (math.isfinite(t)):
            raise ValueError(f"threshold_e must be a finite number >= 0, not {t!r}")
        if t < 0:
            raise ValueError(f"threshold_e must be a finite number >= 0, not {t!r}")

    def with_(self, **changes) -> RiccatiConfig:
        return replace(self, **changes)

    def in_pixels(self) -> RiccatiConfig:
        """The same cost with weights in pixel units (``pixel_pitch = 1``)."""
        a, b, g = weights_in_pixels(self.alpha, self.beta, self.gamma, self.pixel_pitch)
        return replace(self, alpha=a, beta=b, gamma=g, pixel_pitch=1.0)


def bryson_config(
    width_px: int,
    z_max: float,
    *,
    g_error: float = 2.26,
    g_edge_error: float = 1e-3,
    **changes,
) -> RiccatiConfig:
    """G5 settings in pixel units from Bryson's rule (eqs 14-16).

    ``z_max`` is the largest acceptable range (scene unit), ``g_error`` / ``g_edge_error``
    the largest acceptable ``|G - Ĝ|`` along the line / at its right edge (grey levels).
    The defaults are what the paper's α = 1, β = 1e-3, γ = 1e6 imply over its 512-px,
    0.195-in line: ``bryson_config(512, 71.6)`` reproduces them (rescaled to pixels)
    to 1 %. Other fields of :class:`RiccatiConfig` come from ``changes``.
    """
    a, b, g = bryson_weights(float(width_px), g_error**2, float(z_max) ** 2, g_edge_error**2)
    return RiccatiConfig(alpha=a, beta=b, gamma=g, pixel_pitch=1.0, **changes)


@dataclass(frozen=True)
class RiccatiLines:
    """Per-line signals of the sweep, shape (m, n); step ``k`` (pixel ``k`` to ``k+1``)
    is stored at column ``k``, so the last column of ``z`` is NaN.

    ``S``, ``K``, ``G`` are the sweep variables at pixel ``k``; ``Q = K + S Ĝ`` and
    ``e = G - Ĝ`` are what the ``lq`` form carries; ``A`` is the coefficient used for
    step ``k`` (at the edge or centre), ``E_diff`` the matching ``E1 - E2``; ``r`` the
    per-pixel reciprocal ``1 / (1 + c S)`` (``lq`` only, else NaN).
    """

    S: np.ndarray
    K: np.ndarray
    G: np.ndarray
    Q: np.ndarray
    e: np.ndarray
    z: np.ndarray
    A: np.ndarray
    G_hat: np.ndarray
    E_diff: np.ndarray
    r: np.ndarray


def _coefficients(
    e1: np.ndarray, e2: np.ndarray, f_px: float, baseline: float, cfg: RiccatiConfig
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """``Ĝ`` (eq 34), the ``E1 - E2`` and ``A`` (eq 33) of each step, and ``δ`` (eq 32)."""
    delta = cfg.pixel_pitch  # eq 32: the distance between pixel centres
    f = f_px * delta  # focal length in the weights' length unit
    dx = -baseline  # SPEC §9: eq 8 holds with the second camera at -Δx
    g_hat = e1 + e2  # eq 34
    diff = e1 - e2
    if cfg.a_sampling == "edge":
        d_step = np.empty_like(diff)
        d_step[:, :-1] = 0.5 * (diff[:, :-1] + diff[:, 1:])
        d_step[:, -1] = diff[:, -1]
    else:
        d_step = diff
    a = 2.0 * d_step / (f * dx)  # eq 33 (eq 10)
    return g_hat, d_step, a, delta


def _sweep_lq(g_hat: np.ndarray, a: np.ndarray, delta: float, cfg: RiccatiConfig) -> dict:
    n = g_hat.shape[1]
    ad, beta = cfg.alpha * delta, cfg.beta
    c = delta * a * a / beta  # c_k = δ A_k² / β
    dg = np.zeros_like(g_hat)
    dg[:, :-1] = g_hat[:, 1:] - g_hat[:, :-1]  # ΔĜ_k, centred at k + ½
    S = np.empty_like(g_hat)
    Q = np.empty_like(g_hat)
    r = np.full_like(g_hat, np.nan)
    S[:, -1] = cfg.gamma  # eq 24
    Q[:, -1] = 0.0  # K(r) + S(r) Ĝ(r) = -γĜ + γĜ
    for k in range(n - 2, -1, -1):  # backward sweep, right edge to left edge
        rk = 1.0 / (1.0 + c[:, k] * S[:, k + 1])
        r[:, k] = rk
        S[:, k] = ad + rk * S[:, k + 1]
        Q[:, k] = rk * (Q[:, k + 1] - S[:, k + 1] * dg[:, k])
    e = np.empty_like(g_hat)
    z = np.full_like(g_hat, np.nan)
    e[:, 0] = 0.0  # G_0 = Ĝ_0
    for k in range(n - 1):  # forward pass, left edge to right edge
        u = e[:, k] - dg[:, k]
        z[:, k] = -(a[:, k] / beta) * r[:, k] * (S[:, k + 1] * u + Q[:, k + 1])
        e[:, k + 1] = r[:, k] * (u - c[:, k] * Q[:, k + 1])
    return {"S": S, "Q": Q, "e": e, "z": z, "r": r, "K": Q - S * g_hat, "G": e + g_hat}


def _sweep_literal(g_hat: np.ndarray, a: np.ndarray, delta: float, cfg: RiccatiConfig) -> dict:
    n = g_hat.shape[1]
    alpha, beta = cfg.alpha, cfg.beta
    w = a * a * delta / beta  # A_j² δ / β
    S = np.empty_like(g_hat)
    K = np.empty_like(g_hat)
    S[:, -1] = cfg.gamma  # S_n = γ
    K[:, -1] = -cfg.gamma * g_hat[:, -1]  # K_n = -γ Ĝ_n
    with np.errstate(over="ignore", invalid="ignore"):
        for j in range(n - 1, 0, -1):  # eqs 35-36 as printed, j = n, n-1, ..., 1
            S[:, j - 1] = S[:, j] + S[:, j] ** 2 * w[:, j] - alpha * delta
            K[:, j - 1] = K[:, j] + S[:, j] * w[:, j] * K[:, j] + alpha * g_hat[:, j] * delta
        G = np.empty_like(g_hat)
        G[:, 0] = g_hat[:, 0]  # G_1 = Ĝ_1
        for k in range(n - 1):  # eq 37
            G[:, k + 1] = G[:, k] - w[:, k] * (S[:, k] * G[:, k] + K[:, k])
        z = -(S * G + K) * a / beta  # eq 38 (printed as a second "(33)")
        z[:, -1] = np.nan
        Q = K + S * g_hat
    return {
        "S": S,
        "Q": Q,
        "e": G - g_hat,
        "z": z,
        "r": np.full_like(g_hat, np.nan),
        "K": K,
        "G": G,
    }


def _check_lines(image: np.ndarray, name: str) -> np.ndarray:
    """Like :func:`validate_image`, but one line is enough (the sweep runs per line)."""
    arr = np.asarray(image)
    if arr.ndim == 2 and arr.shape[0] == 1 and arr.shape[1] >= 2:
        return validate_image(np.vstack([arr, arr]), name)[:1]
    return validate_image(arr, name)


def riccati_sweep(
    image1: np.ndarray,
    image2: np.ndarray,
    f_px: float,
    baseline: float,
    config: RiccatiConfig | None = None,
) -> RiccatiLines:
    """Run the G5 sweep on every line of a registered pair (E1 left, E2 right).

    ``f_px`` is the focal length in pixels, ``baseline`` the displacement of camera 2 to
    the right of camera 1 in the scene's length unit (negative: to the left). Lines are
    independent: all ``m`` lines are swept together, one column per step.
    """
    cfg = config or RiccatiConfig()
    e1 = _check_lines(image1, "image1")
    e2 = _check_lines(image2, "image2")
    if e1.shape != e2.shape:
        raise ValueError(f"image pair shapes differ: {e1.shape} vs {e2.shape}")
    if not (math.isfinite(f_px) and f_px > 0):
        raise ValueError(f"focal length must be a positive finite number of pixels, not {f_px!r}")
    if not (math.isfinite(baseline) and baseline != 0):
        raise ValueError(f"stereo baseline must be a non-zero finite length, not {baseline!r}")
    g_hat, d_step, a, delta = _coefficients(e1, e2, f_px, baseline, cfg)
    sweep = _sweep_lq if cfg.form == "lq" else _sweep_literal
    out = sweep(g_hat, a, delta, cfg)
    return RiccatiLines(A=a, G_hat=g_hat, E_diff=d_step, **out)


def stereo_baseline(motion: MotionIncrement) -> float:
    """Baseline ``b`` of a registered stereo pair (camera 2 displaced ``b`` along the image
    x axis); ``ValueError`` for any other displacement."""
    fwd, right, down = motion.camera_displacement
    if abs(fwd) > 1e-9 * abs(right) or abs(down) > 1e-9 * abs(right) or right == 0:
        raise ValueError(
            "G5 needs a registered stereo pair (camera 2 displaced along the image x axis "
            f"only); the displacement is {fwd:g} forward, {right:g} right, {down:g} down"
        )
    return float(right)


def range_g5(
    image1: np.ndarray,
    image2: np.ndarray,
    camera: PinholeCamera,
    motion: MotionIncrement,
    config: RiccatiConfig | None = None,
) -> RangeResult:
    """Range map of G5 (eq 38 / the ``lq`` sweep), with the validity rule of SPEC §3.

    Valid where ``|E1 - E2| >= threshold_e`` at the sample of ``A`` and
    ``0 < z <= range_max``; the last column has no step and is never valid. ``terms``
    holds the :class:`RiccatiLines` signals ``S, K, G, Q, e, A, G_hat, r`` and
    ``raw_range``.
    """
    cfg = config or RiccatiConfig()
    if image1.shape != (camera.height, camera.width):
        raise ValueError(
            f"images are {np.shape(image1)} but the camera is {camera.height}x{camera.width}"
        )
    lines = riccati_sweep(image1, image2, camera.f_px, stereo_baseline(motion), cfg)
    raw = lines.z
    with np.errstate(invalid="ignore"):
        valid = (
            (np.abs(lines.E_diff) >= cfg.threshold_e)
            & np.isfinite(raw)
            & (raw > 0)
            & (raw <= cfg.range_max)
        )
    rng = np.where(valid, raw, cfg.range_max)
    terms = {name: getattr(lines, name) for name in ("S", "K", "G", "Q", "e", "A", "G_hat", "r")}
    terms["raw_range"] = raw
    return RangeResult(range=rng, valid=valid, terms=terms)


def _bits(lo: float, hi: float) -> int | None:
    """Integer bits (sign included) of a two's-complement word holding ``[lo, hi]``."""
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return None
    mag = max(abs(lo), abs(hi))
    if mag == 0:
        return 1
    return max(1, math.floor(math.log2(mag)) + 1) + (1 if lo < 0 else 0)


def riccati_signal_ranges(
    scene: Scene,
    config: RiccatiConfig | None = None,
    *,
    rows: slice | np.ndarray | None = None,
    columns: slice | None = None,
) -> dict[str, dict[str, float | int | None]]:
    """Min / max / integer bits of ``S, K, G, z`` (and ``Q, e, r, A``) along lines of a scene.

    ``scene`` is a :class:`~rangefx.golden.scenes.Scene` (stereo); ``rows`` selects the
    lines (default all) and ``columns`` the pixels along them (default all; e.g.
    ``slice(8, -8)`` leaves out the right-edge transient where ``S`` starts at ``γ``).
    ``z`` is reported over all steps and over valid pixels
    (``z_valid``). ``int_bits`` is the number of integer bits, sign included, of a
    two's-complement word that holds the range (``None`` if not finite); these decide
    the fixed-point formats of the hardware model; ``msb`` is ``floor(log2(max |v|))``,
    the weight of the leading bit (negative for signals below 1, e.g. ``S``).
    """
    cfg = config or RiccatiConfig()
    res = range_g5(scene.image1, scene.image2, scene.camera, scene.motion, cfg)
    sel = (slice(None) if rows is None else rows, slice(None) if columns is None else columns)
    out: dict[str, dict[str, float | int | None]] = {}
    signals = {k: res.terms[k] for k in ("S", "K", "G", "Q", "e", "r", "A")}
    signals["z"] = res.terms["raw_range"]
    for name, arr in signals.items():
        v = np.asarray(arr)[sel]
        v = v[~np.isnan(v)]
        lo, hi = (float(v.min()), float(v.max())) if v.size else (math.nan, math.nan)
        out[name] = _span(lo, hi)
    zv = res.terms["raw_range"][sel][res.valid[sel]]
    lo, hi = (float(zv.min()), float(zv.max())) if zv.size else (math.nan, math.nan)
    out["z_valid"] = _span(lo, hi)
    return out


def _span(lo: float, hi: float) -> dict[str, float | int | None]:
    mag = max(abs(lo), abs(hi))
    msb = math.floor(math.log2(mag)) if math.isfinite(mag) and mag > 0 else None
    return {"min": lo, "max": hi, "int_bits": _bits(lo, hi), "msb": msb}
