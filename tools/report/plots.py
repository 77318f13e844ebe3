"""Figures of a ranging result, in the style of the report (Fig. 3 image pair, Fig. 4
3-D range points, Fig. 8 gray-coded range map, error histograms).

Figures are drawn on :class:`matplotlib.figure.Figure` objects with an Agg canvas, never
through :mod:`matplotlib.pyplot`, so no global figure or backend state is touched; every
PNG is written atomically (temporary file + :func:`os.replace`).
"""

from __future__ import annotations

import io
import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .checks import as_mask, as_real_2d, finite_where, positive_finite, same_shape
from .outdir import atomic_write_bytes

__all__ = [
    "new_figure",
    "range_points_3d",
    "range_to_gray",
    "save_error_histogram_png",
    "save_pair_png",
    "save_png",
    "save_points_3d_png",
    "save_range_map_png",
]

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def new_figure(figsize: tuple[float, float]) -> Figure:
    """A figure on its own Agg canvas (no pyplot state)."""
    # matplotlib is imported on first use: ~0.3 s of every command's start-up otherwise
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=100)
    FigureCanvasAgg(fig)
    return fig


def save_png(fig: Figure, path: str | os.PathLike[str]) -> None:
    """Write ``fig`` as a PNG atomically and release its artists."""
    buf = io.BytesIO()
    try:
        fig.savefig(buf, format="png")
    finally:
        fig.clear()
    atomic_write_bytes(path, buf.getvalue())


def range_to_gray(range_map: np.ndarray, valid: np.ndarray, range_max: float) -> np.ndarray:
    """Gray level of each pixel of a range map as in the report's Fig. 8.

    ``gray = 1 - range / range_max`` clipped to [0, 1]: near is bright (1 at range 0),
    far is dark (0 at ``range_max`` and beyond); invalid pixels are 0 (black).

    Parameters
    ----------
    range_map : ndarray, shape (m, n), real
        Range per pixel; must be finite where ``valid``.
    valid : ndarray, shape (m, n), bool
        Validity flag.
    range_max : float
        Range shown as black; positive and finite.

    Returns
    -------
    ndarray, shape (m, n), float64
    """
    r = as_real_2d(range_map, "range_map")
    v = as_mask(valid)
    same_shape(range_map=r, valid=v)
    finite_where(r, v, "range_map", "at valid pixels")
    rmax = positive_finite(range_max, "range_max")
    gray = np.zeros(r.shape, dtype=np.float64)
    gray[v] = np.clip(1.0 - r[v] / rmax, 0.0, 1.0)
    return gray


def save_range_map_png(
    path: str | os.PathLike[str],
    range_map: np.ndarray,
    valid: np.ndarray,
    range_max: float,
    title: str,
    *,
    unit: str = "",
) -> None:
    """Write a gray-coded range map like the report's Fig. 8 as a PNG.

    Gray levels from :func:`range_to_gray` (near bright, far dark, invalid black), with a
    colorbar labelled in range units from 0 (white) to ``range_max`` (black).

    Parameters
    ----------
    path
        Destination PNG file (written atomically).
    range_map, valid, range_max
        As :func:`range_to_gray`.
    title
        Figure title.
    unit
        Range unit for the colorbar label.
    """
    gray = range_to_gray(range_map, valid, range_max)
    m, n = gray.shape
    fig = new_figure((6.4, max(2.5, 5.2 * m / n)))
    ax = fig.add_subplot()
    ax.imshow(gray, cmap="gray", vmin=0.0, vmax=1.0, interpolation="nearest")
    ax.set_title(title)
    ax.set_xlabel("column (pixel)")
    ax.set_ylabel("row (pixel)")
    import matplotlib
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    mappable = ScalarMappable(
        norm=Normalize(0.0, float(range_max)), cmap=matplotlib.colormaps["gray_r"]
    )
    cbar = fig.colorbar(mappable, ax=ax)
    cbar.set_label(f"range ({unit})" if unit else "range")
    fig.tight_layout()
    save_png(fig, path)


def save_pair_png(
    path: str | os.PathLike[str],
    image1: np.ndarray,
    image2: np.ndarray,
    titles: Sequence[str] = ("image 1", "image 2"),
) -> None:
    """Write an image pair side by side, like the report's Fig. 3, as a PNG.

    Both images share one gray scale (minimum to maximum over the pair), so brightness
    differences between them are visible.

    Parameters
    ----------
    path
        Destination PNG file (written atomically).
    image1, image2 : ndarray, shape (m, n), real, finite
        The pair; equal shapes.
    titles
        Two titles, one per image.
    """
    a = as_real_2d(image1, "image1")
    b = as_real_2d(image2, "image2")
    same_shape(image1=a, image2=b)
    everywhere = np.ones(a.shape, dtype=bool)
    finite_where(a, everywhere, "image1", "everywhere")
    finite_where(b, everywhere, "image2", "everywhere")
    if isinstance(titles, str) or len(titles) != 2:
        raise ValueError(f"titles must be a sequence of two strings, not {titles!r}")
    lo = float(min(a.min(), b.min()))
    hi = float(max(a.max(), b.max()))
    if hi <= lo:
        hi = lo + 1.0
    m, n = a.shape
    fig = new_figure((10.0, max(2.5, 4.6 * m / n + 0.8)))
    for k, (img, title) in enumerate(zip((a, b), titles, strict=True)):
        ax = fig.add_subplot(1, 2, k + 1)
        ax.imshow(img, cmap="gray", vmin=lo, vmax=hi, interpolation="nearest")
        ax.set_title(str(title))
        ax.set_axis_off()
    fig.tight_layout()
    save_png(fig, path)


