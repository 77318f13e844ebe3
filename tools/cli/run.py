"""``rangefx run``: one golden method, or one bit-accurate pipeline beside its golden, on a
scene preset or on a user's image pair (SPEC §8, §10).

``--pipeline golden`` (the default) runs ``--method``; ``--pipeline NAME`` runs the
registered pipeline with the shipped default config (or ``--config``), design options
applied where the pipeline has them, and prints its table beside its golden's. An
option that does not apply to the chosen pipeline is an error.
"""

from __future__ import annotations

import argparse
import json
import sys

from rangefx.golden.estimator import EstimatorConfig
from rangefx.golden.methods import METHODS
from rangefx.golden.scenes import SCENE_NAMES
from rangefx.rtl_model.pipeline import Case, Pipeline
from rangefx.rtl_model.registry import PIPELINES

from .. import report
from ..errors import UserError
from ..report import json_safe
from ..studies.banded import require_input_memory
from ..studies.cases import image_pixels, load_image
from ..studies.runner import load_config
from .options import (
    TIMING_OPTIONS,
    add_design_args,
    add_timing_args,
    apply_case_options,
    design_from_args,
    int_at_least,
    out_path,
    pipeline_from_args,
    reject_options,
    timing_from_args,
)

__all__ = [
    "METHOD_FLAGS",
    "METHOD_OPTIONS",
    "add_parser",
    "cmd_run",
    "estimator_from_args",
    "load_image",
    "run_pipeline",
]

DEFAULT_METHOD = "g3_consistent"
#: Golden methods that read only some of the method options (G3 and G4 read all of
#: :data:`METHOD_FLAGS`): G2, G5 and G6 have no causal estimator (no pole, no bias), G5
#: no gradient threshold, G6 its own validity tests (docs/multiscale.md).
METHOD_OPTIONS: dict[str, tuple[str, ...]] = {
    "g2_central": ("threshold_e", "threshold_g", "range_max"),
    "g5_riccati": ("threshold_e", "range_max"),
    "g6_multiscale": ("range_max",),
}
#: The options a golden method may read: attribute -> flag.
METHOD_FLAGS = {
    "threshold_e": "--threshold-e",
    "threshold_g": "--threshold-g",
    "range_max": "--range-max",
    "pole": "--pole",
    "bias": "--bias",
}


def estimator_from_args(args: argparse.Namespace) -> EstimatorConfig:
    """The golden estimator with ``--pole``/``--bias`` where given."""
    changes = {k: getattr(args, k) for k in ("pole", "bias") if getattr(args, k, None) is not None}
    try:
        return EstimatorConfig(**changes)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def _case(args: argparse.Namespace) -> Case:
    from rangefx import api

    if args.scene is not None and (args.left or args.right):  # which one would be run?
        raise UserError(
            f"--scene {args.scene} and --left/--right name two inputs; give one of them"
        )
    if args.left or args.right:
        if not (args.left and args.right):
            raise UserError("--left and --right must be given together")
        for path in (args.left, args.right):  # before decoding: a 12000x12000 pair is refused
            pixels = image_pixels(path)
            if pixels is not None:
                pipe = PIPELINES.get(args.pipeline)  # None: a golden method
                require_input_memory(pipe, f"run on {path} ({pixels} pixels)", pixels)
        return api.image_case(args.left, args.right, f_px=args.f_px, baseline=args.baseline)
    return api.scene_case(args.scene or "lab", seed=args.seed)


def cmd_run(args: argparse.Namespace) -> int:
    from rangefx import api
    from rangefx.tools.studies.cases import with_thresholds

    case = _case(args)
    if args.pipeline != "golden":
        if args.method is not None:
            raise UserError("--method applies to --pipeline golden only")
        return run_pipeline(pipeline_from_args(args), case, args)
    why = f"applies to the fixed-point pipelines only (--pipeline {'|'.join(PIPELINES)})"
    reject_options(
        args, {"config": "--config", "variant": "--variant", "band_lines": "--band-lines"}, why
    )
    reject_options(args, {"divider": "--divider", **TIMING_OPTIONS}, why)
    method = args.method or DEFAULT_METHOD
    used = METHOD_OPTIONS.get(method, tuple(METHOD_FLAGS))
    unused = {k: v for k, v in METHOD_FLAGS.items() if k not in used}
    reject_options(args, unused, f"does not apply to method {method}")
    case = with_thresholds(
        case, threshold_e=args.threshold_e, threshold_g=args.threshold_g, range_max=args.range_max
    )
    run = api.run(case, pipeline="golden", method=method, estimator=estimator_from_args(args))
    if args.out:
        run.write(args.out)
    figures, scene = run.figures, case.scene
    if args.json:
        print(json.dumps(json_safe(figures)))
    else:
        if scene is not None:
            print(
                report.table_markdown(figures["table"], scene.unit, title=f"{scene.name}: {method}")
            )
        print(f"valid-pixel fraction {run.result.valid_fraction:.3f}")
    return 0


