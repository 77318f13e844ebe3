"""Obstacle point sets for the guidance law: synthetic (the report's example) and from
range maps (eqs 32-33 of the obstacle-location paper of chapter 4).

Guidance frame
--------------
Eqs 4-6 put ``x`` down range, ``y`` cross range, ``z`` altitude, with the heading ``χ``
measured from ``x`` towards ``y`` and, by eq 2, a positive bank turning towards
increasing ``χ``. A positive (right-wing-down) bank turns right, so ``y`` is to the right
of ``x``: the guidance frame is the NED inertial frame of :mod:`rangefx.golden.geometry`
with its vertical axis flipped, ``(x, y, z)_guidance = (x_N, y_E, -z_D)`` (left-handed,
as usual in trajectory work). :func:`ned_from_guidance` and :func:`guidance_from_ned`
convert; :class:`FrameMap` additionally places a scene's vehicle at a chosen guidance
position and heading.

The report's obstacle set (its Figs 2-3: 293 range points on four vehicles parked on the
two sides of a runway, from a camera ~7 ft up) is not available;
:func:`synthetic_runway_obstacles` builds a documented stand-in, and
:func:`obstacles_from_range` turns a real range map into points.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from rangefx.golden.geometry import (
    MotionIncrement,
    PinholeCamera,
    camera_points_from_range,
    inertial_from_camera,
)

__all__ = [
    "REPORT_VEHICLES",
    "FrameMap",
    "ParkedVehicle",
    "RangeMapSource",
    "RunwayRange",
    "golden_range_source",
    "guidance_from_ned",
    "ned_from_guidance",
    "obstacles_from_range",
    "reduce_points",
    "runway_frame_map",
    "runway_range",
    "runway_scene_obstacles",
    "synthetic_runway_obstacles",
    "usable_range",
]


def ned_from_guidance(p: np.ndarray) -> np.ndarray:
    """NED inertial coordinates of guidance-frame points (``z`` altitude → ``-z_D``)."""
    p = np.array(p, dtype=np.float64)
    p[..., 2] *= -1.0
    return p


def guidance_from_ned(p: np.ndarray) -> np.ndarray:
    """Guidance-frame coordinates of NED points (the inverse of :func:`ned_from_guidance`)."""
    return ned_from_guidance(p)


@dataclass(frozen=True)
class FrameMap:
    """Horizontal rigid motion from a scene's NED frame to the guidance frame.

    A scene point ``p`` (NED) maps to ``R(ψ_g - ψ_s) (p_h - o_s) + o_g`` horizontally and
    to altitude ``-p_z``: the scene vehicle's ground position ``o_s`` and heading ``ψ_s``
    land on the guidance position ``o_g`` and heading ``ψ_g`` (rad, from ``x`` towards
    ``y``). The ground plane ``z_D = 0`` stays the ground.
    """

    origin_scene: tuple[float, float]
    heading_scene: float
    origin_guidance: tuple[float, float]
    heading_guidance: float

    def _rot(self, sign: float) -> np.ndarray:
        d = sign * (self.heading_guidance - self.heading_scene)
        c, s = math.cos(d), math.sin(d)
        return np.array([[c, -s], [s, c]])

    def to_guidance(self, p_ned: np.ndarray) -> np.ndarray:
        p = np.asarray(p_ned, dtype=np.float64)
        out = np.empty_like(p)
        out[..., :2] = (p[..., :2] - self.origin_scene) @ self._rot(1.0).T + self.origin_guidance
        out[..., 2] = -p[..., 2]
        return out

    def to_scene(self, p_g: np.ndarray) -> np.ndarray:
        p = np.asarray(p_g, dtype=np.float64)
        out = np.empty_like(p)
        out[..., :2] = (p[..., :2] - self.origin_guidance) @ self._rot(-1.0).T + self.origin_scene
        out[..., 2] = -p[..., 2]
        return out


# --------------------------------------------------------------------------- synthetic set


@dataclass(frozen=True)
class ParkedVehicle:
    """A truck-sized box on the ground (guidance frame, ft).

    ``centre`` is the ground-level centre ``(x, y)``; ``size`` is ``(length along x,
    width along y, height)``; ``n_points`` range points are placed on it.
    """

    name: str
    centre: tuple[float, float]
    size: tuple[float, float, float]
    n_points: int


#: Layout of the synthetic stand-in for the report's Figs 2-3 (guidance frame, ft).
#: The helicopter starts at [532, 590, 7] flying along -y (heading -90°), 208 ft to the
#: side of a runway that runs along y with its centre line at x = 740 and is 34 ft wide
#: (edges x = 723 and 757, the width of the ``runway`` scene). Four truck-sized boxes
#: (20 ft along the runway, 8 ft wide, 8 ft tall, as in the ``runway`` scene) are parked
#: 5 ft off the two edges: vehicles 1 and 2 face each other across the runway at y = 0,
#: so the touch-down point [740, 0, 0] lies between them ("a point between the stationary
#: vehicles 1 and 2"); vehicles 3 and 4 stand 340-440 ft ahead of the start (y = 250 on
#: the near side, y = 150 on the far side). 293 points in all, as in the report, shared
#: roughly in proportion to each vehicle's apparent size. The placement is an assumption:
#: the report gives only the description and the (unreadable) figures.
REPORT_VEHICLES: tuple[ParkedVehicle, ...] = (
    ParkedVehicle("Vehicle 1", (714.0, 0.0), (8.0, 20.0, 8.0), 66),
    ParkedVehicle("Vehicle 2", (766.0, 0.0), (8.0, 20.0, 8.0), 62),
    ParkedVehicle("Vehicle 3", (714.0, 250.0), (8.0, 20.0, 8.0), 90),
    ParkedVehicle("Vehicle 4", (766.0, 150.0), (8.0, 20.0, 8.0), 75),
)


def synthetic_runway_obstacles(
    vehicles: tuple[ParkedVehicle, ...] = REPORT_VEHICLES,
    *,
    camera_position: tuple[float, float, float] = (532.0, 590.0, 7.0),
    edge_fraction: float = 0.6,
    seed: int = 0,
    shift: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> np.ndarray:
    """Synthetic range points on parked vehicles, standing in for the report's Fig 3.

    Each vehicle's faces that face ``camera_position`` (outward normal towards it; the
    top is seen only from above, i.e. never at 7 ft) get its points: ``edge_fraction``
    of them on the face outlines (where image contrast, hence range data, exists) and
    the rest uniformly on the faces, drawn with ``numpy.random.default_rng(seed)``.
    Occlusion is ignored. ``shift`` moves the whole set (sensitivity studies).

    Returns
    -------
    ndarray, shape (sum of n_points, 3)
        Guidance-frame points (ft).
    """
    if not 0.0 <= edge_fraction <= 1.0:
        raise ValueError(f"edge_fraction must be in [0, 1], not {edge_fraction!r}")
    if not vehicles:
        raise ValueError("no vehicles: the synthetic obstacle set needs at least one")
    rng = np.random.default_rng(seed)
    cam = np.asarray(camera_position, dtype=np.float64)
    out = []
    for veh in vehicles:
        if veh.n_points < 1:
            raise ValueError(f"{veh.name}: n_points must be >= 1, not {veh.n_points!r}")
        lx, ly, h = veh.size
        c = np.array([veh.centre[0], veh.centre[1], h / 2])
        half = np.array([lx / 2, ly / 2, h / 2])
        faces = []  # (centre, axis u, axis v, half-u, half-v, area)
        for ax in range(3):
            for sgn in (-1.0, 1.0):
                normal = np.zeros(3)
                normal[ax] = sgn
                fc = c + normal * half
                if (cam - fc) @ normal <= 0:
                    continue
                u, v = [k for k in range(3) if k != ax]
                faces.append((fc, u, v, half[u], half[v], 4 * half[u] * half[v]))
        areas = np.array([f[5] for f in faces])
        which = rng.choice(len(faces), size=veh.n_points, p=areas / areas.sum())
        on_edge = rng.random(veh.n_points) < edge_fraction
        s = rng.uniform(-1.0, 1.0, size=(veh.n_points, 2))
        # Edge points: snap one of the two face coordinates to ±1.
        snap = rng.integers(0, 2, veh.n_points)
        idx = np.nonzero(on_edge)[0]
        s[idx, snap[idx]] = np.sign(s[idx, snap[idx]])
        for k in range(veh.n_points):
            fc, u, v, hu, hv, _ = faces[which[k]]
            p = fc.copy()
            p[u] += s[k, 0] * hu
            p[v] += s[k, 1] * hv
            out.append(p)
    pts = np.asarray(out) + np.asarray(shift, dtype=np.float64)
    return pts


# --------------------------------------------------------------------------- from a range map


def reduce_points(
    points: np.ndarray, max_points: int, method: str = "voxel", *, seed: int = 0
) -> np.ndarray:
    """Reduce a point cloud to at most ``max_points`` points.

    Methods
    -------
    ``"voxel"`` (default)
        Grid clustering: points are binned in cubic cells and each occupied cell is
        replaced by the mean of its points; cells are anchored at the cloud's lower
        corner, the cell size starts at 1 ft and grows by √2 until at most
        ``max_points`` cells are occupied. Deterministic, keeps the spatial coverage
        (dense surfaces do not dominate), costs O(N log N) per size.
    ``"subsample"``
        Uniform random subsample without replacement (``numpy.random.default_rng(seed)``);
        keeps the density of the raw range points, like the report's sparse data.

    Note that the guidance law sees only ``n`` and the centroid (SPEC §9), so the
    reduction changes the law through ``n`` (σ, eq 35) and the centroid shift; the
    minimum-distance figure depends on the individual points.
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {pts.shape}")
    if max_points < 1:
        raise ValueError(f"max_points must be >= 1, not {max_points!r}")
    if len(pts) <= max_points:
        return pts.copy()
    if method == "subsample":
        rng = np.random.default_rng(seed)
        return pts[np.sort(rng.choice(len(pts), size=max_points, replace=False))]
    if method != "voxel":
        raise ValueError(f"unknown reduction method {method!r}; choose 'voxel' or 'subsample'")
    cell = 1.0
    lo = pts.min(axis=0)  # cells anchored at the cloud's corner: one cell once it spans it
    while True:
        keys = np.floor((pts - lo) / cell).astype(np.int64)
        uniq, inv = np.unique(keys, axis=0, return_inverse=True)
        if len(uniq) <= max_points:
            inv = inv.reshape(-1)
            sums = np.zeros((len(uniq), 3))
            np.add.at(sums, inv, pts)
            counts = np.bincount(inv, minlength=len(uniq))[:, None]
            return sums / counts
        cell *= math.sqrt(2.0)


