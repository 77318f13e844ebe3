"""G1: passive navigation by image-irradiance tracking (report ch. 2, AIAA 1989 paper).

A camera translates with known velocity ``(ẋ0, ẏ0, ż0)`` (INS data) past a stationary
scene. Chapter 2's axes: ``Y`` forward (depth ``y - y0``), ``x_p`` along the image's
major (horizontal) axis, ``z_p`` along its minor (vertical) axis, eqs 1-2
``x_p = f (x - x0) / (y - y0)``, ``z_p = f (z - z0) / (y - y0)``. Image coordinates here
are continuous, in pixels from the principal point, ``z_p`` up (the paper's front image
plane); the focal length is in pixels (SPEC §2).

Equations and the typos fixed (reasoned from eqs 4-6):

* eq 7, the optical navigation equation, prints its bracket around the ``x_p`` term
  only; from eqs 4-6 it is ``∂E/∂t = -[E_x (x_p ẏ0 - f ẋ0) + E_z (z_p ẏ0 - f ż0)] /
  (y - y0)`` (the chapter's own eq 2.4 has it right), hence
  ``y - y0 = -[E_x u' + E_z v'] / E_t`` with ``u' = x_p ẏ0 - f ẋ0``,
  ``v' = z_p ẏ0 - f ż0`` (:func:`navigation_range`).
* eq 8 prints ``... = 1/(y - y0)``: it is the same product as eq 7 with differences.
  Asking ``ΔE1 = ΔE2 = ΔE3`` ("temporal and spatial differences more or less equal")
  gives eq 9-10 as printed, ``Δt = Δx_p Δz_p (y - y0) / N_r``,
  ``N_r = -[Δz_p u' + Δx_p v']``. ``N_r`` is signed, so its two terms can cancel and
  the bound become infinite while the image still moves; :func:`sampling_interval_bound`
  returns ``|eq 9|`` (``form="printed"``) or the bound with the terms' magnitudes
  added, ``Δx_p Δz_p (y - y0) / (Δz_p |u'| + Δx_p |v'|)`` (``form="absolute"``), i.e.
  the image moves at most about one pixel (L1) per frame. The report recommends
  one fifth to one tenth of the bound.
* eqs 24-26: ``∂r/∂x_p = -b r``, ``∂r/∂z_p = -c r``, ``∂r/∂t = -a r`` for the model
  error ``r = E - E_M`` (eq 11). With eqs 12-14 the model's derivatives are
  ``E_M,t = E_t + a r``, ``E_M,x = E_x + b r``, ``E_M,z = E_z + c r``.
* eq 27, the tracking filter, forward Euler: ``E_M(t_(i+1)) = E_M(t_i) +
  h [E_t + a (E - E_M)]`` — the bracket is ``E_M,t`` of eq 12. It is stable for
  ``0 < a h < 2`` (pole ``1 - a h``) and does not ring for ``a h <= 1``.

Discrete choices (the paper leaves them open): ``E_x``, ``E_z`` are central differences
over ``±Δx_p``, ``±Δz_p`` at ``t_i``; ``E_t`` is the backward difference
``(E_i - E_(i-1)) / h`` (zero at the first sample), or zero throughout
(``temporal="zero"``: "these may be assumed zero, letting the tracking process
compensate"). The raw range at a sample uses the model's derivatives (eqs 7, 12-14); it
is valid where ``|h E_M,t| >= threshold`` (grey levels per frame: the navigation
equation divides by ``E_M,t``) and ``0 < range <= range_max``.

Range low-pass filter (the report's Figs 6-7, "two different time constants"): first
order, time constant ``τ``, exact (zero-order-hold) discretisation
``R_f += (1 - exp(-h/τ)) (R - R_f)``, so it is stable for every ``τ > 0``; it absorbs only
valid raw samples and holds its value across invalid ones (the raw range is unbounded
where ``E_M,t`` crosses zero, and one such sample would dominate a linear filter), and
starts at the first valid sample.

Scene (:func:`chapter2_scene`, the report's Figs 3-4): joined vertical rectangular planes
of equal height — a continuous polyline section ``Y(X)`` — with an irradiance that is a
continuous function of the arc length along the section and of the height, so the
irradiance is continuous across the joints while its gradient is not (where the report's
Fig. 5 shows its anomalies).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "Chapter2Scene",
    "LowPassConfig",
    "TrackingConfig",
    "TrackingRun",
    "chapter2_config",
    "chapter2_scene",
    "lowpass_range",
    "navigation_range",
    "sampling_interval_bound",
    "simulate_tracking",
]

TEMPORAL = ("difference", "zero")
BOUND_FORMS = ("printed", "absolute")


def _positive(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{name} must be a positive finite number, not {value!r}")
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number, not {value!r}")
    return float(value)


# --------------------------------------------------------------------------- equations


def _flow_terms(
    xp: np.ndarray | float, zp: np.ndarray | float, velocity: np.ndarray, f_px: float
) -> tuple[np.ndarray, np.ndarray]:
    """``u' = x_p ẏ0 - f ẋ0`` and ``v' = z_p ẏ0 - f ż0`` (eqs 5-6 times ``y - y0``)."""
    vx, vy, vz = (float(c) for c in velocity)
    xp = np.asarray(xp, dtype=np.float64)
    zp = np.asarray(zp, dtype=np.float64)
    return xp * vy - f_px * vx, zp * vy - f_px * vz


def navigation_range(
    e_t: np.ndarray,
    e_x: np.ndarray,
    e_z: np.ndarray,
    xp: np.ndarray | float,
    zp: np.ndarray | float,
    velocity: np.ndarray | tuple[float, float, float],
    f_px: float,
) -> np.ndarray:
    """Depth ``y - y0`` from the optical navigation equation (eq 7, bracket fixed).

    ``y - y0 = -[E_x (x_p ẏ0 - f ẋ0) + E_z (z_p ẏ0 - f ż0)] / E_t``. Units: ``E_x``,
    ``E_z`` per pixel, ``E_t`` per unit time, velocity in length per unit time, ``f`` in
    pixels. Where ``E_t = 0`` the result is ``±inf`` or NaN.
    """
    u, v = _flow_terms(xp, zp, np.asarray(velocity, dtype=np.float64), f_px)
    with np.errstate(divide="ignore", invalid="ignore"):
        return -(np.asarray(e_x) * u + np.asarray(e_z) * v) / np.asarray(e_t)


def sampling_interval_bound(
    xp: np.ndarray | float,
    zp: np.ndarray | float,
    depth: np.ndarray | float,
    velocity: np.ndarray | tuple[float, float, float],
    f_px: float,
    dx: float = 1.0,
    dz: float = 1.0,
    form: str = "printed",
) -> np.ndarray:
    """Upper bound on the temporal sampling interval (eqs 9-10).

    ``form="printed"``: ``|Δt| = Δx_p Δz_p (y - y0) / |N_r|``,
    ``N_r = -[Δz_p u' + Δx_p v']`` (eq 10) — infinite where the signed terms cancel.
    ``form="absolute"``: ``Δx_p Δz_p (y - y0) / (Δz_p |u'| + Δx_p |v'|)``, never larger
    than the printed one, the time in which the image moves one pixel (L1 norm).
    Use one fifth to one tenth of it (report).
    """
    if form not in BOUND_FORMS:
        raise ValueError(f"unknown bound form {form!r}; choose from {BOUND_FORMS}")
    dx = _positive("dx", dx)
    dz = _positive("dz", dz)
    u, v = _flow_terms(xp, zp, np.asarray(velocity, dtype=np.float64), f_px)
    if form == "printed":
        nr = np.abs(-(dz * u + dx * v))
    else:
        nr = dz * np.abs(u) + dx * np.abs(v)
    with np.errstate(divide="ignore"):
        return dx * dz * np.asarray(depth, dtype=np.float64) / nr


# --------------------------------------------------------------------------- scene


@dataclass(frozen=True, eq=False)
class Chapter2Scene:
    """Piecewise-planar scene of ch. 2 seen by a translating camera (Figs 3-5).

    Attributes
    ----------
    section
        ``(K, 2)`` vertices ``(X, Y)`` of the horizontal section, ``X`` increasing: the
        scene is the vertical planes between consecutive vertices (``Y`` is forward).
    z_range
        Bottom and top ``Z`` of the planes (equal height).
    f_px
        Focal length in pixels.
    position0, velocity
        Camera position at ``t = 0`` and its constant velocity ``(ẋ0, ẏ0, ż0)``.
    irradiance_terms
        ``(amplitude, wavelength, phase, axis)`` sinusoids added to ``mean``; ``axis`` 0
        runs along the section's arc length, 1 along the height ``Z``.
    mean
        Mean grey level.
    unit
        Length unit (time in seconds).
    """

    section: np.ndarray
    z_range: tuple[float, float]
    f_px: float
    position0: np.ndarray
    velocity: np.ndarray
    irradiance_terms: tuple[tuple[float, float, float, int], ...]
    mean: float = 128.0
    unit: str = "ft"
    _arc: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        sec = np.asarray(self.section, dtype=np.float64)
        if sec.ndim != 2 or sec.shape[1] != 2 or sec.shape[0] < 2:
            raise ValueError(f"section must have shape (K >= 2, 2), not {sec.shape}")
        if np.any(np.diff(sec[:, 0]) <= 0):
            raise ValueError("section X coordinates must increase strictly")
        if not self.z_range[0] < self.z_range[1]:
            raise ValueError(f"z_range must be (bottom, top) with bottom < top: {self.z_range}")
        _positive("f_px", self.f_px)
        for name in ("position0", "velocity"):
            if np.asarray(getattr(self, name)).shape != (3,):
                raise ValueError(f"{name} must have 3 components")
        for term in self.irradiance_terms:
            if len(term) != 4 or term[3] not in (0, 1) or not term[1] > 0:
                raise ValueError(
                    f"irradiance term {term!r} is not (amp, wavelength > 0, phase, 0|1)"
                )
        seg = np.hypot(np.diff(sec[:, 0]), np.diff(sec[:, 1]))
        object.__setattr__(self, "section", sec)
        object.__setattr__(self, "position0", np.asarray(self.position0, dtype=np.float64))
        object.__setattr__(self, "velocity", np.asarray(self.velocity, dtype=np.float64))
        object.__setattr__(self, "_arc", np.concatenate([[0.0], np.cumsum(seg)]))

    def camera_position(self, t: np.ndarray | float) -> np.ndarray:
        """Camera position at time(s) ``t``, shape ``(*t.shape, 3)``."""
        t = np.asarray(t, dtype=np.float64)
        return self.position0 + t[..., None] * self.velocity

    def _hit(self, xp: np.ndarray, zp: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, ...]:
        """Depth ``y - y0``, arc length and height of the first plane hit (NaN if none)."""
        xp, zp, t = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (xp, zp, t)))
        cam = self.camera_position(t)
        x0, y0, z0 = cam[..., 0], cam[..., 1], cam[..., 2]
        X, Y = self.section[:, 0], self.section[:, 1]
        slope = np.diff(Y) / np.diff(X)
        best = np.full(xp.shape, np.inf)
        arc = np.full(xp.shape, np.nan)
        for k in range(len(slope)):  # ray (x0 + d xp/f, y0 + d): Y_k + s (x - X_k) = y
            den = 1.0 - slope[k] * xp / self.f_px
            with np.errstate(divide="ignore", invalid="ignore"):
                d = (Y[k] + slope[k] * (x0 - X[k]) - y0) / den
            x = x0 + d * xp / self.f_px
            hit = (d > 0) & (x >= X[k]) & (x <= X[k + 1]) & (d < best)
            best = np.where(hit, d, best)
            seg_len = math.hypot(X[k + 1] - X[k], Y[k + 1] - Y[k])
            s = self._arc[k] + (x - X[k]) / (X[k + 1] - X[k]) * seg_len
            arc = np.where(hit, s, arc)
        z = z0 + best * zp / self.f_px
        inside = np.isfinite(best) & (z >= self.z_range[0]) & (z <= self.z_range[1])
        return np.where(inside, best, np.nan), np.where(inside, arc, np.nan), z

    def true_range(
        self, xp: np.ndarray | float, zp: np.ndarray | float, t: np.ndarray | float
    ) -> np.ndarray:
        """Exact depth ``y - y0`` seen at image point ``(x_p, z_p)`` at time ``t``."""
        return self._hit(np.asarray(xp), np.asarray(zp), np.asarray(t))[0]

    def irradiance(
        self, xp: np.ndarray | float, zp: np.ndarray | float, t: np.ndarray | float
    ) -> np.ndarray:
        """Irradiance at continuous image point ``(x_p, z_p)`` at time ``t`` (NaN off-scene)."""
        depth, arc, z = self._hit(np.asarray(xp), np.asarray(zp), np.asarray(t))
        e = np.full(depth.shape, self.mean)
        for amp, wavelength, phase, axis in self.irradiance_terms:
            coord = arc if axis == 0 else z
            e = e + amp * np.sin(2.0 * np.pi * coord / wavelength + phase)
        return np.where(np.isfinite(depth), e, np.nan)


def chapter2_scene(
    *,
    f_px: float = 256.0,
    velocity: tuple[float, float, float] = (10.0, 5.0, 0.0),
    section: tuple[tuple[float, float], ...] | None = None,
) -> Chapter2Scene:
    """The report's ch. 2 simulated scene (Figs 3-4), in feet and seconds.

    Five joined planes 15-22 ft wide, 40 ft high, 55-75 ft ahead of the camera
    (section vertices below), irradiance ``128 + 50 sin(2π s/9) + 20 sin(2π s/3.7 + 1)
    + 25 sin(2π Z/11 + 0.5)`` (``s`` arc length, ``Z`` height, ft). The camera starts
    at the origin and moves at ``velocity`` (default 10 ft/s right, 5 ft/s forward), a
    slow rotorcraft sidestep. The report's own figures are not legible in the OCR text,
    so sizes are chosen so that the point seen by pixel ``(40, 30)`` crosses joints at
    t ≈ 0.08, 2.27 and 4.52 s of a 5 s run.
    """
    if section is None:
        section = ((-40.0, 70.0), (-8.0, 62.0), (12.0, 72.0), (30.0, 58.0), (52.0, 66.0),
                   (90.0, 60.0))  # fmt: skip
    return Chapter2Scene(
        section=np.asarray(section, dtype=np.float64),
        z_range=(-20.0, 20.0),
        f_px=f_px,
        position0=np.zeros(3),
        velocity=np.asarray(velocity, dtype=np.float64),
        irradiance_terms=((50.0, 9.0, 0.0, 0), (20.0, 3.7, 1.0, 0), (25.0, 11.0, 0.5, 1)),
    )


# --------------------------------------------------------------------------- filters


@dataclass(frozen=True)
class TrackingConfig:
    """Irradiance tracking filter (eqs 24-27) and the navigation equation's gate.

    Attributes
    ----------
    h
        Frame interval (the Euler step of eq 27), seconds.
    a
        Temporal error decay rate of eq 26 (1/s); ``0 < a h < 2`` for stability.
    b, c
        Spatial error decay rates of eqs 24-25 (1/pixel), ``>= 0``.
    dx, dz
        Finite-difference spacings ``Δx_p``, ``Δz_p`` (pixels).
    temporal
        ``"difference"`` (backward difference for ``E_t``) or ``"zero"``.
    threshold
        Minimum ``|h E_M,t|`` (grey levels per frame) for a valid raw range.
    range_max
        Largest valid range (scene unit).
    """

    h: float
    a: float
    b: float = 0.1
    c: float = 0.1
    dx: float = 1.0
    dz: float = 1.0
    temporal: str = "difference"
    threshold: float = 0.1
    range_max: float = 1000.0

    def __post_init__(self) -> None:
        for name in ("h", "a", "dx", "dz", "range_max"):
            _positive(name, getattr(self, name))
        if not 0.0 < self.a * self.h < 2.0:
            raise ValueError(f"tracking filter unstable: a h = {self.a * self.h:g} not in (0, 2)")
        for name in ("b", "c", "threshold"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"{name} must be a finite number >= 0, not {v!r}")
            if v < 0:
                raise ValueError(f"{name} must be a finite number >= 0, not {v!r}")
        if self.temporal not in TEMPORAL:
            raise ValueError(f"unknown temporal derivative {self.temporal!r}; choose {TEMPORAL}")

    @classmethod
    def from_weights(
        cls, h: float, c1: float, c2: float, alpha: float, beta: float, gamma: float, **kw
    ) -> TrackingConfig:
        """Rates from the weights of eq 15: ``a = sqrt(C1/γ)``, ``b = sqrt(C2/α)``,
        ``c = sqrt(C3/β)`` with ``C3 = 1 - C1 - C2`` (eqs 20-23), all ``C > 0`` (eq 21)."""
        c3 = 1.0 - c1 - c2
        if min(c1, c2, c3) <= 0:
            raise ValueError(f"C1, C2, C3 = 1 - C1 - C2 must be > 0 (eq 21): {c1}, {c2}, {c3}")
        for name, w in (("alpha", alpha), ("beta", beta), ("gamma", gamma)):
            _positive(name, w)
        return cls(
            h=h,
            a=math.sqrt(c1 / gamma),
            b=math.sqrt(c2 / alpha),
            c=math.sqrt(c3 / beta),
            **kw,
        )


@dataclass(frozen=True)
class LowPassConfig:
    """First-order range low-pass filter with time constant ``tau`` (seconds)."""

    tau: float

    def __post_init__(self) -> None:
        _positive("tau", self.tau)

    def gain(self, h: float) -> float:
        """Per-sample gain ``1 - exp(-h/τ)`` (exact ZOH discretisation)."""
        return 1.0 - math.exp(-_positive("h", h) / self.tau)


def lowpass_range(raw: np.ndarray, valid: np.ndarray, h: float, tau: float) -> np.ndarray:
    """Low-pass filtered range along axis 0 (time); NaN before the first valid sample.

    ``R_f[i] = R_f[i-1] + κ (R[i] - R_f[i-1])`` at valid samples, ``R_f[i] = R_f[i-1]``
    at invalid ones, ``κ = 1 - exp(-h/τ)``; ``R_f`` starts at the first valid ``R``.
    """
    raw = np.asarray(raw, dtype=np.float64)
    valid = np.asarray(valid, dtype=bool)
    if raw.shape != valid.shape:
        raise ValueError(f"raw range {raw.shape} and valid {valid.shape} shapes differ")
    kappa = LowPassConfig(tau).gain(h)
    out = np.empty_like(raw)
    state = np.full(raw.shape[1:], np.nan)
    for i in range(raw.shape[0]):
        fresh = valid[i] & np.isnan(state)
        state = np.where(fresh, raw[i], state)
        upd = valid[i] & ~fresh
        state = np.where(upd, state + kappa * (raw[i] - state), state)
        out[i] = state
    return out


@dataclass(frozen=True, eq=False)
class TrackingRun:
    """Time series of one G1 simulation; arrays have shape ``(steps, *pixel_shape)``.

    ``range_raw`` is eq 7 on the tracked model's derivatives (NaN where invalid),
    ``range_filtered`` maps time constant to the low-passed range, ``truth`` the exact
    depth, ``model`` the tracked irradiance ``E_M`` and ``irradiance`` the measured ``E``.
    """

    t: np.ndarray
    xp: np.ndarray
    zp: np.ndarray
    truth: np.ndarray
    irradiance: np.ndarray
    model: np.ndarray
    range_raw: np.ndarray
    valid: np.ndarray
    range_filtered: dict[float, np.ndarray]
    config: TrackingConfig


def simulate_tracking(
    scene: Chapter2Scene,
    xp: np.ndarray | float,
    zp: np.ndarray | float,
    config: TrackingConfig,
    steps: int,
    taus: tuple[float, ...] = (),
    *,
    noise_sigma: float = 0.0,
    seed: int = 0,
) -> TrackingRun:
    """Run the navigation scheme of Fig. 2 at image point(s) ``(x_p, z_p)``.

    Per frame ``i`` (``t_i = i h``): sample ``E`` at the point and at ``±Δx_p``,
    ``±Δz_p``; central differences ``E_x``, ``E_z``; ``E_t`` per ``config.temporal``;
    ``r = E - E_M`` (eq 11); model derivatives ``E_t + a r``, ``E_x + b r``,
    ``E_z + c r`` (eqs 12-14, 24-26); raw range from eq 7; then ``E_M += h E_M,t``
    (eq 27), ``E_M`` starting at ``E_0``. Raw ranges go through :func:`lowpass_range`
    for each time constant in ``taus``. ``noise_sigma`` adds seeded Gaussian noise (grey
    levels) to every sample.
    """
    if isinstance(steps, bool) or int(steps) != steps or steps < 2:
        raise ValueError(f"steps must be an integer >= 2, not {steps!r}")
    if not (math.isfinite(noise_sigma) and noise_sigma >= 0):
        raise ValueError(f"noise_sigma must be a finite number >= 0, not {noise_sigma!r}")
    taus = tuple(float(LowPassConfig(tau).tau) for tau in taus)
    xp, zp = np.broadcast_arrays(np.asarray(xp, dtype=np.float64), np.asarray(zp, dtype=np.float64))
    h, dx, dz = config.h, config.dx, config.dz
    t = np.arange(int(steps)) * h
    tt = t.reshape((-1,) + (1,) * xp.ndim)
    offsets = ((0.0, 0.0), (dx, 0.0), (-dx, 0.0), (0.0, dz), (0.0, -dz))
    samples = [scene.irradiance(xp + ox, zp + oz, tt) for ox, oz in offsets]
    if noise_sigma > 0:
        rng = np.random.default_rng(seed)
        samples = [s + rng.normal(0.0, noise_sigma, s.shape) for s in samples]
    e, exp_, exm, ezp, ezm = samples
    if np.isnan(e).any() or np.isnan(exp_).any() or np.isnan(ezp).any():
        raise ValueError("the image point leaves the scene during the run (irradiance NaN)")
    ex = (exp_ - exm) / (2.0 * dx)
    ez = (ezp - ezm) / (2.0 * dz)
    et = np.zeros_like(e)
    if config.temporal == "difference":
        et[1:] = (e[1:] - e[:-1]) / h
    model = np.empty_like(e)
    raw = np.empty_like(e)
    em = e[0].copy()
    for i in range(len(t)):
        model[i] = em
        r = e[i] - em  # eq 11
        em_t = et[i] + config.a * r  # eqs 12, 26
        em_x = ex[i] + config.b * r  # eqs 13, 24
        em_z = ez[i] + config.c * r  # eqs 14, 25
        with np.errstate(divide="ignore", invalid="ignore"):
            rng_i = navigation_range(em_t, em_x, em_z, xp, zp, scene.velocity, scene.f_px)
        ok = np.abs(h * em_t) >= config.threshold
        raw[i] = np.where(ok, rng_i, np.nan)
        em = em + h * em_t  # eq 27
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(raw) & (raw > 0) & (raw <= config.range_max)
    raw = np.where(valid, raw, np.nan)
    filtered = {tau: lowpass_range(np.where(valid, raw, 0.0), valid, h, tau) for tau in taus}
    return TrackingRun(
        t=t,
        xp=xp,
        zp=zp,
        truth=scene.true_range(xp, zp, tt),
        irradiance=e,
        model=model,
        range_raw=raw,
        valid=valid,
        range_filtered=filtered,
        config=config,
    )


def chapter2_config(
    scene: Chapter2Scene,
    xp: float,
    zp: float,
    *,
    fraction: float = 0.1,
    gain: float = 0.5,
    **kwargs: float | str,
) -> TrackingConfig:
    """Tracking settings for a run at ``(x_p, z_p)``: ``h = fraction x`` the eq-9 bound.

    The bound is the ``"absolute"`` form of :func:`sampling_interval_bound` at ``t = 0``
    (the report: use one fifth to one tenth of it); ``a = gain / h`` (Euler pole
    ``1 - gain`` of eq 27). Other fields of :class:`TrackingConfig` pass through.
    """
    _positive("fraction", fraction)
    if not 0.0 < gain < 2.0:
        raise ValueError(f"gain a h must be in (0, 2) for a stable eq 27, not {gain!r}")
    depth = float(scene.true_range(xp, zp, 0.0))
    if not math.isfinite(depth):
        raise ValueError(f"image point ({xp}, {zp}) does not see the scene at t = 0")
    bound = float(
        sampling_interval_bound(xp, zp, depth, scene.velocity, scene.f_px, form="absolute")
    )
    if not math.isfinite(bound):
        raise ValueError(f"the image does not move at ({xp}, {zp}): no range from eq 7")
    h = fraction * bound
    return TrackingConfig(h=h, a=gain / h, **kwargs)  # type: ignore[arg-type]
