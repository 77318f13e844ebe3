"""Textured scenes with exact ground-truth depth, rendered by pinhole cameras (SPEC §3).

The report tests its ranging methods on two image pairs that are not available: a
laboratory stereo pair (SPIE paper of ch. 4, §4 and Table 1; the stereo paper of
ch. 5, Figs 3-5) and two frames from a camera on the nose of a helicopter (obstacle
paper of ch. 4, "Results and Discussions", Figs 3-5 and its table). This module builds
synthetic stand-ins with the same geometry and exact depth everywhere, so that every
algorithm of the golden model and of the fixed-point model can be scored pixel by pixel.

Rendering is analytic ray casting, vectorised with numpy:

* primitives are textured planar rectangles (boxes are made of them) and finite
  cylinders with optional end discs, described in the inertial frame of
  :mod:`rangefx.golden.geometry` (NED for flight, ``x`` forward, ``y`` right,
  ``z`` down for the laboratory);
* the ray through image point ``(xp, yp)`` of a camera leaves its centre
  ``x_v + T2^T l`` along ``T2^T T1^T [1, xp/f, yp/f]^T`` (eqs 8-15 of the obstacle
  paper, inverted as in its eq 33); the second camera uses ``T2 + ΔT2`` and
  ``x_v + Δx_v``. Because the ray's ``x_c`` component is one, the ray parameter of
  the first hit *is* the range along the optical axis, ``x_c``;
* surfaces carry grey-level textures taken from images that scikit-image ships inside
  its package (no network), tiled with mirrored repeat, sampled bilinearly from a
  box-filtered pyramid chosen by the sample's footprint (trilinear mip-mapping), and
  shaded with a view-independent Lambert term so that brightness constancy, on which
  every ranging equation of the report rests, holds exactly between the two views;
* each pixel is the mean of ``S x S`` sub-pixel samples (the sensor's integration);
  depth and labels come from the ray through the pixel centre only;
* seeded Gaussian noise is added and the result is rounded to 256 grey levels, as the
  report's 8-bit cameras did.

Arrays are indexed ``[j, i]`` (row, column) in the camera's raster order (SPEC §2).
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from .geometry import (
    MotionIncrement,
    PinholeCamera,
    camera_from_inertial,
    camera_points_from_range,
    inertial_from_camera,
)

__all__ = [
    "RUNWAY_STEREO_BASELINE_FT",
    "SCENE_NAMES",
    "TEXTURE_NAMES",
    "Scene",
    "SceneObject",
    "frame2_positions",
    "object_corners",
    "render_plane",
    "render_runway_stereo",
    "render_scene",
]

SCENE_NAMES: tuple[str, ...] = ("lab", "runway")
"""Names accepted by :func:`render_scene`."""

TEXTURE_NAMES: tuple[str, ...] = ("gravel", "grass", "brick", "camera", "moon", "coins", "text")
"""scikit-image sample images usable as textures (all load from the installed package)."""

_REF_WIDTH = 512
_MAX_SUPERSAMPLE = 16
_SAMPLES_PER_CHUNK = 1 << 16


# --------------------------------------------------------------------------- public types


@dataclass(frozen=True)
class SceneObject:
    """A named object of a scene, one row of the report's range tables.

    Attributes
    ----------
    name
        Object name as in the report's tables, e.g. ``"Left pencil"``.
    nominal_range
        The report's "actual range": range along the camera-1 optical axis to the
        centre line of the object's camera-facing surface, in the scene's length unit.
    label
        Value of :attr:`Scene.labels1` at the pixels whose centre ray hits the object.
    """

    name: str
    nominal_range: float
    label: int


@dataclass(frozen=True, eq=False)
class Scene:
    """A rendered image pair with exact ground truth for camera / frame 1.

    Equality is identity (the fields are arrays). The arrays are read-only; copy them
    before modifying.

    Attributes
    ----------
    name
        ``"lab"``, ``"runway"`` or ``"plane"``.
    kind
        ``"stereo"`` (two cameras at one instant) or ``"motion"`` (one camera, two frames).
    unit
        Length unit of every length in the scene: ``"in"`` or ``"ft"``.
    camera
        Pinhole camera in pixel units, shared by both views.
    motion
        Camera-vehicle state at view 1 and its increment to view 2 (the INS data);
        for stereo pairs :meth:`MotionIncrement.stereo`.
    image1, image2
        ``(m, n)`` uint8 images ``E1`` and ``E2``.
    depth1
        ``(m, n)`` float64 range along the camera-1 optical axis (``x_c``) of the
        surface hit by the ray through each pixel centre; ``+inf`` where nothing is hit.
    labels1
        ``(m, n)`` int16 label of the object hit by that ray, 0 for unnamed surfaces.
    objects
        The named objects, labels ``1..K``.
    description
        One paragraph: geometry, texture sources and noise.
    seed
        Seed of the noise generator.
    """

    name: str
    kind: str
    unit: str
    camera: PinholeCamera
    motion: MotionIncrement
    image1: np.ndarray
    image2: np.ndarray
    depth1: np.ndarray
    labels1: np.ndarray
    objects: tuple[SceneObject, ...]
    description: str
    seed: int


# --------------------------------------------------------------------------- textures


@functools.cache
def _texture_pyramid(name: str) -> tuple[np.ndarray, ...]:
    """Zero-mean, unit-variance texture and its 2x2 box-filtered pyramid levels."""
    if name not in TEXTURE_NAMES:
        raise ValueError(f"unknown texture {name!r}; valid names: {', '.join(TEXTURE_NAMES)}")
    import skimage.data

    level = np.asarray(getattr(skimage.data, name)(), dtype=np.float64)
    level = (level - level.mean()) / level.std()
    levels = [level]
    while min(level.shape) >= 8:
        h, w = level.shape[0] // 2 * 2, level.shape[1] // 2 * 2
        level = 0.25 * (
            level[0:h:2, 0:w:2] + level[1:h:2, 0:w:2] + level[0:h:2, 1:w:2] + level[1:h:2, 1:w:2]
        )
        levels.append(level)
    for lev in levels:
        lev.setflags(write=False)
    return tuple(levels)


def _mirror(c: np.ndarray, n: int) -> np.ndarray:
    """Fold coordinates into ``[0, n-1]`` by mirrored repetition (no repeated edge)."""
    c = np.mod(c, 2 * (n - 1))
    c -= n - 1
    np.abs(c, out=c)
    return (n - 1) - c


def _bilinear(level: np.ndarray, s: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Bilinear sample of ``level`` at column ``s``, row ``t`` (pixel-centre units)."""
    h, w = level.shape
    x = _mirror(s, w)
    y = _mirror(t, h)
    i0 = np.minimum(x.astype(np.intp), w - 2)
    j0 = np.minimum(y.astype(np.intp), h - 2)
    fx = x - i0
    fy = y - j0
    flat = level.ravel()
    idx = j0 * w + i0
    top = flat[idx] * (1.0 - fx) + flat[idx + 1] * fx
    bottom = flat[idx + w] * (1.0 - fx) + flat[idx + w + 1] * fx
    return top * (1.0 - fy) + bottom * fy


