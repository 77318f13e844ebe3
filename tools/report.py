"""Tables, figures and key figures of a ranging result, in the style of the report.

Pure functions: they take arrays and return rows, strings or write one PNG file; the
command line (:mod:`rangefx.tools.cli`) decides what goes where. Table rows follow the
SPIE paper's Table 1 (``Object | Actual Range | Estimated Range (Std. Dev.) | No. of
Points``, e.g. ``Left Pencil 30.0 26.99 (7.48) 975``); the figures follow the report's
Fig. 3 (image pair), Fig. 4 (3-D range points) and Fig. 8 (gray-coded range map).

Figures are drawn on :class:`matplotlib.figure.Figure` objects with an Agg canvas, never
through :mod:`matplotlib.pyplot`, so no global figure or backend state is touched; every
PNG is written atomically (temporary file + :func:`os.replace`).
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from .outdir import atomic_write_bytes

__all__ = [
    "ROW_KEYS",
    "ReportObject",
    "format_side_by_side",
    "object_table",
    "overall_metrics",
    "range_points_3d",
    "range_to_gray",
    "save_pair_png",
    "save_points_3d_png",
    "save_range_map_png",
    "table_csv",
    "table_markdown",
]

ROW_KEYS: tuple[str, ...] = (
    "object",
    "actual",
    "nominal",
    "estimated_median",
    "std",
    "n_points",
    "median_rel_error_vs_truth",
    "rel_error_of_median",
)
"""Keys of an :func:`object_table` row, in CSV column order."""

_NAN = float("nan")


class ReportObject(Protocol):
    """What :func:`object_table` needs of a scene object."""

    @property
    def name(self) -> str: ...

    @property
    def label(self) -> int: ...

    @property
    def nominal_range(self) -> float: ...


# --------------------------------------------------------------------------- validation


def _as_2d(array: Any, name: str) -> np.ndarray:
    a = np.asarray(array)
    if a.ndim != 2:
        raise ValueError(f"{name} must be a 2-D array, not {a.ndim}-D with shape {a.shape}")
    if a.size == 0:
        raise ValueError(f"{name} must not be empty, got shape {a.shape}")
    return a


def _as_real_2d(array: Any, name: str) -> np.ndarray:
    a = _as_2d(array, name)
    if a.dtype == np.bool_ or not np.issubdtype(a.dtype, np.number):
        raise ValueError(f"{name} must hold real numbers, not dtype {a.dtype}")
    if np.iscomplexobj(a):
        raise ValueError(f"{name} must hold real numbers, not dtype {a.dtype}")
    return a.astype(np.float64, copy=False)


def _as_mask(array: Any, name: str = "valid") -> np.ndarray:
    a = _as_2d(array, name)
    if a.dtype != np.bool_:
        raise ValueError(f"{name} must be a boolean array, not dtype {a.dtype}")
    return a


def _same_shape(**arrays: np.ndarray) -> None:
    shapes = {name: a.shape for name, a in arrays.items()}
    if len(set(shapes.values())) > 1:
        listed = ", ".join(f"{name} {shape}" for name, shape in shapes.items())
        raise ValueError(f"array shapes differ: {listed}")


def _finite_where(a: np.ndarray, mask: np.ndarray, name: str, where: str) -> None:
    bad = mask & ~np.isfinite(a)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise ValueError(
            f"{name} must be finite {where}; {int(bad.sum())} value(s) are not, "
            f"first at row {r}, column {c}: {float(a[r, c])!r}"
        )


def _check_truth(depth_truth: np.ndarray) -> None:
    finite = np.isfinite(depth_truth)
    bad = finite & (depth_truth <= 0)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise ValueError(
            "depth_truth must be positive where finite (unknown depth is +inf); "
            f"{int(bad.sum())} value(s) are not, first at row {r}, column {c}: "
            f"{float(depth_truth[r, c])!r}"
        )


def _positive_finite(value: Any, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive finite number, not {value!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be a positive finite number, not {value!r}")
    return v


def _ranging_inputs(
    range_map: Any, valid: Any, depth_truth: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r = _as_real_2d(range_map, "range_map")
    v = _as_mask(valid)
    t = _as_real_2d(depth_truth, "depth_truth")
    _same_shape(range_map=r, valid=v, depth_truth=t)
    _finite_where(r, v, "range_map", "at valid pixels")
    _check_truth(t)
    return r, v, t


# --------------------------------------------------------------------------- figures


def object_table(
    range_map: np.ndarray,
    valid: np.ndarray,
    labels: np.ndarray,
    objects: Sequence[ReportObject],
    depth_truth: np.ndarray,
) -> list[dict[str, Any]]:
    """One Table-1 row per object: actual range, estimated range (std) and point count.

    Parameters
    ----------
    range_map : ndarray, shape (m, n), real
        Estimated range per pixel; must be finite where ``valid``.
    valid : ndarray, shape (m, n), bool
        Validity flag of each estimate.
    labels : ndarray, shape (m, n), integer
        Object label of each pixel.
    objects : sequence
        Items with ``.name`` (str), ``.label`` (int) and ``.nominal_range`` (float).
    depth_truth : ndarray, shape (m, n), real
        True range per pixel, in the units of ``range_map``; ``+inf`` (or any non-finite
        value) where unknown, positive elsewhere.

    Returns
    -------
    list of dict
        In the order of ``objects``, each with the keys of :data:`ROW_KEYS`:

        ``object``
            ``obj.name``.
        ``actual``
            Median of ``depth_truth`` over **all** pixels carrying the object's label,
            valid or not, finite values only (NaN if there are none). This is the
            rendered object's true range; for a tilted surface it differs from the
            nominal range.
        ``nominal``
            ``obj.nominal_range``.
        ``estimated_median``, ``std``
            Median and population standard deviation (``ddof=0``) of ``range_map`` over
            the object's valid pixels; NaN if there are none.
        ``n_points``
            Number of the object's valid pixels (int).
        ``median_rel_error_vs_truth``
            Median over the object's valid pixels with finite truth of
            ``|range - depth_truth| / depth_truth`` (NaN if none).
        ``rel_error_of_median``
            ``(estimated_median - actual) / actual``, signed (NaN if either is NaN).

        All numbers are Python ``float`` except ``n_points``.

    Raises
    ------
    ValueError
        Arrays not 2-D, of different shapes, of the wrong dtype, ``range_map`` not finite
        at a valid pixel, or ``depth_truth`` non-positive where finite.
    """
    r, v, t = _ranging_inputs(range_map, valid, depth_truth)
    lab = _as_2d(labels, "labels")
    if not np.issubdtype(lab.dtype, np.integer):
        raise ValueError(f"labels must be an integer array, not dtype {lab.dtype}")
    _same_shape(range_map=r, valid=v, labels=lab, depth_truth=t)
    truth_known = np.isfinite(t)
    rows: list[dict[str, Any]] = []
    for obj in objects:
        in_obj = lab == obj.label
        truth = t[in_obj & truth_known]
        actual = float(np.median(truth)) if truth.size else _NAN
        sel = in_obj & v
        est = r[sel]
        n = int(est.size)
        median = float(np.median(est)) if n else _NAN
        std = float(np.std(est)) if n else _NAN
        scored = sel & truth_known
        rel = np.abs(r[scored] - t[scored]) / t[scored]
        rows.append(
            {
                "object": str(obj.name),
                "actual": actual,
                "nominal": float(obj.nominal_range),
                "estimated_median": median,
                "std": std,
                "n_points": n,
                "median_rel_error_vs_truth": float(np.median(rel)) if rel.size else _NAN,
                "rel_error_of_median": (median - actual) / actual,
            }
        )
    return rows


def overall_metrics(range_map: np.ndarray, valid: np.ndarray, depth_truth: np.ndarray) -> dict:
    """Whole-image key figures of a range map against ground truth.

    Parameters
    ----------
    range_map : ndarray, shape (m, n), real
        Estimated range; must be finite where ``valid``.
    valid : ndarray, shape (m, n), bool
        Validity flag of each estimate.
    depth_truth : ndarray, shape (m, n), real
        True range; non-finite (``+inf``) where unknown, positive elsewhere.

    Returns
    -------
    dict
        ``valid_fraction``
            Valid pixels / all pixels.
        ``n_valid``
            Number of valid pixels (int).
        ``n_scored``
            Number of valid pixels with finite truth (int): the population of the
            error figures below.
        ``median_rel_error``, ``p90_rel_error``
            Median and 90th percentile (linear interpolation, numpy's default) of
            ``|range - truth| / truth``; NaN if ``n_scored`` is 0.
        ``within_5pct``, ``within_10pct``
            Fraction of scored pixels with relative error ``<= 0.05`` / ``<= 0.10``;
            NaN if ``n_scored`` is 0.
    """
    r, v, t = _ranging_inputs(range_map, valid, depth_truth)
    scored = v & np.isfinite(t)
    rel = np.abs(r[scored] - t[scored]) / t[scored]
    n_scored = int(rel.size)
    if n_scored:
        median, p90 = (float(q) for q in np.percentile(rel, [50.0, 90.0]))
        within_5 = int(np.count_nonzero(rel <= 0.05)) / n_scored
        within_10 = int(np.count_nonzero(rel <= 0.10)) / n_scored
    else:
        median = p90 = within_5 = within_10 = _NAN
    n_valid = int(np.count_nonzero(v))
    return {
        "valid_fraction": n_valid / v.size,
        "n_valid": n_valid,
        "n_scored": n_scored,
        "median_rel_error": median,
        "p90_rel_error": p90,
        "within_5pct": within_5,
        "within_10pct": within_10,
    }


# --------------------------------------------------------------------------- tables


def _check_rows(rows: Sequence[Mapping[str, Any]], keys: Sequence[str]) -> None:
    for i, row in enumerate(rows):
        missing = [k for k in keys if k not in row]
        if missing:
            raise ValueError(f"table row {i} ({row.get('object', '?')!r}) lacks key(s) {missing}")


def _fmt_num(x: float) -> str:
    return "n/a" if not math.isfinite(x) else f"{x:.2f}"


def _fmt_estimate(median: float, std: float) -> str:
    if not math.isfinite(median):
        return "n/a"
    return f"{median:.2f} ({_fmt_num(std)})"


def _fmt_percent(rel: float) -> str:
    return "n/a" if not math.isfinite(rel) else f"{100.0 * rel:+.1f}%"


def _md_cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def table_markdown(rows: Sequence[Mapping[str, Any]], unit: str, title: str | None = None) -> str:
    """The object table as Markdown, in the report's Table-1 layout.

    Columns: ``Object | Actual range (<unit>) | Estimated range (std) | No. of points |
    Error``. The estimate is printed as ``26.99 (7.48)`` (median, population standard
    deviation, two decimals), the actual range with two decimals, and the error is
    ``rel_error_of_median`` as a signed percent with one decimal (``-10.0%``). Missing
    values print as ``n/a``.

    Parameters
    ----------
    rows
        Rows from :func:`object_table`.
    unit
        Range unit for the header, e.g. ``"in"`` or ``"ft"``.
    title
        Printed as a ``###`` heading above the table when given.

    Returns
    -------
    str
        The table, ending in a newline.
    """
    _check_rows(rows, ("object", "actual", "estimated_median", "std", "n_points"))
    lines = []
    if title:
        lines += [f"### {title}", ""]
    lines += [
        f"| Object | Actual range ({unit}) | Estimated range (std) | No. of points | Error |",
        "|:---|---:|---:|---:|---:|",
    ]
    for row in rows:
        actual = float(row["actual"])
        median = float(row["estimated_median"])
        if "rel_error_of_median" in row:
            err = float(row["rel_error_of_median"])
        else:
            err = (median - actual) / actual if actual else _NAN
        cells = (
            _md_cell(str(row["object"])),
            _fmt_num(actual),
            _fmt_estimate(median, float(row["std"])),
            str(int(row["n_points"])),
            _fmt_percent(err),
        )
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def table_csv(rows: Sequence[Mapping[str, Any]]) -> str:
    """The object table as CSV with the raw row keys (:data:`ROW_KEYS`) as columns.

    Floats are written with full precision (``repr``), missing values as ``nan``; line
    ends are ``\\n``.

    Parameters
    ----------
    rows
        Rows from :func:`object_table`.

    Returns
    -------
    str
        Header line and one line per row.
    """
    _check_rows(rows, ROW_KEYS)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=ROW_KEYS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buf.getvalue()


def format_side_by_side(tables: Mapping[str, Sequence[Mapping[str, Any]]], unit: str) -> str:
    """A compact plain-text comparison of several methods' object tables.

    One line per object (in order of first appearance), its actual range, then for each
    method a block ``estimate (std)`` and ``n``::

        Object       Actual (in) | g3_paper           | g3_consistent
                                 | est. (std)       n | est. (std)       n
        Left Pencil        30.00 | 26.99 (7.48)   975 | 29.80 (2.10)   980

    Parameters
    ----------
    tables
        Method name to rows from :func:`object_table`.
    unit
        Range unit for the header.

    Returns
    -------
    str
        The text, ending in a newline.
    """
    keys = ("object", "actual", "estimated_median", "std", "n_points")
    for name, rows in tables.items():
        try:
            _check_rows(rows, keys)
        except ValueError as exc:
            raise ValueError(f"method {name!r}: {exc}") from None
    methods = list(tables)
    objects: dict[str, float] = {}
    cells: dict[tuple[str, str], tuple[str, str]] = {}
    for method, rows in tables.items():
        for row in rows:
            obj = str(row["object"])
            objects.setdefault(obj, float(row["actual"]))
            est = _fmt_estimate(float(row["estimated_median"]), float(row["std"]))
            cells[method, obj] = (est, str(int(row["n_points"])))

    actual_head = f"Actual ({unit})"
    w_obj = max([len("Object"), *(len(o) for o in objects)])
    w_act = max([len(actual_head), *(len(_fmt_num(a)) for a in objects.values())])
    widths = {}
    for m in methods:
        col = [cells.get((m, o), ("-", "-")) for o in objects]
        w_est = max([len("est. (std)"), *(len(c[0]) for c in col)])
        w_n = max([1, *(len(c[1]) for c in col)])
        w_est = max(w_est, len(m) - w_n - 2)
        widths[m] = (w_est, w_n)

    def line(first: str, second: str, blocks: list[str]) -> str:
        return " | ".join([f"{first:<{w_obj}} {second:>{w_act}}", *blocks]).rstrip()

    out = [
        line("Object", actual_head, [f"{m:<{sum(widths[m]) + 2}}" for m in methods]),
        line("", "", [f"{'est. (std)':<{widths[m][0]}}  {'n':>{widths[m][1]}}" for m in methods]),
    ]
    for obj, actual in objects.items():
        blocks = []
        for m in methods:
            est, n = cells.get((m, obj), ("-", "-"))
            blocks.append(f"{est:<{widths[m][0]}}  {n:>{widths[m][1]}}")
        out.append(line(obj, _fmt_num(actual), blocks))
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------- PNG figures


def _new_figure(figsize: tuple[float, float]) -> Figure:
    fig = Figure(figsize=figsize, dpi=100)
    FigureCanvasAgg(fig)
    return fig


def _save_png(fig: Figure, path: str | os.PathLike[str]) -> None:
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
    r = _as_real_2d(range_map, "range_map")
    v = _as_mask(valid)
    _same_shape(range_map=r, valid=v)
    _finite_where(r, v, "range_map", "at valid pixels")
    rmax = _positive_finite(range_max, "range_max")
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
    range_map : ndarray, shape (m, n), real
        Range per pixel; must be finite where ``valid``.
    valid : ndarray, shape (m, n), bool
        Validity flag.
    range_max : float
        Range shown as black; positive and finite.
    title
        Figure title.
    unit
        Range unit for the colorbar label.
    """
    gray = range_to_gray(range_map, valid, range_max)
    m, n = gray.shape
    fig = _new_figure((6.4, max(2.5, 5.2 * m / n)))
    ax = fig.add_subplot()
    ax.imshow(gray, cmap="gray", vmin=0.0, vmax=1.0, interpolation="nearest")
    ax.set_title(title)
    ax.set_xlabel("column (pixel)")
    ax.set_ylabel("row (pixel)")
    mappable = ScalarMappable(
        norm=Normalize(0.0, float(range_max)), cmap=matplotlib.colormaps["gray_r"]
    )
    cbar = fig.colorbar(mappable, ax=ax)
    cbar.set_label(f"range ({unit})" if unit else "range")
    fig.tight_layout()
    _save_png(fig, path)


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
    a = _as_real_2d(image1, "image1")
    b = _as_real_2d(image2, "image2")
    _same_shape(image1=a, image2=b)
    everywhere = np.ones(a.shape, dtype=bool)
    _finite_where(a, everywhere, "image1", "everywhere")
    _finite_where(b, everywhere, "image2", "everywhere")
    if isinstance(titles, str) or len(titles) != 2:
        raise ValueError(f"titles must be a sequence of two strings, not {titles!r}")
    lo = float(min(a.min(), b.min()))
    hi = float(max(a.max(), b.max()))
    if hi <= lo:
        hi = lo + 1.0
    m, n = a.shape
    fig = _new_figure((10.0, max(2.5, 4.6 * m / n + 0.8)))
    for k, (img, title) in enumerate(zip((a, b), titles, strict=True)):
        ax = fig.add_subplot(1, 2, k + 1)
        ax.imshow(img, cmap="gray", vmin=lo, vmax=hi, interpolation="nearest")
        ax.set_title(str(title))
        ax.set_axis_off()
    fig.tight_layout()
    _save_png(fig, path)


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
    range_map : ndarray, shape (m, n), real
        Range per pixel; must be finite where ``valid``.
    valid : ndarray, shape (m, n), bool
        Validity flag.
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
    r = _as_real_2d(range_map, "range_map")
    v = _as_mask(valid)
    _same_shape(range_map=r, valid=v)
    _finite_where(r, v, "range_map", "at valid pixels")
    x_pix = _broadcast_coord(xp, r.shape, "xp")
    y_pix = _broadcast_coord(yp, r.shape, "yp")
    _finite_where(x_pix, v, "xp", "at valid pixels")
    _finite_where(y_pix, v, "yp", "at valid pixels")
    f = _positive_finite(f_px, "f_px")
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
    fig = _new_figure((7.0, 6.0))
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
    _save_png(fig, path)


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
    fig = _new_figure((6.4, 3.6))
    ax = fig.add_subplot()
    ax.hist(np.maximum(rel, floor), bins=edges, color="0.3")
    ax.set_xscale("log")
    ax.axvline(float(np.median(rel)), color="k", linestyle="--", label="median")
    ax.set_xlabel("|range fixed - range golden| / range golden")
    ax.set_ylabel("pixels")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    _save_png(fig, path)


def json_safe(obj: Any) -> Any:
    """JSON-safe copy for ``--json`` output and ``summary.json``: NaN/inf floats become
    None, numpy scalars Python scalars, tuples lists, dict keys strings."""
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [json_safe(v) for v in obj]
    if isinstance(obj, float | np.floating):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer | np.bool_):
        return obj.item()
    return obj
