"""Chapter-6 guidance flown on obstacles a pipeline ranged (SPEC §7, §13, §15): what
``rangefx guide`` computes, as one call (:func:`guide_flight`).

The report's boundary conditions (initial [532, 590, 7] ft, [0, -38, 0] ft/s; final
[740, 0, 0] ft, [1, 0, 0] ft/s; ζ = 0.96, α = 0.5, μ = 0, β = 1e-6) are flown through
one of three obstacle sets:

* ``synthetic``: the documented stand-in for the report's 293 range points on four
  parked vehicles (:func:`rangefx.guidance.obstacles.synthetic_runway_obstacles`);
* ``runway``: the ``runway`` scene ranged by the golden ``g4_consistent`` method;
* ``runway-p1``, ``runway-p3``, ...: end to end, the same scene through a bit-accurate
  pipeline: P1 on the motion pair (one stream, frame store, rotation on), a stereo-only
  pipeline on the runway's stereo pair (:func:`rangefx.guidance.cases.runway_scene_for`).

Three programmes: one flight (the avoiding law keeps a clearance from every extracted
obstacle extent, :mod:`rangefx.guidance.avoid`, with the report's law flown beside it;
or the report's law, eqs 20-69), a layout sweep (the avoiding law over the ±10 ft shift
grid and seeded random layouts of the synthetic set) and the stress programme (both laws
over seeded layouts of the ``runway`` scene ranged by a pipeline, each moved so that a
true vehicle stands on or near the nominal path, :mod:`rangefx.guidance.stress`).
:class:`GuideResult` holds the figures and writes the files.
"""

from __future__ import annotations

import io
import json
import math
import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rangefx.rtl_model.registry import PIPELINES

from ..errors import UserError
from ..interrupts import set_stop_line
from ..report import atomic_output_dir, atomic_write_text, json_safe

__all__ = [
    "DEFAULT_PIPELINE",
    "OBSTACLE_SETS",
    "PROGRAMMES",
    "STRESS_JOURNAL",
    "GuideResult",
    "guide_flight",
    "read_stress_journal",
    "runway_config",
    "stress_table",
]

#: Obstacle sets of a single flight.
OBSTACLE_SETS = ("synthetic", "runway", *(f"runway-{name}" for name in PIPELINES))
#: The pipeline whose range map the end-to-end chain flies by default (the stress
#: programme's ``--pipeline``, the demo's end-to-end flight): P3 on the runway's stereo
#: pair. On ``rangefx guide --stress 20`` (issue 39) it flew better than P1 on the motion
#: pair -- more landings, the same 0 collisions and 0 crashes -- from shorter extents
#: along the viewing rays (docs/guidance.md has the figures). ``runway-p1`` stays
#: available.
DEFAULT_PIPELINE = "p3"
#: The programmes :func:`guide_flight` flies.
PROGRAMMES = ("flight", "layout-sweep", "stress")
#: The stress programme's journal in its output directory: one JSON line per finished
#: layout, appended (and synced) as it finishes, so that an interrupted programme keeps
#: the layouts it flew and a re-run of the same command flies only the others.
STRESS_JOURNAL = "stress_layouts.jsonl"


def _csv(header: str, rows: np.ndarray) -> str:
    buf = io.StringIO()
    np.savetxt(buf, rows, delimiter=",", header=header, comments="", fmt="%.6f")
    return buf.getvalue()


@dataclass(frozen=True)
class GuideResult:
    """One guidance programme's outcome.

    Attributes
    ----------
    programme
        ``"flight"``, ``"layout-sweep"`` or ``"stress"``.
    summary
        What the programme's JSON file holds (``summary.json``, ``sweep.json``,
        ``stress.json``) and ``rangefx guide --json`` prints.
    warnings
        The flight's warnings (an infeasible clearance, a safe manoeuvre taken).
    metrics
        The flown law's headline figures (a flight only).
    """

    programme: str
    summary: dict[str, Any]
    warnings: list[str] = field(default_factory=list)
    metrics: dict[str, Any] = field(default_factory=dict)
    _payload: Any = field(default=None, repr=False, compare=False)

    def to_dict(self) -> dict[str, Any]:
        """The summary as JSON-able values."""
        return json_safe(self.summary)

    def write(self, out: str | Path) -> Path:
        """Write the programme's files into directory ``out``, atomically: a flight's
        figures (Figs 4-10 look-alikes), ``trajectory.csv``, ``obstacles.csv``,
        ``extents.csv`` and ``summary.json``; a layout sweep's ``sweep.json``; the stress
        programme's ``stress.json`` and ``stress_worst.png``."""
        with atomic_output_dir(Path(out)) as tmp:
            self.write_files(tmp)
        return Path(out)

    def write_files(self, directory: str | Path) -> None:
        """The files of :meth:`write` into the existing ``directory``, not atomically (for
        a caller that fills its own atomic output directory, as ``rangefx demo``)."""
        d = Path(directory)
        if self.programme == "flight":
            _write_flight(d, self._payload, self.summary)
        elif self.programme == "layout-sweep":
            atomic_write_text(d / "sweep.json", _json(self.summary))
        else:
            from rangefx.guidance.plots import save_stress_figure

            atomic_write_text(d / "stress.json", _json(self.summary))
            if self._payload.runs:
                save_stress_figure(self._payload, d / "stress_worst.png")


