"""Plots like the report's Figures 4-10 (chapter 6), written as PNG files.

Uses matplotlib's non-interactive Agg backend (no display needed).
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from rangefx.golden.geometry import (
    MotionIncrement,
    PinholeCamera,
    camera_from_inertial,
)

from .obstacles import ned_from_guidance
from .simulate import SimulationResult

__all__ = ["FIGURES", "default_view", "project_to_image", "save_figures"]

#: File names written by :func:`save_figures`, with the report figure they mirror.
FIGURES: dict[str, str] = {
    "fig4_altitude_vs_downrange.png": "Fig 4: down range vs altitude",
    "fig5_horizontal_projection.png": "Fig 5: horizontal projection with obstacles",
    "fig6_closest_obstacle.png": "Fig 6: distance to the closest obstacle",
    "fig7_airspeed.png": "Fig 7: airspeed vs time",
    "fig8_heading.png": "Fig 8: heading vs time",
    "fig9_bank.png": "Fig 9: bank angle vs time",
    "fig10_image_projection.png": "Fig 10: trajectory projected on the image plane",
}


def default_view(
    res: SimulationResult,
    *,
    hfov_deg: float = 60.0,
    size: tuple[int, int] = (512, 512),
    depression_deg: float = 3.0,
) -> tuple[PinholeCamera, MotionIncrement]:
    """A nose camera at the initial state, looking along the initial heading.

    The report's camera data for Fig 10 are not given; this camera (assumption) has a
    60° horizontal field of view so that the whole manoeuvre is in view, and is
    depressed 3° below the horizon like the ``runway`` scene's.
    """
    v0 = res.bc.v0
    psi = math.atan2(v0[1], v0[0])
    motion = MotionIncrement.from_attitudes(
        camera_angles=(0.0, math.radians(-depression_deg), 0.0),
        attitude1=(psi, 0.0, 0.0),
        position1=tuple(ned_from_guidance(res.bc.r0)),
    )
    return PinholeCamera.from_fov(size[1], size[0], hfov_deg), motion


def project_to_image(
    points_ned: np.ndarray, camera: PinholeCamera, motion: MotionIncrement
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel column/row of NED points seen by camera 1 (eqs 8-9, 12, 15); ``in_front`` mask."""
    xc = camera_from_inertial(motion, points_ned)
    cx, cy = camera.principal_point
    front = xc[..., 0] > 1e-6
    with np.errstate(divide="ignore", invalid="ignore"):
        col = np.where(front, camera.f_px * xc[..., 1] / xc[..., 0] + cx, np.nan)
        row = np.where(front, camera.f_px * xc[..., 2] / xc[..., 0] + cy, np.nan)
    return col, row, front


def _clearance_ring(box, clearance: float, n: int = 24) -> np.ndarray:
    """Horizontal outline at ``clearance`` from a box's footprint (rounded corners): the
    convex hull of circles of that radius about its corners."""
    from scipy.spatial import ConvexHull

    ang = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    circle = clearance * np.column_stack([np.cos(ang), np.sin(ang)])
    pts = (box.footprint()[:, None, :] + circle[None]).reshape(-1, 2)
    ring = pts[ConvexHull(pts).vertices]
    return np.vstack([ring, ring[:1]])


_BOX_EDGES = ((0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5),
              (2, 6), (3, 7))  # fmt: skip


def _draw_box_edges(ax, box, to_ned, camera, motion, color, ls, label) -> None:
    col, row, front = project_to_image(to_ned(box.corners()), camera, motion)
    for k, (i, j) in enumerate(_BOX_EDGES):
        if front[i] and front[j]:
            ax.plot([col[i], col[j]], [row[i], row[j]], ls, color=color, lw=0.9,
                    label=label if k == 0 else None)  # fmt: skip


def _save(fig, path: Path) -> None:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    path.write_bytes(buf.getvalue())


