"""Plots and CSV tables of word-length studies (matplotlib Agg, no pyplot state).

* :func:`save_pareto` — accuracy vs cost, every point and the Pareto front marked;
* :func:`save_sensitivity` — error vs the bits of one signal, the others at the base;
* :func:`save_buildup` — error build-up profiles along a pipeline's scan (computed by
  :mod:`rangefx.tools.studies.buildup`: P1's row and column filters, P2's backward
  Riccati sweep), one panel per profile, each curve beside its dotted ``LSB / sqrt(12)``.

Plots only: every input is data a study computed. Every PNG is written atomically, and
every plot has its data beside it as CSV.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .outdir import atomic_write_text
from .plots import new_figure, save_png

__all__ = [
    "save_buildup",
    "save_pareto",
    "save_sensitivity",
    "write_csv",
]


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


def save_buildup(
    out_dir: Path,
    stem: str,
    profiles: Mapping[str, Mapping[str, np.ndarray]],
    title: str,
    *,
    xlabels: Mapping[str, str] | None = None,
) -> list[Path]:
    """``<stem>.png`` (one panel per profile) and ``<stem>_<profile>.csv``.

    ``profiles``: name -> ``{"index": positions, curve: values, curve + ".lsb_rms":
    reference}``; ``xlabels``: name -> what its index counts (default: the name)."""
    written: list[Path] = []
    names = [k for k in profiles if profiles[k]]
    if not names:
        return written
    fig = new_figure((7.0, 3.2 * len(names)))
    xlabels = xlabels or {}
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
        ax.set_xlabel(xlabels.get(name, name))
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
