"""Plots and CSV tables of word-length studies (matplotlib Agg, no pyplot state).

* :func:`save_pareto` — accuracy vs cost, every point and the Pareto front marked;
* :func:`save_sensitivity` — error vs the bits of one signal, the others at the base;
* :func:`buildup_profiles` / :func:`save_buildup` — error build-up along the scan: RMS
  fixed-vs-golden error of the row-filter taps against the column index (averaged over
  rows) and of the column-filter taps against the row index (averaged over columns),
  beside ``LSB / sqrt(12)`` of the tap's format (one rounding's RMS error), since a
  recursive filter accumulates quantisation error where a per-signal min/max cannot show
  it. :data:`BUILDUP_HOOKS` takes more profiles (the Riccati sweep of P2 when its model
  exists).

Every PNG is written atomically, and every plot has its data beside it as CSV.
"""

from __future__ import annotations

import csv
import io
import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .outdir import atomic_write_text
from .plots import new_figure, save_png

__all__ = [
    "BUILDUP_HOOKS",
    "COL_TAPS",
    "ROW_TAPS",
    "buildup_profiles",
    "save_buildup",
    "save_pareto",
    "save_sensitivity",
    "write_csv",
]

#: Row-filter taps (error against the column index) and column-filter taps (against the
#: row index), of stream E2.
ROW_TAPS: tuple[str, ...] = ("e2.row_state", "e2.row_r1", "e2.row_r2")
COL_TAPS: tuple[str, ...] = ("e2.col_state", "e2.col_s1", "e2.col_s2")

#: Extra build-up profiles: name -> callable(case, config) returning a dict
#: ``{"axis": "position", "index": array, "<curve>": array, ...}`` or None when the
#: model it needs does not exist. The P2 Riccati sweep registers itself here.
BUILDUP_HOOKS: dict[str, Callable[[Any, Any], Mapping[str, np.ndarray] | None]] = {}