def _broadcast_coord(a: Any, shape: tuple[int, ...], name: str) -> np.ndarray:
    c = np.asarray(a, dtype=np.float64)
    try:
        return np.broadcast_to(c, shape)
    except ValueError:
        raise ValueError(
            f"{name} of shape {c.shape} does not broadcast to the range_map shape {shape}"
        ) from None


def range_points_3d(
    range_map: np.ndarray,
    valid: np.ndarray,
    xp: np.ndarray,
    yp: np.ndarray,
    f_px: float,
    max_points: int | None = None,
) -> np.ndarray:
    """The valid range points as 3-D coordinates (lateral, range, height).

    Each valid pixel, in row-major order, becomes ``(range * xp / f_px, range,
    -range * yp / f_px)`` (image ``yp`` grows downwards, so height is its negative). With
    more than ``max_points`` valid pixels, an evenly spaced deterministic subset (indices
    ``round(linspace(0, k - 1, max_points))``) is returned.

    Parameters
    ----------
    range_map, valid
        As :func:`range_to_gray`.
    xp, yp : array_like, broadcastable to (m, n)
        Image-plane coordinates of each pixel centre relative to the principal point, in
        pixels (e.g. ``PinholeCamera.pixel_grid()``); finite at valid pixels.
    f_px : float
        Focal length in pixels.
    max_points : int or None
        Largest number of points returned; ``None`` for all.

    Returns
    -------
    ndarray, shape (k, 3), float64
        Columns lateral, range, height.
    """
    r = as_real_2d(range_map, "range_map")
    v = as_mask(valid)
    same_shape(range_map=r, valid=v)
    finite_where(r, v, "range_map", "at valid pixels")
    x_pix = _broadcast_coord(xp, r.shape, "xp")
    y_pix = _broadcast_coord(yp, r.shape, "yp")
    finite_where(x_pix, v, "xp", "at valid pixels")
    finite_where(y_pix, v, "yp", "at valid pixels")
    f = positive_finite(f_px, "f_px")
    if max_points is not None and (
        isinstance(max_points, bool) or int(max_points) != max_points or max_points < 1
    ):
        raise ValueError(f"max_points must be a positive integer or None, not {max_points!r}")
    rng = r[v]
    points = np.stack([rng * x_pix[v] / f, rng, -rng * y_pix[v] / f], axis=-1)
    if max_points is not None and len(points) > max_points:
        keep = np.round(np.linspace(0, len(points) - 1, int(max_points))).astype(np.intp)
        points = points[keep]
    return points


def save_points_3d_png(
    path: str | os.PathLike[str],
    range_map: np.ndarray,
    valid: np.ndarray,
    xp: np.ndarray,
    yp: np.ndarray,
    f_px: float,
    title: str,
    max_points: int = 20000,
    *,
    unit: str = "",
) -> None:
    """Write a 3-D scatter of the valid range points, like the report's Fig. 4, as a PNG.

    The points are those of :func:`range_points_3d` (lateral, range, height), at most
    ``max_points`` of them, chosen deterministically; they are coloured by range.

    Parameters
    ----------
    path
        Destination PNG file (written atomically).
    range_map : ndarray, shape (m, n), real
        Range per pixel; must be finite where ``valid``.
    valid : ndarray, shape (m, n), bool
        Validity flag.
    xp, yp : array_like, broadcastable to (m, n)
        Image-plane pixel coordinates relative to the principal point.
    f_px : float
        Focal length in pixels.
    title
        Figure title.
    max_points : int
        Largest number of points drawn; a positive integer.
    unit
        Range unit for the axis labels.
    """
    if max_points is None:
        raise ValueError("max_points must be a positive integer, not None")
    points = range_points_3d(range_map, valid, xp, yp, f_px, max_points)
    lateral, rng, height = points.T
    fig = new_figure((7.0, 6.0))
    ax = fig.add_subplot(projection="3d")
    if rng.size:
        ax.scatter(lateral, rng, height, s=1.0, c=rng, cmap="viridis", depthshade=False)
    else:
        ax.text2D(0.5, 0.5, "no valid points", transform=ax.transAxes, ha="center")
    suffix = f" ({unit})" if unit else ""
    ax.set_xlabel("lateral" + suffix)
    ax.set_ylabel("range" + suffix)
    ax.set_zlabel("height" + suffix)
    ax.set_title(title)
    save_png(fig, path)


def save_error_histogram_png(
    path: str | os.PathLike[str],
    rel_diff: np.ndarray,
    title: str,
) -> None:
    """Histogram of relative range differences (fixed vs golden), log-spaced bins.

    ``rel_diff`` holds ``|r_fixed - r_golden| / r_golden`` on pixels valid in both; exact
    zeros are counted in the first bin.
    """
    rel = np.asarray(rel_diff, dtype=np.float64).ravel()
    if rel.size == 0 or not np.all(np.isfinite(rel)) or np.any(rel < 0):
        raise ValueError("rel_diff must be a non-empty array of finite non-negative values")
    floor = 1e-9
    edges = np.logspace(np.log10(floor), np.log10(max(rel.max(), floor * 10)) + 0.1, 60)
    fig = new_figure((6.4, 3.6))
    ax = fig.add_subplot()
    ax.hist(np.maximum(rel, floor), bins=edges, color="0.3")
    ax.set_xscale("log")
    ax.axvline(float(np.median(rel)), color="k", linestyle="--", label="median")
    ax.set_xlabel("|range fixed - range golden| / range golden")
    ax.set_ylabel("pixels")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    save_png(fig, path)
