"""Real stereo data with ground truth: the Middlebury 2014 "motorcycle" pair.

scikit-image ships the pair (``skimage.data.stereo_motorcycle()``, already down-sampled
4x from the benchmark, 500 x 741) with its ground-truth disparity and, in the docstring,
the calibration of that scale: focal length 994.978 px, principal point (311.193,
254.877) px, principal-point offset ``doffs`` = 31.086 px between the two cameras,
baseline 193.001 mm. It loads from the installed package (no network).

Conventions (SPEC §3, checked here):

* unknown disparity is ``+inf`` in the array (the docstring says NaN); both are treated
  as unknown;
* a left pixel at column ``x`` corresponds to the right pixel at ``x - d``: the right
  camera sits to the right, exactly as :meth:`MotionIncrement.stereo` with a positive
  baseline and ``E1`` = left, ``E2`` = right (as the ``lab`` scene builds its pair);
* the two principal points differ by ``doffs``, so the metric depth is
  ``Z = f B / (d + doffs)``. The ranging methods of this package assume one principal
  point for both views (a registered pair, disparity ``f b / z``). On the pair as
  shipped (``register=False``, default) the ground truth they should find is the depth
  of the registered pair with the same disparities, ``z = f B / d`` (returned as
  ``depth``; ``metric_depth`` holds ``Z``). With ``register=True`` the right image is
  shifted by ``round(doffs)`` columns at the shipped scale (and both cropped) so that the
  disparity becomes ``d + round(doffs) ≈ f B / Z``; ``depth`` is then the metric depth
  up to the 0.086 px rounding of the shift (≤ 0.3 % here).

Down-sampling is an area mean over ``factor x factor`` blocks (the sensor's integration,
as in the scenes): images and disparity alike; a block's truth is unknown unless
three quarters of it is known (its truth is then the mean disparity of the known part).
The grey image is the luminance ``0.2125 R + 0.7154 G + 0.0721 B`` (``rgb2gray``) on
the 0..255 scale, kept in float64.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, fields, replace

import numpy as np

from .geometry import MotionIncrement, PinholeCamera

__all__ = [
    "MIDDLEBURY_THRESHOLDS",
    "MOTORCYCLE_CALIBRATION",
    "Perturbation",
    "StereoData",
    "choose_factor",
    "disparity_from_range",
    "evaluate",
    "load_motorcycle",
    "middlebury_metrics",
    "perturb_right",
    "search_range",
]

#: Calibration of the pair shipped by scikit-image (its docstring), pixels and mm.
MOTORCYCLE_CALIBRATION: dict[str, float] = {
    "f_px": 994.978,
    "cx": 311.193,
    "cy": 254.877,
    "doffs": 31.086,
    "baseline_mm": 193.001,
}


#: A down-sampled pixel has ground truth when at least this fraction of its block has.
_MIN_KNOWN = 0.75


@dataclass(frozen=True, eq=False)
class StereoData:
    """A real registered stereo pair with ground truth (arrays are float64, shape (m, n)).

    ``depth`` is the ground truth the ranging methods should find (see the module
    docstring), ``+inf`` where unknown; ``metric_depth`` the calibrated metric depth;
    ``disparity`` the block-mean disparity in pixels at this scale (``+inf`` unknown).
    ``range_max`` is a maximum scene depth for the ranging stage (twice the largest
    known depth). ``doffs_px`` is the principal-point offset left in the pair at this
    scale: ``metric_depth = f B / (disparity + doffs_px)``.
    """

    name: str
    unit: str
    factor: int
    camera: PinholeCamera
    motion: MotionIncrement
    image1: np.ndarray
    image2: np.ndarray
    depth: np.ndarray
    metric_depth: np.ndarray
    disparity: np.ndarray
    range_max: float
    registered: bool
    doffs_px: float = 0.0  # principal-point offset left in the pair, px at this scale

    @property
    def median_disparity(self) -> float:
        d = self.disparity[np.isfinite(self.disparity)]
        return float(np.median(d)) if d.size else math.nan


@functools.cache
def _shipped() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grey left, grey right (0..255 float64) and disparity (+inf unknown), read-only."""
    from skimage.color import rgb2gray
    from skimage.data import stereo_motorcycle

    left, right, disp = stereo_motorcycle()
    g1 = rgb2gray(left) * 255.0
    g2 = rgb2gray(right) * 255.0
    d = np.asarray(disp, dtype=np.float64)
    d = np.where(np.isfinite(d), d, np.inf)
    for a in (g1, g2, d):
        a.setflags(write=False)
    return g1, g2, d