def _json(data: Any) -> str:
    return json.dumps(json_safe(data), indent=2) + "\n"


def _configs(guidance_interval: float, clearance_ft: float, replan_interval: float):
    from rangefx.guidance.avoid import AvoidConfig
    from rangefx.guidance.simulate import SimulationConfig

    try:
        config = SimulationConfig(
            guidance_interval=guidance_interval, sample_interval=min(0.02, guidance_interval)
        )
    except ValueError as exc:
        raise UserError(f"--guidance-interval: {exc}") from None
    try:
        avoid = AvoidConfig(clearance_ft=clearance_ft, replan_interval=replan_interval)
    except ValueError as exc:
        raise UserError(f"--clearance / --replan-interval: {exc}") from None
    return config, avoid


# fmt: off
def guide_flight(
    obstacles: str = "synthetic", *, law: str = "avoid", clearance_ft: float = 20.0,
    shift: Sequence[float] = (0.0, 0.0, 0.0), guidance_interval: float = 0.1,
    replan_interval: float = 0.5, layout_sweep: int | None = None, stress: int | None = None,
    pipeline: str = DEFAULT_PIPELINE, seed: int = 0, jobs: int = 1,
    out: str | Path | None = None,
) -> GuideResult:
    """:func:`rangefx.api.guide` (its parameters and errors are documented there): one
    flight of ``law`` on ``obstacles``, the layout sweep, or the stress programme (with
    ``out``, journalled in that output directory: :data:`STRESS_JOURNAL`)."""
    # fmt: on
    if len(shift) != 3 or not all(math.isfinite(v) for v in shift):
        raise UserError(f"--shift must be finite numbers, not {list(shift)}")
    if not (math.isfinite(clearance_ft) and clearance_ft > 0):
        raise UserError(f"--clearance must be a positive number of feet, not {clearance_ft}")
    if obstacles not in OBSTACLE_SETS:
        raise UserError(
            f"unknown obstacle set {obstacles!r}; choose from {', '.join(OBSTACLE_SETS)}"
        )
    if law not in ("avoid", "report"):
        raise UserError(f"unknown law {law!r}; choose avoid or report")
    if stress is not None:
        if stress < 0:
            raise UserError(f"--stress must be >= 0, not {stress}")
        if layout_sweep is not None:
            raise UserError("--stress and --layout-sweep are separate programmes: give one")
        if jobs < 1:
            raise UserError(f"--jobs must be >= 1, not {jobs}")
        return _stress(stress, pipeline, seed, clearance_ft, guidance_interval, replan_interval,
                       jobs, out)  # fmt: skip
    if layout_sweep is not None:
        if layout_sweep < 0:
            raise UserError(f"--layout-sweep must be >= 0, not {layout_sweep}")
        return _layout_sweep(layout_sweep, clearance_ft, guidance_interval, replan_interval)
    return _flight(obstacles, law, clearance_ft, tuple(shift), guidance_interval,
                   replan_interval)  # fmt: skip


def _case(obstacles: str):
    from rangefx.guidance.cases import synthetic_case

    if obstacles == "runway":
        return _runway_case(None)
    if obstacles.startswith("runway-"):
        return _runway_case(obstacles.removeprefix("runway-"))
    return synthetic_case()


