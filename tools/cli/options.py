"""Option groups shared by the subcommands, and the rule that an option a pipeline does
not use is an error (one ``rangefx: error:`` line), never silently ignored (SPEC §10).

Design options (``--variant``, ``--divider``, ``--pole``, ``--bias``) go to the chosen
pipeline's config only if it has that design field (:attr:`Pipeline.options`); case
options (``--threshold-e``, ``--threshold-g``, ``--range-max``) only if the pipeline
reads that setting (:attr:`Pipeline.case_options`). Every such option defaults to ``None``
("not given") so that a given one can be checked.
"""

from __future__ import annotations

import argparse
from typing import Any

from rangefx.rtl_model.config import TimingConfig
from rangefx.rtl_model.pipeline import Case, Pipeline
from rangefx.rtl_model.registry import PIPELINES, get_pipeline
from rangefx.rtl_model.runtime import DIVIDERS

from ..errors import UserError
from .argtypes import int_at_least, out_path

__all__ = [
    "CASE_OPTIONS",
    "DESIGN_OPTIONS",
    "TIMING_OPTIONS",
    "add_design_args",
    "add_pipeline_arg",
    "add_pipelines_arg",
    "add_timing_args",
    "apply_case_options",
    "design_from_args",
    "int_at_least",
    "out_path",
    "pipeline_from_args",
    "reject_options",
    "timing_from_args",
]

#: Design options: attribute of the parsed arguments -> command-line flag.
DESIGN_OPTIONS: dict[str, str] = {
    "variant": "--variant",
    "divider": "--divider",
    "pole": "--pole",
    "bias": "--bias",
    "filter_form": "--filter-form",
}
#: Case options: attribute (a field of a pipeline's settings) -> command-line flag.
CASE_OPTIONS: dict[str, str] = {
    "threshold_e": "--threshold-e",
    "threshold_g": "--threshold-g",
    "range_max": "--range-max",
}
#: Timing options: attribute -> flag.
TIMING_OPTIONS: dict[str, str] = {
    "hblank": "--hblank",
    "vblank": "--vblank",
    "gap_prob": "--gap-prob",
    "gap_seed": "--gap-seed",
}


def add_pipeline_arg(p: argparse.ArgumentParser, *, default: str | None = "p1") -> None:
    p.add_argument(
        "--pipeline",
        choices=tuple(PIPELINES),
        default=default,
        help=f"bit-accurate pipeline: {', '.join(PIPELINES)} (default {default})",
    )


def add_pipelines_arg(p: argparse.ArgumentParser) -> None:
    """``--pipeline NAME [NAME ...]``: the pipelines a command covers (default: all)."""
    p.add_argument(
        "--pipeline",
        nargs="+",
        choices=tuple(PIPELINES),
        default=list(PIPELINES),
        help=f"the fixed-point pipelines to include (default: all: {' '.join(PIPELINES)})",
    )


def add_design_args(g: argparse._ActionsContainer, *, estimator: bool = True) -> None:
    """``--config``, ``--variant``, ``--divider`` and (``estimator``) ``--pole``/``--bias``."""
    g.add_argument("--config", help="word-length config TOML (default: the shipped default)")
    g.add_argument("--variant", choices=("paper", "consistent"), help="P1 estimator variant")
    g.add_argument("--divider", choices=DIVIDERS, help="divider model")
    if estimator:
        g.add_argument("--pole", type=float, help="filter pole c per pixel (default 0.5)")
        g.add_argument("--bias", type=float, help="input bias B, eq 19 (default 16)")
        g.add_argument(
            "--filter-form",
            choices=("direct", "shift"),
            help="P1 filters: multiply by the pole, or shift by k for a pole 2^-k (default)",
        )


def add_timing_args(g: argparse._ActionsContainer) -> None:
    g.add_argument("--hblank", type=int, help="horizontal blanking, cycles (default 0)")
    g.add_argument("--vblank", type=int, help="vertical blanking, cycles (default 0)")
    g.add_argument("--gap-prob", type=float, help="input gap probability (default 0)")
    g.add_argument("--gap-seed", type=int, help="input gap seed (default 0)")


def pipeline_from_args(args: argparse.Namespace) -> Pipeline:
    try:
        return get_pipeline(args.pipeline)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def _given(args: argparse.Namespace, name: str) -> bool:
    return getattr(args, name, None) is not None


def design_from_args(pipeline: Pipeline, args: argparse.Namespace) -> dict[str, Any]:
    """The design options given on the command line, for ``pipeline``; one that it has
    no design field for is a :class:`UserError` naming the option and the pipeline."""
    design = {}
    for name, flag in DESIGN_OPTIONS.items():
        if not _given(args, name):
            continue
        if name not in pipeline.options:
            takes = ", ".join(DESIGN_OPTIONS[o] for o in pipeline.options) or "none"
            raise UserError(
                f"{flag} does not apply to pipeline {pipeline.name} (its design options: {takes})"
            )
        design[name] = getattr(args, name)
    return design


def apply_case_options(pipeline: Pipeline, case: Case, args: argparse.Namespace) -> Case:
    """The case with the given case options; one the pipeline does not read is an error."""
    given = {name: getattr(args, name) for name in CASE_OPTIONS if _given(args, name)}
    for name in given:
        if name not in pipeline.case_options:
            raise UserError(f"{CASE_OPTIONS[name]} does not apply to pipeline {pipeline.name}")
    try:
        return pipeline.with_case_options(case, **given)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def reject_options(args: argparse.Namespace, names: dict[str, str], why: str) -> None:
    """A :class:`UserError` for the first given option of ``names`` (attr -> flag)."""
    for name, flag in names.items():
        if _given(args, name):
            raise UserError(f"{flag} {why}")


def timing_from_args(args: argparse.Namespace) -> TimingConfig:
    """The input stream timing of the timing options (0 where not given)."""
    values = {k: getattr(args, k, None) for k in TIMING_OPTIONS}
    try:
        return TimingConfig(
            hblank=values["hblank"] or 0,
            vblank=values["vblank"] or 0,
            gap_prob=values["gap_prob"] or 0.0,
            seed=values["gap_seed"] or 0,
        )
    except ValueError as exc:
        raise UserError(str(exc)) from None
