"""The resumable sweep directory (SPEC §6, §15): one sweep definition's results, state
and derived files in one directory, safe to resume, restart or interrupt.

:func:`sweep_in_dir` runs a sweep definition (:mod:`rangefx.tools.studies.sweep`) into a
directory: ``results.jsonl`` (one line per finished point, appended as it finishes:
running the same definition again after an interruption computes only the missing
points), then the derived files (``points.csv``, Pareto fronts, sensitivity, build-up;
:func:`~rangefx.tools.studies.sweep.write_outputs`) and ``summary.json``
(``complete: true``) once every point is in. ``sweep.json`` records which definition the
directory holds and which files rangefx derived (so a resumed or restarted run removes
only those, never a user's file).
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
from pathlib import Path
from typing import Any

from rangefx.rtl_model.config import loads_json
from rangefx.rtl_model.registry import PIPELINES

from ..errors import UserError, require_memory
from ..interrupts import raise_if_interrupted
from ..report import atomic_write_text
from ..report.lock import output_lock
from ..report.outdir import refuse_links
from ..sweepbound import DEFAULT_SIZE, SWEEP_SECONDS_PER_PIXEL, refuse_too_many_points
from .sweep import MAX_POINTS, RESULTS_NAME, SweepDef, SweepOutcome, load_sweep

__all__ = [
    "SWEEP_BYTES_PER_PIXEL",
    "SWEEP_SECONDS_PER_PIXEL",
    "SWEEP_STATE_NAME",
    "check_point_count",
    "example_path",
    "sweep_in_dir",
]


def example_path() -> Path:
    """Path of the example sweep definition: the first registered pipeline's first."""
    return next(p for pipe in PIPELINES.values() for p in pipe.sweep_example_paths())


def sweep_in_dir(
    definition: str | Path | SweepDef,
    out: str | Path,
    *,
    workers: int = 2,
    scheduler: str | None = None,
    max_points: int = MAX_POINTS,
    restart: bool = False,
    cost: str = "proxy",
    progress: bool = True,
) -> tuple[SweepDef, SweepOutcome, dict[str, Any]]:
    """Run the sweep ``definition`` (a TOML path or a parsed :class:`SweepDef`) into
    directory ``out``, resuming the points already there; return the definition as run,
    the outcome and the summary (``summary.json``).

    ``cost="synth"`` adds the Yosys area metrics to the definition; ``restart`` deletes
    the results and derived files of another definition in ``out`` first (otherwise
    that is a :class:`UserError`). A directory this call created is removed again if it
    fails before its first point.

    Raises
    ------
    UserError
        A bad definition, a directory holding something else, too many points, too
        little memory, or the outputs cannot be written.
    """
    if isinstance(definition, SweepDef):
        defn, source = definition, f"<{definition.name}>"
    else:
        defn, source = load_sweep(definition), str(definition)
    if cost not in ("proxy", "synth"):
        raise UserError(f"unknown sweep cost {cost!r}; choose proxy or synth")
    if cost == "synth" and "synth" not in defn.metrics:
        try:
            defn = dataclasses.replace(defn, metrics=(*defn.metrics, "synth"))
        except ValueError as exc:
            raise UserError(f"--cost synth: {exc}") from None
    if "synth" in defn.metrics:
        from .synth import yosys_version

        yosys_version()  # one error line now if yosys is missing, not one per point
    out = Path(out)
    with output_lock(out):  # one writer per sweep directory (re-entered under the CLI's)
        if out.exists() and not out.is_dir():
            raise UserError(f"output path {str(out)!r} exists and is not a directory")
        if out.is_dir() and any(out.iterdir()) and not (out / RESULTS_NAME).exists():
            raise UserError(
                f"output directory {str(out)!r} is not empty and holds no sweep results; "
                "choose a new directory"
            )
        m, n = defn.size or DEFAULT_SIZE
        check_point_count(defn, m * n, max_points, 1 if scheduler else workers)
        require_memory(
            f"sweep {defn.name!r}: size [{m}, {n}] with --workers {workers}",
            m * n * SWEEP_BYTES_PER_PIXEL * (1 if scheduler else workers),
        )
        identity, keys = _sweep_identity(defn, source, max_points)
        outcome, summary = _sweep_locked(
            defn, out, identity, keys, workers, scheduler, max_points, restart, progress
        )
    return defn, outcome, summary


def _sweep_locked(
    defn: SweepDef,
    out: Path,
    identity: dict[str, Any],
    keys: set[str],
    workers: int,
    scheduler: str | None,
    max_points: int,
    restart: bool,
    progress: bool,
) -> tuple[SweepOutcome, dict[str, Any]]:
    from .sweep import run_sweep, write_outputs

    fresh = not out.exists()
    try:
        refuse_links(out, (RESULTS_NAME, SWEEP_STATE_NAME))
        state = _claim_sweep_dir(out, identity, keys, restart=restart)
        # a resumed sweep is incomplete until it finishes: the derived files of the earlier
        # run (rangefx's own, listed in sweep.json) go, the user's files stay
        for name in state.get("outputs", []):
            if _own_plain_file(out, name):
                with contextlib.suppress(FileNotFoundError):
                    (out / name).unlink()
        _write_state(out, {**identity, "outputs": []})
        outcome = run_sweep(
            defn, out, workers=workers, scheduler=scheduler, progress=progress,
            max_points=max_points,
        )  # fmt: skip
    except BaseException:
        if fresh:
            _remove_if_no_results(out)
        raise
    raise_if_interrupted()  # an interrupt a finaliser swallowed: no summary "complete"
    before = _file_stamps(out)
    try:
        summary = write_outputs(defn, outcome, out)
    except OSError as exc:  # each is written whole or not at all; summary.json comes last
        raise UserError(
            f"cannot write the sweep's outputs in {str(out)!r}: {exc.strerror}; its "
            f"{len(outcome.records)} results are saved: free space, then re-run the same "
            "command to write them"
        ) from None
    # rangefx's derived files: those write_outputs created or replaced (each is written
    # to a temporary file and renamed, so it has a new inode); the user's are unchanged
    written = sorted(
        name for name, stamp in _file_stamps(out).items()
        if before.get(name) != stamp and name not in (RESULTS_NAME, SWEEP_STATE_NAME)
    )  # fmt: skip
    _write_state(out, {**identity, "outputs": written})
    return outcome, summary