def usable_range(
    range_map: np.ndarray, valid: np.ndarray, camera: PinholeCamera, max_range: float | None
) -> tuple[np.ndarray, np.ndarray]:
    """``(range_map as float64, the pixels to use)``: valid, finite, positive and, unless
    ``max_range`` is None, not beyond it. ``ValueError`` unless ``range_map`` and
    ``valid`` are both the camera's shape."""
    rng_map = np.asarray(range_map, dtype=np.float64)
    ok = np.asarray(valid, dtype=bool)
    if rng_map.shape != (camera.height, camera.width) or ok.shape != rng_map.shape:
        raise ValueError(
            f"range map {rng_map.shape} and valid {ok.shape} must match the camera "
            f"({camera.height}, {camera.width})"
        )
    ok = ok & np.isfinite(rng_map) & (rng_map > 0)
    if max_range is not None:
        ok &= rng_map <= max_range
    return rng_map, ok


def obstacles_from_range(
    range_map: np.ndarray,
    valid: np.ndarray,
    camera: PinholeCamera,
    motion: MotionIncrement,
    *,
    max_points: int = 300,
    method: str = "voxel",
    min_height: float | None = 0.5,
    max_range: float | None = None,
    frame_map: FrameMap | None = None,
    seed: int = 0,
) -> np.ndarray:
    """Obstacle points from a range map: eq 32 (camera frame), eq 33 (inertial), reduce.

    Parameters
    ----------
    range_map
        ``(m, n)`` range along the camera-1 optical axis ``x_c`` (scene length unit).
    valid
        ``(m, n)`` bool validity flags of the ranging stage; only valid pixels are used.
    camera, motion
        The camera and the INS state of frame 1 (the frame the range map refers to).
    max_points
        Upper bound on the number of returned points (see :func:`reduce_points`).
    method
        ``"voxel"`` or ``"subsample"`` (:func:`reduce_points`).
    min_height
        Drop points lower than this above the ground plane ``z_D = 0`` (ft): the ground
        itself is not an obstacle, and the law would otherwise be dominated by runway
        texture. ``None`` keeps every point.
    max_range
        Drop points with ``x_c`` beyond this (e.g. below the ranging ``range_max``).
    frame_map
        Map from the scene's NED frame to the guidance frame; ``None`` uses
        :func:`guidance_from_ned` (same horizontal axes, altitude up).
    seed
        For ``method="subsample"``.

    Returns
    -------
    ndarray, shape (k, 3)
        Guidance-frame points, ``k <= max_points``.

    Raises
    ------
    ValueError
        Shape mismatch, or no valid point left (the guidance law needs ``n >= 1``).
    """
    rng_map, ok = usable_range(range_map, valid, camera, max_range)
    xp, yp = camera.pixel_grid()
    pc = camera_points_from_range(rng_map[ok], xp[ok], yp[ok], camera.f_px)  # eq 32
    pn = inertial_from_camera(motion, pc)  # eq 33
    if min_height is not None:
        pn = pn[-pn[:, 2] >= min_height]
    if len(pn) == 0:
        raise ValueError("no obstacle points: the range map has no valid point above the ground")
    pg = guidance_from_ned(pn) if frame_map is None else frame_map.to_guidance(pn)
    return reduce_points(pg, max_points, method, seed=seed)