def _runway_case(pipeline: str | None):
    """The ``runway`` scene end to end, ranged by golden ``g4_consistent`` (``None``) or
    by the bit-accurate ``pipeline``: the motion pair if it models motion mode, else the
    stereo pair (:func:`rangefx.guidance.cases.runway_scene_for`)."""
    from rangefx.guidance.cases import runway_case, runway_scene_for
    from rangefx.rtl_model.registry import get_pipeline

    from .runner import range_source

    source, scene = None, None
    label = f"--pipeline {pipeline}" if pipeline else "--obstacles runway"
    if pipeline is not None:
        pipe = get_pipeline(pipeline)
        config = runway_config(pipeline)
        source = range_source(pipe, config)
        try:
            scene = runway_scene_for(pipe.modes)
        except ValueError as exc:
            raise UserError(f"{label}: {exc}") from None
    try:
        case = runway_case(source, scene=scene)
    except ValueError as exc:
        raise UserError(f"{label}: {exc}") from None
    mode = "motion" if scene is None else scene.kind
    case.info["method"] = (
        f"{pipeline.upper()} fixed point, {mode} mode, default config"
        + (", consistent" if pipeline == "p1" else "")
        + (f", p3_range {config.formats['p3_range']}" if pipeline == "p3" else "")
        if pipeline
        else "golden g4_consistent"
    )
    case.info["reduction"] = "voxel"
    return case


def runway_config(pipeline: str):
    """The config ``pipeline`` ranges the runway scene with in the guidance chain: P1's
    consistent variant (as the documented figures), P3's default with a range word that
    holds the runway's ``range_max`` (2000 ft), any other pipeline's default.

    P3's default ``p3_range`` is u20.12: 8 integer bits, so its ``range_max`` register
    saturates at 256 ft and the ``u >= u_min`` gate (``z <= range_max``) flags every
    pixel beyond it invalid -- on the stereo runway pair 4 of the 5 vehicles (300-607
    ft; measured: 0 valid pixels of 2 922). The same 20-bit word with 11 integer bits
    (u20.9, 1/512 ft) ranges all 5 (every pixel of Vehicles 1, 2, 4, 5)."""
    from dataclasses import replace

    from rangefx.golden.methods import SCENE_RANGING
    from rangefx.rtl_model.registry import get_pipeline

    if pipeline == "p1":
        from rangefx.rtl_model.p1 import P1Config

        return P1Config.default(variant="consistent")
    config = get_pipeline(pipeline).default_config()
    if pipeline != "p3":
        return config
    fmt = config.formats["p3_range"]
    need = SCENE_RANGING["runway"].range_max
    if fmt.raw_max * fmt.lsb >= need:
        return config
    int_bits = math.ceil(math.log2(need)) + int(fmt.signed)
    return config.with_formats(p3_range=replace(fmt, frac=fmt.word - int_bits))


def _stress(
    count: int, pipeline: str, seed: int, clearance_ft: float, guidance_interval: float,
    replan_interval: float, jobs: int = 1, out: str | Path | None = None,
) -> GuideResult:  # fmt: skip
    """The stress programme (:func:`rangefx.guidance.stress.stress_programme`) on the
    ``runway`` scene ranged by ``pipeline``; with ``out``, each finished layout is
    appended to ``out/``:data:`STRESS_JOURNAL` and the layouts already there (of the
    same settings) are taken from it instead of flown again."""
    from tqdm import tqdm

    from rangefx.guidance.stress import stress_programme

    config, avoid = _configs(guidance_interval, clearance_ft, replan_interval)
    settings = {
        "source": f"runway-{pipeline}", "seed": seed, "clearance_ft": clearance_ft,
        "guidance_interval_s": guidance_interval, "replan_interval_s": replan_interval,
    }  # fmt: skip
    case = _runway_case(pipeline)  # a user error here leaves no output directory behind
    journal = None if out is None else _open_stress_journal(Path(out))
    done = {} if journal is None else read_stress_journal(journal, settings)
    bar = tqdm(total=count, desc="stress", disable=not sys.stderr.isatty())
    flags = os.O_WRONLY | os.O_APPEND | os.O_CREAT
    fd = None if journal is None else os.open(journal, flags, 0o666)

    def append(row: dict) -> None:
        if fd is None:
            return
        # NaN and inf kept (Python's JSON reads them back): a resumed row is the row flown
        rec = {"settings": settings, "row": row}
        data = (json.dumps(rec, default=_numpy_scalar) + "\n").encode()
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view) :]
            os.fsync(fd)
        except OSError as exc:
            raise UserError(f"cannot append to {journal}: {exc.strerror}") from None

    kept = set(done)  # the layouts of these settings in the journal

    def journalled(row: dict) -> None:
        append(row)
        kept.add(row["name"])
        set_stop_line(_stress_stop_line(journal, len(kept)))

    if journal is not None:
        set_stop_line(_stress_stop_line(journal, len(kept)))
    try:
        res = stress_programme(
            case, count, seed=seed, source=settings["source"], clearance_ft=clearance_ft,
            config=config, avoid=avoid, progress=lambda _n: bar.update(), jobs=jobs,
            done=done, on_row=journalled,
        )  # fmt: skip
    except KeyboardInterrupt as exc:
        if journal is not None:  # the command's line says what the journal kept
            exc.stop_line = _stress_stop_line(journal, len(kept))
        raise
    finally:
        bar.close()
        if fd is not None:
            os.close(fd)
    summary = res.to_dict()
    summary["resumed_layouts"] = sorted(n for n in done if n in {r["name"] for r in res.rows})
    return GuideResult("stress", summary, _payload=res)