#: Peak bytes per pixel of one point in flight (scene, golden and fixed-point taps with the
#: sqnr metrics; about 1.2 KiB measured on lab, doubled for headroom).
SWEEP_BYTES_PER_PIXEL = 2048


def check_point_count(defn: SweepDef, pixels: int, max_points: int, workers: int) -> None:
    """Refuse, before a point is listed or a scene rendered, a sweep of more than
    ``max_points`` points, with its count and estimated time."""
    from .sweep import point_count

    refuse_too_many_points(defn.name, defn.pipeline, point_count(defn), pixels, max_points, workers)


#: The sweep directory's own record: which definition it holds and which files rangefx
#: derived from the results (so a resumed or restarted run removes only those).
SWEEP_STATE_NAME = "sweep.json"


def _sweep_identity(
    defn: SweepDef, source: str, max_points: int = MAX_POINTS
) -> tuple[dict[str, Any], set[str]]:
    """What sweep.json records of a definition (its hash: of its name and the keys of
    all its points, i.e. of everything that decides the results) and those point keys."""
    from .sweep import expand

    keys = {p.key for p in expand(defn, max_points)}
    digest = hashlib.sha256(json.dumps([defn.name, sorted(keys)]).encode()).hexdigest()
    return {"name": defn.name, "definition_sha256": digest, "definition": str(source)}, keys


def _file_stamps(out: Path) -> dict[str, tuple[int, int]]:
    return {
        p.name: (p.stat().st_ino, p.stat().st_mtime_ns)
        for p in out.iterdir()
        if p.is_file() and not p.name.startswith(".")
    }


def _own_plain_file(out: Path, name: object) -> bool:
    """``name`` (from sweep.json) is a derived file rangefx may delete: a plain name in
    ``out``, not the results or the state, and not a link the user put there."""
    return (
        isinstance(name, str)
        and name not in ("", ".", "..", RESULTS_NAME, SWEEP_STATE_NAME)
        and Path(name).name == name
        and not (out / name).is_symlink()
    )


def _remove_if_no_results(out: Path) -> None:
    """Undo the creation of sweep directory ``out`` by a run that failed or was stopped
    before its first point (an unreachable ``--scheduler`` left an empty directory):
    only if it holds nothing but an empty ``results.jsonl`` and ``sweep.json``."""
    try:
        names = {p.name for p in out.iterdir()}
        if not names <= {RESULTS_NAME, SWEEP_STATE_NAME}:
            return
        results = out / RESULTS_NAME
        if results.exists() and (results.is_symlink() or results.stat().st_size):
            return
        for name in names:
            (out / name).unlink()
        out.rmdir()
    except OSError:
        pass


def _write_state(out: Path, state: dict[str, Any]) -> None:
    try:
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / SWEEP_STATE_NAME, json.dumps(state, indent=1) + "\n")
    except OSError as exc:
        raise UserError(f"cannot write sweep directory {str(out)!r}: {exc.strerror}") from None


def _claim_sweep_dir(
    out: Path, identity: dict[str, Any], keys: set[str], *, restart: bool
) -> dict[str, Any]:
    """The earlier state of sweep directory ``out``, after checking that it holds this
    sweep (or nothing); ``restart`` deletes the earlier results and derived files first.

    Raises
    ------
    UserError
        ``out`` holds the results of another sweep definition, and ``restart`` is off.
    """
    from .sweep import load_results

    path = out / SWEEP_STATE_NAME
    state: dict[str, Any] = {}
    if path.is_file():
        try:
            state = loads_json(path.read_bytes())
            if not isinstance(state, dict):
                raise ValueError
        except (ValueError, UnicodeDecodeError):
            raise UserError(f"{path} is not a rangefx sweep state file") from None
    results = out / RESULTS_NAME
    if not results.exists() and not state:
        return {}
    if results.exists() and not results.is_file():  # not ours: --restart must not delete it
        raise UserError(
            f"{results} is not a file (rangefx writes its sweep results there); move it "
            "away or choose another --out"
        )
    if restart:
        for name in [RESULTS_NAME, *state.get("outputs", [])]:
            if name == RESULTS_NAME or _own_plain_file(out, name):
                with contextlib.suppress(FileNotFoundError):
                    (out / name).unlink()
        return {}
    if state:
        same = state.get("definition_sha256") == identity["definition_sha256"]
    else:  # a directory from before sweep.json: its records must be this sweep's points
        same = set(load_results(results)) <= keys
    if not same:
        raise UserError(
            f"sweep directory {str(out)!r} holds results of another sweep definition "
            f"({state.get('name', 'unknown')!r}, from {state.get('definition', 'unknown')}); "
            "choose another --out, or add --restart to delete those results and start over"
        )
    return state