@dataclass(frozen=True)
class _Layer:
    """Grey level ``mean + contrast * texture(scale * (u, v) + offset)``.

    ``scale`` is texture pixels per scene length unit; ``offset`` in texture pixels.
    """

    texture: str
    scale: float
    mean: float
    contrast: float
    offset: tuple[float, float] = (0.0, 0.0)

    def sample(self, u: np.ndarray, v: np.ndarray, footprint: np.ndarray) -> np.ndarray:
        """Trilinear (mip-mapped) sample; ``footprint`` is the sample spacing in scene units."""
        if self.contrast == 0.0:
            return np.full(u.shape, float(self.mean))
        pyramid = _texture_pyramid(self.texture)
        s = u * self.scale + self.offset[0]
        t = v * self.scale + self.offset[1]
        lod = np.log2(np.maximum(footprint * self.scale, 1.0))
        np.minimum(lod, len(pyramid) - 1, out=lod)
        k0 = lod.astype(np.intp)
        frac = lod - k0
        out = np.empty(u.shape)
        for k in range(int(k0.min(initial=0)), int(k0.max(initial=0)) + 1):
            sel = k0 == k
            if not sel.any():
                continue
            whole = bool(sel.all())
            ss, tt, fr = (s, t, frac) if whole else (s[sel], t[sel], frac[sel])
            val = self._level(pyramid, k, ss, tt)
            if k + 1 < len(pyramid):
                nz = fr > 0
                if nz.any():
                    val[nz] += fr[nz] * (self._level(pyramid, k + 1, ss[nz], tt[nz]) - val[nz])
            if whole:
                out = val
            else:
                out[sel] = val
        return self.mean + self.contrast * out

    @staticmethod
    def _level(pyramid: tuple[np.ndarray, ...], k: int, s: np.ndarray, t: np.ndarray) -> np.ndarray:
        scale = 0.5**k
        return _bilinear(pyramid[k], (s + 0.5) * scale - 0.5, (t + 0.5) * scale - 0.5)