def _blocks(a: np.ndarray, factor: int) -> np.ndarray:
    m, n = (a.shape[0] // factor) * factor, (a.shape[1] // factor) * factor
    return a[:m, :n].reshape(m // factor, factor, n // factor, factor)


def _block_mean(a: np.ndarray, factor: int) -> np.ndarray:
    return _blocks(a, factor).mean(axis=(1, 3))


def _block_mean_known(d: np.ndarray, factor: int, min_known: float) -> np.ndarray:
    """Mean of the known (finite) values of each block; ``+inf`` unless at least
    ``min_known`` of the block is known."""
    b = _blocks(d, factor)
    known = np.isfinite(b)
    count = known.sum(axis=(1, 3))
    total = np.where(known, b, 0.0).sum(axis=(1, 3))
    ok = count >= min_known * factor * factor
    return np.where(ok, total / np.maximum(count, 1), np.inf)


def _check_factor(factor: object) -> int:
    if isinstance(factor, bool) or not isinstance(factor, (int, np.integer)) or factor < 1:
        raise ValueError(f"down-sampling factor must be an integer >= 1, not {factor!r}")
    if factor > 100:
        raise ValueError(f"down-sampling factor {factor} leaves fewer than 5 rows; use <= 100")
    return int(factor)


def load_motorcycle(factor: int = 19, *, register: bool = False) -> StereoData:
    """The Middlebury 2014 motorcycle pair down-sampled by ``factor`` (area mean).

    ``factor`` 19 is the one where the median disparity is closest to 2 px on the pair
    as shipped (:func:`choose_factor`). Lengths are in mm. ``E1`` = left, ``E2`` = right,
    camera 2 at ``+baseline`` to the right (``MotionIncrement.stereo``).
    """
    factor = _check_factor(factor)
    cal = MOTORCYCLE_CALIBRATION
    g1, g2, d = _shipped()
    shift = 0
    if register:
        shift = round(cal["doffs"])
        # right'(x) = right(x + shift): the disparity grows by `shift`; crop to the overlap
        g1, g2, d = g1[:, : g1.shape[1] - shift], g2[:, shift:], d[:, : d.shape[1] - shift] + shift
    e1 = _block_mean(g1, factor)
    e2 = _block_mean(g2, factor)
    disp = _block_mean_known(d, factor, _MIN_KNOWN) / factor
    f_px = cal["f_px"] / factor
    # pixel-centre convention: full-res centre c maps to (c + 0.5) / F - 0.5
    cx = (cal["cx"] + 0.5) / factor - 0.5
    cy = (cal["cy"] + 0.5) / factor - 0.5
    baseline = cal["baseline_mm"]
    known = np.isfinite(disp) & (disp > 0)
    with np.errstate(divide="ignore"):
        depth = np.where(known, f_px * baseline / np.where(known, disp, 1.0), np.inf)
        d_metric = disp + (cal["doffs"] - shift) / factor
        metric = np.where(known, f_px * baseline / np.where(known, d_metric, 1.0), np.inf)
    if not known.any():
        raise ValueError(f"factor {factor} leaves no pixel with known disparity")
    camera = PinholeCamera(e1.shape[1], e1.shape[0], f_px, cx, cy)
    return StereoData(
        name="motorcycle",
        unit="mm",
        factor=factor,
        camera=camera,
        motion=MotionIncrement.stereo(baseline),
        image1=e1,
        image2=e2,
        depth=depth,
        metric_depth=metric,
        disparity=np.where(known, disp, np.inf),
        range_max=float(2.0 * depth[known].max()),
        registered=register,
        doffs_px=(cal["doffs"] - shift) / factor,
    )


def choose_factor(target_px: float = 2.0, *, register: bool = False, max_factor: int = 60) -> int:
    """The integer factor whose block-mean median disparity is closest to ``target_px``."""
    if not (math.isfinite(target_px) and target_px > 0):
        raise ValueError(f"target disparity must be a positive number of pixels, not {target_px!r}")
    best, best_err = 1, math.inf
    for f in range(1, max_factor + 1):
        err = abs(load_motorcycle(f, register=register).median_disparity - target_px)
        if err < best_err:
            best, best_err = f, err
    return best


def evaluate(range_map: np.ndarray, valid: np.ndarray, truth: np.ndarray) -> dict[str, float | int]:
    """Density and accuracy of a range map against ground truth (+inf / NaN = unknown).

    Returns ``density`` (valid pixels among those with known truth), ``n_scored``
    (valid pixels with known truth), ``median_rel_error`` (median of
    ``|range - truth| / truth`` over them), ``within_5pct`` and ``within_10pct``
    (fractions of them with relative error ``<= 0.05`` / ``<= 0.10``). Error figures are
    NaN when nothing is scored.
    """
    r = np.asarray(range_map, dtype=np.float64)
    v = np.asarray(valid)
    t = np.asarray(truth, dtype=np.float64)
    if r.shape != v.shape or r.shape != t.shape:
        raise ValueError(
            f"range_map {r.shape}, valid {v.shape} and truth {t.shape} must have one shape"
        )
    if v.dtype != np.bool_:
        raise ValueError(f"valid must be a boolean array, not dtype {v.dtype}")
    known = np.isfinite(t)
    if np.any(t[known] <= 0):
        raise ValueError("truth must be positive where known")
    scored = v & known
    if np.any(~np.isfinite(r[scored])):
        raise ValueError("range_map is not finite at a valid pixel")
    n_known = int(np.count_nonzero(known))
    n = int(np.count_nonzero(scored))
    rel = np.abs(r[scored] - t[scored]) / t[scored]
    nan = math.nan
    return {
        "density": n / n_known if n_known else nan,
        "n_scored": n,
        "median_rel_error": float(np.median(rel)) if n else nan,
        "within_5pct": float(np.mean(rel <= 0.05)) if n else nan,
        "within_10pct": float(np.mean(rel <= 0.10)) if n else nan,
    }


#: Bad-pixel thresholds of the Middlebury tables (px): ``bad_0_5``, ``bad_1``, ``bad_2``.
MIDDLEBURY_THRESHOLDS: dict[str, float] = {"bad_0_5": 0.5, "bad_1": 1.0, "bad_2": 2.0}


def disparity_from_range(range_map: np.ndarray, data: StereoData) -> np.ndarray:
    """The disparity ``f B / z`` of a range map on ``data``'s registered pair (px).

    The inverse of the ranging methods' depth (module docstring); non-positive or
    non-finite ranges give ``+inf`` (no disparity).
    """
    r = np.asarray(range_map, dtype=np.float64)
    fb = data.camera.f_px * abs(float(data.motion.camera_displacement[1]))
    ok = np.isfinite(r) & (r > 0)
    return np.where(ok, fb / np.where(ok, r, 1.0), np.inf)


def search_range(data: StereoData) -> int:
    """The disparity search range of ``data`` (px), as Middlebury's ``ndisp``: the
    largest known disparity rounded up, plus one."""
    known = np.isfinite(data.disparity)
    return math.ceil(float(data.disparity[known].max())) + 1


def middlebury_metrics(
    disparity: np.ndarray,
    valid: np.ndarray,
    truth: np.ndarray,
    metric_truth: np.ndarray,
    doffs_px: float,
    f_px: float,
    baseline: float,
) -> dict[str, float | int]:
    """The Middlebury 2014 figures of a disparity map (its sparse protocol).

    Parameters
    ----------
    disparity
        Estimated disparity (px, left x matches right ``x - d``); read where ``valid``.
    valid
        Boolean map of the pixels that carry an estimate.
    truth
        True disparity of the registered pair (px); ``+inf`` / NaN unknown.
    metric_truth
        True metric depth ``f B / (d + doffs)``; ``+inf`` / NaN unknown.
    doffs_px, f_px, baseline
        Principal-point offset (px at this scale), focal length (px) and baseline: the
        estimate's metric depth is ``f B / (d + doffs)``.

    Returns
    -------
    dict
        ``density``: valid pixels / **all** pixels (Middlebury's density);
        ``n_scored``: valid pixels with known truth, the population of the rest;
        ``mae_px``: mean ``|d - d_true|`` (Middlebury's avgerr);
        ``bad_0_5``, ``bad_1``, ``bad_2``: percent of scored pixels with
        ``|d - d_true|`` above 0.5, 1 and 2 px;
        ``rel_depth_error``: median ``|Z - Z_true| / Z_true`` of the metric depths
        (with ``doffs``). Error figures are NaN when nothing is scored.
    """
    d = np.asarray(disparity, dtype=np.float64)
    v = np.asarray(valid)
    t = np.asarray(truth, dtype=np.float64)
    zt = np.asarray(metric_truth, dtype=np.float64)
    if not (d.shape == v.shape == t.shape == zt.shape):
        raise ValueError(
            f"disparity {d.shape}, valid {v.shape}, truth {t.shape} and metric_truth "
            f"{zt.shape} must have one shape"
        )
    if v.dtype != np.bool_:
        raise ValueError(f"valid must be a boolean array, not dtype {v.dtype}")
    scored = v & np.isfinite(t) & np.isfinite(zt)
    if np.any(~np.isfinite(d[scored])):
        raise ValueError("disparity is not finite at a valid pixel with known truth")
    err = np.abs(d[scored] - t[scored])
    n = int(err.size)
    nan = math.nan
    out: dict[str, float | int] = {
        "density": float(np.count_nonzero(v)) / v.size if v.size else nan,
        "n_scored": n,
        "mae_px": float(err.mean()) if n else nan,
    }
    for key, thr in MIDDLEBURY_THRESHOLDS.items():
        out[key] = 100.0 * float(np.count_nonzero(err > thr)) / n if n else nan
    with np.errstate(divide="ignore"):
        z = f_px * baseline / (d[scored] + doffs_px)
    rel = np.abs(z - zt[scored]) / zt[scored]
    out["rel_depth_error"] = float(np.median(rel)) if n else nan
    return out


@dataclass(frozen=True)
class Perturbation:
    """What differs between the two cameras of a real rig, applied to the right image
    (E2) in this order: ``blur`` (Gaussian, σ px), ``vshift`` (vertical misalignment,
    px down, linear interpolation), ``gain`` (× grey level), ``offset`` (+ grey levels),
    ``noise`` (Gaussian, σ grey levels, ``seed``), then clipped to 0..255 as a sensor
    does. Borders replicate."""

    gain: float = 1.0
    offset: float = 0.0
    noise: float = 0.0
    vshift: float = 0.0
    blur: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "seed":
                if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
                    raise ValueError(f"seed must be an integer >= 0, not {v!r}")
            elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"{f.name} must be a finite number, not {v!r}")
        if self.gain <= 0 or self.noise < 0 or self.blur < 0:
            raise ValueError("gain must be > 0, noise and blur >= 0")

    @property
    def is_identity(self) -> bool:
        return self == Perturbation(seed=self.seed)

    def apply(self, image: np.ndarray) -> np.ndarray:
        """The perturbed copy of ``image`` (float64 grey levels)."""
        from scipy.ndimage import gaussian_filter, shift

        out = np.asarray(image, dtype=np.float64)
        if self.blur > 0:
            out = gaussian_filter(out, self.blur, mode="nearest")
        if self.vshift != 0:
            out = shift(out, (self.vshift, 0.0), order=1, mode="nearest")
        out = self.gain * out + self.offset
        if self.noise > 0:
            out = out + np.random.default_rng(self.seed).normal(0.0, self.noise, out.shape)
        return np.clip(out, 0.0, 255.0)


def perturb_right(data: StereoData, perturbation: Perturbation) -> StereoData:
    """``data`` with its right image perturbed (the ground truth unchanged)."""
    image2 = perturbation.apply(data.image2)
    image2.setflags(write=False)
    return replace(data, image2=image2)
