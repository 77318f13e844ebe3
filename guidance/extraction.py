"""Obstacles from range points: ground removal, clustering, along-ray outlier rejection,
extents grown by the range uncertainty, and scoring against a scene's true geometry
(SPEC §13).

The report's law (chapter 6) takes every range point as an obstacle. A range map is
not that clean: most valid points lie on the ground, and a point's bearing is known to
the pixel while its range along the ray is only as good as the ranging equation. This
module turns points into a few obstacles, each an :class:`ObstacleBox` — an upright box
on the ground, oriented along the mean viewing ray of its points, whose along-ray extent
carries the range uncertainty and whose cross-ray extent carries the pixel footprint.

Steps of :func:`extract_obstacles` (range map) and :func:`extract_from_points` (a bare
cloud, e.g. the synthetic set):

1. **Ground removal**: points lower than ``min_height`` above the ground plane are
   dropped (and, as an absurd range, higher than ``max_height``).
2. **Range-error bound**: the ranging error equation (eq 14 of the ch. 3 paper; the
   error polynomial, eq 11, of the SPIE paper, degree 1) is
   ``0 = ½ (∇E1 - ∇E2)·d δ``, ``d`` the disparity per unit inverse range (eq 9; for the
   rotation form of ch. 4 the translation part ``[f k4 - xp k3, f k5 - yp k3]`` of eqs
   25-26). Its residual relative to the ranging equation's ``½ (∇E1 + ∇E2)·d δ``
   (eq 13) is the relative truncation error of the first-order model; with the sensor
   noise σ_n on ``E1 - E2`` it gives the predicted relative range error
   ``ε = sqrt((|(∇E1 - ∇E2)·d| / |(∇E1 + ∇E2)·d|)² + 2 σ_n² / (E1 - E2)²)``
   (:func:`predicted_range_error`). Points with ``ε > max_relative_error`` are
   rejected: the first-order model does not support their range.
3. **Clustering**: in the image (range map) by connectivity of the kept pixels after a
   dilation of ``link_px`` pixels; in a bare cloud by single linkage at ``link_ft``.
   With range errors (``ε > 0``) a cluster then takes every valid pixel of its
   dilated image region within the error bound, also those step 1 called ground: step
   1 selects on the range error (a pixel ranged short rises along its ray, one ranged
   long sinks into the ground), and its survivors alone are a vehicle's short tail.
4. **Along-ray outliers**: in each cluster, points whose log range is further than
   ``along_ray_k`` robust standard deviations (1.4826 MAD, at least
   ``min_log_spread`` and at least the point's own ``ε``) from the cluster's median
   are set aside; if at least ``min_points`` of them remain and they are contiguous in
   the image they are treated as a further cluster (an object behind another in the
   image), else they are rejected. Clusters with fewer than ``min_points`` points are
   isolated points, rejected; range-map clusters spanning fewer than ``min_rows`` image
   rows (texture edges of the ground), clusters whose range scales like the ground's
   along their rays (a mis-ranged ground patch lies on a plane above the ground) and
   clusters not upright at their own median range are rejected as ground.
5. **Extent**: the box axis is the horizontal direction from the camera to the
   cluster's median point; the along-ray extent spans the inliers and is grown by
   ``grow_k`` times the cluster's range uncertainty (the larger of its median ``ε``
   times its range and its robust range spread); the cross-ray extent spans the
   inliers grown by ``lateral_margin_ft``; the top is the highest inlier grown the same
   way; the bottom is the ground.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from rangefx.golden.estimator import EstimatorConfig, estimate_derivatives
from rangefx.golden.geometry import (
    MotionIncrement,
    PinholeCamera,
    camera_points_from_range,
    inertial_from_camera,
    k_coefficients,
)

from .checks import check_choice, check_numbers
from .obstacles import FrameMap, ParkedVehicle, guidance_from_ned, usable_range

__all__ = [
    "ERROR_MODELS",
    "BoxSet",
    "ExtractionConfig",
    "ExtractionResult",
    "ObstacleBox",
    "box_from_corners",
    "boxes_from_vehicles",
    "extract_from_points",
    "extract_obstacles",
    "predicted_range_error",
    "scene_truth_boxes",
    "score_extraction",
]


@dataclass(frozen=True)
class ObstacleBox:
    """An upright box standing on the ground ``z = 0`` (guidance frame, ft).

    ``centre`` is the horizontal centre ``(x, y)``; ``heading`` the direction of the
    box's ``u`` axis (rad, from ``x`` towards ``y``); ``half_u``, ``half_v`` the half
    sizes along ``u`` and the perpendicular ``v``; ``top`` the height of the top face;
    ``base`` that of the bottom face (0, the ground, for every extent and object; an
    escape wall of the avoiding law reaches below it, so that from inside the nearest
    way out is a side or the top, never the ground).
    """

    name: str
    centre: tuple[float, float]
    heading: float
    half_u: float
    half_v: float
    top: float
    n_points: int = 0
    base: float = 0.0

    def __post_init__(self) -> None:
        vals = (*self.centre, self.heading, self.half_u, self.half_v, self.top, self.base)
        if not all(math.isfinite(v) for v in vals):
            raise ValueError(f"obstacle box {self.name!r} has a non-finite field: {vals}")
        if self.half_u < 0 or self.half_v < 0 or self.top <= max(self.base, 0.0):
            raise ValueError(
                f"obstacle box {self.name!r} needs half sizes >= 0 and top > max(base, 0), "
                f"got {self.half_u!r}, {self.half_v!r}, {self.top!r} (base {self.base!r})"
            )

    @property
    def axes(self) -> np.ndarray:
        """``[[u_x, u_y], [v_x, v_y]]``."""
        c, s = math.cos(self.heading), math.sin(self.heading)
        return np.array([[c, s], [-s, c]])

    def local(self, p: np.ndarray) -> np.ndarray:
        """Coordinates ``(u, v, z)`` of guidance-frame points in the box frame."""
        p = np.asarray(p, dtype=np.float64)
        uv = (p[..., :2] - np.asarray(self.centre)) @ self.axes.T
        return np.concatenate([uv, p[..., 2:3]], axis=-1)

    def signed_distance(self, p: np.ndarray) -> np.ndarray:
        """Signed Euclidean distance from points ``p`` (shape (..., 3)) to the box.

        Positive outside, negative inside (minus the distance to the nearest face).
        Below the ground (``z < 0``) counts as outside by ``-z``.
        """
        return BoxSet((self,)).signed_distance(p)[..., 0]

    def signed_distance_gradient(self, p: np.ndarray) -> np.ndarray:
        """Gradient of :meth:`signed_distance` with respect to ``p`` (shape (..., 3))."""
        return BoxSet((self,)).signed_distance_gradient(p)[..., 0, :]

    def corners(self) -> np.ndarray:
        """The 8 corners (guidance frame), shape (8, 3)."""
        out = []
        for su in (-1.0, 1.0):
            for sv in (-1.0, 1.0):
                xy = np.asarray(self.centre) + np.array([su * self.half_u, sv * self.half_v]) @ (
                    self.axes
                )
                for z in (self.base, self.top):
                    out.append([xy[0], xy[1], z])
        return np.asarray(out)

    def footprint(self) -> np.ndarray:
        """The 4 ground corners in order (closed polygon without repetition), (4, 2)."""
        c = self.corners()[::2, :2]
        return c[[0, 1, 3, 2]]

    def grown(self, margin: float) -> ObstacleBox:
        """The box grown by ``margin`` on every side (and on top)."""
        return ObstacleBox(
            self.name,
            self.centre,
            self.heading,
            self.half_u + margin,
            self.half_v + margin,
            self.top + margin,
            self.n_points,
        )


class BoxSet:
    """Several :class:`ObstacleBox` evaluated at once: the signed distance of points to
    every box and its gradient, vectorised over points and boxes (the avoiding law's
    clearance constraints evaluate them at every SLSQP step)."""

    def __init__(self, boxes: tuple[ObstacleBox, ...]) -> None:
        self.boxes = tuple(boxes)
        self.centres = np.array([b.centre for b in self.boxes], dtype=np.float64).reshape(-1, 2)
        self.axes = np.array([b.axes for b in self.boxes], dtype=np.float64).reshape(-1, 2, 2)
        self.half = np.array(
            [(b.half_u, b.half_v, 0.5 * (b.top - b.base)) for b in self.boxes], dtype=np.float64
        ).reshape(-1, 3)
        self.mid_z = np.array([0.5 * (b.top + b.base) for b in self.boxes]).reshape(-1, 1)

    def __len__(self) -> int:
        return len(self.boxes)

    def _relative(self, p: np.ndarray) -> np.ndarray:
        """Point minus box centre in each box's frame ``(u, v, z - (top + base)/2)``:
        (..., k, 3)."""
        p = np.asarray(p, dtype=np.float64)
        d = p[..., None, :2] - self.centres  # (..., k, 2)
        uv = np.einsum("...kd,kjd->...kj", d, self.axes)
        return np.concatenate([uv, p[..., None, 2:3] - self.mid_z], axis=-1)

    def signed_distance(self, p: np.ndarray) -> np.ndarray:
        """:meth:`ObstacleBox.signed_distance` to every box, shape (..., k)."""
        d = np.abs(self._relative(p)) - self.half
        outside = np.linalg.norm(np.maximum(d, 0.0), axis=-1)
        inside = np.minimum(d.max(axis=-1), 0.0)
        return outside + inside

    def signed_distance_gradient(self, p: np.ndarray) -> np.ndarray:
        """Gradient of :meth:`signed_distance` with respect to ``p``, shape (..., k, 3)."""
        rel = self._relative(p)
        d = np.abs(rel) - self.half
        sign = np.where(rel >= 0, 1.0, -1.0)
        pos = np.maximum(d, 0.0)
        norm = np.linalg.norm(pos, axis=-1, keepdims=True)
        outside = norm[..., 0] > 0
        g_local = np.where(outside[..., None], pos * sign / np.where(norm > 0, norm, 1.0), 0.0)
        k = np.argmax(d, axis=-1)
        inside_g = np.zeros_like(d)
        np.put_along_axis(inside_g, k[..., None], 1.0, axis=-1)
        g_local = np.where(outside[..., None], g_local, inside_g * sign)
        g = np.empty_like(g_local)
        g[..., :2] = np.einsum("...kj,kjd->...kd", g_local[..., :2], self.axes)
        g[..., 2] = g_local[..., 2]
        return g


def box_from_corners(name: str, corners: np.ndarray) -> ObstacleBox:
    """Smallest upright box (oriented along one of its footprint's edges) holding
    ``corners`` (shape (k, 3), guidance frame); exact for a box's own 8 corners."""
    pts = np.asarray(corners, dtype=np.float64)
    xy = pts[:, :2]
    hull = xy[_convex_hull_indices(xy)]
    candidates = []  # (area, perimeter, heading, centre, half sizes) per hull-edge direction
    for k in range(len(hull)):
        e = hull[(k + 1) % len(hull)] - hull[k]
        if np.hypot(*e) < 1e-12:
            continue
        h = math.atan2(e[1], e[0])
        c, s = math.cos(h), math.sin(h)
        uv = xy @ np.array([[c, -s], [s, c]])
        lo, hi = uv.min(axis=0), uv.max(axis=0)
        mid = 0.5 * (lo + hi)
        centre = mid[0] * np.array([c, s]) + mid[1] * np.array([-s, c])
        size = hi - lo
        candidates.append((float(np.prod(size)), float(size.sum()), h, centre, 0.5 * size))
    best = None
    if candidates:
        # Two visible faces of a box give a right triangle, whose hypotenuse encloses the
        # same area as the faces: among near-minimal areas take the smallest perimeter.
        a_min = min(c[0] for c in candidates)
        near = [c for c in candidates if c[0] <= 1.02 * a_min + 1e-9]
        best = min(near, key=lambda c: c[1])[1:]
    if best is None:  # all corners on one vertical line
        best = (0.0, 0.0, xy[0], np.zeros(2))
    _, h, centre, half = best
    return ObstacleBox(
        name, (float(centre[0]), float(centre[1])), h, float(half[0]), float(half[1]),
        float(pts[:, 2].max()), 0,
    )  # fmt: skip


def _convex_hull_indices(xy: np.ndarray) -> np.ndarray:
    """Indices of the 2-D convex hull (monotone chain; no scipy.spatial.ConvexHull so
    that collinear or duplicate corners do not raise)."""
    order = np.lexsort((xy[:, 1], xy[:, 0]))
    if len(order) < 3:
        return order

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[int] = []
    for i in order:
        while len(lower) >= 2 and cross(xy[lower[-2]], xy[lower[-1]], xy[i]) <= 1e-12:
            lower.pop()
        lower.append(int(i))
    upper: list[int] = []
    for i in order[::-1]:
        while len(upper) >= 2 and cross(xy[upper[-2]], xy[upper[-1]], xy[i]) <= 1e-12:
            upper.pop()
        upper.append(int(i))
    return np.asarray(lower[:-1] + upper[:-1])


def boxes_from_vehicles(vehicles: tuple[ParkedVehicle, ...]) -> tuple[ObstacleBox, ...]:
    """True geometry of the synthetic set's parked vehicles (axis-aligned boxes)."""
    return tuple(
        ObstacleBox(v.name, v.centre, 0.0, v.size[0] / 2, v.size[1] / 2, v.size[2])
        for v in vehicles
    )


def scene_truth_boxes(
    scene_name: str, frame_map: FrameMap | None = None
) -> tuple[ObstacleBox, ...]:
    """True geometry of a rendered scene's boxed objects in the guidance frame
    (:func:`rangefx.golden.scenes.object_corners` mapped by ``frame_map``)."""
    from rangefx.golden.scenes import object_corners

    to_g = guidance_from_ned if frame_map is None else frame_map.to_guidance
    return tuple(box_from_corners(n, to_g(c)) for n, c in object_corners(scene_name).items())


# --------------------------------------------------------------------------- range error


#: Range-error models of :func:`predicted_range_error`.
ERROR_MODELS: tuple[str, ...] = ("motion", "stereo")


def predicted_range_error(
    image1: np.ndarray,
    image2: np.ndarray,
    camera: PinholeCamera,
    motion: MotionIncrement,
    range_map: np.ndarray,
    *,
    noise_sigma: float = 0.5,
    disparity_sigma_px: float = 0.25,
    estimator: EstimatorConfig | None = None,
    model: str = "motion",
) -> np.ndarray:
    """Predicted relative range error ``ε`` per pixel (module docstring, step 2).

    ``model="motion"`` (the first-order motion ranging of ch. 3-4: P1, the golden
    methods) adds three parts in quadrature:

    * **truncation**, from the ranging error equation (ch. 3 eq 14; SPIE eq 11 at
      degree 1): its residual over the ranging equation (eq 13),
      ``ρ = |(∇E1 - ∇E2)·d| / |(∇E1 + ∇E2)·d|``, is the relative error of the one-sided
      forms (eqs 11-12); their mean (eq 13) cancels that first-order error and leaves
      a second-order remainder, taken as ``ρ² / 3`` (the ratio for a locally
      sinusoidal irradiance);
    * **sensor noise** ``√2 σ_n / |E1 - E2|`` (eq 15 differentiated in ``E1 - E2``);
    * **parallax**: a disparity error of ``disparity_sigma_px`` pixels over the
      parallax ``|d| / range`` (eq 9; ``d = [f k4 - xp k3, f k5 - yp k3]``, ch. 4 eqs
      25-26): unbounded at the focus of expansion, where no range is supported.

    ``model="stereo"`` (a registered stereo pair ranged by a warped, coarse-to-fine
    disparity estimate: P3) is the disparity error over the disparity
    ``δ = |d| / range`` (``f B / Z`` for a baseline ``B``): ``ε = σ_δ / δ`` with
    ``σ_δ² = disparity_sigma_px² + 2 σ_n² / E_b²``, ``E_b`` the irradiance gradient
    along the baseline (the mean of both images'), i.e. ``Z² / (f B)`` times the
    disparity error. There is no truncation term: the estimate is re-linearised at the
    warped disparity at every scale, so the first-order residual of eq 14 (which grows
    with the disparity) is not its error.

    Derivatives come from the golden estimator (``consistent`` unless ``estimator``
    says otherwise), the same the ranging methods use. ``+inf`` where undefined.
    """
    if model not in ERROR_MODELS:
        raise ValueError(
            f"range error model must be one of {', '.join(ERROR_MODELS)}, not {model!r}"
        )
    est = estimator or EstimatorConfig().with_(variant="consistent")
    d1 = estimate_derivatives(image1, est)
    d2 = estimate_derivatives(image2, est)
    xp, yp = camera.pixel_grid()
    f = camera.f_px
    _, (k3, k4, k5) = k_coefficients(motion, xp, yp, f)
    dx = f * k4 - xp * k3
    dy = f * k5 - yp * k3
    total = (d1.Ex + d2.Ex) * dx + (d1.Ey + d2.Ey) * dy  # 2 a1 of eq 13
    diff = (d1.Ex - d2.Ex) * dx + (d1.Ey - d2.Ey) * dy  # 2 b1 of eq 14
    c1 = d1.E - d2.E
    rng_map = np.asarray(range_map, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if model == "stereo":
            norm = np.hypot(dx, dy)
            grad_b = 0.5 * ((d1.Ex + d2.Ex) * dx + (d1.Ey + d2.Ey) * dy) / norm
            sigma_d = np.sqrt(disparity_sigma_px**2 + 2.0 * noise_sigma**2 / grad_b**2)
            eps = sigma_d * rng_map / norm  # σ_δ / δ, δ = |d| / range
            return np.where(np.isfinite(eps), eps, np.inf)
        rho = np.abs(diff) / np.abs(total)
        noise = math.sqrt(2.0) * noise_sigma / np.abs(c1)
        parallax = disparity_sigma_px * rng_map / np.hypot(dx, dy)
        eps = np.sqrt((rho**2 / 3.0) ** 2 + noise**2 + parallax**2)
    return np.where(np.isfinite(eps), eps, np.inf)


# --------------------------------------------------------------------------- extraction


@dataclass(frozen=True)
class ExtractionConfig:
    """Settings of the obstacle extraction (module docstring, steps 1-5).

    Parameters
    ----------
    min_height, max_height
        Ground removal: keep points with ``min_height <= z <= max_height`` (ft).
    max_relative_error
        Reject points whose predicted relative range error ``ε`` exceeds this.
    noise_sigma, disparity_sigma_px
        Sensor noise on each image (grey levels) and disparity error (px) for ``ε``.
    link_px
        Image-plane linking: kept pixels closer than this (dilation radius, px) join.
    link_ft
        Point-cloud linking distance (ft) for :func:`extract_from_points`.
    min_points
        Smallest cluster (after along-ray rejection) kept as an obstacle.
    along_ray_k
        Along-ray outlier threshold in robust standard deviations of log range.
    min_log_spread
        Floor of that robust deviation (relative range error), so tight clusters do
        not reject their own surface.
    grow_k
        Along-ray growth in units of the cluster's range uncertainty.
    ground_k
        Ground removal with uncertainty: a point is a ground return unless its height
        stays ``>= min_height`` when its range moves by ``ground_k`` times its
        predicted error ``ε``.
    ground_slope
        A cluster whose log range rises with the log range to the ground along its
        rays faster than this is a mis-ranged ground patch (:func:`_ground_like`).
    min_rows
        A range-map cluster spanning fewer image rows has no upright extent (a
        horizontal texture edge of the ground): rejected.
    lateral_margin_ft
        Growth across the ray and on top (ft): pixel footprint and edge blur.
    max_range
        Drop points beyond this range along the optical axis (``None``: keep all).
    error_model
        ``"motion"`` or ``"stereo"``: the range-error model of
        :func:`predicted_range_error` (the pair's and the pipeline's ranging).
    """

    min_height: float = 1.0
    max_height: float = 60.0
    max_relative_error: float = 0.5
    noise_sigma: float = 0.5
    disparity_sigma_px: float = 0.25
    link_px: int = 3
    link_ft: float = 6.0
    min_points: int = 12
    along_ray_k: float = 2.5
    min_log_spread: float = 0.05
    grow_k: float = 1.0
    ground_k: float = 2.0
    ground_slope: float = 0.8
    min_rows: int = 3
    lateral_margin_ft: float = 1.0
    max_range: float | None = None
    error_model: str = "motion"

    def __post_init__(self) -> None:
        check_choice("extraction", "error_model", self.error_model, ERROR_MODELS)
        check_numbers("extraction", self, (
            "max_height", "max_relative_error", "link_ft", "along_ray_k",
            "min_log_spread", "lateral_margin_ft", "ground_slope",
        ))  # fmt: skip
        check_numbers("extraction", self, ("min_height", "noise_sigma", "disparity_sigma_px",
                                           "grow_k", "ground_k"), positive=False)  # fmt: skip
        if self.min_height >= self.max_height:
            raise ValueError(
                f"min_height ({self.min_height:g}) must be < max_height ({self.max_height:g})"
            )
        if not isinstance(self.link_px, int) or self.link_px < 0:
            raise ValueError(f"link_px must be an integer >= 0, not {self.link_px!r}")
        if not isinstance(self.min_rows, int) or self.min_rows < 1:
            raise ValueError(f"min_rows must be an integer >= 1, not {self.min_rows!r}")
        if not isinstance(self.min_points, int) or self.min_points < 1:
            raise ValueError(f"min_points must be an integer >= 1, not {self.min_points!r}")


@dataclass
class ExtractionResult:
    """Obstacles and the bookkeeping of every rejection step (counts of points)."""

    obstacles: tuple[ObstacleBox, ...]
    points: np.ndarray  # inlier points of all obstacles, guidance frame, (k, 3)
    counts: dict[str, int] = field(default_factory=dict)
    cluster_of_point: np.ndarray | None = None  # obstacle index of each inlier point

    def as_dict(self) -> dict:
        return {
            "n_obstacles": len(self.obstacles),
            "counts": dict(self.counts),
            "obstacles": [_box_dict(b) for b in self.obstacles],
        }


def _box_dict(b: ObstacleBox) -> dict:
    return {
        "name": b.name,
        "centre_ft": [b.centre[0], b.centre[1]],
        "heading_deg": math.degrees(b.heading),
        "size_ft": [2 * b.half_u, 2 * b.half_v, b.top],
        "n_points": b.n_points,
    }


def _robust_log_spread(log_r: np.ndarray) -> tuple[float, float]:
    med = float(np.median(log_r))
    return med, 1.4826 * float(np.median(np.abs(log_r - med)))


def _cluster_box(
    name: str,
    pts: np.ndarray,
    ranges: np.ndarray,
    eps: np.ndarray,
    camera_xy: np.ndarray,
    cfg: ExtractionConfig,
) -> ObstacleBox:
    """Box of one cluster's inliers: along the viewing ray through their median point."""
    rel = pts[:, :2] - camera_xy
    med = np.median(rel, axis=0)
    h = math.atan2(med[1], med[0])
    c, s = math.cos(h), math.sin(h)
    u = rel @ np.array([c, s])
    v = rel @ np.array([-s, c])
    _, spread = _robust_log_spread(np.log(ranges))
    eps_med = float(np.median(eps)) if np.all(np.isfinite(eps)) else 0.0
    u_med = float(np.median(u))
    # Along the ray the surface is where the inliers' middle half lies, and the centre
    # is uncertain by the predicted range error (or, without one, the measured spread).
    sigma_u = (eps_med if eps_med > 0 else spread) * u_med
    grow_u = cfg.grow_k * sigma_u
    q_lo, q_hi = np.quantile(u, [0.25, 0.75])
    u_lo, u_hi = min(float(q_lo), u_med - grow_u), max(float(q_hi), u_med + grow_u)
    m = cfg.lateral_margin_ft
    # Across the ray a point is its bearing (known to the pixel) times its range (known
    # to ε): the object lies in the wedge of its points' bearings anywhere in [u_lo,
    # u_hi]. The box holds that wedge as well as the points themselves.
    bearing = v / np.maximum(u, 1e-9)
    near_far = (max(u_lo, 0.0), u_hi)
    wedge = [w * e for w in (float(bearing.min()), float(bearing.max())) for e in near_far]
    v_lo = min(float(v.min()), *wedge) - m
    v_hi = max(float(v.max()), *wedge) + m
    mid_u, mid_v = 0.5 * (u_lo + u_hi), 0.5 * (v_lo + v_hi)
    centre = camera_xy + mid_u * np.array([c, s]) + mid_v * np.array([-s, c])
    top = float(pts[:, 2].max()) * (1.0 + cfg.grow_k * (eps_med if eps_med > 0 else spread)) + m
    return ObstacleBox(
        name, (float(centre[0]), float(centre[1])), h,
        0.5 * (u_hi - u_lo), 0.5 * (v_hi - v_lo), top, len(pts),
    )  # fmt: skip


def _ground_like(ranges: np.ndarray, ground_range: np.ndarray, cfg: ExtractionConfig) -> bool:
    """True when a cluster's ranges scale like the ground's along its rays.

    A ground patch whose range is over- or under-estimated by a common factor ``k``
    maps onto the plane at height ``(1 - k) h_camera``: above the ground, but flat. An
    upright object keeps one range over the rows it spans, while the range to the
    ground behind it changes. The slope of ``log range`` on ``log ground range``
    (least squares over the cluster) is ~1 for the first, ~0 for the second.
    """
    ok = np.isfinite(ground_range) & (ground_range > 0)
    if ok.sum() < cfg.min_points:
        return False
    xg, yr = np.log(ground_range[ok]), np.log(ranges[ok])
    if xg.std() < cfg.min_log_spread:  # too few rows to tell
        return False
    slope = float(np.cov(xg, yr, bias=True)[0, 1] / xg.var())
    return slope > cfg.ground_slope


def _upright(z: np.ndarray, ranges: np.ndarray, camera_z: float, cfg: ExtractionConfig) -> bool:
    """True when a cluster stands off the ground at its own (median) range.

    Each point is moved along its ray to the cluster's median range, where its height
    is ``z_c + (z - z_c) r̂ / r`` (the height is linear in the range along a ray); the
    cluster is upright when the upper quartile of those heights is at least
    ``min_height``. A region of ground pixels, ranged right or scattered both ways,
    stays at ~0 ft; a vehicle's pixels span its height.
    """
    med = float(np.median(ranges))
    h = camera_z + (z - camera_z) * med / ranges
    return float(np.quantile(h, 0.75)) >= cfg.min_height


def _contiguous(rows: np.ndarray, cols: np.ndarray, share: float = 0.5) -> bool:
    """True when pixels form one image region: the largest 8-connected component
    (after a 1-pixel dilation) holds at least ``share`` of them. An object in front
    of another occludes it over a contiguous patch; a cluster's short or long tail is
    scattered over the cluster (runway/P1: 14 pixels of vehicle 1 ranged 0.58 x over a
    35 x 19 pixel area)."""
    r0, c0 = rows.min(), cols.min()
    img = np.zeros((np.ptp(rows) + 1, np.ptp(cols) + 1), dtype=bool)
    img[rows - r0, cols - c0] = True
    lab, n = ndimage.label(ndimage.binary_dilation(img, np.ones((3, 3))), np.ones((3, 3)))
    if n <= 1:
        return True
    counts = np.bincount(lab[rows - r0, cols - c0], minlength=n + 1)[1:]
    return counts.max() >= share * len(rows)


def _boxes_from_clusters(
    labels: np.ndarray,
    pts: np.ndarray,
    ranges: np.ndarray,
    eps: np.ndarray,
    camera_xy: np.ndarray,
    cfg: ExtractionConfig,
    counts: dict[str, int],
    *,
    ray_aligned: bool = True,
    ground_range: np.ndarray | None = None,
    rows: np.ndarray | None = None,
    cols: np.ndarray | None = None,
    camera_z: float | None = None,
) -> ExtractionResult:
    boxes, keep_pts, keep_lab = [], [], []
    counts.setdefault("along_ray_outliers", 0)
    counts.setdefault("isolated", 0)
    counts.setdefault("ground_like", 0)
    counts.setdefault("flat", 0)
    pending = [np.nonzero(labels == lab)[0] for lab in np.unique(labels)]
    while pending:
        sel = pending.pop(0)
        log_r = np.log(ranges[sel])
        med, spread = _robust_log_spread(log_r)
        # A point's own predicted error widens its test: a point ranged 40 % short with
        # ε = 0.25 is the same surface, not a second object in front of it.
        scale = np.maximum(max(spread, cfg.min_log_spread), eps[sel])
        near = np.abs(log_r - med) <= cfg.along_ray_k * scale
        inl, out = sel[near], sel[~near]
        if len(out) >= cfg.min_points and (cols is None or _contiguous(rows[out], cols[out])):
            pending.append(out)  # a second object behind (or before) the first along the rays
        else:
            counts["along_ray_outliers"] += len(out)
        if len(inl) < cfg.min_points:
            counts["isolated"] += len(inl)
            continue
        if rows is not None and np.ptp(rows[inl]) + 1 < cfg.min_rows:
            counts["flat"] += len(inl)  # no image height: a texture edge, not upright
            continue
        if ground_range is not None and _ground_like(ranges[inl], ground_range[inl], cfg):
            counts["ground_like"] += len(inl)
            continue
        if camera_z is not None and not _upright(pts[inl, 2], ranges[inl], camera_z, cfg):
            counts["ground"] += len(inl)
            continue
        name = f"obstacle {len(boxes) + 1}"
        if ray_aligned:
            box = _cluster_box(name, pts[inl], ranges[inl], eps[inl], camera_xy, cfg)
        else:  # exact points: the smallest enclosing box, grown by the lateral margin
            fit = box_from_corners(name, np.vstack([pts[inl], pts[inl] * [1, 1, 0]]))
            box = replace(fit.grown(cfg.lateral_margin_ft), n_points=len(inl))
        keep_lab.append(np.full(len(inl), len(boxes)))
        boxes.append(box)
        keep_pts.append(pts[inl])
    counts["inliers"] = int(sum(len(p) for p in keep_pts))
    points = np.concatenate(keep_pts) if keep_pts else np.empty((0, 3))
    lab_arr = np.concatenate(keep_lab) if keep_lab else np.empty(0, dtype=int)
    return ExtractionResult(tuple(boxes), points, counts, lab_arr)


def extract_obstacles(
    range_map: np.ndarray,
    valid: np.ndarray,
    camera: PinholeCamera,
    motion: MotionIncrement,
    *,
    images: tuple[np.ndarray, np.ndarray] | None = None,
    frame_map: FrameMap | None = None,
    config: ExtractionConfig | None = None,
) -> ExtractionResult:
    """Obstacles from a range map (module docstring, steps 1-5).

    Parameters
    ----------
    range_map, valid
        ``(m, n)`` range along the camera-1 optical axis and its validity flags.
    camera, motion
        Camera and INS state of frame 1 (eqs 32-33).
    images
        ``(E1, E2)`` for the range-error equation; ``None`` skips step 2 (``ε = 0``).
    frame_map
        Scene NED → guidance frame (default :func:`guidance_from_ned`).
    config
        :class:`ExtractionConfig`.

    Returns
    -------
    ExtractionResult
        ``counts`` has ``valid``, ``ground`` (removed), ``error_bound`` (rejected by
        ``ε``), ``along_ray_outliers``, ``isolated``, ``inliers``.
    """
    cfg = config or ExtractionConfig()
    rng_map, ok = usable_range(range_map, valid, camera, cfg.max_range)
    counts = {"valid": int(ok.sum())}
    xp, yp = camera.pixel_grid()
    pn = np.full((*rng_map.shape, 3), np.nan)
    pn[ok] = inertial_from_camera(
        motion, camera_points_from_range(rng_map[ok], xp[ok], yp[ok], camera.f_px)
    )  # eqs 32-33
    if images is not None:
        eps = predicted_range_error(
            images[0], images[1], camera, motion, rng_map,
            noise_sigma=cfg.noise_sigma, disparity_sigma_px=cfg.disparity_sigma_px,
            model=cfg.error_model,
        )  # fmt: skip
    else:
        eps = np.zeros(rng_map.shape)
    cam_ned = inertial_from_camera(motion, np.zeros(3))
    height = -pn[..., 2]
    # A point is off the ground only if it stays so anywhere within its predicted range
    # error: along the ray the height is linear in the range, h(r') = h_c + (h - h_c) r'/r.
    with np.errstate(invalid="ignore"):
        low = height - np.abs(height + cam_ned[2]) * cfg.ground_k * np.where(ok, eps, 0.0)
        above = ok & (low >= cfg.min_height) & (height <= cfg.max_height)
    counts["ground"] = int(ok.sum() - above.sum())
    keep = above & (eps <= cfg.max_relative_error)
    counts["error_bound"] = int(above.sum() - keep.sum())
    if cfg.link_px > 0:
        grown = ndimage.binary_dilation(keep, structure=np.ones((3, 3)), iterations=cfg.link_px)
    else:
        grown = keep
    comp, _ = ndimage.label(grown, structure=np.ones((3, 3)))
    # With range errors (ε > 0) a cluster's range comes from every valid pixel of its
    # image region within the error bound, not only from the pixels that passed the
    # ground test: that test favours short ranges (a point ranged short rises along its
    # ray, away from the ground; one ranged long sinks into it), so on a far vehicle the
    # survivors alone sit 30-40 % short (measured on runway/P1) while the region's
    # median is within 15 %. Exact ranges (ε = 0) are not biased by the test.
    region = keep | (
        (comp > 0) & ok & (eps > 0) & (eps <= cfg.max_relative_error) & (height <= cfg.max_height)
    )
    counts["region_added"] = int(region.sum() - (region & keep).sum())
    keep = region
    to_g = guidance_from_ned if frame_map is None else frame_map.to_guidance
    pts = to_g(pn[keep])
    camera_xy = to_g(cam_ned)[:2]
    # Range along the optical axis at which each pixel's ray meets the ground (x_c = 1
    # direction of eq 32 mapped by eq 33; NED z is down, the ground is z = 0).
    ray = (
        inertial_from_camera(
            motion,
            camera_points_from_range(np.ones(int(keep.sum())), xp[keep], yp[keep], camera.f_px),
        )
        - cam_ned
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        ground_range = np.where(ray[:, 2] > 0, -cam_ned[2] / ray[:, 2], np.inf)
    return _boxes_from_clusters(
        comp[keep], pts, rng_map[keep], eps[keep], camera_xy, cfg, counts,
        ground_range=ground_range, rows=np.nonzero(keep)[0], cols=np.nonzero(keep)[1],
        camera_z=float(to_g(cam_ned)[2]),
    )  # fmt: skip


def extract_from_points(
    points: np.ndarray,
    *,
    camera_position: tuple[float, float, float] | np.ndarray,
    config: ExtractionConfig | None = None,
) -> ExtractionResult:
    """Obstacles from a bare guidance-frame point cloud (no range map, no error equation).

    Ground removal (step 1), single-linkage clustering at ``link_ft`` (step 3) and the
    along-ray test with the range measured from ``camera_position`` (step 4). The
    points carry no range error, so each extent is the smallest box holding the
    cluster down to the ground, grown by ``lateral_margin_ft``.
    """
    cfg = config or ExtractionConfig()
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or not np.all(np.isfinite(pts)):
        raise ValueError(f"points must be a finite (N, 3) array, got shape {pts.shape}")
    counts = {"valid": len(pts)}
    above = (pts[:, 2] >= cfg.min_height) & (pts[:, 2] <= cfg.max_height)
    counts["ground"] = int(len(pts) - above.sum())
    counts["error_bound"] = 0
    pts = pts[above]
    if len(pts) == 0:
        return ExtractionResult((), np.empty((0, 3)), {**counts, "inliers": 0}, None)
    pairs = cKDTree(pts).query_pairs(cfg.link_ft, output_type="ndarray")
    graph = coo_matrix(
        (np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(pts), len(pts))
    )
    _, labels = connected_components(graph, directed=False)
    cam = np.asarray(camera_position, dtype=np.float64)
    ranges = np.linalg.norm(pts - cam, axis=1)
    return _boxes_from_clusters(
        labels, pts, ranges, np.zeros(len(pts)), cam[:2], cfg, counts, ray_aligned=False
    )


# --------------------------------------------------------------------------- scoring


def score_extraction(obstacles: tuple[ObstacleBox, ...], truth: tuple[ObstacleBox, ...]) -> dict:
    """Score extracted obstacles against the true objects.

    A true object is **detected** when some obstacle's extent intersects it (their
    footprints overlap); its **centre error** is the horizontal distance from its
    centre to the nearest such obstacle's centre, its **extent error** the difference
    of the footprint diagonals and ``contained`` whether that obstacle holds the whole
    true box. An obstacle that intersects no true object is **false**.

    Returns
    -------
    dict
        ``per_object`` (list of dicts), ``detected``, ``n_true``, ``false_obstacles``,
        ``false_obstacle_names``, ``max_centre_error_ft``, ``mean_centre_error_ft``.
    """
    hits = np.zeros((len(obstacles), len(truth)), dtype=bool)
    for i, ob in enumerate(obstacles):
        for j, tr in enumerate(truth):
            hits[i, j] = _footprints_overlap(ob, tr)
    per = []
    errs = []
    for j, tr in enumerate(truth):
        idx = np.nonzero(hits[:, j])[0]
        row = {"name": tr.name, "detected": bool(len(idx))}
        if len(idx):
            d = [math.dist(obstacles[i].centre, tr.centre) for i in idx]
            k = int(idx[int(np.argmin(d))])
            ob = obstacles[k]
            row.update(
                obstacle=ob.name,
                centre_error_ft=float(min(d)),
                extent_error_ft=float(
                    math.hypot(2 * ob.half_u, 2 * ob.half_v)
                    - math.hypot(2 * tr.half_u, 2 * tr.half_v)
                ),
                contained=bool(np.all(ob.signed_distance(tr.corners()) <= 1e-9)),
            )
            errs.append(row["centre_error_ft"])
        per.append(row)
    false = [obstacles[i].name for i in range(len(obstacles)) if not hits[i].any()]
    return {
        "per_object": per,
        "n_true": len(truth),
        "detected": int(sum(r["detected"] for r in per)),
        "false_obstacles": len(false),
        "false_obstacle_names": false,
        "max_centre_error_ft": float(max(errs)) if errs else math.nan,
        "mean_centre_error_ft": float(np.mean(errs)) if errs else math.nan,
    }


def _footprints_overlap(a: ObstacleBox, b: ObstacleBox) -> bool:
    """Separating-axis test of two oriented rectangles (footprints)."""
    pa, pb = a.footprint(), b.footprint()
    for poly in (pa, pb):
        for k in range(4):
            e = poly[(k + 1) % 4] - poly[k]
            n = np.array([-e[1], e[0]])
            if np.hypot(*n) == 0:
                continue
            ia, ib = pa @ n, pb @ n
            if ia.max() < ib.min() - 1e-9 or ib.max() < ia.min() - 1e-9:
                return False
    return True
