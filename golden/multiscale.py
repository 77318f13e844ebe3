"""G6: streaming multi-scale ranging, beyond the report (float64 golden model, SPEC §12).

Derivation from the report
--------------------------
The SPIE paper (ch. 4) expands the second image about the first (eq 6) and keeps the
first-order term: with the inverse depth ``δ`` and the disparity per unit inverse depth
``v = [xp Δz0 - f Δx0, yp Δz0 - f Δy0]`` (eq 9), the degree-1 ranging polynomial
(eq 10) is

    c1 = E1 - E2 = a1 δ,        a1 = ½ (g1 + g2) · v                      (eq 10, n = 1)

and G3 solves it per pixel, ``δ = c1 / a1`` (then the depth ``1/δ + Δz0``, eq 12).
For a stereo pair (``Δz0 = Δy0 = 0``, baseline ``B = Δx0``) ``v = (-f B, 0)``: the
disparity ``u = f B δ`` is along the row and ``E1(x) = E2(x - u)``.

G6 changes three things, and only these (plus two options for real rigs, below):

1. **Normal equations over a window.** Instead of dividing per pixel it solves eq 10
   in the least-squares sense over a small window ``w`` (a Gaussian of ``σ`` px,
   separable): minimise ``Σ w (c1 - a1 δ)²`` ⇒ ``δ = Σ w a1 c1 / Σ w a1²``; with
   ``g = ½ (E1x + E2x)`` (the eq 6 mean gradient along the row) this is a 1-D
   Lucas–Kanade step along the disparity direction, ``Δu = -Σ w g e / Σ w g²``, with
   ``e = E1 - E2``. The per-pixel division of G3 is the limit ``w → δ_0``.
2. **Warping.** Eq 6 is a Taylor expansion, right only while ``u`` is a small fraction
   of the texture's scale (measured for G3: ≤ 0.06 px error up to 1 px, 1.8 px at
   4 px). G6 expands about the current estimate instead of about 0: the second image
   is resampled along its row, ``W(x) = E2(x - u(x))`` (Keys cubic interpolation, from
   a line buffer of E2 at least the largest disparity wide), eq 10 is written for
   ``E1`` and ``W`` (``e = E1 - W``, ``g = ½ (E1x + Wx)``) and its solution is added to
   ``u``. Each warp is one more Gauss–Newton step; 1-3 per level.
3. **Pyramid.** The warps converge only from within about a pixel. A pyramid by
   line-buffered decimation (5-tap binomial, every second row and column) brings any
   disparity below ``2^(L-1)`` px (``L`` levels) to about a pixel at the coarsest
   level; each level starts from the coarser estimate, up-sampled (bilinear) and
   doubled.

Derivatives are the report's central differences (ch. 3, eqs 18-19) along the row;
every filter is separable with replicated borders, so the whole method streams
(:func:`streaming_schedule`). Validity: the windowed RMS gradient ``sqrt(Σ w g²)``
at least ``T_g`` (the report's gradient threshold, now over the window), the windowed
RMS residual of the last fit at most ``T_r`` (rejects occlusions and the pixels the
linear model does not fit), the matching pixel ``x - u`` inside the second image, and
``0 < u <= u_max``; invalid pixels carry ``range_max`` as in G3.

Real rigs
---------
Two cameras differ in gain and offset, and a rectification leaves up to a pixel of
vertical misalignment; eq 10 assumes neither (``e = E1 - W`` takes any photometric
difference for a disparity). Two options, each a config field:

* ``normalise`` — a streaming photometric normalisation of each camera at every level
  of the pyramid (the pyramid itself is built from the raw images), over a
  ``(2 R + 1)²`` box (``R = normalise_radius``; replicated borders; ``2 R`` line
  buffers per camera and level, run beside the coarse-to-fine wait so that only the
  coarsest level's adds latency): ``"local_mean"`` subtracts the box mean,
  ``N = E - mean(E)`` (an offset cancels exactly, a gain scales the residual only by the
  local contrast; a running sum, no divider); ``"zncc"`` also divides by the local
  standard deviation, ``N = S (E - mean) / sqrt(var + ε²)`` (ZNCC's normalisation;
  invariant to gain and offset, costs a square root and a divider per pixel);
  ``"none"`` the report's raw grey levels. Normalising before the pyramid instead
  (one box at full scale) leaves the coarse levels almost no contrast (the box removes
  what they see): G6 still scores, but their ill-conditioned fits amplify P3's
  rounding (median P3-vs-G6 range difference on ``lab`` 0.86 % against 0.05 %).
* ``vertical`` — eq 6 with the vertical term kept: ``e ≈ g u + g_y v`` with
  ``g_y = ½ (E1y + Wy)`` (central differences down the columns), solved over the
  window as a 2x2 system (the Lucas–Kanade form), ``v`` estimated and discarded:
  ``Δu = -(Σgy² Σge - Σg gy Σgy e) / (Σg² Σgy² - (Σg gy)²)`` (one division: the
  numerator ``ν_u`` over the determinant ``det``). The residual test uses the 2x2 fit's
  residual, ``Σe² - (Σge ν_u + Σgy e ν_v) / det`` with ``ν_v = Σg² Σgy e - Σg gy Σge``
  (the discarded ``v``'s numerator), and a pixel needs ``det > 0`` (the determinant
  test). The central difference down the columns needs line ``y + 1`` of E1 and of W:
  each warp stage takes one more line (:func:`streaming_schedule`). P3 builds it.
  With ``vertical_radius`` ``rv`` > 0 (the box form) ``v`` is not fitted with ``u`` in
  the window: a rig's misalignment is smooth across the image, so each warp stage
  solves the 2x2 system over a ``(2 rv + 1)²`` box of plain sums, ``v = -ν_v / det``
  (``ν_v = Σg² Σgy e - Σg gy Σge``, ``det = Σg² Σgy² - (Σg gy)²``, 0 where ``det ≤ 0``),
  taken ``rv`` lines late (``v`` of line ``y - rv`` corrects line ``y``; top lines
  replicate), and ``u`` comes from the 1-D fit (eq 10) on ``e + gy v``, whose residual
  is the validity test (no determinant test). P3 builds it too.

The motion form (obstacle eq 28) is not built: there the disparity direction is radial
from the focus of expansion and differs per pixel, so the warp is a 2-D resampling along
each pixel's epipolar line — line buffers as tall as the largest vertical parallax,
rotation compensation before the pyramid, and ``k0..k5`` per pyramid level; that is a
design of its own, not a small step. G6 accepts stereo pairs (lateral baseline, no
rotation) and says so otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.ndimage import correlate1d

from .estimator import validate_image
from .geometry import MotionIncrement, PinholeCamera
from .ranging import RangeResult, RangingConfig

__all__ = [
    "AUTO_DISPARITY_FRACTION",
    "AUTO_MAX_LEVELS",
    "NORMALISATIONS",
    "MultiscaleConfig",
    "auto_levels",
    "claimed_max_disparity",
    "disparity_g6",
    "normalise_image",
    "pyramid_levels",
    "range_g6",
    "streaming_schedule",
]

#: 5-tap binomial low-pass of the pyramid's decimation (Burt & Adelson's a = 3/8).
_BINOMIAL5 = np.array([1.0, 4.0, 6.0, 4.0, 1.0]) / 16.0
#: Central difference along the row (ch. 3, eqs 18-19), per pixel.
_CENTRAL = np.array([-0.5, 0.0, 0.5])
#: Keys' cubic convolution parameter (a = -1/2: exact for quadratics).
_KEYS_A = -0.5
#: The disparity limit chosen without the user: this fraction of the image width (the
#: rule of OpenCV's ``stereo_match`` sample, ``numDisparities = width / 8``). No setting
#: comes from a ground truth (SPEC §12).
AUTO_DISPARITY_FRACTION = 1 / 8
_MAX_LEVELS = 6
#: The deepest pyramid chosen without the user: each level doubles the coarse-to-fine
#: wait, so the sixth took ``lab`` (512 px, limit 64 px) from 372 to 756 lines of latency
#: and 0.57 to 1.10 M words of line buffers, for nothing the data needed (docs/multiscale.md,
#: "The depth chosen without the user"); 5 levels converge from 32 px (measured).
AUTO_MAX_LEVELS = 5
#: Photometric normalisations of each camera (``MultiscaleConfig.normalise``).
NORMALISATIONS: tuple[str, ...] = ("none", "local_mean", "zncc")
#: ``"zncc"``: the normalised image's scale ``S`` (grey levels per local standard
#: deviation) and the contrast floor ``ε`` (grey levels) that keeps flat areas from being
#: amplified into noise.
ZNCC_SCALE = 32.0
ZNCC_FLOOR = 4.0


@dataclass(frozen=True)
class MultiscaleConfig:
    """Settings of G6; the defaults are the measured ones of docs/multiscale.md
    ("Config and its measured defaults": the motorcycle pair at 1/4, 1/8, 1/16 and
    ``lab``, one setting changed at a time).

    Attributes
    ----------
    levels
        Pyramid levels ``L`` (1 = no pyramid); the estimate is claimed up to
        ``2^(L-1) * coarse_px`` px (:func:`claimed_max_disparity`). ``None``: chosen from
        the disparity limit, the fewest levels whose claim covers it
        (:func:`auto_levels`), at most :data:`AUTO_MAX_LEVELS`; either way no more than
        the image's size allows (:func:`pyramid_levels`).
    warps
        Gauss–Newton steps (warp + windowed eq 10) per level.
    sigma
        Standard deviation of the Gaussian window, px (at every level).
    radius
        Half-width of the window, px: taps ``-radius..radius``; also the latency of one
        warp stage in lines.
    threshold_g
        ``T_g``: minimum windowed RMS gradient along the row, grey levels per px.
    threshold_r
        ``T_r``: maximum windowed RMS residual of the last fit, grey levels.
    coarse_px
        Disparity (px at the coarsest level) the warps converge from; sets the claim.
    max_disparity
        Largest disparity, px of the input (= the width of the E2 line buffer that the
        warp reads): the user's setting; ``None``: chosen from the image width,
        :data:`AUTO_DISPARITY_FRACTION` of it (:meth:`resolve`). Estimates are clipped
        to ``[0, max_disparity]`` at every step.
    normalise
        Photometric normalisation of each camera before the pyramid, one of
        :data:`NORMALISATIONS` (module docstring, "Real rigs"; :func:`normalise_image`).
    normalise_radius
        ``R``: the normalisation's box is ``(2 R + 1)²`` px; also its latency in lines.
    vertical
        Keep the vertical term of eq 6 (module docstring, "Real rigs"): with
        ``vertical_radius`` 0 a 2x2 normal system per window, ``v`` discarded (the
        window form); above 0 ``v`` from the 2x2 system over a box, ``u`` from the 1-D
        fit on ``e + g_y v`` (the box form).
    vertical_radius
        ``rv`` of the box form: ``v`` from the ``(2 rv + 1)²`` box, taken ``rv`` lines
        late; 0 = the window form. Read only with ``vertical``.
    coarse_lag
        Lines (of the finer level) by which the up-sampled coarse estimate reaches each
        finer level late: fine line ``y`` starts from the coarse estimate of line
        ``y - coarse_lag`` (top lines replicate). Each lag line saves one line of delay
        buffer per image at that level (:func:`streaming_schedule`); 0 = none.
    """

    levels: int | None = None
    warps: int = 2
    sigma: float = 2.0
    radius: int = 4
    threshold_g: float = 0.5
    threshold_r: float = 25.0
    coarse_px: float = 1.0
    max_disparity: float | None = None
    coarse_lag: int = 0
    normalise: str = "local_mean"
    normalise_radius: int = 4
    vertical: bool = True
    vertical_radius: int = 8

    def __post_init__(self) -> None:
        if self.levels is not None:
            v = self.levels
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= 6:
                raise ValueError(f"levels must be an integer in 1..6 or None, not {v!r}")
        for name, lo, hi in (
            ("warps", 1, 5),
            ("radius", 1, 16),
            ("coarse_lag", 0, 1024),
            ("normalise_radius", 1, 16),
            ("vertical_radius", 0, 32),
        ):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
                raise ValueError(f"{name} must be an integer in {lo}..{hi}, not {v!r}")
        for name in ("sigma", "coarse_px"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number, not {v!r}")
        for name in ("threshold_g", "threshold_r"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and not math.isnan(v) and v >= 0):
                raise ValueError(f"{name} must be a number >= 0, not {v!r}")
        if self.normalise not in NORMALISATIONS:
            raise ValueError(
                f"normalise must be one of {', '.join(NORMALISATIONS)}, not {self.normalise!r}"
            )
        if not isinstance(self.vertical, (bool, np.bool_)):
            raise ValueError(f"vertical must be true or false, not {self.vertical!r}")
        md = self.max_disparity
        if md is not None and not (isinstance(md, (int, float)) and math.isfinite(md) and md > 0):
            raise ValueError(f"max_disparity must be a positive number of px or None, not {md!r}")

    @property
    def vertical_form(self) -> str:
        """``"off"``, ``"window"`` (the 2x2 system in the window, ``v`` discarded) or
        ``"box"`` (``v`` from the box, ``vertical_radius`` > 0): the vertical term in use."""
        if not self.vertical:
            return "off"
        return "box" if self.vertical_radius > 0 else "window"

    def with_(self, **changes) -> MultiscaleConfig:
        return replace(self, **changes)

    def resolve(self, width: int) -> MultiscaleConfig:
        """This config for images ``width`` px wide with nothing left to choose: the
        disparity limit (``max_disparity`` or :data:`AUTO_DISPARITY_FRACTION` of the
        width) and the levels (``levels`` or :func:`auto_levels` of that limit, at most
        :data:`AUTO_MAX_LEVELS`)."""
        if isinstance(width, bool) or not isinstance(width, (int, np.integer)) or width < 1:
            raise ValueError(f"width must be a positive integer, not {width!r}")
        md = self.max_disparity
        if md is None:
            md = max(float(width) * AUTO_DISPARITY_FRACTION, self.coarse_px)
        levels = self.levels
        if levels is None:
            levels = min(auto_levels(md, self.coarse_px), AUTO_MAX_LEVELS)
        return replace(self, max_disparity=float(md), levels=int(levels))

    @property
    def disparity_limit(self) -> float:
        """The clip (and E2 line-buffer width) in full-scale px of a resolved config
        (:meth:`resolve`)."""
        if self.max_disparity is None:
            raise ValueError("the disparity limit depends on the image width: resolve(width)")
        return float(self.max_disparity)

    def window(self) -> np.ndarray:
        """The normalised Gaussian window taps (sum 1), length ``2 radius + 1``."""
        k = np.arange(-self.radius, self.radius + 1, dtype=np.float64)
        w = np.exp(-0.5 * (k / self.sigma) ** 2)
        return w / w.sum()


def auto_levels(limit: float, coarse_px: float) -> int:
    """The fewest pyramid levels whose claim ``2^(L-1) coarse_px`` covers ``limit`` px
    (1..6)."""
    need = 1 + math.ceil(math.log2(max(limit / coarse_px, 1.0)))
    return int(min(max(need, 1), _MAX_LEVELS))


def pyramid_levels(config: MultiscaleConfig, shape: tuple[int, int]) -> int:
    """Levels actually built for an image of ``shape``: the pyramid stops before a level
    whose parent is smaller than the window (``2 radius + 2`` rows or columns), where a
    coarser level adds nothing."""
    m, n = shape
    config = config.resolve(int(n))
    built = 1
    while built < config.levels and min(m, n) >= 2 * config.radius + 2:
        m, n = (m + 1) // 2, (n + 1) // 2
        built += 1
    return built


def claimed_max_disparity(config: MultiscaleConfig) -> float:
    """The disparity (full-scale px) the pyramid claims: ``2^(L-1) * coarse_px`` (a
    config with its levels set, e.g. resolved)."""
    if config.levels is None:
        raise ValueError("the claim needs the levels: set them or resolve(width)")
    return float(2 ** (config.levels - 1) * config.coarse_px)


def _filt(a: np.ndarray, taps: np.ndarray, axis: int) -> np.ndarray:
    # replicated borders: what a streaming filter does at a frame edge
    return correlate1d(a, taps, axis=axis, mode="nearest")


def normalise_image(image: np.ndarray, method: str, radius: int) -> np.ndarray:
    """One camera's image normalised as ``method`` (:data:`NORMALISATIONS`) over the
    ``(2 radius + 1)²`` box with replicated borders (module docstring, "Real rigs")."""
    e = np.asarray(image, dtype=np.float64)
    if method == "none":
        return e
    if method not in NORMALISATIONS:
        raise ValueError(f"normalise must be one of {', '.join(NORMALISATIONS)}, not {method!r}")
    box = np.full(2 * radius + 1, 1.0 / (2 * radius + 1))
    mean = _filt(_filt(e, box, 1), box, 0)
    if method == "local_mean":
        return e - mean
    var = np.maximum(_filt(_filt(e * e, box, 1), box, 0) - mean * mean, 0.0)
    return ZNCC_SCALE * (e - mean) / np.sqrt(var + ZNCC_FLOOR**2)


def _reduce(a: np.ndarray) -> np.ndarray:
    """One pyramid step: separable 5-tap binomial, keep even rows and columns."""
    return _filt(_filt(a, _BINOMIAL5, 1), _BINOMIAL5, 0)[::2, ::2]


def _expand(u: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Coarse disparity to the finer level: bilinear at (y/2, x/2), doubled (px scale)."""
    m, n = shape
    out = u
    for axis, size in ((0, m), (1, n)):
        pos = np.arange(size) / 2.0  # fine pixel k sits at coarse position k/2
        lo = np.minimum(np.floor(pos).astype(np.intp), out.shape[axis] - 1)
        hi = np.minimum(lo + 1, out.shape[axis] - 1)
        t = pos - lo
        a, b = np.take(out, lo, axis=axis), np.take(out, hi, axis=axis)
        shape_t = [1, 1]
        shape_t[axis] = size
        t = t.reshape(shape_t)
        out = (1 - t) * a + t * b
    return 2.0 * out


