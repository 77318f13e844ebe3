"""Camera and frame geometry of the report, in pixel units (SPEC §2).

Two camera conventions appear in the report and both are kept:

* translation-only forms (ch. 3, SPIE paper of ch. 4): camera frame x right, y down,
  z forward (depth); ``xp = f x / z``, ``yp = f y / z``.
* rotation form (obstacle-location paper of ch. 4): camera frame ``x_c`` along the
  optical axis, ``y_c`` right, ``z_c`` down; ``xp / f = y_c / x_c`` and
  ``yp / f = z_c / x_c`` (its eqs 8-9). Body and inertial frames are NED with
  yaw-pitch-roll Euler angles (its eqs 10-15).

Image-plane coordinates are in pixels from the principal point: ``xp = i - cx``,
``yp = j - cy`` (x right, y down), and the focal length is in pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "MotionIncrement",
    "PinholeCamera",
    "camera_from_inertial",
    "inertial_from_camera",
    "k_coefficients",
    "k_matrix",
    "rotation_body_to_camera",
    "rotation_inertial_to_body",
]


@dataclass(frozen=True)
class PinholeCamera:
    """Pinhole camera in pixel units.

    Parameters
    ----------
    width, height
        Active image size in pixels (n columns, m rows).
    f_px
        Focal length in pixels (``f / pixel_pitch``).
    cx, cy
        Principal point in pixel indices; ``None`` puts it at the image centre
        ``((n - 1) / 2, (m - 1) / 2)``.
    """

    width: int
    height: int
    f_px: float
    cx: float | None = None
    cy: float | None = None

    def __post_init__(self) -> None:
        if int(self.width) != self.width or self.width < 2:
            raise ValueError(f"camera width must be an integer >= 2, not {self.width!r}")
        if int(self.height) != self.height or self.height < 2:
            raise ValueError(f"camera height must be an integer >= 2, not {self.height!r}")
        if not np.isfinite(self.f_px) or self.f_px <= 0:
            raise ValueError(
                f"focal length must be a positive finite number of pixels, not {self.f_px!r}"
            )

    @classmethod
    def from_fov(cls, width: int, height: int, hfov_deg: float) -> PinholeCamera:
        """Camera whose horizontal field of view across ``width`` pixels is ``hfov_deg``."""
        if not 0 < hfov_deg < 180:
            raise ValueError(
                f"horizontal field of view must be in (0, 180) degrees, not {hfov_deg!r}"
            )
        f_px = (width / 2) / np.tan(np.radians(hfov_deg) / 2)
        return cls(width, height, float(f_px))

    @property
    def principal_point(self) -> tuple[float, float]:
        cx = (self.width - 1) / 2 if self.cx is None else float(self.cx)
        cy = (self.height - 1) / 2 if self.cy is None else float(self.cy)
        return cx, cy

    def pixel_grid(self) -> tuple[np.ndarray, np.ndarray]:
        """Image-plane coordinates ``(xp, yp)`` of every pixel centre, shape (m, n)."""
        cx, cy = self.principal_point
        xp = np.arange(self.width, dtype=np.float64) - cx
        yp = np.arange(self.height, dtype=np.float64) - cy
        return np.broadcast_to(xp, (self.height, self.width)), np.broadcast_to(
            yp[:, None], (self.height, self.width)
        )


def _rot(a3: float, a2: float, a1: float) -> np.ndarray:
    """3-2-1 Euler rotation: about z by a3, then y by a2, then x by a1 (eqs 11 and 14)."""
    c3, s3 = np.cos(a3), np.sin(a3)
    c2, s2 = np.cos(a2), np.sin(a2)
    c1, s1 = np.cos(a1), np.sin(a1)
    return np.array(
        [
            [c2 * c3, c2 * s3, -s2],
            [s1 * s2 * c3 - c1 * s3, s1 * s2 * s3 + c1 * c3, s1 * c2],
            [c1 * s2 * c3 + s1 * s3, c1 * s2 * s3 - s1 * c3, c1 * c2],
        ]
    )


def rotation_body_to_camera(eps1: float, eps2: float, eps3: float) -> np.ndarray:
    """``T1`` of the obstacle-location paper, eq 11: ``x_c = T1 (x_b - l)`` (eq 12).

    The camera is oriented by ``eps1, eps2, eps3`` (radians) about its z, y and x axes.
    """
    return _rot(eps1, eps2, eps3)


def rotation_inertial_to_body(psi: float, theta: float, phi: float) -> np.ndarray:
    """``T2`` of the obstacle-location paper, eq 14: ``x_b = T2 (x - x_v)`` (eq 15).

    Yaw ``psi``, pitch ``theta``, roll ``phi`` in radians (standard flight-dynamics
    convention, NED inertial frame).
    """
    return _rot(psi, theta, phi)


@dataclass(frozen=True)
class MotionIncrement:
    """Camera-vehicle state at frame 1 and its change to frame 2 (the INS data).

    Attributes
    ----------
    T1
        Body-to-camera rotation (eq 11); the camera is fixed to the vehicle.
    l
        Camera position in the body frame (eq 10), in the scene's length unit.
    T2
        Inertial-to-body rotation at frame 1 (eq 14).
    dT2
        Change of ``T2`` from frame 1 to frame 2 (the ``ΔT2`` of eq 19).
    dxv
        Vehicle displacement in the inertial frame from frame 1 to frame 2.
    xv
        Vehicle position at frame 1 in the inertial frame.
    """

    T1: np.ndarray
    l: np.ndarray  # noqa: E741 - the report names the camera offset l (eq 10)
    T2: np.ndarray
    dT2: np.ndarray
    dxv: np.ndarray
    xv: np.ndarray

    @classmethod
    def from_attitudes(
        cls,
        *,
        camera_angles: tuple[float, float, float] = (0.0, 0.0, 0.0),
        camera_offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
        attitude1: tuple[float, float, float] = (0.0, 0.0, 0.0),
        attitude2: tuple[float, float, float] = (0.0, 0.0, 0.0),
        position1: tuple[float, float, float] = (0.0, 0.0, 0.0),
        position2: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> MotionIncrement:
        """Build the increment from two INS samples.

        ``camera_angles`` are ``(eps1, eps2, eps3)``; attitudes are ``(psi, theta, phi)``
        in radians; positions are the vehicle positions in the inertial (NED) frame.
        """
        T2a = rotation_inertial_to_body(*attitude1)
        T2b = rotation_inertial_to_body(*attitude2)
        xv1 = np.asarray(position1, dtype=np.float64)
        xv2 = np.asarray(position2, dtype=np.float64)
        return cls(
            T1=rotation_body_to_camera(*camera_angles),
            l=np.asarray(camera_offset, dtype=np.float64),
            T2=T2a,
            dT2=T2b - T2a,
            dxv=xv2 - xv1,
            xv=xv1,
        )

    @classmethod
    def stereo(cls, baseline: float) -> MotionIncrement:
        """Second camera displaced by ``baseline`` along the camera's ``y_c`` (right) axis."""
        if not np.isfinite(baseline) or baseline == 0:
            raise ValueError(f"stereo baseline must be a non-zero finite length, not {baseline!r}")
        return cls.from_attitudes(position2=(0.0, float(baseline), 0.0))

    @property
    def camera_displacement(self) -> np.ndarray:
        """Displacement of the camera centre from frame 1 to frame 2, in camera-1 axes."""
        # Camera centre in the inertial frame: x_v + T2^T l (from eq 21 with x_c = 0).
        c1 = self.xv + self.T2.T @ self.l
        T2b = self.T2 + self.dT2
        c2 = self.xv + self.dxv + T2b.T @ self.l
        return self.T1 @ self.T2 @ (c2 - c1)


