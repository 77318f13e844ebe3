"""``rangefx sweep`` and ``rangefx optimise``: word-length studies of every pipeline of
the registry (SPEC §6, §8, §10).

``rangefx sweep DEF.toml --out DIR [--scheduler ADDR] [--workers N] [--json]`` runs a
sweep definition (:mod:`rangefx.tools.studies.sweep`; its ``[sweep] pipeline`` names the
pipeline, default ``p1``; examples ``tools/studies/sweeps/p1_lab.toml`` and
``p2_lab.toml``, ``rangefx sweep --example`` prints the first's path) and writes to
``DIR``: ``results.jsonl``
(one line per finished point, appended as it finishes: re-running the same command
after an interruption computes only the missing points), then ``points.csv``,
``pareto_<scene>.png/.csv``, ``sensitivity.png/.csv``, ``buildup_base.png`` + CSV (the
pipeline's own error build-up: P1's row and column filters, P2's backward sweep) and
``summary.json`` (``complete: true``) once every point is in.

``rangefx optimise [--pipeline NAME] --scene lab [runway motorcycle ...] --budget 0.01
[--agreement 0.99] [--margin M] [--verify SCENE] [--config PATH] [--variant V]
[--divider D] [--pole C] [--bias B] [--size H W] [--workers N] [--out DIR] [--json]``
finds the cheapest config of the pipeline meeting the budget on every tuning scene
(:mod:`rangefx.tools.studies.optimiser`; with ``--margin M`` the budget tightened by the
guard band M while tuning, JSON ``tuning_budget``) and prints it (TOML), ``cost_bits`` and
``default_cost_bits`` (the shipped default formats under the start's design fields) on
the first tuning scene's shape and mode (the cost minimised),
the accuracy and cost on each tuning scene (JSON ``scenes``; the top-level
``median_rel_range_diff``, ``p95_rel_range_diff`` and ``valid_agreement`` are the worst
case over them, reported against the user's budget) and on the verification scene
(``verify``), which must not be a tuning scene. A tuning or verification scene is a
synthetic preset (rendered at ``--size``) or ``motorcycle``, the real Middlebury pair
(:func:`rangefx.tools.studies.runner.real_pair_case`, its own 26x39 size); ``--verify`` also
takes ``plane``, a synthetic scene held out of tuning (``--scene plane`` is a one-line
error; :func:`rangefx.tools.studies.runner.held_out_case`, rendered at ``--size``).
Every scene must be of a mode the pipeline models (P2 is stereo only: ``runway`` is a
one-line error), and a design option the pipeline has no field for (``--variant``,
``--pole``, ``--bias`` with P2) is a one-line error
(:func:`rangefx.tools.cli.options.design_from_args`).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import hashlib
import json
import sys
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any

from rangefx.golden.scenes import SCENE_NAMES
from rangefx.rtl_model.config import WordLengthConfig, loads_json
from rangefx.rtl_model.pipeline import Case, Pipeline
from rangefx.rtl_model.registry import PIPELINES

from ..errors import UserError, require_memory
from ..interrupts import raise_if_interrupted
from ..report import atomic_output_dir, atomic_write_text, json_safe
from ..report.outdir import refuse_links
from ..studies.cases import HELD_OUT_SCENES, REAL_PAIRS, held_out_case, real_pair_case
from ..studies.runner import load_config
from ..studies.sweep import MAX_POINTS, RESULTS_NAME
from .options import (
    add_design_args,
    add_pipeline_arg,
    design_from_args,
    int_at_least,
    out_path,
    pipeline_from_args,
)

_positive_int = int_at_least(1)

__all__ = [
    "DEFAULT_MARGIN",
    "TUNING_SCENES",
    "VERIFY_SCENES",
    "add_parser",
    "cmd_optimise",
    "cmd_sweep",
    "example_path",
]

#: ``rangefx optimise``'s guard band (``--margin``): the smallest measured margin at which
#: the median on the real pair held out of lab + runway tuning stays within a 1 % budget
#: (docs/wordlength.md, "Guard band"). :func:`rangefx.tools.studies.optimiser.optimise`
#: defaults to 0.
DEFAULT_MARGIN = 0.5

#: Scenes ``--scene`` accepts: the synthetic presets and the real pairs.
TUNING_SCENES: tuple[str, ...] = (*SCENE_NAMES, *REAL_PAIRS)
#: Scenes ``--verify`` accepts: the tuning scenes and the held-out synthetic ones.
VERIFY_SCENES: tuple[str, ...] = (*TUNING_SCENES, *HELD_OUT_SCENES)


def example_path() -> Path:
    """Path of the shipped example sweep definition."""
    return Path(str(resources.files("rangefx.tools.studies").joinpath("sweeps", "p1_lab.toml")))


def cmd_sweep(args: argparse.Namespace) -> int:
    from ..studies.sweep import load_sweep, run_sweep, write_outputs

    if args.example:
        print(example_path())
        return 0
    if not args.definition or not args.out:
        raise UserError("sweep needs a definition file and --out DIR (or --example)")
    defn = load_sweep(args.definition)
    if args.cost == "synth" and "synth" not in defn.metrics:
        try:
            defn = dataclasses.replace(defn, metrics=(*defn.metrics, "synth"))
        except ValueError as exc:
            raise UserError(f"--cost synth: {exc}") from None
    if "synth" in defn.metrics:
        from ..studies.synth import yosys_version

        yosys_version()  # one error line now if yosys is missing, not one per point
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UserError(f"output path {str(out)!r} exists and is not a directory")
    if out.is_dir() and any(out.iterdir()) and not (out / "results.jsonl").exists():
        raise UserError(
            f"output directory {str(out)!r} is not empty and holds no sweep results; "
            "choose a new directory"
        )
    m, n = defn.size or (512, 512)  # the presets' default size
    _check_point_count(defn, m * n, args.max_points, 1 if args.scheduler else args.workers)
    require_memory(
        f"sweep {defn.name!r}: size [{m}, {n}] with --workers {args.workers}",
        m * n * SWEEP_BYTES_PER_PIXEL * (1 if args.scheduler else args.workers),
    )
    identity, keys = _sweep_identity(defn, args.definition, args.max_points)
    fresh = not out.exists()
    try:
        refuse_links(out, (RESULTS_NAME, SWEEP_STATE_NAME))
        state = _claim_sweep_dir(out, identity, keys, restart=args.restart)
        # a resumed sweep is incomplete until it finishes: the derived files of the earlier
        # run (rangefx's own, listed in sweep.json) go, the user's files stay
        for name in state.get("outputs", []):
            if _own_plain_file(out, name):
                with contextlib.suppress(FileNotFoundError):
                    (out / name).unlink()
        _write_state(out, {**identity, "outputs": []})
        outcome = run_sweep(
            defn, out, workers=args.workers, scheduler=args.scheduler, progress=not args.json,
            max_points=args.max_points,
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
    if args.json:
        print(json.dumps(json_safe(summary)))
    else:
        print(
            f"sweep {defn.name!r}: {summary['n_points']} points ({summary['n_ok']} ran, "
            f"{summary['n_invalid']} invalid configs), {summary['computed_this_run']} computed "
            f"now in {summary['wall_seconds_this_run']:.1f} s; results in {out}"
        )
        for scene, front in summary["pareto"].items():
            print(f"Pareto front on {scene}: {len(front)} configs")
    return 0


#: Peak bytes per pixel of one point in flight (scene, golden and fixed-point taps with the
#: sqnr metrics; about 1.2 KiB measured on lab, doubled for headroom).
SWEEP_BYTES_PER_PIXEL = 2048
#: Seconds of one point per pixel: P1 with the golden metrics on lab at 256x256, median
#: of 6 points 0.057 s (AMD EPYC, 2 cores; ``rangefx sweep`` of row_state.frac 6..11).
SWEEP_SECONDS_PER_PIXEL = 0.9e-6


def _check_point_count(defn, pixels: int, max_points: int, workers: int) -> None:
    """Refuse, before a point is listed or a scene rendered, a sweep of more than
    ``max_points`` points, with its count and estimated time."""
    from ..studies.sweep import point_count

    count = point_count(defn)
    if count > max_points:
        hours = count * pixels * SWEEP_SECONDS_PER_PIXEL / workers / 3600
        raise UserError(
            f"sweep {defn.name!r}: {count} points (about {hours:.3g} hours at "
            f"{pixels * SWEEP_SECONDS_PER_PIXEL:.2g} s a point with {workers} workers), more "
            f"than --max-points {max_points}; narrow the axes or raise --max-points"
        )


#: The sweep directory's own record: which definition it holds and which files rangefx
#: derived from the results (so a resumed or restarted run removes only those).
SWEEP_STATE_NAME = "sweep.json"


def _sweep_identity(
    defn, source: str, max_points: int = MAX_POINTS
) -> tuple[dict[str, Any], set[str]]:
    """What sweep.json records of a definition (its hash: of its name and the keys of
    all its points, i.e. of everything that decides the results) and those point keys."""
    from ..studies.sweep import expand

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
    from ..studies.sweep import load_results

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


def _case(pipe: Pipeline, name: str, size: list[int] | None, flag: str) -> Case:
    """A synthetic scene preset or held-out scene (rendered at ``size``) or a real pair
    (its own size); a scene of a mode ``pipe`` does not model is a :class:`UserError`
    naming ``flag``."""
    from ..studies.cases import scene_case

    if name in REAL_PAIRS:
        case = real_pair_case(name)
    elif name in HELD_OUT_SCENES:
        case = held_out_case(name, tuple(size) if size else None)
    else:
        case = scene_case(name, size)
    try:
        pipe.check_mode(case)
    except ValueError as exc:
        raise UserError(f"{flag} {name}: {exc}") from None
    return case


def _default_for(pipe: Pipeline, start: WordLengthConfig) -> WordLengthConfig:
    """The shipped default formats under ``start``'s design fields (so that the cost
    difference is the word lengths alone); the shipped default itself if those design
    fields do not validate with its formats."""
    try:
        return pipe.default_config(**start.design())
    except ValueError:
        return pipe.default_config()


def _figures(figs: dict[str, Any]) -> dict[str, Any]:
    keys = ("median_rel_range_diff", "p95_rel_range_diff", "valid_agreement", "saturated_registers")
    return {k: figs[k] for k in keys}


def _synth_cost(pipe: Pipeline, args: argparse.Namespace, case: Case) -> Callable[[Any], float]:
    """``--cost synth``: the Yosys LUT + FF of the whole P1 on the first tuning scene's
    shape and mode (:func:`rangefx.tools.studies.synth.synth_p1`, cached per stage)."""
    from ..studies.synth import synth_p1, yosys_version

    if pipe.name != "p1":
        raise UserError(f"--cost synth: only P1 has RTL in hdl/, not {pipe.name}")
    yosys_version()  # a one-line error when yosys is missing, before any run

    def cost(config) -> float:
        area = synth_p1(config, args.synth_target, case.shape, case.mode)
        return float(area["lut"] + area["ff"])

    return cost


def cmd_optimise(args: argparse.Namespace) -> int:
    from ..studies.optimiser import Budget, evaluate, optimise

    try:
        budget = Budget(args.budget, args.agreement)
    except ValueError as exc:
        raise UserError(f"--budget/--agreement: {exc}") from None
    tuning = budget.tightened(args.margin)  # a one-line UserError for a bad --margin
    pipe = pipeline_from_args(args)
    start = load_config(pipe, args.config, **design_from_args(pipe, args))
    if args.signals:
        from ..studies.sweep import check_signals

        try:
            check_signals(args.signals, start)
        except ValueError as exc:
            raise UserError(f"--signals: {exc}") from None
    scenes: list[str] = list(args.scene)
    held = [s for s in scenes if s in HELD_OUT_SCENES]
    if held:
        raise UserError(
            f"--scene {held[0]}: it is held out of tuning, for --verify only; tune on "
            f"{', '.join(TUNING_SCENES)}"
        )
    if len(set(scenes)) != len(scenes):
        raise UserError(f"--scene: a scene is named twice in {scenes}")
    if args.verify in scenes:
        raise UserError(
            f"--verify {args.verify}: it is a tuning scene; verify on one the optimiser did "
            f"not see ({', '.join(s for s in VERIFY_SCENES if s not in scenes)})"
        )
    m, n = args.size or (512, 512)  # the presets' default size
    require_memory(
        f"optimise --size {m} {n} with --workers {args.workers}",
        m * n * SWEEP_BYTES_PER_PIXEL * args.workers,
    )
    default = _default_for(pipe, start)
    cases = [_case(pipe, name, args.size, "--scene") for name in scenes]
    vcase = _case(pipe, args.verify, args.size, "--verify") if args.verify else None
    synth_cost = _synth_cost(pipe, args, cases[0]) if args.cost == "synth" else None
    fmax = None
    if args.fmax_min is not None:
        from ..studies.optimiser import FmaxConstraint
        from ..studies.timing import TimingOptions, fmax_measure

        timing = TimingOptions(stage=args.timing_stage, speed=args.timing_speed)
        measure = fmax_measure(cases[0].shape, cases[0].mode, timing, pipe.name)
        try:
            fmax = FmaxConstraint(args.fmax_min, measure)
        except ValueError as exc:
            raise UserError(f"--fmax-min: {exc}") from None
    res = optimise(
        cases, start, budget, pipeline=pipe, margin=args.margin, signals=args.signals,
        tune_registers=args.tune_registers, workers=args.workers, progress=not args.json,
        cost_fn=synth_cost, fmax=fmax,
    )  # fmt: skip
    case = cases[0]
    shape, mode = case.shape, case.mode
    cost = pipe.cost(res.config, shape, mode)
    dcost = pipe.cost(default, shape, mode)
    per_scene: dict[str, Any] = {}
    for name, c, figs, sfigs, runs in zip(
        scenes, cases, res.scene_figures, res.start_scene_figures, res.scene_runs, strict=True
    ):
        per_scene[name] = {
            "mode": c.mode,
            "size": list(c.shape),
            **_figures(figs),
            "start_median_rel_range_diff": sfigs["median_rel_range_diff"],
            "start_valid_agreement": sfigs["valid_agreement"],
            "cost_bits": pipe.cost(res.config, c.shape, c.mode).cost_bits,
            "default_cost_bits": pipe.cost(default, c.shape, c.mode).cost_bits,
            "runs": runs,
        }
    figures: dict[str, Any] = {
        "pipeline": pipe.name,
        "golden": pipe.golden_label(start),
        "scene": scenes[0],
        "tuning_scenes": scenes,
        "mode": mode,
        "size": list(shape),
        **({"variant": start.variant} if "variant" in start.design_fields() else {}),
        "design": start.design(),
        "budget": {"median_rel_range_diff": budget.median, "valid_agreement": budget.agreement},
        "margin": args.margin,
        "tuning_budget": {
            "median_rel_range_diff": tuning.median,
            "valid_agreement": tuning.agreement,
        },
        "tune_registers": args.tune_registers,
        "config_toml": res.config.to_toml(),
        "cost_scene": scenes[0],
        "cost_bits": cost.cost_bits,
        "default_cost_bits": dcost.cost_bits,
        "bits_saved": dcost.cost_bits - cost.cost_bits,
        "cost": cost.as_dict(),
        "default_cost": dcost.as_dict(),
        "median_rel_range_diff": res.figures["median_rel_range_diff"],
        "p95_rel_range_diff": res.figures["p95_rel_range_diff"],
        "valid_agreement": res.figures["valid_agreement"],
        "start_median_rel_range_diff": res.start_figures["median_rel_range_diff"],
        "start_valid_agreement": res.start_figures["valid_agreement"],
        "scenes": per_scene,
        "evaluations": res.evaluations,
        "seconds": res.seconds,
        "steps": res.steps,
    }
    if synth_cost is not None:
        figures["synth_cost"] = {
            "cost": "lut + ff",
            "target": args.synth_target,
            **{k: synth_cost(c) for k, c in (("start", start), ("default", default),
                                             ("optimised", res.config))},
        }  # fmt: skip
    if fmax is not None:
        figures["fmax"] = {"minimum_mhz": args.fmax_min, **timing.as_dict(), **res.fmax_mhz}
    if vcase is not None:
        golden = pipe.golden(vcase, res.config).result
        fig_opt = evaluate(vcase, res.config, golden, pipeline=pipe)
        fig_def = evaluate(vcase, default, golden, pipeline=pipe)
        if fig_opt is None:
            raise UserError(f"the optimised config cannot run on {args.verify!r}")
        figures["verify"] = {
            "scene": args.verify,
            "mode": vcase.mode,
            "size": list(vcase.shape),
            **_figures(fig_opt),
            "meets_budget": budget.met(fig_opt),
            "default_median_rel_range_diff": fig_def["median_rel_range_diff"] if fig_def else None,
            "default_valid_agreement": fig_def["valid_agreement"] if fig_def else None,
            "default_saturated_registers": fig_def["saturated_registers"] if fig_def else None,
            "cost_bits": pipe.cost(res.config, vcase.shape, vcase.mode).cost_bits,
            "default_cost_bits": pipe.cost(default, vcase.shape, vcase.mode).cost_bits,
        }
    if args.out:
        _write_optimise_out(Path(args.out), pipe, res, figures, case)
    if args.json:
        print(json.dumps(json_safe(figures)))
        return 0
    sys.stdout.write(res.config.to_toml())
    print(
        f"# {pipe.name} cost_bits on {scenes[0]} {cost.cost_bits} (default {dcost.cost_bits}, "
        f"saved {figures['bits_saved']}); DSP {cost.dsp} (default {dcost.dsp}); BRAM18 "
        f"{cost.bram18} (default {dcost.bram18}); {res.evaluations} runs, {res.seconds:.1f} s"
    )
    if fmax is not None:
        f = figures["fmax"]
        print(f"# Fmax ({f['stage']}, speed {f['speed']}) {f['optimised']:.1f} MHz (start "
              f"{f['start']:.1f}; floor --fmax-min {args.fmax_min:g})")  # fmt: skip
    if args.margin:
        print(
            f"# tuned with margin {args.margin}: median_rel_range_diff <= {tuning.median:.4g}, "
            f"valid_agreement >= {tuning.agreement:.6g} on every tuning scene (budget "
            f"{budget.median:.4g}, {budget.agreement:.6g})"
        )
    for name, sf in per_scene.items():
        print(
            f"# {name} ({sf['mode']}): median_rel_range_diff {sf['median_rel_range_diff']:.3e}, "
            f"valid_agreement {sf['valid_agreement']:.5f}, cost_bits {sf['cost_bits']} "
            f"(default {sf['default_cost_bits']})"
        )
    if args.verify:
        v = figures["verify"]
        print(
            f"# verify {args.verify} ({v['mode']}): median_rel_range_diff "
            f"{v['median_rel_range_diff']:.3e}, valid_agreement {v['valid_agreement']:.5f}, "
            f"meets budget: {v['meets_budget']}"
        )
    return 0


def _write_optimise_out(
    out: Path, pipe: Pipeline, res: Any, figures: dict[str, Any], case: Case
) -> None:
    """optimised.toml, the build-up plots of the result and of the start on the first
    tuning scene (:func:`rangefx.tools.studies.buildup.buildup_for`), summary.json."""
    from ..report.wlplots import save_buildup
    from ..studies.buildup import PROFILE_AXES, buildup_for

    # as every other command: filled aside, then put in place; the user's files are kept
    with atomic_output_dir(out) as tmp:
        atomic_write_text(tmp / "optimised.toml", res.config.to_toml())
        for stem, cfg in (("buildup_optimised", res.config), ("buildup_start", res.start)):
            title = f"{pipe.name} " + stem.replace("_", " ").replace("buildup", "build-up,")
            save_buildup(tmp, stem, buildup_for(pipe, case, cfg), title, xlabels=PROFILE_AXES)
        atomic_write_text(tmp / "summary.json", json.dumps(json_safe(figures), indent=2) + "\n")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("sweep", help="word-length sweep of any pipeline (resumable, local or dask)")
    p.add_argument("definition", nargs="?", help="sweep definition TOML")
    p.add_argument(
        "--out", type=out_path, help="output directory (re-run the same command to resume)"
    )
    p.add_argument("--scheduler", help="address of a dask.distributed scheduler")
    p.add_argument("--workers", type=_positive_int, default=2, help="local threads (default 2)")
    p.add_argument("--example", action="store_true", help="print the example definition's path")
    p.add_argument("--cost", choices=("proxy", "synth"), default="proxy",
                   help="cost axis of the Pareto fronts: proxy (cost_bits, default) or synth "
                   "(Yosys xcup LUT + FF of the P1 RTL per point, cached; adds the synth "
                   "metrics)")  # fmt: skip
    p.add_argument(
        "--restart", action="store_true",
        help="delete the results of an earlier sweep in --out (another definition) and start over",
    )  # fmt: skip
    p.add_argument(
        "--max-points", type=_positive_int, default=MAX_POINTS,
        help=f"refuse a sweep of more points (default {MAX_POINTS})",
    )  # fmt: skip
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.set_defaults(func=cmd_sweep)
    p = sub.add_parser("optimise", help="cheapest word lengths meeting an accuracy budget")
    add_pipeline_arg(p)
    p.add_argument("--scene", choices=VERIFY_SCENES, nargs="+", default=["lab"],
                   help="tuning scene(s): a config must meet the budget on every one; the "
                   "cost minimised is the first's (default lab; motorcycle: the real "
                   "Middlebury pair, stereo; plane is held out: --verify only)")  # fmt: skip
    p.add_argument("--budget", type=float, default=0.01,
                   help="max median relative range error vs golden, on every tuning scene "
                   "(default 0.01)")  # fmt: skip
    p.add_argument("--agreement", type=float, default=0.99,
                   help="min validity agreement with golden, on every tuning scene "
                   "(default 0.99)")  # fmt: skip
    p.add_argument("--margin", type=float, default=DEFAULT_MARGIN,
                   help="guard band M in [0, 1): while tuning, a candidate must meet median "
                   "<= budget*(1-M) and disagreement <= (1-agreement)*(1-M); the result is "
                   f"reported against the budget itself (default {DEFAULT_MARGIN}; 0: no "
                   "guard band)")  # fmt: skip
    p.add_argument("--verify", choices=VERIFY_SCENES,
                   help="scene to verify the result on (not a tuning scene; motorcycle: the "
                   "real Middlebury pair, stereo; plane: a synthetic textured plane no "
                   "tuning run may use)")  # fmt: skip
    add_design_args(p)  # --config: the starting (safe) config; design options per pipeline
    p.add_argument("--size", type=_positive_int, nargs=2, metavar=("H", "W"),
                   help="render synthetic scenes at this size (not motorcycle)")  # fmt: skip
    p.add_argument("--signals", nargs="+",
                   help="only these signals, host registers included if named (default: "
                   "all but the input pixel and the host-written registers, see "
                   "--tune-registers)")  # fmt: skip
    registers = "; ".join(
        f"{name}: {', '.join(pipe.config_type.HOST_REGISTERS)}" for name, pipe in PIPELINES.items()
    )
    p.add_argument("--tune-registers", action="store_true",
                   help=f"also narrow the host-written registers ({registers}); off by default: "
                   "their formats must cover every camera and geometry the "
                   "host may load (focal length, baseline, thresholds), which tuning scenes "
                   "do not sample, so they keep the starting config's formats")  # fmt: skip
    p.add_argument("--workers", type=_positive_int, default=2, help="concurrent runs (default 2)")
    p.add_argument("--cost", choices=("proxy", "synth"), default="proxy",
                   help="cost minimised: proxy (cost_bits, default) or synth (Yosys LUT + FF "
                   "of the whole P1: a narrowing that does not lower it is not kept)")  # fmt: skip
    p.add_argument("--synth-target", choices=("xc7", "xcup", "ecp5", "ice40"), default="xcup",
                   help="Yosys target of --cost synth (default xcup)")  # fmt: skip
    p.add_argument("--fmax-min", type=float, metavar="MHZ",
                   help="P1: keep a narrowing only if the RTL still places and routes at "
                   ">= MHZ (Yosys + nextpnr-ecp5, LFE5U-85F, one seed, cached; the start must "
                   "meet it too)")  # fmt: skip
    p.add_argument("--timing-stage", choices=("top", "frontend"), default="top",
                   help="what --fmax-min times: all of P1 (default) or one front end")  # fmt: skip
    p.add_argument("--timing-speed", type=int, choices=(6, 7, 8), default=6,
                   help="ECP5 speed grade of --fmax-min (default 6)")  # fmt: skip
    p.add_argument(
        "--out", type=out_path, help="write optimised.toml, build-up plots and summary.json here"
    )
    p.add_argument("--json", action="store_true",
                   help="print the figures as one JSON object (top-level accuracy: worst case "
                   "over the tuning scenes; per scene under 'scenes')")  # fmt: skip
    p.set_defaults(func=cmd_optimise)
