"""Causal, product-factorised partial-derivative estimator (float64 golden model).

The report (ch. 4, SPIE paper eqs 13-21; obstacle paper eqs 34-42) factors the image as
``E = e1(xp) e2(yp)`` and runs a linear dynamic system along each scan line (eq 15)
whose outputs (eq 16) are the smoothed line and its derivatives, then a second system
down each column (eq 17) on the first row output, with outputs eq 18. The partial
derivatives follow from eq 19 (SPIE) / eq 40 (obstacle).

Discrete form (SPEC §3). One first-order section with pole ``c`` per pixel (the paper's
``a = 0.5`` with ``h = 1`` gives ``c = 0.5``), per sample ``k``::

    e = x[k] - p[k];   r1 = p[k];   r2 = (c / h) e;   p[k+1] = p[k] + c e

which is forward Euler of ``p' = -a p + a x`` (eq 20): ``r2`` is the exact forward
difference ``p[k+1] - p[k]`` of the smoothed sequence. With forward Euler ``c = a h``, so
``r2 = a e`` as SPEC §3 writes it; for a pole mapped with the exact ZOH discretisation
(``c = 1 - exp(-a h)``) the output stays the discrete difference ``(c / h) e``, which is
the derivative consistent with the sampled ``r1`` sequence (``a e`` would not be).
Higher derivatives come from a
cascade of ``n`` such sections (``order = n``); the ``d``-th output is the ``d``-th
forward difference of the cascade's last state, so the estimator of order ``n``
delivers derivatives up to order ``n`` from its states and the current input only
(the ``r = C p + D x`` of eq 16).

Two variants (SPEC §3):

``paper``
    Exactly the report's scheme: the column system runs on ``r1`` only, and
    ``dE/dx = s1 r2 / r1`` (eq 19 prints ``E_hat_1 r2 / r1``: SPEC §9, it must read
    ``s1 r2 / r1`` as obstacle eq 40), ``dE/dy = s2``, ``E_hat = s1``,
    ``d2E/dx2 = s1 r3 / r1``, ``d2E/dy2 = s3``, ``d2E/dxdy = r2 s2 / r1``. A bias ``b``
    is added to the image first so that ``r1 >= b > 0`` (eq 19 note). On real images
    the scheme has two structural errors: the ``d``-th output sits ``d/2`` pixel ahead
    of ``r1`` (a forward difference is centred between samples), and ``s1 r2 / r1`` is
    the x-derivative of ``s1`` only for a separable image with zero bias — the bias
    pushes ``s1 / r1`` towards 1, so ``dE/dx`` degenerates to the *unsmoothed-in-y*
    row derivative.
``consistent``
    Every output is centred on the same sample ``k + n/2`` (e.g. ``r1 = (p[k] +
    p[k+1]) / 2`` for ``n = 1``), and every row output ``r_d`` is filtered down the
    columns by its own column estimator (one more line buffer per row output, no
    divider): ``d^{a+b} E / dx^a dy^b`` is column output ``b`` of the column estimator
    fed with row output ``a``. All estimates then belong to one smoothed image
    ``E_hat`` at one position, which is what the ranging equation assumes. The columns
    are centred in the same way as the rows.

Both variants are causal: at sample ``k`` they use inputs up to ``k`` only, so they
stream in scan order. The smoothed image lags the input by the filter's group delay
(``(1 - c) / c`` pixels per section, plus the half-sample centring); both images of a
pair lag alike, so the lag does not bias a disparity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

__all__ = [
    "Derivatives",
    "EstimatorConfig",
    "causal_estimator_1d",
    "estimate_derivatives",
    "validate_image",
]

VARIANTS = ("paper", "consistent")
INITS = ("first", "zero")


@dataclass(frozen=True)
class EstimatorConfig:
    """Settings of the causal derivative estimator.

    Attributes
    ----------
    pole
        Discrete pole ``c`` per pixel, in (0, 1]; the SPIE paper's ``a = 0.5`` with
        ``h = 1`` is ``c = 0.5``. ``|1 - c| >= 1`` is unstable and rejected.
    order
        Number of cascaded first-order sections ``n`` = highest derivative order
        estimated (1 as in the paper's results; 2 for second derivatives).
    variant
        ``"paper"`` (the report's scheme, bias-added division) or ``"consistent"``.
    bias
        Constant added to the image before the filters (eqs 19/40: keeps ``r1 > 0``).
        It cancels in ``E1_hat - E2_hat`` and in the derivatives of the ``consistent``
        variant; in the ``paper`` variant it changes ``s1 r2 / r1``.
    init
        Filter state at the start of each line/column: ``"first"`` (the first input,
        i.e. steady state for a constant line) or ``"zero"``.
    """

    pole: float = 0.5
    order: int = 1
    variant: str = "paper"
    bias: float = 16.0
    init: str = "first"

    def __post_init__(self) -> None:
        c = self.pole
        if isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c):
            raise ValueError(f"filter pole must be a finite number, not {c!r}")
        if abs(1.0 - c) >= 1.0:
            raise ValueError(
                f"filter pole c = {c!r} is unstable (|1 - c| >= 1); a continuous pole a "
                "with step h maps to a stable c by EstimatorConfig.from_continuous(a, h, "
                "discretisation='zoh')"
            )
        if c > 1.0:
            raise ValueError(
                f"filter pole c = {c!r} is in (1, 2): stable but oscillating, not a "
                "low-pass; use c in (0, 1]"
            )
        if int(self.order) != self.order or not 1 <= self.order <= 4:
            raise ValueError(f"estimator order must be an integer in 1..4, not {self.order!r}")
        if self.variant not in VARIANTS:
            raise ValueError(f"unknown estimator variant {self.variant!r}; choose from {VARIANTS}")
        if self.init not in INITS:
            raise ValueError(f"unknown filter init {self.init!r}; choose from {INITS}")
        b = self.bias
        if isinstance(b, bool) or not isinstance(b, (int, float)) or not math.isfinite(b) or b < 0:
            raise ValueError(f"bias must be a finite non-negative number, not {self.bias!r}")

    @classmethod
    def from_continuous(
        cls, a: float, h: float = 1.0, *, discretisation: str = "euler", **kwargs
    ) -> EstimatorConfig:
        """Map the continuous pole ``a`` (per unit length) with step ``h`` to ``c``.

        ``"euler"`` (forward Euler, as the report's filters): ``c = a h`` — the obstacle
        paper's ``a = 5.0`` per pixel gives ``c = 5``, unstable, and is rejected.
        ``"zoh"`` (exact zero-order-hold): ``c = 1 - exp(-a h)``, stable for any
        ``a > 0``.
        """
        if not (math.isfinite(a) and a > 0 and math.isfinite(h) and h > 0):
            raise ValueError(f"continuous pole and step must be positive, not a={a!r}, h={h!r}")
        if discretisation == "euler":
            c = a * h
        elif discretisation == "zoh":
            c = 1.0 - math.exp(-a * h)
        else:
            raise ValueError(f"unknown discretisation {discretisation!r}; choose 'euler' or 'zoh'")
        return cls(pole=c, **kwargs)

    def with_(self, **changes) -> EstimatorConfig:
        return replace(self, **changes)


@dataclass(frozen=True)
class Derivatives:
    """Estimated image and partial derivatives, all shape (m, n), per pixel units.

    ``E`` is ``E_hat`` with the bias removed. Second derivatives are ``None`` when the
    estimator order is 1. ``taps`` holds the raw filter outputs (with bias) by name:
    ``r1..``, ``s1..`` (and, for ``consistent``, ``u{a}{b}`` = column output ``b`` of
    row output ``a``) — the signals a hardware model exposes.
    """

    E: np.ndarray
    Ex: np.ndarray
    Ey: np.ndarray
    Exx: np.ndarray | None = None
    Eyy: np.ndarray | None = None
    Exy: np.ndarray | None = None
    taps: dict[str, np.ndarray] = field(default_factory=dict)


def _cascade_last_state(x: np.ndarray, c: float, order: int, init: str, extra: int) -> np.ndarray:
    """Run ``order`` first-order sections along axis 0; return ``y[k] = p_n[k]``.

    ``y`` has ``len(x) + extra`` samples; ``y[k]`` depends on ``x[0..k-order]`` only, so
    samples up to ``len(x) - 1 + order`` are fully determined by ``x`` (the padding
    beyond the end never reaches them).
    """
    n_in = x.shape[0]
    length = n_in + extra
    xpad = np.concatenate([x, np.zeros((extra, *x.shape[1:]))], axis=0)
    states = [x[0].copy() if init == "first" else np.zeros(x.shape[1:]) for _ in range(order)]
    y = np.empty((length, *x.shape[1:]))
    for k in range(length):
        y[k] = states[-1]
        prev = [xpad[k], *states[:-1]]  # old values feed the next section (simultaneous update)
        states = [s + c * (u - s) for s, u in zip(states, prev, strict=True)]
    return y


def causal_estimator_1d(
    x: np.ndarray, config: EstimatorConfig, axis: int = -1, *, centred: bool | None = None
) -> list[np.ndarray]:
    """Outputs ``[r1, r2, ..., r_{n+1}]`` of the order-``n`` estimator along ``axis``.

    ``r_{d+1}`` estimates the ``d``-th derivative (per pixel) of the smoothed signal.
    ``centred=False`` (the paper's outputs, eq 16): ``r_{d+1}[k] = Δ^d y[k]`` where
    ``y[k] = p_n[k]`` is the last state *before* sample ``k`` is absorbed, so
    ``r_{d+1}`` is centred at ``k + d/2``. ``centred=True``: every output centred at
    ``k + n/2`` (``Δ^d y[k + (n-d)/2]``, averaged over the two neighbours when
    ``n - d`` is odd). The default follows ``config.variant``.
    """
    if centred is None:
        centred = config.variant == "consistent"
    n = config.order
    xm = np.moveaxis(np.asarray(x, dtype=np.float64), axis, 0)
    length = xm.shape[0]
    y = _cascade_last_state(xm, config.pole, n, config.init, extra=n + 1)
    outs = []
    for d in range(n + 1):
        diff = np.diff(y, n=d, axis=0) if d else y  # Δ^d y, index k ↔ centre k + d/2
        if not centred:
            out = diff[:length]
        else:
            j2 = n - d  # twice the shift to the common centre
            lo = j2 // 2
            out = diff[lo : lo + length]
            if j2 % 2:
                out = 0.5 * (out + diff[lo + 1 : lo + 1 + length])
        outs.append(np.moveaxis(out, 0, axis))
    return outs


def validate_image(image: np.ndarray, name: str = "image") -> np.ndarray:
    """Check one grey-level image (2-D, numeric, at least 2x2, finite); return it as float64.

    Raises ``ValueError`` naming ``name`` and what is wrong.
    """
    arr = np.asarray(image)
    if arr.ndim != 2:
        raise ValueError(f"{name} must be a 2-D array, got shape {arr.shape}")
    if arr.dtype.kind not in "uif":
        raise ValueError(f"{name} must be numeric, got dtype {arr.dtype}")
    if arr.shape[0] < 2 or arr.shape[1] < 2:
        raise ValueError(f"{name} must be at least 2x2, got shape {arr.shape}")
    arr = arr.astype(np.float64)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or inf")
    return arr


def estimate_derivatives(image: np.ndarray, config: EstimatorConfig | None = None) -> Derivatives:
    """Estimate ``E_hat`` and its partial derivatives in scan order (SPIE eqs 13-21).

    Parameters
    ----------
    image
        2-D array (rows = scan lines, top to bottom), grey levels.
    config
        Estimator settings; the default is the paper's first-order filter with
        ``c = 0.5`` in the ``paper`` variant.

    Returns
    -------
    Derivatives
        Derivatives are per pixel, x to the right (along a line), y down (across lines).
    """
    config = config or EstimatorConfig()
    x = validate_image(image) + config.bias
    n = config.order
    rows = causal_estimator_1d(x, config, axis=1)
    taps = {f"r{d + 1}": r for d, r in enumerate(rows)}
    if config.variant == "paper":
        s = causal_estimator_1d(rows[0], config, axis=0)
        taps.update({f"s{d + 1}": v for d, v in enumerate(s)})
        r1, r2 = rows[0], rows[1]
        ratio = s[0] / r1  # the divider of eq 19 / eq 40: s1 / r1
        out = dict(E=s[0] - config.bias, Ex=ratio * r2, Ey=s[1])
        if n >= 2:
            out.update(Exx=ratio * rows[2], Eyy=s[2], Exy=r2 * s[1] / r1)
        return Derivatives(**out, taps=taps)
    # consistent: column-filter each row output that a wanted derivative needs.
    u = {}
    for a in range(n + 1):
        cols = causal_estimator_1d(rows[a], config, axis=0)
        for b in range(n + 1 - a):
            u[(a, b)] = cols[b]
            taps[f"u{a}{b}"] = cols[b]
    out = dict(E=u[(0, 0)] - config.bias, Ex=u[(1, 0)], Ey=u[(0, 1)])
    if n >= 2:
        out.update(Exx=u[(2, 0)], Eyy=u[(0, 2)], Exy=u[(1, 1)])
    return Derivatives(**out, taps=taps)