# --------------------------------------------------------------------------- runway demo

#: A range-map source: ``(scene) -> (range_map, valid)``. The golden source below uses
#: ``rangefx.golden.methods.run_method``; the fixed-point P1 pipeline plugs in here.
RangeMapSource = Callable[[object], tuple[np.ndarray, np.ndarray]]


def golden_range_source(method: str = "g4_consistent") -> RangeMapSource:
    """Range-map source running a golden method on a scene's image pair."""
    from rangefx.golden.methods import SCENE_RANGING, run_method

    def source(scene) -> tuple[np.ndarray, np.ndarray]:
        res = run_method(
            method,
            scene.image1,
            scene.image2,
            scene.camera,
            scene.motion,
            ranging=SCENE_RANGING.get(scene.name),
        )
        return res.range, res.valid

    return source


def runway_frame_map(
    scene, start: tuple[float, float] = (532.0, 590.0), heading_deg: float = -90.0
) -> FrameMap:
    """Place the ``runway`` scene's frame-1 vehicle at ``start`` flying at ``heading_deg``.

    The scene's heading is that of its INS translation ``Δx_v`` (the runway direction);
    of a stereo pair (:func:`rangefx.golden.scenes.render_runway_stereo`, whose ``Δx_v``
    is the lateral baseline) the vehicle's yaw at view 1, the same direction.
    """
    m = scene.motion
    if getattr(scene, "kind", "motion") == "stereo":
        heading = math.atan2(float(m.T2[0, 1]), float(m.T2[0, 0]))
    else:
        heading = math.atan2(float(m.dxv[1]), float(m.dxv[0]))
    return FrameMap(
        origin_scene=(float(m.xv[0]), float(m.xv[1])),
        heading_scene=heading,
        origin_guidance=(float(start[0]), float(start[1])),
        heading_guidance=math.radians(heading_deg),
    )