def run_pipeline(pipeline: Pipeline, case: Case, args: argparse.Namespace) -> int:
    """``rangefx run --pipeline NAME``: range map + taps + report, beside its golden."""
    from rangefx import api

    case = apply_case_options(pipeline, case, args)
    config = load_config(pipeline, args.config, **design_from_args(pipeline, args))
    run = api.run(
        case, config, pipeline=pipeline, timing=timing_from_args(args), taps=bool(args.out),
        allow_saturated_input=args.allow_saturated_input, band_lines=args.band_lines,
        input_names=(args.left or "image1", args.right or "image2"),
    )  # fmt: skip
    result, figures, name = run.result, run.figures, pipeline.name
    for reg in result.saturated_registers:
        requested, held = result.registers[reg]
        print(
            f"rangefx: warning: register {reg} saturates: {requested:g} is held as {held:g} "
            "(widen its format)",
            file=sys.stderr,
        )
    if args.out:
        run.write(args.out)
    if args.json:
        print(json.dumps(json_safe(figures)))
        return 0
    if case.scene is not None:
        print(
            report.format_side_by_side(
                {
                    f"golden {pipeline.golden_label(config)}": figures["golden_table"],
                    f"{name} fixed": figures["table"],
                },
                case.scene.unit,
            )
        )
    design = ", ".join(f"{k} {v}" for k, v in config.design().items() if k in pipeline.options)
    print(
        f"{name.upper()} {result.mode} ({design}): overflows {result.overflow_total}, "
        f"median |fixed-golden|/golden {report.median_text(figures)}, valid "
        f"agreement {figures['valid_agreement']:.4f}, latency {result.latency} cycles, "
        f"buffers {result.line_buffer_bits} line + {result.frame_store_bits} frame store + "
        f"{result.sweep_buffer_bits} sweep bits"
    )
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="one golden method, or a fixed-point pipeline beside golden")
    p.add_argument(
        "--scene",
        help=f"scene preset: {', '.join(SCENE_NAMES)} (default lab, unless --left/--right)",
    )
    p.add_argument("--method", choices=METHODS, help=f"golden method (default {DEFAULT_METHOD})")
    p.add_argument("--left", help="E1 image (.npy or image file)")
    p.add_argument("--right", help="E2 image, second camera to the right")
    p.add_argument("--f-px", type=float, help="focal length in pixels (image pair)")
    p.add_argument("--baseline", type=float, help="stereo baseline (image pair)")
    p.add_argument("--threshold-e", type=float, help="T_E, grey levels")
    p.add_argument("--threshold-g", type=float, help="T_g, grey levels per pixel (golden, p1)")
    p.add_argument("--range-max", type=float, help="maximum scene depth")
    p.add_argument(
        "--out", type=out_path, help="write range.npy, valid.npy, range.png, summary.json here"
    )
    p.add_argument(
        "--pipeline",
        choices=("golden", *PIPELINES),
        default="golden",
        help=f"golden (float64 method) or a bit-accurate pipeline: {', '.join(PIPELINES)}",
    )
    p.add_argument("--seed", type=int, default=0, help="scene noise seed")
    p.add_argument("--json", action="store_true", help="print one JSON object with the figures")
    g = p.add_argument_group(
        f"fixed-point pipelines (--pipeline {'|'.join(PIPELINES)}); --pole/--bias also golden"
    )
    add_design_args(g)
    add_timing_args(g)
    g.add_argument(
        "--allow-saturated-input", action="store_true",
        help="accept grey levels outside the input format (saturated, with a warning)",
    )  # fmt: skip
    g.add_argument(
        "--band-lines", type=int_at_least(1), metavar="N",
        help="a pipeline whose lines are independent (P2): run the frame in bands of N "
        "lines, the same result bit for bit (default: the whole frame if it fits in the "
        "memory available, else bands that do)",
    )  # fmt: skip
    p.set_defaults(func=cmd_run)