def _stress_stop_line(journal: Path, kept: int) -> str:
    """The line of an interrupted stress programme: the journal keeps its finished
    layouts (nothing else was written), and the same command resumes from them."""
    return (
        f"interrupted; {kept} finished stress layout{'s' if kept != 1 else ''} kept in "
        f"{journal} (no other output was written): the same command flies only the others"
    )


def _numpy_scalar(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def _open_stress_journal(out: Path) -> Path:
    """``out/``:data:`STRESS_JOURNAL`, creating ``out`` as an (empty) rangefx output
    directory if it does not exist, so that the journal lives where the results go."""
    if not out.exists():
        with atomic_output_dir(out):
            pass
    path = out / STRESS_JOURNAL
    if path.exists() and (path.is_symlink() or not path.is_file()):
        raise UserError(f"{path} is not a file (rangefx journals the stress layouts there)")
    return path


def read_stress_journal(path: str | Path, settings: dict) -> dict[str, dict]:
    """The rows of stress journal ``path`` flown with ``settings`` (source, seed,
    clearance and intervals), by layout name; records of other settings are ignored (a
    later record of a layout wins). A torn last line (a kill mid-write) is cut off the
    file, so that appending continues on a clean line; any other unreadable line is a
    :class:`UserError`."""
    path = Path(path)
    if not path.exists():
        return {}
    data = path.read_bytes()
    end = data.rfind(b"\n") + 1
    if end != len(data):
        with open(path, "r+b") as f:
            f.truncate(end)
    rows: dict[str, dict] = {}
    for n, line in enumerate(data[:end].splitlines(), 1):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
            row = rec["row"]
            if rec["settings"] == settings:
                rows[row["name"]] = row
        except (ValueError, KeyError, TypeError):
            raise UserError(
                f"{path}: line {n} is not a stress layout record; delete it (and the lines "
                "after it) to resume from the layouts before it"
            ) from None
    return rows


def _layout_sweep(
    n_random: int, clearance_ft: float, guidance_interval: float, replan_interval: float
) -> GuideResult:
    """The layout sweep (:func:`rangefx.guidance.cases.layout_sweep`)."""
    from tqdm import tqdm

    from rangefx.guidance.cases import layout_sweep, random_layouts, shift_grid_layouts

    # the same programme as a single flight: the sweep measures what `guide` flies
    config, avoid = _configs(guidance_interval, clearance_ft, replan_interval)
    layouts = shift_grid_layouts() + random_layouts(n_random)
    bar = tqdm(total=len(layouts), desc="layout sweep", disable=not sys.stderr.isatty())
    try:
        out = layout_sweep(
            layouts, clearance_ft=clearance_ft, config=config, avoid=avoid,
            progress=lambda _n: bar.update(),
        )  # fmt: skip
    finally:
        bar.close()
    return GuideResult("layout-sweep", out)


@dataclass(frozen=True)
class _Flight:
    """What a flight's files are drawn from."""

    case: Any
    runs: dict[str, Any]
    law: str
    obstacles: str
    clearance_ft: float


def _flight(
    obstacles: str, law: str, clearance_ft: float, shift: tuple[float, float, float],
    guidance_interval: float, replan_interval: float,
) -> GuideResult:  # fmt: skip
    """Fly the chosen law on the chosen obstacle set (the report's law beside the
    avoiding one)."""
    from rangefx.guidance.cases import fly
    from rangefx.guidance.example import REPORT_FIGURES
    from rangefx.guidance.plots import FIGURES

    config, avoid = _configs(guidance_interval, clearance_ft, replan_interval)
    case = _case(obstacles).shifted(shift)
    runs = {}
    for which in (law, "report") if law == "avoid" else (law,):
        try:
            runs[which] = fly(case, which, clearance_ft=clearance_ft, config=config, avoid=avoid)
        except (ValueError, RuntimeError) as exc:
            raise UserError(f"guidance ({which} law) failed: {exc}") from None
    run = runs[law]
    notes = list(run.warnings)
    summary = {
        **run.metrics,
        "obstacles": {"source": obstacles, **case.info},
        "extraction": {**case.extraction.as_dict(), "scores": case.scores},
        "shift_ft": list(shift),
        "guidance_interval_s": config.guidance_interval,
        "replan_interval_s": replan_interval,
        "report": REPORT_FIGURES,
        "warnings": notes,
        "figures": sorted(FIGURES),
    }
    if law == "avoid":
        rep = runs["report"]
        summary["report_law"] = {**rep.metrics, "warnings": rep.warnings}
        t_rep = rep.metrics["flight_time_s"]
        summary["flight_time_ratio_to_report_law"] = run.metrics["flight_time_s"] / t_rep
    payload = _Flight(case, runs, law, obstacles, clearance_ft)
    return GuideResult("flight", summary, notes, run.metrics, _payload=payload)


def _write_flight(tmp: Path, flight: _Flight, summary: dict[str, Any]) -> None:
    """A flight's figures, CSVs and ``summary.json`` into the existing directory ``tmp``."""
    from rangefx.guidance.plots import save_figures

    case, law, run = flight.case, flight.law, flight.runs[flight.law]
    kw = {}
    if case.scene is not None:
        kw = {
            "image": case.scene.image1,
            "view": (case.scene.camera, case.scene.motion),
            "to_ned": case.frame_map.to_scene,
        }
    compare = flight.runs["report"].result if law == "avoid" else None
    save_figures(
        run.result, tmp, title=f"rangefx guide ({flight.obstacles}, {law})", extents=case.boxes,
        truth=case.truth, clearance_ft=flight.clearance_ft, compare=compare,
        labels=(f"{law} law", "report law"), **kw,
    )  # fmt: skip
    res = run.result
    d_true = np.min([b.signed_distance(res.positions) for b in case.truth], axis=0)
    traj = np.column_stack(
        [
            res.t,
            res.states[:, :3],
            res.states[:, 3],
            np.degrees(res.states[:, 4]),
            np.degrees(res.states[:, 5]),
            res.closest_obstacle_distance(),
            d_true,
        ]
    )
    atomic_write_text(
        tmp / "trajectory.csv",
        _csv(
            "t_s,x_ft,y_ft,z_ft,airspeed_ft_s,gamma_deg,chi_deg,closest_obstacle_ft,"
            "closest_true_vehicle_ft",
            traj,
        ),
    )
    atomic_write_text(tmp / "obstacles.csv", _csv("x_ft,y_ft,z_ft", res.obstacles))
    ext = np.array(
        [
            [*b.centre, math.degrees(b.heading), 2 * b.half_u, 2 * b.half_v, b.top]
            for b in case.boxes
        ]
    ).reshape(-1, 6)
    atomic_write_text(
        tmp / "extents.csv", _csv("x_ft,y_ft,heading_deg,length_ft,width_ft,height_ft", ext)
    )
    atomic_write_text(tmp / "summary.json", _json(summary))


def stress_table(data: dict) -> str:
    """The stress programme's per-layout table and summary as text."""
    head = (
        f"{'layout':<12} {'vehicle':<10} {'t (s)':>6} {'off':>6} {'outcome':<10} "
        f"{'manoeuvre':<10} {'true':>7} {'extent':>7} {'time':>6} {'n':>6} {'|θ|':>5} "
        f"{'|φ|':>5} {'report':>7}"
    )
    lines = [head]
    for r in data["layouts"]:
        lines.append(
            f"{r['name']:<12} {r['vehicle']:<10} {r['path_time_s']:6.1f} {r['offset_ft']:+6.1f} "
            f"{r['outcome']:<10} {r['manoeuvre'] or '-':<10} {r['min_true_distance_ft']:7.2f} "
            f"{r['min_extent_distance_ft']:7.2f} {r['flight_time_ratio']:6.3f} "
            f"{r['max_load_factor']:6.3f} {r['max_abs_theta_deg']:5.1f} "
            f"{r['max_abs_phi_deg']:5.1f} {r['report_law_min_true_distance_ft']:7.2f}"
        )
    s = data["summary"]
    lines.append(
        f"stress ({data['source']}, {s['layouts']} layouts, clearance {data['clearance_ft']:g} "
        f"ft): outcomes {s['outcomes']}, collisions {s['collisions']} (report law "
        f"{s['report_law_collisions']}), crashes {s['crashes']}, landings keeping the "
        f"clearance {s['landings_keeping_clearance']} of {s['outcomes']['landing']}, min true "
        f"distance {s['min_true_distance_ft']:.2f} ft, max load factor "
        f"{s['max_load_factor']:.3f}"
    )
    return "\n".join(lines)