def _keys(t: np.ndarray) -> tuple[np.ndarray, ...]:
    """Keys cubic weights of the taps at offsets -1, 0, 1, 2 for fraction ``t``."""
    a = _KEYS_A
    t2, t3 = t * t, t * t * t
    w0 = a * (t3 - 2 * t2 + t)
    w1 = (a + 2) * t3 - (a + 3) * t2 + 1
    w2 = -(a + 2) * t3 + (2 * a + 3) * t2 - a * t
    w3 = -a * (t3 - t2)
    return w0, w1, w2, w3


def warp_rows(image: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``W(x) = image(x - u(x))`` along each row (Keys cubic, replicated borders) and the
    mask of pixels whose source ``x - u`` lies inside the row."""
    m, n = image.shape
    src = np.arange(n, dtype=np.float64)[None, :] - u
    base = np.floor(src)
    t = src - base
    base = base.astype(np.intp)
    rows = np.arange(m)[:, None]
    image = np.asarray(image, dtype=np.float64)
    out = np.zeros(u.shape)
    for off, w in zip((-1, 0, 1, 2), _keys(t), strict=True):
        out += w * image[rows, np.clip(base + off, 0, n - 1)]
    inside = (src >= 0) & (src <= n - 1)
    return out, inside


def disparity_g6(
    image1: np.ndarray,
    image2: np.ndarray,
    config: MultiscaleConfig | None = None,
    *,
    trace: bool = False,
) -> dict[str, np.ndarray]:
    """Disparity ``u`` with ``E1(x) = E2(x - u)`` along the rows, coarse to fine.

    Returns a dict of full-scale arrays: ``disparity`` (px), ``valid``, ``grad_rms``
    (windowed RMS of ``g``), ``residual_rms`` (windowed RMS residual of the last fit,
    grey levels), ``inside`` (the matching pixel lies in the second image). With
    ``trace``, also every intermediate of level 0 under the names of the fixed-point
    P3's taps (the float value of each): ``e1.norm``, ``e2.norm`` (the normalised
    images, unless ``normalise`` is ``"none"``), ``ax`` (``E1x``), ``u_start``, and per warp
    ``k`` ``warp{k}`` (W), ``wx{k}``, ``g{k}``, ``err{k}`` (e), the row passes ``rgg{k}``,
    ``rge{k}``, ``ree{k}``, the window sums ``sgg{k}``, ``sge{k}``, ``see{k}``, ``du{k}``
    and the updated ``u{k}``; with ``vertical`` also ``ay`` (``E1y``), per warp ``wy{k}``,
    ``gy{k}``, ``ryy{k}``, ``rgy{k}``, ``rye{k}``, ``syy{k}``, ``sgy{k}``, ``sye{k}``,
    ``det{k}``, ``nu{k}`` (``ν_u``) and, after the last, ``nv`` (``ν_v``); in the box
    form (``vertical_radius`` > 0) instead ``ay``, per warp ``wy{k}``, ``gy{k}``, the box
    sums ``bgg{k}``, ``bge{k}``, ``byy{k}``, ``bgy{k}``, ``bye{k}``, ``bdet{k}``,
    ``bnv{k}``, ``v{k}`` (those line ``y`` uses: the box ``vertical_radius`` lines up)
    and ``ev{k}`` (``e + gy v``; ``rge{k}`` .. ``see{k}`` are then on it).
    """
    config = config or MultiscaleConfig()
    e1 = validate_image(image1, "image1")
    e2 = validate_image(image2, "image2")
    if e1.shape != e2.shape:
        raise ValueError(f"image pair shapes differ: {e1.shape} vs {e2.shape}")
    config = config.resolve(e1.shape[1])
    w = config.window()
    pyr = [(e1, e2)]
    for _ in range(pyramid_levels(config, e1.shape) - 1):
        a, b = pyr[-1]
        pyr.append((_reduce(a), _reduce(b)))
    # each level normalised on its own (module docstring, "Real rigs")
    pyr = [
        tuple(normalise_image(e, config.normalise, config.normalise_radius) for e in p) for p in pyr
    ]
    limit = config.disparity_limit
    box, window2 = config.vertical_form == "box", config.vertical_form == "window"
    rbox = np.ones(2 * config.vertical_radius + 1)  # the box form's sums
    u = np.zeros(pyr[-1][0].shape)
    for level in range(len(pyr) - 1, -1, -1):
        a, b = pyr[level]
        if u.shape != a.shape:
            u = _expand(u, a.shape)
            lag = min(config.coarse_lag, u.shape[0])
            if lag:  # the coarse estimate arrives late: line y gets that of y - lag
                u = np.concatenate([np.repeat(u[:1], lag, axis=0), u[: u.shape[0] - lag]])
        cap = limit / 2**level
        ax = _filt(a, _CENTRAL, 1)
        ay = _filt(a, _CENTRAL, 0) if config.vertical else None
        traced = {"ax": ax, "u_start": u} if trace and level == 0 else None
        if traced is not None and ay is not None:
            traced["ay"] = ay
        if traced is not None and config.normalise != "none":
            traced.update({"e1.norm": a, "e2.norm": b})
        for k in range(config.warps):
            wimg, inside = warp_rows(b, u)
            wx = _filt(wimg, _CENTRAL, 1)
            g = 0.5 * (ax + wx)  # eq 6: the mean gradient of the two images
            e = a - wimg  # c1 of eq 10, about the current estimate
            ev = e
            if box:  # v from the 2x2 system over the box, rv lines late; e corrected by it
                wy = _filt(wimg, _CENTRAL, 0)
                gy = 0.5 * (ay + wy)
                bsum = {p: _filt(_filt(q, rbox, 1), rbox, 0) for p, q in (
                    ("bgg", g * g), ("bge", g * e), ("byy", gy * gy), ("bgy", g * gy),
                    ("bye", gy * e))}  # fmt: skip
                bdet = bsum["bgg"] * bsum["byy"] - bsum["bgy"] * bsum["bgy"]
                bnv = bsum["bgg"] * bsum["bye"] - bsum["bgy"] * bsum["bge"]
                with np.errstate(divide="ignore", invalid="ignore"):
                    v = np.where(bdet > 0, -bnv / bdet, 0.0)
                late = v[np.maximum(np.arange(v.shape[0]) - config.vertical_radius, 0)]
                ev = e + gy * late
            rows = {"gg": _filt(g * g, w, 1), "ge": _filt(g * ev, w, 1), "ee": _filt(ev * ev, w, 1)}
            sgg, sge, see = (_filt(rows[p], w, 0) for p in ("gg", "ge", "ee"))
            if window2:  # the 2x2 system in (u, v); v discarded
                wy = _filt(wimg, _CENTRAL, 0)
                gy = 0.5 * (ay + wy)
                vrows = {"yy": _filt(gy * gy, w, 1), "gy": _filt(g * gy, w, 1)}
                vrows["ye"] = _filt(gy * e, w, 1)
                syy, sgy, sye = (_filt(vrows[p], w, 0) for p in ("yy", "gy", "ye"))
                det = sgg * syy - sgy * sgy
                nu = syy * sge - sgy * sye  # numerators of u and of the discarded v
                nv = sgg * sye - sgy * sge
                with np.errstate(divide="ignore", invalid="ignore"):
                    du = np.where(det > 0, -nu / det, 0.0)
                    fit = np.where(det > 0, (sge * nu + sye * nv) / det, 0.0)
            else:
                with np.errstate(divide="ignore", invalid="ignore"):
                    du = np.where(sgg > 0, -sge / sgg, 0.0)  # normal equation of eq 10
                    fit = np.where(sgg > 0, sge * sge / sgg, 0.0)
            u = np.clip(u + du, 0.0, cap)
            if traced is not None:
                stage = {"warp": wimg, "wx": wx, "g": g, "err": e, "sgg": sgg, "sge": sge}
                stage.update(see=see, du=du, u=u, **{f"r{p}": v for p, v in rows.items()})
                if window2:
                    stage.update(wy=wy, gy=gy, syy=syy, sgy=sgy, sye=sye, det=det, nu=nu)
                    stage.update({f"r{p}": v for p, v in vrows.items()})
                elif box:
                    # the box's values as line y uses them: the box rv lines up
                    lag = np.maximum(np.arange(v.shape[0]) - config.vertical_radius, 0)
                    boxed = {"bdet": bdet, "bnv": bnv, "v": v, **bsum}
                    stage.update(wy=wy, gy=gy, ev=ev, **{k: q[lag] for k, q in boxed.items()})
                traced.update({f"{name}{k}": v for name, v in stage.items()})
    resid = np.sqrt(np.maximum(see - fit, 0.0))
    grad_rms = np.sqrt(sgg)
    _, inside = warp_rows(pyr[0][1], u)
    solved = det > 0 if window2 else True  # the determinant test
    if trace and window2:
        traced["nv"] = nv
    valid = (
        solved
        & (grad_rms >= config.threshold_g)
        & (resid <= config.threshold_r)
        & inside
        & (u > 0)
        & (u <= limit)
    )
    out = {
        "disparity": u,
        "valid": valid,
        "grad_rms": grad_rms,
        "residual_rms": resid,
        "inside": inside,
    }
    return {**out, **traced} if trace else out


def _stereo_baseline(motion: MotionIncrement) -> float:
    fwd, right, down = motion.camera_displacement
    if right == 0 or abs(fwd) > 1e-9 * abs(right) or abs(down) > 1e-9 * abs(right):
        raise ValueError(
            "g6_multiscale needs a stereo pair (a lateral baseline, no forward or vertical "
            f"displacement; got {fwd:g}, {right:g}, {down:g}): the motion form (eq 28) is "
            "not built (rangefx.golden.multiscale)"
        )
    if not np.allclose(motion.dT2, 0.0):
        raise ValueError("g6_multiscale needs a stereo pair without rotation between the views")
    return float(right)


def range_g6(
    image1: np.ndarray,
    image2: np.ndarray,
    camera: PinholeCamera,
    motion: MotionIncrement,
    config: MultiscaleConfig | None = None,
    ranging: RangingConfig | None = None,
) -> RangeResult:
    """Depth ``z = f B / u`` of the G6 disparity (eq 10 with ``δ = u / (f B)``).

    Only ``ranging.range_max`` is used (the thresholds of G6 are in ``config``). A
    negative baseline (second camera on the left) is handled by mirroring both rows.
    """
    config = config or MultiscaleConfig()
    ranging = ranging or RangingConfig()
    baseline = _stereo_baseline(motion)
    e1, e2 = np.asarray(image1), np.asarray(image2)
    if e1.shape != (camera.height, camera.width):
        raise ValueError(f"images are {e1.shape} but the camera is {camera.height}x{camera.width}")
    if baseline < 0:  # E1(x) = E2(x + |u|): the same problem on mirrored rows
        e1, e2 = e1[:, ::-1], e2[:, ::-1]
    out = disparity_g6(e1, e2, config)
    if baseline < 0:
        out = {k: v[:, ::-1] for k, v in out.items()}
    u = out["disparity"]
    fb = camera.f_px * abs(baseline)
    with np.errstate(divide="ignore"):
        raw = np.where(u > 0, fb / np.where(u > 0, u, 1.0), np.inf)
    valid = out["valid"] & np.isfinite(raw) & (raw <= ranging.range_max)
    rng = np.where(valid, raw, ranging.range_max)
    terms = {k: v for k, v in out.items() if k != "valid"}
    terms["raw_range"] = raw
    return RangeResult(range=rng, valid=valid, terms=terms)


def streaming_schedule(config: MultiscaleConfig, width: int, height: int | None = None) -> dict:
    """Latency (lines) and line buffers (words) of G6 streamed one pixel per clock.

    Per level ``l`` (width ``n_l = ceil(width / 2^l)``), in the order the data flows:

    * **normalise** (``normalise`` not ``"none"``): the ``(2 R + 1)²`` box of each
      camera holds ``2 R`` lines of the level (the incoming line completes the column
      sums); the normalised line ``y`` is ready ``R`` lines after line ``y``. It runs at
      the end of the wait for the coarse estimate (below): the delay lines hold the raw
      level, ``R`` lines fewer of them, and the box's lines are their last.

    * **reduce** (l ≥ 1): the 5-tap binomial down the columns of level ``l-1`` holds 4
      lines of each image; a level-``l`` line is complete 2 level-``l-1`` lines after
      its centre line.
    * **warp stage** (``warps`` per level): E2's row is read by the cubic warp from a
      row buffer of ``ceil(u_max,l) + 4`` words; the three windowed products (``g²``,
      ``g e``, ``e²``) are summed along the row at once and down the columns through
      ``2 r`` lines each; E1, E2 and ``u`` wait ``r`` lines for the window's centre.
      Latency ``r`` lines.
    * **expand** (l < L-1): one line of the coarse ``u`` for the bilinear rows; the
      coarse estimate of fine line ``y`` is ready ``4 + 2 λ_{l+1}`` fine lines after
      line ``y`` arrives (2 for the reduce, 2 for one coarse line of interpolation,
      ``λ_{l+1}`` the coarse level's latency in its own lines), so E1 and E2 of level
      ``l`` wait that long in **delay lines** — the only buffers that grow with the
      depth of the pyramid, and still lines, not a frame; ``coarse_lag`` lines of
      staleness accepted in the coarse estimate save as many delay lines. A level's
      warps start after ``max(R, delay)`` lines.
    * **vertical** (``vertical``): the central differences down the columns hold 2 lines
      of E1 per level and 2 lines of W per warp stage; ``g`` and ``e`` wait one line for
      ``gy`` (1 line each per stage); the three more windowed products (``gy²``,
      ``g gy``, ``gy e``) sum down the columns through ``2 r`` lines each; a warp stage's
      latency is ``r + 1`` lines and E1, E2 and ``u`` wait that long. The box form
      (``vertical_radius`` ``rv`` > 0) sums five products (``g²``, ``g e``, ``gy²``,
      ``g gy``, ``gy e``) down the columns through ``2 rv`` lines each instead; ``v`` of
      the box centred ``rv`` lines up is ready as line ``y``'s ``gy`` is, so ``e + gy v``
      and the 1-D window's three products start then: the same ``r + 1`` lines a stage.

    Returns per level ``width``, ``latency_lines`` (from the level's input line to its
    output line, in its own lines), ``delay_lines`` (the wait for the coarse estimate)
    and ``buffer_words`` by buffer, and the totals ``latency_lines`` (full-scale lines)
    and ``buffer_words``. With
    ``height``, only the levels :func:`pyramid_levels` builds for that image count.
    """
    for name, v in (("width", width), ("height", height)):
        if v is None and name == "height":
            continue
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"{name} must be a positive integer, not {v!r}")
    config = config.resolve(width)
    r, k = config.radius, config.warps
    v = int(bool(config.vertical))  # the line below the centre, for the column differences
    rv = config.vertical_radius
    # lines of row sums down the columns: the window form's three of 2 r, the box form's five
    # of 2 rv
    vsums = 5 * 2 * rv if rv else 3 * 2 * r
    rn = 0 if config.normalise == "none" else config.normalise_radius
    built = config.levels if height is None else pyramid_levels(config, (height, width))
    levels = []
    lam_coarse = None
    for level in range(built - 1, -1, -1):
        n_l = -(-width // 2**level)
        cap = config.disparity_limit / 2**level
        delay = 0 if lam_coarse is None else max(0, 4 + 2 * lam_coarse - config.coarse_lag)
        lam = max(rn, delay) + k * (r + v)
        words = {
            "normalise": 2 * 2 * rn * n_l,
            "reduce": 0 if level == 0 else 2 * 4 * -(-width // 2 ** (level - 1)),
            "warp_row": k * (math.ceil(cap) + 4),
            "window_products": k * 3 * 2 * r * n_l,
            "window_align": k * 3 * (r + v) * n_l,
            "vertical_e1": v * 2 * n_l,
            "vertical_warp": v * k * 2 * n_l,
            "vertical_align": v * k * 2 * n_l,
            "vertical_products": v * k * vsums * n_l,
            "expand": 0 if lam_coarse is None else -(-width // 2 ** (level + 1)),
            "coarse_delay": 2 * max(delay - rn, 0) * n_l,
        }
        levels.append(
            {
                "level": level,
                "width": n_l,
                "latency_lines": lam,
                "delay_lines": delay,
                "buffer_words": words,
            }
        )
        lam_coarse = lam
    levels.reverse()
    return {
        "levels": levels,
        "latency_lines": levels[0]["latency_lines"],
        "buffer_words": sum(sum(lv["buffer_words"].values()) for lv in levels),
    }
