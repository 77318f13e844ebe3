"""Word-length optimisation on named scenes, verified on a held-out one, with its report
(SPEC §6, §15): what ``rangefx optimise`` computes, as one call.

:func:`optimise_on_scenes` tunes a pipeline's config with
:func:`rangefx.tools.studies.optimiser.optimise` on one or more tuning scenes (synthetic
presets rendered at ``size``, or ``motorcycle``, the real Middlebury pair), then measures
the result against the user's budget on every tuning scene and on a verification scene the
optimiser did not see (a tuning scene not used, or ``plane``, a synthetic scene held out of
all tuning: :func:`rangefx.tools.studies.cases.held_out_case`). The
:class:`OptimiseReport` holds the result, its figures (costs against the shipped default,
accuracy per scene, the worst case over the tuning scenes) and writes
``optimised.toml``, the build-up plots and ``summary.json``.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rangefx.golden.scenes import SCENE_NAMES
from rangefx.rtl_model.config import WordLengthConfig
from rangefx.rtl_model.pipeline import Case, Pipeline

from ..errors import UserError, require_memory
from ..report import atomic_output_dir, atomic_write_text, json_safe
from .cases import HELD_OUT_SCENES, REAL_PAIRS, held_out_case, real_pair_case, scene_case
from .optimiser import Budget, OptimiseResult
from .sweepdir import SWEEP_BYTES_PER_PIXEL

__all__ = [
    "DEFAULT_MARGIN",
    "TUNING_SCENES",
    "VERIFY_SCENES",
    "OptimiseReport",
    "optimise_on_scenes",
    "tuning_case",
]

#: ``rangefx optimise``'s guard band (``--margin``): the smallest measured margin at which
#: the median on the real pair held out of lab + runway tuning stays within a 1 % budget
#: (docs/wordlength.md, "Guard band"). :func:`rangefx.tools.studies.optimiser.optimise`
#: defaults to 0.
DEFAULT_MARGIN = 0.5
#: Scenes a config may be tuned on: the synthetic presets and the real pairs.
TUNING_SCENES: tuple[str, ...] = (*SCENE_NAMES, *REAL_PAIRS)
#: Scenes a result may be verified on: the tuning scenes and the held-out synthetic ones.
VERIFY_SCENES: tuple[str, ...] = (*TUNING_SCENES, *HELD_OUT_SCENES)
_FIGURE_KEYS = ("median_rel_range_diff", "p95_rel_range_diff", "valid_agreement",
                "saturated_registers")  # fmt: skip


@dataclass(frozen=True)
class OptimiseReport:
    """An optimisation with its verification: the pipeline, the optimiser's
    :class:`~rangefx.tools.studies.optimiser.OptimiseResult`, the first tuning scene's case
    (whose shape and mode the cost is measured on) and the figures (``summary.json``:
    ``cost_bits`` / ``default_cost_bits``, the worst case over the tuning scenes at the top
    level, each scene under ``scenes``, the verification scene under ``verify``)."""

    pipeline: Pipeline
    result: OptimiseResult
    case: Case
    figures: dict[str, Any]

    @property
    def config(self) -> WordLengthConfig:
        """The optimised config."""
        return self.result.config

    def to_dict(self) -> dict[str, Any]:
        """The figures as JSON-able values (``rangefx optimise --json``)."""
        return json_safe(self.figures)

    def write(self, out: str | Path) -> Path:
        """Write ``optimised.toml``, the build-up plots of the result and of the start on
        the first tuning scene and ``summary.json`` into directory ``out``, atomically
        (:func:`rangefx.tools.report.atomic_output_dir`: a user's files are kept)."""
        from ..report.wlplots import save_buildup
        from .buildup import buildup_for

        res, pipe = self.result, self.pipeline
        with atomic_output_dir(Path(out)) as tmp:
            atomic_write_text(tmp / "optimised.toml", res.config.to_toml())
            for stem, cfg in (("buildup_optimised", res.config), ("buildup_start", res.start)):
                title = f"{pipe.name} " + stem.replace("_", " ").replace("buildup", "build-up,")
                save_buildup(
                    tmp, stem, buildup_for(pipe, self.case, cfg), title, xlabels=pipe.buildup_axes
                )
            atomic_write_text(tmp / "summary.json", json.dumps(self.to_dict(), indent=2) + "\n")
        return Path(out)


def tuning_case(pipe: Pipeline, name: str, size: Sequence[int] | None, flag: str) -> Case:
    """A synthetic scene preset or held-out scene (rendered at ``size``) or a real pair
    (its own size); a scene of a mode ``pipe`` does not model is a :class:`UserError`
    naming ``flag``."""
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
    return {k: figs[k] for k in _FIGURE_KEYS}


def _synth_cost(pipe: Pipeline, target: str, case: Case) -> Callable[[Any], float]:
    """``cost="synth"``: the Yosys LUT + FF of the pipeline's whole top (any pipeline of
    :data:`rangefx.tools.studies.synth.RTL_TOPS`) on the first tuning scene's shape and
    mode (:func:`rangefx.tools.studies.synth.synth_record`, cached per design)."""
    from .synth import RTL_TOPS, synth_record, yosys_version

    if pipe.name not in RTL_TOPS:
        raise UserError(f"--cost synth: pipeline {pipe.name} has no RTL in hdl/ (only "
                        f"{', '.join(RTL_TOPS)}): nothing to synthesise")  # fmt: skip
    modes = RTL_TOPS[pipe.name].modes
    if case.mode not in modes:
        raise UserError(f"--cost synth: {pipe.name} has no {case.mode} mode in hdl/ (it has "
                        f"{', '.join(modes)})")  # fmt: skip
    yosys_version()  # a one-line error when yosys is missing, before any run

    def cost(config) -> float:
        return float(synth_record(config, case.shape, case.mode, target, pipe.name)["synth_cost"])

    return cost


def _check_scenes(scenes: list[str], verify: str | None) -> None:
    held = [s for s in scenes if s in HELD_OUT_SCENES]
    if held:
        raise UserError(
            f"--scene {held[0]}: it is held out of tuning, for --verify only; tune on "
            f"{', '.join(TUNING_SCENES)}"
        )
    if len(set(scenes)) != len(scenes):
        raise UserError(f"--scene: a scene is named twice in {scenes}")
    if verify in scenes:
        raise UserError(
            f"--verify {verify}: it is a tuning scene; verify on one the optimiser did "
            f"not see ({', '.join(s for s in VERIFY_SCENES if s not in scenes)})"
        )


# fmt: off
def optimise_on_scenes(
    pipeline: Pipeline, start: WordLengthConfig, scenes: Sequence[str] = ("lab",), *,
    budget: float = 0.01, agreement: float = 0.99, margin: float = DEFAULT_MARGIN,
    verify: str | None = None, size: Sequence[int] | None = None,
    signals: Sequence[str] | None = None, tune_registers: bool = False, workers: int = 2,
    cost: str = "proxy", synth_target: str = "xcup", fmax_min: float | None = None,
    timing_stage: str = "top", timing_speed: int = 6, progress: bool = True,
) -> OptimiseReport:
    """:func:`rangefx.api.optimise` (its parameters and errors are documented there): the
    cheapest config of ``pipeline`` reachable from ``start`` that meets the budget
    (tightened by ``margin`` while tuning) on every tuning scene, measured there and on
    the held-out ``verify`` scene."""
    # fmt: on
    from .optimiser import optimise

    try:
        user_budget = Budget(budget, agreement)
    except ValueError as exc:
        raise UserError(f"--budget/--agreement: {exc}") from None
    tuning = user_budget.tightened(margin)  # a one-line UserError for a bad margin
    if signals:
        from .sweep import check_signals

        try:
            check_signals(signals, start)
        except ValueError as exc:
            raise UserError(f"--signals: {exc}") from None
    scenes = list(scenes)
    _check_scenes(scenes, verify)
    m, n = size or (512, 512)  # the presets' default size
    require_memory(
        f"optimise --size {m} {n} with --workers {workers}",
        m * n * SWEEP_BYTES_PER_PIXEL * workers,
    )
    pipe = pipeline
    default = _default_for(pipe, start)
    cases = [tuning_case(pipe, name, size, "--scene") for name in scenes]
    vcase = tuning_case(pipe, verify, size, "--verify") if verify else None
    synth_cost = _synth_cost(pipe, synth_target, cases[0]) if cost == "synth" else None
    fmax = timing = None
    if fmax_min is not None:
        from .optimiser import FmaxConstraint
        from .timing import TimingOptions, fmax_measure

        timing = TimingOptions(stage=timing_stage, speed=timing_speed)
        measure = fmax_measure(cases[0].shape, cases[0].mode, timing, pipe.name)
        try:
            fmax = FmaxConstraint(fmax_min, measure)
        except ValueError as exc:
            raise UserError(f"--fmax-min: {exc}") from None
    res = optimise(
        cases, start, user_budget, pipeline=pipe, margin=margin, signals=signals,
        tune_registers=tune_registers, workers=workers, progress=progress,
        cost_fn=synth_cost, fmax=fmax,
    )  # fmt: skip
    figures = _report_figures(pipe, res, start, default, scenes, cases, user_budget, tuning,
                              margin, tune_registers)  # fmt: skip
    if synth_cost is not None:
        figures["synth_cost"] = {
            "cost": "lut + ff",
            "target": synth_target,
            **{k: synth_cost(c) for k, c in (("start", start), ("default", default),
                                             ("optimised", res.config))},
        }  # fmt: skip
    if fmax is not None:
        figures["fmax"] = {"minimum_mhz": fmax_min, **timing.as_dict(), **res.fmax_mhz}
    if vcase is not None:
        figures["verify"] = _verify_figures(pipe, res.config, default, verify, vcase, user_budget)
    return OptimiseReport(pipe, res, cases[0], figures)


def _report_figures(
    pipe: Pipeline, res: OptimiseResult, start: WordLengthConfig, default: WordLengthConfig,
    scenes: list[str], cases: list[Case], budget: Budget, tuning: Budget, margin: float,
    tune_registers: bool,
) -> dict[str, Any]:  # fmt: skip
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
    return {
        "pipeline": pipe.name,
        "golden": pipe.golden_label(start),
        "scene": scenes[0],
        "tuning_scenes": scenes,
        "mode": mode,
        "size": list(shape),
        **({"variant": start.variant} if "variant" in start.design_fields() else {}),
        "design": start.design(),
        "budget": {"median_rel_range_diff": budget.median, "valid_agreement": budget.agreement},
        "margin": margin,
        "tuning_budget": {
            "median_rel_range_diff": tuning.median,
            "valid_agreement": tuning.agreement,
        },
        "tune_registers": tune_registers,
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


def _verify_figures(
    pipe: Pipeline, config: WordLengthConfig, default: WordLengthConfig, name: str,
    vcase: Case, budget: Budget,
) -> dict[str, Any]:  # fmt: skip
    """The held-out verification: the optimised and the default config on ``vcase``."""
    from .optimiser import evaluate

    golden = pipe.golden(vcase, config).result
    fig_opt = evaluate(vcase, config, golden, pipeline=pipe)
    fig_def = evaluate(vcase, default, golden, pipeline=pipe)
    if fig_opt is None:
        raise UserError(f"the optimised config cannot run on {name!r}")
    return {
        "scene": name,
        "mode": vcase.mode,
        "size": list(vcase.shape),
        **_figures(fig_opt),
        "meets_budget": budget.met(fig_opt),
        "default_median_rel_range_diff": fig_def["median_rel_range_diff"] if fig_def else None,
        "default_valid_agreement": fig_def["valid_agreement"] if fig_def else None,
        "default_saturated_registers": fig_def["saturated_registers"] if fig_def else None,
        "cost_bits": pipe.cost(config, vcase.shape, vcase.mode).cost_bits,
        "default_cost_bits": pipe.cost(default, vcase.shape, vcase.mode).cost_bits,
    }