class RunwayRange(NamedTuple):
    """The ``runway`` scene ranged (:func:`runway_range`): the scene, its range map and
    validity, the map to the guidance frame and the range the points are kept below."""

    scene: Any
    range_map: np.ndarray
    valid: np.ndarray
    frame_map: FrameMap
    max_range: float | None


def runway_range(source: RangeMapSource | None = None, *, scene=None) -> RunwayRange:
    """Render ``runway`` (unless ``scene`` is given) and range it with ``source`` (default
    :func:`golden_range_source` with ``g4_consistent``; a fixed-point pipeline is another
    source); the frame map is :func:`runway_frame_map` (the scene's helicopter placed at
    the example's start, flying along -y) and ``max_range`` just below the scene's
    ranging ``range_max`` (None for a scene without one)."""
    from rangefx.golden.methods import SCENE_RANGING
    from rangefx.golden.scenes import render_scene

    scene = render_scene("runway") if scene is None else scene
    rng_map, valid = (source or golden_range_source())(scene)
    cfg = SCENE_RANGING.get(scene.name)
    max_range = None if cfg is None else 0.999 * cfg.range_max
    return RunwayRange(scene, rng_map, valid, runway_frame_map(scene), max_range)


def runway_scene_obstacles(
    source: RangeMapSource | None = None,
    *,
    scene=None,
    max_points: int = 300,
    method: str = "voxel",
    min_height: float | None = 0.5,
    seed: int = 0,
) -> tuple[np.ndarray, object, FrameMap, dict]:
    """End-to-end obstacle points from the ``runway`` scene: :func:`runway_range`, then
    the valid points below the ranging ``range_max`` mapped to the guidance frame and
    reduced to ``max_points`` (:func:`obstacles_from_range`).

    Returns
    -------
    points, scene, frame_map, info
        ``info`` has ``valid_pixels`` and ``obstacle_points`` counts.
    """
    r = runway_range(source, scene=scene)
    pts = obstacles_from_range(
        r.range_map, r.valid, r.scene.camera, r.scene.motion,
        max_points=max_points, method=method, min_height=min_height,
        max_range=r.max_range, frame_map=r.frame_map, seed=seed,
    )  # fmt: skip
    info = {"valid_pixels": int(np.count_nonzero(r.valid)), "obstacle_points": len(pts)}
    return pts, r.scene, r.frame_map, info
