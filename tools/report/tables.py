"""Tables and key figures of a ranging result, in the style of the report.

Pure functions: they take arrays and return rows or strings; the command line
(:mod:`rangefx.tools.cli`) decides what goes where. Table rows follow the SPIE paper's
Table 1 (``Object | Actual Range | Estimated Range (Std. Dev.) | No. of Points``, e.g.
``Left Pencil 30.0 26.99 (7.48) 975``). :func:`json_safe` makes figures JSON-safe.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from .checks import as_2d, as_mask, as_real_2d, finite_where, same_shape

__all__ = [
    "ROW_KEYS",
    "ReportObject",
    "format_side_by_side",
    "json_safe",
    "median_text",
    "object_table",
    "overall_metrics",
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


def _ranging_inputs(
    range_map: Any, valid: Any, depth_truth: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r = as_real_2d(range_map, "range_map")
    v = as_mask(valid)
    t = as_real_2d(depth_truth, "depth_truth")
    same_shape(range_map=r, valid=v, depth_truth=t)
    finite_where(r, v, "range_map", "at valid pixels")
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
    lab = as_2d(labels, "labels")
    if not np.issubdtype(lab.dtype, np.integer):
        raise ValueError(f"labels must be an integer array, not dtype {lab.dtype}")
    same_shape(range_map=r, valid=v, labels=lab, depth_truth=t)
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


def median_text(figures: Mapping[str, Any]) -> str:
    """The median relative range difference for a report line; with no pixel valid in
    both results there is no median, and the line says so instead of printing nan."""
    if not figures.get("n_valid_both"):
        return "n/a (no pixel valid in both fixed and golden)"
    return f"{figures['median_rel_range_diff']:.2e}"


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