@dataclass(frozen=True)
class _Overlay:
    """A layer painted on part of a surface: ``u0 <= u' < u1``, ``v0 <= v < v1``.

    ``u' = u mod period`` when ``period`` is given (dashed markings). ``label`` None
    keeps the surface's label.
    """

    layer: _Layer
    u_range: tuple[float, float]
    v_range: tuple[float, float]
    period: float | None = None
    label: int | None = None

    def covers(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        uu = np.mod(u, self.period) if self.period is not None else u
        return (
            (uu >= self.u_range[0])
            & (uu < self.u_range[1])
            & (v >= self.v_range[0])
            & (v < self.v_range[1])
        )


@dataclass(frozen=True)
class _Material:
    """Surface appearance: a base layer, overlays, a label and Lambert shading.

    The shading factor is ``ambient + (1 - ambient) * max(0, n . L)`` with the normal
    turned towards the viewer; it depends on the surface point only, not on the view.
    """

    layer: _Layer
    label: int = 0
    ambient: float = 1.0
    overlays: tuple[_Overlay, ...] = ()

    def shade(
        self,
        u: np.ndarray,
        v: np.ndarray,
        footprint: np.ndarray,
        cos_light: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        which = np.full(u.shape, -1, dtype=np.intp)
        for k, ov in enumerate(self.overlays):
            which[ov.covers(u, v)] = k
        values = np.empty(u.shape)
        labels = np.full(u.shape, self.label, dtype=np.int16)
        layers = [self.layer, *(ov.layer for ov in self.overlays)]
        for k, layer in enumerate(layers, start=-1):
            sel = which == k
            if not np.any(sel):
                continue
            values[sel] = layer.sample(u[sel], v[sel], footprint[sel])
            if k >= 0 and self.overlays[k].label is not None:
                labels[sel] = self.overlays[k].label
        if self.ambient != 1.0:
            values *= self.ambient + (1.0 - self.ambient) * np.maximum(cos_light, 0.0)
        return values, labels

    def labels(self) -> set[int]:
        found = {self.label}
        found.update(ov.label for ov in self.overlays if ov.label is not None)
        return found


# --------------------------------------------------------------------------- primitives


def _unit(v: Sequence[float] | np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def _dot(a: np.ndarray, dx: np.ndarray, dy: np.ndarray, dz: np.ndarray) -> np.ndarray:
    return a[0] * dx + a[1] * dy + a[2] * dz


class _Rect:
    """Planar rectangle ``origin + u e_u + v e_v``, ``u`` in ``u_range``, ``v`` in ``v_range``.

    Ranges may be infinite (an unbounded plane). Two-sided. Texture coordinates are
    ``(u, v)`` in scene units.
    """

    def __init__(
        self,
        origin: Sequence[float],
        e_u: Sequence[float],
        e_v: Sequence[float],
        u_range: tuple[float, float],
        v_range: tuple[float, float],
        material: _Material,
    ) -> None:
        self.origin = np.asarray(origin, dtype=np.float64)
        self.e_u = _unit(e_u)
        self.e_v = _unit(e_v)
        if abs(self.e_u @ self.e_v) > 1e-12:
            raise ValueError("rectangle axes must be orthogonal")
        self.normal = np.cross(self.e_u, self.e_v)
        self.u_range = (float(u_range[0]), float(u_range[1]))
        self.v_range = (float(v_range[0]), float(v_range[1]))
        self.materials = (material,)

    def corners(self) -> np.ndarray | None:
        if not np.all(np.isfinite(self.u_range + self.v_range)):
            return None
        return np.array(
            [self.origin + u * self.e_u + v * self.e_v for u in self.u_range for v in self.v_range]
        )

    def intersect(
        self, c: np.ndarray, dx: np.ndarray, dy: np.ndarray, dz: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray | None]:
        w = self.origin - c
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (self.normal @ w) / _dot(self.normal, dx, dy, dz)
            u = t * _dot(self.e_u, dx, dy, dz) - self.e_u @ w
            v = t * _dot(self.e_v, dx, dy, dz) - self.e_v @ w
            hit = (
                (t > 0)
                & (t < np.inf)
                & (u >= self.u_range[0])
                & (u <= self.u_range[1])
                & (v >= self.v_range[0])
                & (v <= self.v_range[1])
            )
        return np.where(hit, t, np.inf), None

    def surface(
        self, c: np.ndarray, d: np.ndarray, t: np.ndarray, part: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        q = c[:, None] + t * d - self.origin[:, None]
        normal = np.broadcast_to(self.normal[:, None], d.shape)
        return self.e_u @ q, self.e_v @ q, normal, np.zeros(t.shape, dtype=np.intp)

    def distance(self, p: np.ndarray) -> np.ndarray:
        """Euclidean distance from points ``p`` (shape (N, 3)) to the rectangle."""
        q = p - self.origin
        u = np.clip(q @ self.e_u, *self.u_range)
        v = np.clip(q @ self.e_v, *self.v_range)
        return np.linalg.norm(q - u[:, None] * self.e_u - v[:, None] * self.e_v, axis=1)


class _Cylinder:
    """Finite circular cylinder: axis from ``base`` along ``axis`` for ``length``.

    Parts: 0 the side, 1 the disc at ``base``, 2 the disc at the far end (each disc only
    if its flag in ``caps`` is set). Side texture coordinates are the arc length
    ``r * angle`` (angle 0 on the generator facing ``facing``, seam opposite) and the
    height along the axis; disc coordinates are the components along ``e1``, ``e2``.
    """

    def __init__(
        self,
        base: Sequence[float],
        axis: Sequence[float],
        radius: float,
        length: float,
        side: _Material,
        cap: _Material | None = None,
        *,
        caps: tuple[bool, bool] = (False, True),
        facing: Sequence[float] = (0.0, 0.0, 0.0),
    ) -> None:
        self.base = np.asarray(base, dtype=np.float64)
        self.axis = _unit(axis)
        self.radius = float(radius)
        self.length = float(length)
        self.caps = caps
        toward = np.asarray(facing, dtype=np.float64) - self.base
        toward = toward - (toward @ self.axis) * self.axis
        if np.linalg.norm(toward) < 1e-9:
            toward = np.cross(self.axis, [1.0, 0.0, 0.0])
            if np.linalg.norm(toward) < 1e-9:
                toward = np.cross(self.axis, [0.0, 1.0, 0.0])
        self.e1 = _unit(toward)
        self.e2 = np.cross(self.axis, self.e1)
        self.materials = (side, cap if cap is not None else side)

    def corners(self) -> np.ndarray:
        r = self.radius
        return np.array(
            [
                self.base + h * self.axis + s1 * r * self.e1 + s2 * r * self.e2
                for h in (0.0, self.length)
                for s1 in (-1.0, 1.0)
                for s2 in (-1.0, 1.0)
            ]
        )

    def intersect(
        self, c: np.ndarray, dx: np.ndarray, dy: np.ndarray, dz: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        a = self.axis
        w = c - self.base
        wa = w @ a
        wp = w - wa * a
        da = _dot(a, dx, dy, dz)
        px, py, pz = dx - da * a[0], dy - da * a[1], dz - da * a[2]
        qa = px * px + py * py + pz * pz
        qb = 2.0 * _dot(wp, px, py, pz)
        qc = wp @ wp - self.radius**2
        disc = qb * qb - 4.0 * qa * qc
        with np.errstate(divide="ignore", invalid="ignore"):
            q = -0.5 * (qb + np.copysign(np.sqrt(np.maximum(disc, 0.0)), qb))
            t = np.full(dx.shape, np.inf)
            for root in (q / qa, qc / q):
                h = wa + root * da
                ok = (disc >= 0) & (root > 0) & (h >= 0) & (h <= self.length) & (root < t)
                t = np.where(ok, root, t)
            part = np.zeros(dx.shape, dtype=np.int8)
            for index, h_cap in ((1, 0.0), (2, self.length)):
                if not self.caps[index - 1]:
                    continue
                tc = (h_cap - wa) / da
                rx, ry, rz = wp[0] + tc * px, wp[1] + tc * py, wp[2] + tc * pz
                ok = (tc > 0) & (rx * rx + ry * ry + rz * rz <= self.radius**2) & (tc < t)
                t = np.where(ok, tc, t)
                part = np.where(ok, np.int8(index), part)
        return t, part

    def surface(
        self, c: np.ndarray, d: np.ndarray, t: np.ndarray, part: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        q = c[:, None] + t * d - self.base[:, None]
        h = self.axis @ q
        radial = q - self.axis[:, None] * h
        c1 = self.e1 @ radial
        c2 = self.e2 @ radial
        on_side = part == 0
        u = np.where(on_side, self.radius * np.arctan2(c2, c1), c1)
        v = np.where(on_side, h, c2)
        sign = np.where(part == 1, -1.0, 1.0)
        normal = np.where(on_side, radial / self.radius, sign * self.axis[:, None])
        return u, v, normal, np.where(on_side, 0, 1)

    def distance(self, p: np.ndarray) -> np.ndarray:
        """Distance from points ``p`` (shape (N, 3)) to the boundary of the closed solid."""
        q = p - self.base
        h = q @ self.axis
        rad = np.linalg.norm(q - h[:, None] * self.axis, axis=1)
        inside = (rad <= self.radius) & (h >= 0) & (h <= self.length)
        dr = np.maximum(rad - self.radius, 0.0)
        dh = np.maximum(np.maximum(-h, h - self.length), 0.0)
        d_in = np.minimum(np.minimum(self.radius - rad, h), self.length - h)
        return np.where(inside, d_in, np.hypot(dr, dh))


_Primitive = _Rect | _Cylinder


def _box(
    corner: Sequence[float],
    axes: tuple[Sequence[float], Sequence[float], Sequence[float]],
    size: tuple[float, float, float],
    material: _Material,
    *,
    skip: tuple[tuple[int, int], ...] = (),
) -> list[_Rect]:
    """Faces of the box ``corner + sum(s_i e_i)``, ``0 <= s_i <= size_i``.

    Face ``(i, side)`` lies at ``s_i = side * size_i``; faces listed in ``skip`` (e.g. a
    bottom resting on the ground) are left out.
    """
    corner = np.asarray(corner, dtype=np.float64)
    e = [_unit(a) for a in axes]
    faces = []
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        for side in (0, 1):
            if (i, side) in skip:
                continue
            origin = corner + side * size[i] * e[i]
            faces.append(_Rect(origin, e[j], e[k], (0.0, size[j]), (0.0, size[k]), material))
    return faces


@dataclass(frozen=True)
class _World:
    primitives: tuple[_Primitive, ...]
    sky: Callable[[np.ndarray], np.ndarray]
    light: np.ndarray


# --------------------------------------------------------------------------- ray casting


def _view(motion: MotionIncrement, frame: int) -> tuple[np.ndarray, np.ndarray]:
    """Camera centre and camera-to-inertial rotation ``T2^T T1^T`` of view ``frame``."""
    t2 = motion.T2 if frame == 1 else motion.T2 + motion.dT2
    xv = motion.xv if frame == 1 else motion.xv + motion.dxv
    return xv + t2.T @ motion.l, t2.T @ motion.T1.T


def _window(
    prim: _Primitive,
    camera: PinholeCamera,
    motion: MotionIncrement,
    frame: int,
    ss: int,
) -> tuple[int, int, int, int]:
    """Rows ``[r0, r1)`` and columns ``[c0, c1)`` of the sample grid that may hit ``prim``.

    The image of a convex set in front of a pinhole camera is the convex hull of the
    images of its corners, so the corners' bounding box (plus a sample of margin) bounds
    the primitive; a primitive reaching behind the camera gets the whole grid.
    """
    rows, cols = camera.height * ss, camera.width * ss
    corners = prim.corners()
    if corners is None:
        return 0, rows, 0, cols
    xc = camera_from_inertial(motion, corners, frame=frame)
    if np.any(xc[:, 0] <= 1e-9 * np.abs(xc).max()):
        return 0, rows, 0, cols
    cx, cy = camera.principal_point
    f = camera.f_px
    col = (f * xc[:, 1] / xc[:, 0] + cx + 0.5) * ss - 0.5
    row = (f * xc[:, 2] / xc[:, 0] + cy + 0.5) * ss - 0.5
    c0 = int(np.clip(np.floor(col.min()) - 1, 0, cols))
    c1 = int(np.clip(np.ceil(col.max()) + 2, 0, cols))
    r0 = int(np.clip(np.floor(row.min()) - 1, 0, rows))
    r1 = int(np.clip(np.ceil(row.max()) + 2, 0, rows))
    return r0, r1, c0, c1


def _trace(
    world: _World,
    camera: PinholeCamera,
    motion: MotionIncrement,
    frame: int,
    ss: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cast ``ss x ss`` rays per pixel of view ``frame``.

    Returns
    -------
    image : ndarray, shape (m, n)
        Mean grey level of the sub-pixel samples (before noise and quantisation).
    t, labels : ndarray, shape (m*ss, n*ss)
        Ray parameter of the first hit (``x_c`` of that view; ``inf`` for no hit) and
        the label hit, per sample.
    """
    m, n = camera.height, camera.width
    f = camera.f_px
    cx, cy = camera.principal_point
    centre, rot = _view(motion, frame)
    a = ((np.arange(n * ss) + 0.5) / ss - 0.5 - cx) / f
    b = ((np.arange(m * ss) + 0.5) / ss - 0.5 - cy) / f
    prims = world.primitives
    windows = [_window(p, camera, motion, frame, ss) for p in prims]
    image = np.empty((m, n))
    t_all = np.empty((m * ss, n * ss))
    lab_all = np.zeros((m * ss, n * ss), dtype=np.int16)
    chunk = max(1, _SAMPLES_PER_CHUNK // (n * ss * ss))

    def directions(rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, ...]:
        return tuple(rot[k, 0] + rot[k, 1] * a[cols] + rot[k, 2] * b[rows] for k in range(3))

    for p0 in range(0, m, chunk):
        p1 = min(m, p0 + chunk)
        g0, g1 = p0 * ss, p1 * ss
        t_best = t_all[g0:g1]
        t_best.fill(np.inf)
        pid = np.full(t_best.shape, -1, dtype=np.int16)
        part = np.zeros(t_best.shape, dtype=np.int8)
        for k, (prim, (r0, r1, c0, c1)) in enumerate(zip(prims, windows, strict=True)):
            r0, r1 = max(r0, g0), min(r1, g1)
            if r0 >= r1 or c0 >= c1:
                continue
            rows = np.arange(r0, r1)[:, None]
            cols = np.arange(c0, c1)[None, :]
            t, pt = prim.intersect(centre, *directions(rows, cols))
            win = (slice(r0 - g0, r1 - g0), slice(c0, c1))
            closer = t < t_best[win]
            t_best[win][closer] = t[closer]
            pid[win][closer] = k
            if pt is not None:
                part[win][closer] = pt[closer]
        values = np.empty(t_best.shape)
        labels = lab_all[g0:g1]
        flat_id = pid.ravel()
        order = np.argsort(flat_id, kind="stable")
        bounds = np.searchsorted(flat_id[order], np.arange(-1, len(prims) + 1))
        for k in range(-1, len(prims)):
            idx = order[bounds[k + 1] : bounds[k + 2]]
            if idx.size == 0:
                continue
            rows, cols = np.divmod(idx, t_best.shape[1])
            d = np.stack(directions(rows + g0, cols))
            if k < 0:
                values.ravel()[idx] = world.sky(d)
                continue
            prim = prims[k]
            t = t_best.ravel()[idx]
            u, v, normal, mat = prim.surface(centre, d, t, part.ravel()[idx])
            nd = np.einsum("ij,ij->j", normal, d)
            cos_view = np.abs(nd) / np.linalg.norm(d, axis=0)
            cos_light = -np.sign(nd) * (world.light @ normal)
            footprint = t / (f * ss * np.maximum(cos_view, 1e-3))
            for mi, material in enumerate(prim.materials):
                sel = mat == mi
                if not np.any(sel):
                    continue
                val, lab = material.shade(u[sel], v[sel], footprint[sel], cos_light[sel])
                values.ravel()[idx[sel]] = val
                labels.ravel()[idx[sel]] = lab
        image[p0:p1] = values.reshape(p1 - p0, ss, n, ss).mean(axis=(1, 3))
    return image, t_all, lab_all


# --------------------------------------------------------------------------- validation


def _check_size(size: object) -> tuple[int, int]:
    if (
        not isinstance(size, Sequence)
        or len(size) != 2
        or not all(isinstance(s, (int, np.integer)) and not isinstance(s, bool) for s in size)
        or min(size) < 8
    ):
        raise ValueError(f"size must be (height, width), two integers >= 8, not {size!r}")
    return int(size[0]), int(size[1])


def _check_noise(noise_sigma: object) -> float:
    if (
        isinstance(noise_sigma, bool)
        or not isinstance(noise_sigma, (int, float, np.integer, np.floating))
        or not math.isfinite(noise_sigma)
        or noise_sigma < 0
    ):
        raise ValueError(
            f"noise_sigma must be a finite number >= 0 grey levels, not {noise_sigma!r}"
        )
    return float(noise_sigma)


def _check_supersample(supersample: object) -> int:
    if (
        isinstance(supersample, bool)
        or not isinstance(supersample, (int, np.integer))
        or not 1 <= supersample <= _MAX_SUPERSAMPLE
    ):
        raise ValueError(
            f"supersample must be an integer in 1..{_MAX_SUPERSAMPLE}, not {supersample!r}"
        )
    return int(supersample)


def _check_seed(seed: object) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, not {seed!r}")
    return int(seed)


# --------------------------------------------------------------------------- rendering


@dataclass(frozen=True)
class _Preset:
    name: str
    kind: str
    unit: str
    hfov_deg: float
    motion: MotionIncrement
    world: _World
    objects: tuple[SceneObject, ...]
    description: str
    size: tuple[int, int] = (512, 512)
    noise_sigma: float = 0.5
    supersample: int = 4


_T = TypeVar("_T")


def _result_interruptibly(future: Future[_T]) -> _T:
    """``future.result()``, waited for in short slices: an untimed wait on a lock in the
    main thread missed a SIGINT that arrived on the way into it (or on another thread),
    and ``rangefx demo`` then ignored Ctrl-C until the render was done (> 60 s seen under
    load; a stack dump showed the main thread in ``Future.result``)."""
    while True:
        try:
            return future.result(timeout=0.1)
        except TimeoutError:
            continue


def _render(
    preset: _Preset,
    camera: PinholeCamera,
    seed: int,
    noise_sigma: float,
    supersample: int,
) -> Scene:
    for prim in preset.world.primitives:
        for material in prim.materials:
            for layer in (material.layer, *(ov.layer for ov in material.overlays)):
                if layer.contrast != 0.0:
                    _texture_pyramid(layer.texture)
    jobs = ((1, supersample), (2, supersample), (1, 1))
    workers = max(1, min(len(jobs), os.cpu_count() or 1))
    pool = ThreadPoolExecutor(max_workers=workers)
    try:
        futures = [
            pool.submit(_trace, preset.world, camera, preset.motion, frame, ss)
            for frame, ss in jobs
        ]
        (clean1, _, _), (clean2, _, _), (_, depth, labels) = (
            _result_interruptibly(fut) for fut in futures
        )
    except BaseException:
        # interrupted (Ctrl-C, kill): the traces are pure Python, seconds each; joining
        # them held the interrupt 2-9 s (a pool's ``with`` waits), so they are left to
        # finish on their own and the caller's cleanup runs now
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()
    rng = np.random.default_rng(seed)
    noise1 = rng.standard_normal(clean1.shape)
    noise2 = rng.standard_normal(clean2.shape)

    def quantise(clean: np.ndarray, noise: np.ndarray) -> np.ndarray:
        return np.clip(np.rint(clean + noise_sigma * noise), 0, 255).astype(np.uint8)

    arrays = (quantise(clean1, noise1), quantise(clean2, noise2), depth, labels)
    for arr in arrays:
        arr.setflags(write=False)
    return Scene(
        name=preset.name,
        kind=preset.kind,
        unit=preset.unit,
        camera=camera,
        motion=preset.motion,
        image1=arrays[0],
        image2=arrays[1],
        depth1=arrays[2],
        labels1=arrays[3],
        objects=preset.objects,
        description=preset.description.format(
            noise=noise_sigma, ss=supersample, height=camera.height, width=camera.width
        ),
        seed=seed,
    )


def render_scene(
    name: str,
    *,
    seed: int = 0,
    size: tuple[int, int] | None = None,
    noise_sigma: float | None = None,
    supersample: int | None = None,
) -> Scene:
    """Render a preset scene of the report.

    Parameters
    ----------
    name
        One of :data:`SCENE_NAMES`: ``"lab"`` (the laboratory stereo pair of the SPIE
        and stereo papers, inches) or ``"runway"`` (the helicopter flight pair of the
        obstacle-location paper, feet).
    seed
        Seed of ``numpy.random.default_rng`` for the sensor noise. The scene and the
        noise-free images do not depend on it.
    size
        ``(height, width)`` in pixels; default ``(512, 512)`` as in the report. The
        horizontal field of view is kept, so the focal length in pixels scales with
        the width (small sizes make fast tests).
    noise_sigma
        Standard deviation of the additive Gaussian noise in grey levels, applied
        before rounding to uint8; default 0.5.
    supersample
        Sub-pixel samples per pixel side (box integration over the pixel); default 4.

    Returns
    -------
    Scene
        Images, exact camera-1 depth and labels.

    Raises
    ------
    ValueError
        For an unknown name or an invalid argument; the message quotes the bad value.

    Examples
    --------
    >>> scene = render_scene("lab", size=(64, 64))
    >>> scene.image1.shape, scene.image1.dtype, scene.unit
    ((64, 64), dtype('uint8'), 'in')
    >>> [o.name for o in scene.objects][:2]
    ['Left pencil', 'Right pencil']
    """
    builders = {"lab": _lab_preset, "runway": _runway_preset}
    if name not in builders:
        raise ValueError(f"unknown scene name {name!r}; valid names: {', '.join(SCENE_NAMES)}")
    seed = _check_seed(seed)
    preset = builders[name]()
    height, width = preset.size if size is None else _check_size(size)
    sigma = preset.noise_sigma if noise_sigma is None else _check_noise(noise_sigma)
    ss = preset.supersample if supersample is None else _check_supersample(supersample)
    camera = PinholeCamera.from_fov(width, height, preset.hfov_deg)
    return _render(preset, camera, seed, sigma, ss)


#: Baseline of :func:`render_runway_stereo` (ft): its disparity at the nearest ground
#: in view (24.1 ft along the optical axis, the bottom image corners) is 59 px at
#: 512 px width (f = 812 px), within P3's 64 px search range there; the vehicles
#: (233-607 ft) have 6.1-2.3 px.
RUNWAY_STEREO_BASELINE_FT: float = 1.75


def render_runway_stereo(
    baseline: float = RUNWAY_STEREO_BASELINE_FT,
    *,
    seed: int = 0,
    size: tuple[int, int] | None = None,
    noise_sigma: float | None = None,
    supersample: int | None = None,
) -> Scene:
    """The ``runway`` scene as a stereo pair: view 1 of :func:`render_scene` ``("runway")``
    (the same camera, world, objects, ``depth1`` and ``labels1``) and a second camera
    ``baseline`` ft to its right (``+y_c``) at the same instant and attitude.

    Why: a stereo-only pipeline (P3) ranges the runway from it. The motion pair's
    translation is along the line of sight to the runway ahead, whose image points lie
    near the focus of expansion where motion ranging has no parallax; a lateral
    baseline gives every pixel a disparity ``f B / x_c``. The scene keeps the name
    ``"runway"`` (its ranging preset, frame map and vehicles are the motion pair's) and
    has ``kind == "stereo"``. Parameters as in :func:`render_scene`.
    """
    if (
        isinstance(baseline, bool)
        or not isinstance(baseline, (int, float, np.integer, np.floating))
        or not (math.isfinite(baseline) and baseline > 0)
    ):
        raise ValueError(f"stereo baseline must be a positive finite length, not {baseline!r}")
    seed = _check_seed(seed)
    preset = _runway_preset(float(baseline))
    height, width = preset.size if size is None else _check_size(size)
    sigma = preset.noise_sigma if noise_sigma is None else _check_noise(noise_sigma)
    ss = preset.supersample if supersample is None else _check_supersample(supersample)
    camera = PinholeCamera.from_fov(width, height, preset.hfov_deg)
    return _render(preset, camera, seed, sigma, ss)


def object_corners(name: str) -> dict[str, np.ndarray]:
    """True geometry of a preset's named objects: the corners of their planar faces.

    For the ``runway`` vehicles (boxes on the ground, the bottom face left out) these are
    the box's 8 corners, in the scene's NED frame and length unit. Objects made of
    curved surfaces only (the lab pencils) have no entry. Scoring obstacle extraction
    against the scene uses this (``rangefx.guidance.extraction``).

    Raises
    ------
    ValueError
        For an unknown scene name.
    """
    builders = {"lab": _lab_preset, "runway": _runway_preset}
    if name not in builders:
        raise ValueError(f"unknown scene name {name!r}; valid names: {', '.join(SCENE_NAMES)}")
    preset = builders[name]()
    by_label: dict[int, list[np.ndarray]] = {}
    for prim in preset.world.primitives:
        if not isinstance(prim, _Rect):
            continue
        corners = prim.corners()
        if corners is not None:
            by_label.setdefault(prim.materials[0].label, []).append(corners)
    out = {}
    for obj in preset.objects:
        if obj.label in by_label:
            pts = np.concatenate(by_label[obj.label])
            out[obj.name] = np.unique(np.round(pts, 9), axis=0)
    return out


def render_plane(
    *,
    depth: float,
    size: tuple[int, int] = (64, 64),
    f_px: float | None = None,
    baseline: float = 0.1,
    seed: int = 0,
    noise_sigma: float = 0.5,
    supersample: int = 4,
    texture: str = "gravel",
    texture_scale: float = 1.0,
    mean: float = 128.0,
    contrast: float = 40.0,
    unit: str = "in",
) -> Scene:
    """Stereo pair of a fronto-parallel textured plane at constant depth (for tests).

    The plane ``x = depth`` fills the view of camera 1 (at the origin, looking along
    ``+x``); camera 2 sits ``baseline`` to the right (:meth:`MotionIncrement.stereo`), so
    the disparity is ``f_px * baseline / depth`` pixels everywhere: image 2 at column
    ``i - disparity`` shows what image 1 shows at column ``i``.

    Parameters
    ----------
    depth
        Range of the plane along the optical axis (positive).
    size
        ``(height, width)`` in pixels.
    f_px
        Focal length in pixels; default that of a 45° horizontal field of view.
    baseline
        Stereo baseline (non-zero, scene units; negative puts camera 2 on the left).
    seed, noise_sigma, supersample
        As in :func:`render_scene`.
    texture
        Name of a scikit-image sample image (:data:`TEXTURE_NAMES`).
    texture_scale
        Texture pixels per image pixel on the plane (smaller magnifies the texture).
    mean, contrast
        Grey level is ``mean + contrast * t`` with ``t`` the zero-mean, unit-variance
        texture.
    unit
        Length unit recorded in the scene.

    Returns
    -------
    Scene
        ``name="plane"``, one object ``"Plane"`` (label 1) covering every pixel.

    Examples
    --------
    >>> scene = render_plane(depth=20.0, size=(32, 32))
    >>> float(scene.depth1.min()), float(scene.depth1.max())
    (20.0, 20.0)
    """
    if (
        isinstance(depth, bool)
        or not isinstance(depth, (int, float, np.integer, np.floating))
        or not (math.isfinite(depth) and depth > 0)
    ):
        raise ValueError(f"depth must be a positive finite number, not {depth!r}")
    height, width = _check_size(size)
    sigma = _check_noise(noise_sigma)
    ss = _check_supersample(supersample)
    seed = _check_seed(seed)
    if texture not in TEXTURE_NAMES:
        raise ValueError(f"unknown texture {texture!r}; valid names: {', '.join(TEXTURE_NAMES)}")
    if not (math.isfinite(texture_scale) and texture_scale > 0):
        raise ValueError(f"texture_scale must be a positive finite number, not {texture_scale!r}")
    if f_px is None:
        camera = PinholeCamera.from_fov(width, height, 45.0)
    else:
        camera = PinholeCamera(width, height, float(f_px))
    motion = MotionIncrement.stereo(baseline)
    th, tw = _texture_pyramid(texture)[0].shape
    layer = _Layer(texture, texture_scale * camera.f_px / depth, mean, contrast, (tw / 2, th / 2))
    inf = math.inf
    plane = _Rect(
        (depth, 0.0, 0.0), (0, 1, 0), (0, 0, 1), (-inf, inf), (-inf, inf), _Material(layer, 1)
    )
    disparity = camera.f_px * baseline / depth
    preset = _Preset(
        name="plane",
        kind="stereo",
        unit=unit,
        hfov_deg=0.0,
        motion=motion,
        world=_World((plane,), lambda d: np.full(d.shape[1], 0.0), _unit([-1.0, 0.0, 0.0])),
        objects=(SceneObject("Plane", float(depth), 1),),
        description=(
            f"Fronto-parallel plane at {depth:g} {unit} filling a {{height}}x{{width}} view "
            f"(f = {camera.f_px:.4g} px), scikit-image '{texture}' texture at "
            f"{texture_scale:g} texture px per image px, grey {mean:g} ± {contrast:g}; "
            f"stereo baseline {baseline:g} {unit} to the right, disparity "
            f"{disparity:.4g} px; {{ss}}x{{ss}} supersampling, Gaussian noise "
            f"sigma = {{noise:g}} grey levels, 8-bit quantisation."
        ),
    )
    return _render(preset, camera, seed, sigma, ss)


def frame2_positions(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """Where the surface point seen at each camera-1 pixel centre appears in view 2.

    Points are rebuilt from :attr:`Scene.depth1` with eq 32 of the obstacle paper and
    eq 33, then projected with eqs 12 and 15 at frame 2. Pixels with infinite depth
    (sky) use the direction of the ray (a point at infinity).

    Parameters
    ----------
    scene
        A rendered scene.

    Returns
    -------
    i2, j2 : ndarray, shape (m, n)
        Column and row coordinates (pixel indices, fractional) in ``image2``; NaN where
        the point is behind camera 2.
    """
    cam, motion = scene.camera, scene.motion
    f = cam.f_px
    cx, cy = cam.principal_point
    xp, yp = cam.pixel_grid()
    finite = np.isfinite(scene.depth1)
    pts = inertial_from_camera(
        motion, camera_points_from_range(np.where(finite, scene.depth1, 1.0), xp, yp, f)
    )
    c2 = camera_from_inertial(motion, pts, frame=2)
    ray = np.stack([np.ones_like(xp), xp / f, yp / f], axis=-1)
    t2 = motion.T2 + motion.dT2
    rot = motion.T1 @ t2 @ motion.T2.T @ motion.T1.T
    c2 = np.where(finite[..., None], c2, ray @ rot.T)
    with np.errstate(divide="ignore", invalid="ignore"):
        front = c2[..., 0] > 0
        i2 = np.where(front, f * c2[..., 1] / c2[..., 0] + cx, np.nan)
        j2 = np.where(front, f * c2[..., 2] / c2[..., 0] + cy, np.nan)
    return i2, j2


# --------------------------------------------------------------------------- presets


def _ref_f(hfov_deg: float) -> float:
    """Focal length in pixels of the report's 512-pixel-wide camera."""
    return (_REF_WIDTH / 2) / math.tan(math.radians(hfov_deg) / 2)


def _cylinder_axis_x(nominal: float, y: float, radius: float) -> float:
    """Axis ``x`` of a vertical cylinder at lateral ``y`` whose point nearest the camera
    (at the origin) has ``x = nominal``."""
    x = nominal + radius
    for _ in range(60):
        x = nominal + radius * x / math.hypot(x, y)
    return x


def _lab_preset() -> _Preset:
    """Laboratory scene of the SPIE paper (§4, Table 1) and the stereo paper (Figs 3-5)."""
    hfov = 45.0
    f_ref = _ref_f(hfov)
    table_z = 5.0
    wall_x = 60.0
    up = (0.0, 0.0, -1.0)
    light = _unit([-1.0, -0.6, -0.8])

    def scale_at(depth: float, texels_per_px: float = 1.0) -> float:
        return texels_per_px * f_ref / depth

    tape = _Overlay(
        _Layer("gravel", scale_at(wall_x, 1.5), 200.0, 18.0, (101.0, 37.0)),
        u_range=(-6.0, 6.0),
        v_range=(-8.0, -7.0),
        label=3,
    )
    wall = _Rect(
        (wall_x, 0.0, 0.0),
        (0, 1, 0),
        (0, 0, 1),
        (-40.0, 40.0),
        (-40.0, table_z),
        _Material(_Layer("gravel", scale_at(wall_x, 2.0), 45.0, 6.0), 0, overlays=(tape,)),
    )
    table = _Rect(
        (10.0, 0.0, table_z),
        (1, 0, 0),
        (0, 1, 0),
        (0.0, wall_x - 10.0),
        (-30.0, 30.0),
        _Material(_Layer("grass", 30.0, 115.0, 22.0, (17.0, 230.0))),
    )
    r_pencil, h_pencil = 0.17, 7.0
    y_left, y_right = -3.0, 3.5
    x_left = _cylinder_axis_x(30.0, y_left, r_pencil)
    x_right = _cylinder_axis_x(26.0, y_right, r_pencil)

    def pencil(x: float, y: float, label: int, offset: tuple[float, float]) -> _Cylinder:
        body = _Material(_Layer("gravel", scale_at(28.0, 1.0), 180.0, 28.0, offset), label, 0.55)
        return _Cylinder((x, y, table_z), up, r_pencil, h_pencil, body, facing=(0, 0, 0))

    left = pencil(x_left, y_left, 1, (40.0, 300.0))
    right = pencil(x_right, y_right, 2, (260.0, 90.0))
    r_can, h_can, y_can = 1.3, 4.8, 0.3
    x_can = _cylinder_axis_x(28.5, y_can, r_can)
    can = _Cylinder(
        (x_can, y_can, table_z),
        up,
        r_can,
        h_can,
        _Material(
            _Layer("camera", 512 / (2 * math.pi * r_can), 150.0, 45.0, (256.0, 140.0)), 4, 0.5
        ),
        _Material(_Layer("moon", 40.0, 175.0, 12.0), 4, 0.5),
        facing=(0, 0, 0),
    )
    bw, bh, bt, y_bracket = 1.5, 2.5, 0.12, -6.5
    bracket = _box(
        (19.0, y_bracket - bw / 2, table_z),
        ((1, 0, 0), (0, 1, 0), up),
        (bt, bw, bh),
        _Material(_Layer("brick", scale_at(19.0, 1.0), 95.0, 32.0, (250.0, 10.0)), 5, 0.7),
        skip=((2, 0),),
    )
    wire_z = -1.5
    p_left = np.array([x_left, y_left, wire_z])
    p_right = np.array([x_right, y_right, wire_z])
    wire = _Cylinder(
        p_left,
        p_right - p_left,
        0.012,
        float(np.linalg.norm(p_right - p_left)),
        _Material(_Layer("gravel", 1.0, 215.0, 0.0), 0, 0.6),
        caps=(False, False),
        facing=(0, 0, 0),
    )
    world = _World(
        (wall, table, left, right, can, *bracket, wire),
        lambda d: np.full(d.shape[1], 40.0),
        light,
    )
    objects = (
        SceneObject("Left pencil", 30.0, 1),
        SceneObject("Right pencil", 26.0, 2),
        SceneObject("Tape-on-wall", 60.0, 3),
        SceneObject("Soda can", 28.5, 4),
        SceneObject("Bracket", 19.0, 5),
    )
    description = (
        "Laboratory stereo pair after the SPIE paper of ch. 4 (§4, Table 1) and the stereo "
        "paper of ch. 5 (Figs 3-5); lengths in inches. A {height}x{width} camera with a 45° "
        "horizontal field of view at the origin looks along +x (x forward, y right, z down); "
        "the second camera is 0.1 in to the right. A dark, faintly textured wall at x = 60 "
        "carries a bright 12 in x 1 in strip of tape (Tape-on-wall, 60 in); a table top "
        f"{table_z:g} in below the camera runs from 10 in to the wall. Standing on it: the "
        "left and right pencils (vertical cylinders 0.34 in across, 7 in tall, front "
        "surfaces at 30 and 26 in), a soda can (radius 1.3 in, 4.8 in tall, front at "
        "28.5 in) between them, and a 1.5 in x 2.5 in bracket plate facing the camera at "
        "19 in on the left; a 0.024 in wire is strung between the pencils 1.5 in above "
        "eye level. Textures are scikit-image's gravel (wall, tape, pencils), grass "
        "(table), camera (the can's label wrapped once round it), moon (can top) and brick "
        "(bracket), scaled to one to three texture pixels per image pixel; curved and boxed "
        "objects carry Lambert shading from a light up and to the left. {ss}x{ss} "
        "supersampling per pixel, Gaussian noise sigma = {noise:g} grey levels, 8-bit "
        "quantisation."
    )
    return _Preset(
        "lab", "stereo", "in", hfov, MotionIncrement.stereo(0.1), world, objects, description
    )


#: Runway vehicles: name, range along the camera-1 optical axis (ft) to the centre of the
#: camera-facing side, cross-track position of the vehicle centre (ft, + right),
#: texture, mean grey, contrast, texture pixels per image pixel at that range.
_VEHICLES: tuple[tuple[str, float, float, str, float, float, float], ...] = (
    ("Vehicle 1", 356.4, -78.0, "brick", 175.0, 35.0, 4.0),
    ("Vehicle 2", 607.0, 140.0, "gravel", 65.0, 25.0, 1.0),
    ("Vehicle 3", 232.8, -29.0, "camera", 150.0, 50.0, 6.0),
    ("Vehicle 4", 300.0, 30.0, "grass", 125.0, 30.0, 1.0),
    ("Vehicle 5", 470.0, 78.0, "coins", 185.0, 35.0, 5.0),
)


def _runway_preset(stereo_baseline: float | None = None) -> _Preset:
    """Flight pair of the obstacle-location paper of ch. 4 (Figs 3-5 and its table); with
    ``stereo_baseline`` (ft) the same view 1 and a second camera that far to its right
    at the same instant and attitude (:func:`render_runway_stereo`)."""
    hfov = 35.0
    f_ref = _ref_f(hfov)
    deg = math.pi / 180.0
    altitude = 11.0
    heading = math.atan2(-0.44, 5.41)
    attitude1 = (heading, -2.0 * deg, 0.5 * deg)
    increments = (-0.08 * deg, 0.059 * deg, 0.12 * deg)
    attitude2 = tuple(a + b for a, b in zip(attitude1, increments, strict=True))
    position1 = (0.0, 0.0, -altitude)

    def helicopter(attitude2: tuple[float, ...], position2: tuple[float, ...]) -> MotionIncrement:
        """From view 1 to a view at ``attitude2``, ``position2`` of the same camera
        mounting on the vehicle."""
        return MotionIncrement.from_attitudes(
            camera_angles=(0.0, -3.0 * deg, 0.0), camera_offset=(8.0, 0.0, 1.0),
            attitude1=attitude1, attitude2=attitude2, position1=position1, position2=position2,
        )  # fmt: skip

    motion = helicopter(attitude2, (5.41, -0.44, -altitude + 0.02))
    centre, rot = _view(motion, 1)
    axis = rot[:, 0]
    kind = "motion"
    if stereo_baseline is not None:
        # Camera 2 beside camera 1 along its right axis y_c (rot[:, 1] in NED), same
        # instant and attitude: the vehicle position moves by that vector.
        right = float(stereo_baseline) * rot[:, 1]
        motion = helicopter(
            attitude1, tuple(float(a + b) for a, b in zip(position1, right, strict=True))
        )
        kind = "stereo"
    e_u = np.array([math.cos(heading), math.sin(heading), 0.0])
    e_v = np.array([-math.sin(heading), math.cos(heading), 0.0])
    up = np.array([0.0, 0.0, -1.0])
    origin = np.array([centre[0], centre[1], 0.0])
    half_width = 17.0
    inf = math.inf
    paint = _Layer("gravel", 30.0, 215.0, 7.0, (300.0, 300.0))
    overlays = (
        _Overlay(_Layer("gravel", 30.0, 85.0, 20.0), (-inf, inf), (-half_width, half_width)),
        _Overlay(paint, (0.0, 120.0), (-0.75, 0.75), period=200.0),
        _Overlay(paint, (-inf, inf), (-half_width + 1.0, -half_width + 2.5)),
        _Overlay(paint, (-inf, inf), (half_width - 2.5, half_width - 1.0)),
    )
    ground = _Rect(
        origin,
        e_u,
        e_v,
        (-inf, inf),
        (-inf, inf),
        _Material(_Layer("grass", 30.0, 95.0, 22.0, (100.0, 0.0)), 0, overlays=overlays),
    )
    prims: list[_Primitive] = [ground]
    objects = []
    length, depth_, height = 20.0, 8.0, 8.0
    for label, (name, rng, d, tex, mean, contrast, texels) in enumerate(_VEHICLES, start=1):
        face_centre = origin + d * e_v + 0.5 * height * up
        s = (rng - axis @ (face_centre - centre)) / (axis @ e_u)
        corner = origin + s * e_u + (d - length / 2) * e_v
        scale = texels * f_ref / rng
        material = _Material(
            _Layer(tex, scale, mean, contrast, (37.0 * label, 61.0 * label)), label, 0.6
        )
        prims += _box(corner, (e_u, e_v, up), (depth_, length, height), material, skip=((2, 0),))
        objects.append(SceneObject(name, rng, label))

    def sky(d: np.ndarray) -> np.ndarray:
        elevation = np.arcsin(np.clip(-d[2] / np.linalg.norm(d, axis=0), -1.0, 1.0))
        return 190.0 + 40.0 * np.exp(-np.maximum(elevation, 0.0) / 0.2)

    world = _World(tuple(prims), sky, _unit([-0.4, -0.5, -1.0]))
    description = (
        "Helicopter flight pair after the obstacle-location paper of ch. 4 (Figs 3-5 and "
        "its range table); lengths in feet, NED inertial frame, ground plane z = 0. The "
        f"helicopter flies at {altitude:g} ft along a runway heading {heading / deg:.2f}° "
        "(the direction of its INS translation), pitched 2° nose down and rolled 0.5°; a "
        "{height}x{width} camera with a 35° horizontal field of view sits on the nose "
        "(l = [8, 0, 1] ft) depressed 3° (ε2 = -3°), so the horizon lies in the upper "
        "part of the image and the sky above it (infinite depth) is a smooth bright "
        "gradient. Between the two frames (0.17 s at 32.6 ft/s) the helicopter translates "
        "[5.41, -0.44, 0.02] ft and turns by -0.08° yaw, 0.059° pitch, 0.12° roll, as in "
        f"the report. The runway is {2 * half_width:g} ft of asphalt (scikit-image gravel) "
        "with painted edge lines and a dashed centre line, in grass (scikit-image grass). "
        "Five truck-sized boxes (20 ft long across the runway, 8 ft wide, 8 ft tall), "
        "textured with brick, gravel, camera, grass and coins, are parked beside it with "
        "their long sides facing the camera; Vehicles 1-5 stand at 356.4, 607.0, 232.8, "
        "300 and 470 ft (range along the optical axis to the centre of the facing side). "
        "Textures are mip-mapped, boxes carry Lambert shading from a high sun; {ss}x{ss} "
        "supersampling per pixel, Gaussian noise sigma = {noise:g} grey levels, 8-bit "
        "quantisation."
    )
    if stereo_baseline is not None:
        description += (
            f" Stereo variant: the same view 1 and a second camera {stereo_baseline:g} ft "
            "to its right (along y_c) at the same instant and attitude, instead of the "
            "second frame."
        )
    return _Preset("runway", kind, "ft", hfov, motion, world, tuple(objects), description)