def save_figures(
    res: SimulationResult,
    out_dir: str | Path,
    *,
    title: str = "",
    image: np.ndarray | None = None,
    view: tuple[PinholeCamera, MotionIncrement] | None = None,
    to_ned=ned_from_guidance,
    extents: tuple = (),
    truth: tuple = (),
    clearance_ft: float | None = None,
    compare: SimulationResult | None = None,
    labels: tuple[str, str] = ("trajectory", "report law"),
) -> list[Path]:
    """Write Figs 4-10 for a run into ``out_dir`` (which must exist).

    Parameters
    ----------
    res
        A closed-loop run.
    out_dir
        Destination directory.
    title
        Prefix for the figure titles.
    image
        Background image for Fig 10 (e.g. the ``runway`` scene's ``image1``), drawn in
        the camera ``view``; ``None`` draws the ground grid and horizon only.
    view
        ``(camera, motion)`` for Fig 10; default :func:`default_view`.
    to_ned
        Map from guidance-frame points to the camera's NED frame (default: flip ``z``;
        for the ``runway`` scene, :meth:`FrameMap.to_scene`).
    extents, truth
        Obstacle extents used by the law and the true objects
        (:class:`~rangefx.guidance.extraction.ObstacleBox`), drawn in Figs 5 and 10.
    clearance_ft
        Drawn around each extent (the extent grown by it) in Figs 5 and 10.
    compare
        A second run (e.g. the report's law on the same obstacles) drawn beside the
        first in Figs 5, 6 and 10; ``labels`` name the two.
    """
    out = Path(out_dir)
    pos = res.positions
    t = res.t
    obs = res.obstacles
    pre = f"{title}: " if title else ""
    written: list[Path] = []

    def finish(fig, ax, name):
        ax.set_title(pre + FIGURES[name].split(": ", 1)[1], fontsize=10)
        ax.grid(True, alpha=0.3)
        fig.tight_layout()
        _save(fig, out / name)
        written.append(out / name)

    fig, ax = plt.subplots(figsize=(7, 3.5))  # Fig 4
    ax.plot(pos[:, 0], pos[:, 2], "b-", label="trajectory")
    ax.plot(obs[:, 0], obs[:, 2], "o", mfc="none", ms=4, color="0.4", label="obstacle points")
    ax.set_xlabel("down range x (ft)")
    ax.set_ylabel("altitude z (ft)")
    ax.legend(loc="best", fontsize=8)
    finish(fig, ax, "fig4_altitude_vs_downrange.png")

    fig, ax = plt.subplots(figsize=(6, 6))  # Fig 5
    ax.plot(pos[:, 1], pos[:, 0], "b-", label=labels[0])
    if compare is not None:
        ax.plot(compare.positions[:, 1], compare.positions[:, 0], "m--", label=labels[1])
    ax.plot(obs[:, 1], obs[:, 0], "o", mfc="none", ms=3, color="0.6", label="obstacle points")
    for k, box in enumerate(extents):
        fp = np.vstack([box.footprint(), box.footprint()[:1]])
        ax.plot(fp[:, 1], fp[:, 0], "-", color="darkorange", lw=1.2,
                label="obstacle extents" if k == 0 else None)  # fmt: skip
        if clearance_ft:
            ring = _clearance_ring(box, clearance_ft)
            ax.plot(ring[:, 1], ring[:, 0], ":", color="darkorange", lw=0.8,
                    label=f"clearance {clearance_ft:g} ft" if k == 0 else None)  # fmt: skip
    for k, box in enumerate(truth):
        fp = np.vstack([box.footprint(), box.footprint()[:1]])
        ax.fill(fp[:, 1], fp[:, 0], color="k", alpha=0.6, label="true vehicles" if k == 0 else None)
    ax.plot(*res.bc.r0[[1, 0]], "g^", label="start")
    man = res.extras.get("manoeuvre")
    td = np.asarray(res.extras.get("touchdown", res.bc.rf))
    ax.plot(td[1], td[0], "rv", label="touch-down")
    if man:  # the law took a safe manoeuvre: where it holds
        hp = man["hold_point_ft"]
        then = (man.get("landing_after") or {}).get("landed")
        label = f"hold point ({man['kind']}{', then landed' if then else ''})"
        ax.plot(hp[1], hp[0], "bs", mfc="none", label=label)
    ax.set_xlabel("cross range y (ft)")
    ax.set_ylabel("down range x (ft)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="best", fontsize=8)
    finish(fig, ax, "fig5_horizontal_projection.png")

    dist = res.closest_obstacle_distance()
    fig, ax = plt.subplots(figsize=(7, 3.5))  # Fig 6
    ax.plot(t, dist, "b-", label="to obstacle points")
    if truth:
        d_true = np.min([b.signed_distance(pos) for b in truth], axis=0)
        ax.plot(t, d_true, "k-", label="to true vehicles")
    if compare is not None and truth:
        d_cmp = np.min([b.signed_distance(compare.positions) for b in truth], axis=0)
        ax.plot(compare.t, d_cmp, "m--", label=f"{labels[1]}, to true vehicles")
    if clearance_ft:
        ax.axhline(clearance_ft, color="darkorange", ls=":", label=f"clearance {clearance_ft:g} ft")
    k = int(np.argmin(dist))
    ax.plot(t[k], dist[k], "r.", label=f"min {dist[k]:.2f} ft at {t[k]:.2f} s")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("distance to closest obstacle (ft)")
    ax.legend(loc="best", fontsize=8)
    finish(fig, ax, "fig6_closest_obstacle.png")

    fig, ax = plt.subplots(figsize=(7, 3.5))  # Fig 7
    ax.plot(t, res.states[:, 3], "b-")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("airspeed V (ft/s)")
    finish(fig, ax, "fig7_airspeed.png")

    fig, ax = plt.subplots(figsize=(7, 3.5))  # Fig 8
    ax.plot(t, np.degrees(np.unwrap(res.states[:, 5])), "b-")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("heading χ (deg)")
    finish(fig, ax, "fig8_heading.png")

    fig, ax = plt.subplots(figsize=(7, 3.5))  # Fig 9
    ax.step(res.t_cmd, np.degrees(res.phi), where="post", color="b", label="bank φ")
    ax.step(res.t_cmd, np.degrees(res.theta), where="post", color="g", label="thrust angle θ")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("angle (deg)")
    ax.legend(loc="best", fontsize=8)
    finish(fig, ax, "fig9_bank.png")

    camera, motion = view or default_view(res)
    fig, ax = plt.subplots(figsize=(6, 6))  # Fig 10
    if image is not None:
        ax.imshow(image, cmap="gray", vmin=0, vmax=255)
    else:
        ax.set_facecolor("0.92")
    ground = pos.copy()
    ground[:, 2] = 0.0
    c_t, r_t, f_t = project_to_image(to_ned(pos), camera, motion)
    c_g, r_g, f_g = project_to_image(to_ned(ground), camera, motion)
    c_o, r_o, _ = project_to_image(to_ned(obs), camera, motion)
    ax.plot(c_o, r_o, "s", ms=2, color="w" if image is not None else "0.3", label="obstacles")
    ax.plot(c_t, r_t, "-", color="yellow" if image is not None else "b", label=labels[0])
    if compare is not None:
        c_c, r_c, _ = project_to_image(to_ned(compare.positions), camera, motion)
        ax.plot(c_c, r_c, "--", color="m", label=labels[1])
    for k, box in enumerate(extents):
        _draw_box_edges(ax, box, to_ned, camera, motion, "darkorange", "-",
                        "obstacle extents" if k == 0 else None)  # fmt: skip
        if clearance_ft:
            _draw_box_edges(ax, box.grown(clearance_ft), to_ned, camera, motion, "darkorange",
                            ":", f"clearance {clearance_ft:g} ft" if k == 0 else None)  # fmt: skip
    step = max(1, len(pos) // 40)
    for i in range(0, len(pos), step):  # vertical lines: altitude above the runway
        if f_t[i] and f_g[i]:
            ax.plot([c_t[i], c_g[i]], [r_t[i], r_g[i]], "-", lw=0.6, color="orange")
    end_label = f"hold point ({man['kind']})" if man else "touch-down"
    ax.plot(c_t[-1], r_t[-1], marker=7, ms=9, color="r", ls="none", label=end_label)
    ax.set_xlim(0, camera.width - 1)
    ax.set_ylim(camera.height - 1, 0)
    if image is None:  # no picture to show: zoom on the rows that hold the manoeuvre
        rows = np.concatenate([r_t[f_t], r_g[f_g], r_o[np.isfinite(r_o)]])
        rows = rows[(rows >= 0) & (rows < camera.height)]
        if rows.size:
            lo, hi = max(rows.min() - 30, 0), min(rows.max() + 30, camera.height - 1)
            ax.set_ylim(hi, lo)
    ax.set_xlabel("column i (px)")
    ax.set_ylabel("row j (px)")
    ax.legend(loc="lower left", fontsize=8)
    finish(fig, ax, "fig10_image_projection.png")
    return written


def save_stress_figure(stress, path: str | Path, k: int = 4) -> Path:
    """The ``k`` stress layouts that came closest to a true vehicle, in plan view
    (:class:`~rangefx.guidance.stress.StressResult`): extents and their clearance, true
    vehicles, the avoiding law's path (its hold point when it took a safe manoeuvre)
    and the report law's path. Layouts taken from an earlier run's journal (no
    flight in ``stress.runs``) are left out."""
    worst = [r for r in stress.worst(len(stress.rows)) if r["name"] in stress.runs][:k]
    n = max(len(worst), 1)
    cols = min(n, 2)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(6 * cols, 6 * rows), squeeze=False)
    for ax in axes.ravel()[len(worst) :]:
        ax.set_visible(False)
    for ax, row in zip(axes.ravel(), worst, strict=False):
        case, run, rep = stress.runs[row["name"]]
        pos, pr = run.result.positions, rep.result.positions
        for j, box in enumerate(case.boxes):
            fp = np.vstack([box.footprint(), box.footprint()[:1]])
            ax.plot(fp[:, 1], fp[:, 0], "-", color="darkorange", lw=1.0,
                    label="obstacle extents" if j == 0 else None)  # fmt: skip
            ring = _clearance_ring(box, stress.clearance_ft)
            ax.plot(ring[:, 1], ring[:, 0], ":", color="darkorange", lw=0.7,
                    label=f"clearance {stress.clearance_ft:g} ft" if j == 0 else None)  # fmt: skip
        for j, box in enumerate(case.truth):
            fp = np.vstack([box.footprint(), box.footprint()[:1]])
            ax.fill(fp[:, 1], fp[:, 0], color="k", alpha=0.6,
                    label="true vehicles" if j == 0 else None)  # fmt: skip
        ax.plot(pr[:, 1], pr[:, 0], "m--", lw=1.0, label="report law")
        ax.plot(pos[:, 1], pos[:, 0], "b-", label=f"avoid law: {row['outcome']}")
        td = run.result.extras["touchdown"]
        ax.plot(td[1], td[0], "rv", label="touch-down")
        if row["hold_point_ft"]:
            hp = row["hold_point_ft"]
            then = ", then landed" if row.get("landed_after_manoeuvre") else ""
            ax.plot(hp[1], hp[0], "bs", mfc="none", label=f"hold point ({row['manoeuvre']}{then})")
        ax.set_title(
            f"{row['name']}: {row['vehicle']} at t = {row['path_time_s']:.1f} s, "
            f"{row['offset_ft']:+.1f} ft\nmin true distance {row['min_true_distance_ft']:.1f} ft"
            f" (report law {row['report_law_min_true_distance_ft']:.1f} ft)",
            fontsize=9,
        )
        lo = np.minimum(pos.min(axis=0), pr.min(axis=0)) - 60
        hi = np.maximum(pos.max(axis=0), pr.max(axis=0)) + 60
        ax.set_xlim(lo[1], hi[1])
        ax.set_ylim(lo[0], hi[0])
        ax.set_xlabel("cross range y (ft)")
        ax.set_ylabel("down range x (ft)")
        ax.set_aspect("equal", adjustable="box")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize=7)
    fig.suptitle(f"stress programme ({stress.source}): the closest layouts", fontsize=10)
    fig.tight_layout()
    out = Path(path)
    _save(fig, out)
    return out