def k_coefficients(motion: MotionIncrement, xp: np.ndarray, yp: np.ndarray, f_px: float):
    """The coefficients ``k0..k5`` of the obstacle paper's eqs 23-24.

    Eq 23 carries no number in the print (SPEC §9). From eq 22 divided by ``x_c``::

        [k0, k1, k2]^T = T1 ΔT2 T2^T T1^T [1, xp/f, yp/f]^T      (pixel-dependent)
        [k3, k4, k5]^T = T1 ΔT2 T2^T l - T1 (T2 + ΔT2) Δx_v       (constant per frame)

    so that ``Δx_c / x_c = k0 + k3 / x_c`` and likewise for ``y_c`` and ``z_c``. The
    relation is exact: ``T2 + ΔT2`` is the attitude at frame 2, nothing is linearised.

    Returns
    -------
    k012 : ndarray, shape (3, *xp.shape)
    k345 : ndarray, shape (3,)
    """
    M, k345 = k_matrix(motion)
    xp = np.asarray(xp, dtype=np.float64)
    yp = np.asarray(yp, dtype=np.float64)
    ray = np.stack([np.ones_like(xp), xp / f_px, yp / f_px])
    k012 = np.tensordot(M, ray, axes=1)
    return k012, k345


def k_matrix(motion: MotionIncrement) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame constants of eq 23 (SPEC §9): ``M = T1 ΔT2 T2^T T1^T`` and ``k3..k5``.

    ``[k0, k1, k2] = M [1, xp/f, yp/f]``; a hardware range stage holds ``M`` (scaled by
    ``1/f`` in its last two columns) and ``k3..k5`` in registers.
    """
    M = motion.T1 @ motion.dT2 @ motion.T2.T @ motion.T1.T
    k345 = (
        motion.T1 @ motion.dT2 @ motion.T2.T @ motion.l
        - motion.T1 @ (motion.T2 + motion.dT2) @ motion.dxv
    )
    return M, k345


def camera_from_inertial(motion: MotionIncrement, x: np.ndarray, frame: int = 1) -> np.ndarray:
    """Camera-frame coordinates of inertial points ``x`` (shape (..., 3)), eqs 12 and 15.

    ``frame`` 1 or 2 selects the vehicle state before or after the increment.
    """
    if frame not in (1, 2):
        raise ValueError(f"frame must be 1 or 2, not {frame!r}")
    T2 = motion.T2 if frame == 1 else motion.T2 + motion.dT2
    xv = motion.xv if frame == 1 else motion.xv + motion.dxv
    xb = (np.asarray(x, dtype=np.float64) - xv) @ T2.T
    return (xb - motion.l) @ motion.T1.T


def inertial_from_camera(motion: MotionIncrement, xc: np.ndarray) -> np.ndarray:
    """Inertial coordinates of camera-1 points ``xc`` (shape (..., 3)), eq 33.

    ``x = x_v + T2^T (T1^T x_c + l)``.
    """
    xc = np.asarray(xc, dtype=np.float64)
    return motion.xv + (xc @ motion.T1 + motion.l) @ motion.T2


def camera_points_from_range(
    x_c: np.ndarray, xp: np.ndarray, yp: np.ndarray, f_px: float
) -> np.ndarray:
    """Camera-frame points from the range along the optical axis, eq 32.

    ``y_c = x_c xp / f``, ``z_c = x_c yp / f``; returns shape (..., 3).
    """
    x_c = np.asarray(x_c, dtype=np.float64)
    return np.stack([x_c, x_c * xp / f_px, x_c * yp / f_px], axis=-1)