def p2_riccati_profile(case: Any, config: Any) -> dict[str, np.ndarray] | None:
    """P2 (``rtl_model/p2/model.py``) against golden G5 along the backward Riccati sweep.

    Index = position in the sweep (0: the first step, at column ``n - 2``); curves: RMS
    relative range error over the rows (pixels valid in both) and RMS error of
    ``e = G - G_hat`` (tap ``e`` vs G5's ``e``). ``config`` (P1's) is not used: P2 runs
    its own default config. ``None`` when P2 is absent or the case is not stereo.
    """
    from rangefx.rtl_model.registry import PIPELINES

    if getattr(case, "mode", "") != "stereo":
        return None
    p2 = PIPELINES["p2"]
    p2cfg = p2.default_config()
    res = p2.run(case, p2cfg, taps=True)
    gold = p2.golden(case, p2cfg).result
    n = case.image1.shape[1]
    both = res.valid & gold.valid
    with np.errstate(divide="ignore", invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns: no valid pixel
        rel = np.where(both, np.abs(res.range - gold.range) / gold.range, np.nan)
        e_fx = np.ldexp(res.taps["e"].astype(float), -p2cfg.formats["p2_e"].frac)
        e_err = e_fx - gold.terms["e"]
        cols = np.arange(n - 2, -1, -1)  # backward sweep order
        z_rms = np.sqrt(np.nanmean(rel[:, cols] ** 2, axis=0))
        e_rms = np.sqrt(np.nanmean(e_err[:, cols] ** 2, axis=0))
    return {"index": np.arange(cols.size), "p2.range_rel": z_rms, "p2.e": e_rms}


BUILDUP_HOOKS["riccati"] = p2_riccati_profile


def write_csv(path: Path, rows: Sequence[Mapping[str, Any]], fields: Sequence[str]) -> None:
    """Rows as CSV (missing keys empty), written atomically."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(fields), extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in fields})
    atomic_write_text(path, buf.getvalue())


def save_pareto(
    path: Path,
    costs: Sequence[float],
    errors: Sequence[float],
    front: Sequence[int],
    *,
    xlabel: str = "cost (register + line-buffer + frame-store bits)",
    ylabel: str = "median relative range error vs golden",
    title: str = "",
    budget: float | None = None,
    marks: Mapping[str, tuple[float, float]] | None = None,
) -> None:
    fig = new_figure((7.0, 4.8))
    ax = fig.add_subplot(1, 1, 1)
    c = np.asarray(costs, dtype=float)
    e = np.asarray(errors, dtype=float)
    ok = np.isfinite(e) & (e > 0)
    ax.scatter(c[ok], e[ok], s=10, color="0.6", label=f"configs ({int(ok.sum())})")
    if front:
        fc, fe = c[list(front)], e[list(front)]
        ax.step(fc, fe, where="post", color="tab:red", lw=1.2)
        ax.scatter(fc, fe, s=24, color="tab:red", label=f"Pareto front ({len(front)})", zorder=3)
    if budget is not None:
        ax.axhline(budget, color="tab:blue", ls="--", lw=1, label=f"budget {budget:g}")
    for name, (x, y) in (marks or {}).items():
        ax.scatter([x], [y], marker="*", s=120, zorder=4, label=name)
    if ok.any():
        ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_png(fig, path)


def save_sensitivity(
    path: Path, curves: Mapping[str, Sequence[tuple[float, float]]], *, xlabel: str, ylabel: str
) -> None:
    """One curve per signal: (bits, error) pairs."""
    fig = new_figure((8.0, 5.0))
    ax = fig.add_subplot(1, 1, 1)
    any_pos = False
    for k, (name, pts) in enumerate(sorted(curves.items())):
        xs = [x for x, y in pts if y is not None and math.isfinite(y) and y > 0]
        ys = [y for x, y in pts if y is not None and math.isfinite(y) and y > 0]
        if xs:
            any_pos = True
            ax.plot(xs, ys, marker="o", ms=3, lw=1, ls="-" if k < 10 else "--", label=name)
    if any_pos:
        ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    save_png(fig, path)


def buildup_profiles(
    fixed: Mapping[str, np.ndarray],
    golden: Mapping[str, np.ndarray],
    lsb: Mapping[str, float],
) -> dict[str, dict[str, np.ndarray]]:
    """RMS |fixed - golden| per column (row taps) and per row (column taps).

    ``fixed`` and ``golden`` map tap names to float arrays (m, n); ``lsb`` the LSB of
    each tap's format. Returns ``{"row": {"index": cols, tap: rms, tap + ".lsb_rms":
    ...}, "col": {...}}``.
    """
    out: dict[str, dict[str, np.ndarray]] = {}
    for kind, taps, axis in (("row", ROW_TAPS, 0), ("col", COL_TAPS, 1)):
        prof: dict[str, np.ndarray] = {}
        for tap in taps:
            if tap not in fixed or tap not in golden:
                continue
            err = np.asarray(fixed[tap], dtype=float) - np.asarray(golden[tap], dtype=float)
            prof[tap] = np.sqrt(np.mean(err * err, axis=axis))
            prof[f"{tap}.lsb_rms"] = np.full(prof[tap].shape, lsb[tap] / math.sqrt(12.0))
        if prof:
            length = next(iter(prof.values())).shape[0]
            out[kind] = {"index": np.arange(length), **prof}
    return out


def save_buildup(
    out_dir: Path, stem: str, profiles: Mapping[str, Mapping[str, np.ndarray]], title: str
) -> list[Path]:
    """``<stem>.png`` (one panel per profile) and ``<stem>_<profile>.csv``."""
    written: list[Path] = []
    names = [k for k in profiles if profiles[k]]
    if not names:
        return written
    fig = new_figure((7.0, 3.2 * len(names)))
    xlabels = {"row": "column index (along the line)", "col": "row index (down the columns)"}
    for k, name in enumerate(names):
        prof = profiles[name]
        ax = fig.add_subplot(len(names), 1, k + 1)
        idx = prof["index"]
        for j, (tap, y) in enumerate((t, v) for t, v in prof.items() if t != "index"):
            if tap.endswith(".lsb_rms"):
                continue
            line = ax.plot(idx, y, lw=1, label=tap)[0]
            ref = prof.get(f"{tap}.lsb_rms")
            if ref is not None and j < 6:
                ax.plot(idx, ref, lw=0.8, ls=":", color=line.get_color())
        ax.set_xlabel(xlabels.get(name, "position in the backward Riccati sweep (P2)"))
        ax.set_ylabel("RMS fixed - golden")
        if any(np.nanmax(v, initial=0) > 0 for t, v in prof.items() if t != "index"):
            ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, title="dotted: LSB/sqrt(12)", title_fontsize=7)
        if k == 0:
            ax.set_title(title)
        rows = [
            {key: float(v[i]) if key != "index" else int(v[i]) for key, v in prof.items()}
            for i in range(len(idx))
        ]
        csv_path = out_dir / f"{stem}_{name}.csv"
        write_csv(csv_path, rows, list(prof))
        written.append(csv_path)
    fig.tight_layout()
    png = out_dir / f"{stem}.png"
    save_png(fig, png)
    written.append(png)
    return written
