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
import warnings
from pathlib import Path

import numpy as np

from rangefx.golden.estimator import EstimatorConfig, validate_image
from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.methods import METHODS, run_method
from rangefx.golden.scenes import SCENE_NAMES, render_scene
from rangefx.rtl_model.pipeline import Case, Pipeline
from rangefx.rtl_model.registry import PIPELINES

from .. import report
from ..errors import UserError
from ..report import atomic_output_dir, atomic_write_text, json_safe
from ..studies.cases import case_from_scene, integer_case, with_thresholds
from ..studies.runner import (
    check_input_levels,
    golden_case,
    load_config,
    pipeline_figures,
    require_run_memory,
    run_case,
)
from .options import (
    TIMING_OPTIONS,
    add_design_args,
    add_timing_args,
    apply_case_options,
    design_from_args,
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


def load_image(path: str) -> np.ndarray:
    """A grey-level image from ``.npy`` or an image file; one clear error otherwise."""
    p = Path(path)
    if not p.is_file():
        raise UserError(f"image file not found: {path}")
    try:
        if p.suffix == ".npy":
            arr = np.load(p, allow_pickle=False)
        else:
            from skimage.io import imread

            with warnings.catch_warnings():  # imageio's plugin search warns about plugins
                warnings.simplefilter("ignore")
                arr = imread(p)
    except Exception:  # any decoder failure is the user's file
        # one line, without the decoder's text: it runs to several lines of plugin hints
        reason = "the file is empty" if p.stat().st_size == 0 else "not a readable image file"
        raise UserError(f"cannot read image {path}: {reason}") from None
    try:
        return validate_image(arr, name=f"image {path}")
    except ValueError as exc:
        raise UserError(str(exc)) from None


def image_pixels(path: str) -> int | None:
    """Pixels of an image file from its header alone (``.npy`` memory-mapped, others
    through Pillow's lazy open), so that a huge image is refused before it is decoded;
    ``None`` when the header does not say (then :func:`load_image` reports the file)."""
    try:
        if Path(path).suffix == ".npy":
            shape = np.load(path, mmap_mode="r", allow_pickle=False).shape
        else:
            from PIL import Image

            with warnings.catch_warnings(), Image.open(path) as im:
                warnings.simplefilter("ignore")  # Pillow's decompression-bomb warning
                shape = im.size
        return int(np.prod(shape[:2], dtype=object))
    except Exception:  # any header the readers cannot parse: load_image says why
        return None


def estimator_from_args(args: argparse.Namespace) -> EstimatorConfig:
    """The golden estimator with ``--pole``/``--bias`` where given."""
    changes = {k: getattr(args, k) for k in ("pole", "bias") if getattr(args, k, None) is not None}
    try:
        return EstimatorConfig(**changes)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def _case(args: argparse.Namespace) -> Case:
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
                require_run_memory(f"run on {path} ({pixels} pixels)", pixels)
        e1, e2 = load_image(args.left), load_image(args.right)
        if e1.shape != e2.shape:
            raise UserError(
                f"image pair shapes differ: {args.left} {e1.shape} vs {args.right} {e2.shape}"
            )
        if args.f_px is None or args.baseline is None:
            raise UserError("an image pair needs --f-px and --baseline")
        try:
            camera = PinholeCamera(e1.shape[1], e1.shape[0], args.f_px)
            motion = MotionIncrement.stereo(args.baseline)
        except ValueError as exc:
            raise UserError(str(exc)) from None
        return Case(e1, e2, camera, motion, label=f"{args.left} + {args.right}")
    try:
        return case_from_scene(render_scene(args.scene or "lab", seed=args.seed))
    except ValueError as exc:
        raise UserError(str(exc)) from None


def cmd_run(args: argparse.Namespace) -> int:
    case = _case(args)
    if args.pipeline != "golden":
        if args.method is not None:
            raise UserError("--method applies to --pipeline golden only")
        return run_pipeline(pipeline_from_args(args), case, args)
    why = f"applies to the fixed-point pipelines only (--pipeline {'|'.join(PIPELINES)})"
    reject_options(args, {"config": "--config", "variant": "--variant"}, why)
    reject_options(args, {"divider": "--divider", **TIMING_OPTIONS}, why)
    method = args.method or DEFAULT_METHOD
    used = METHOD_OPTIONS.get(method, tuple(METHOD_FLAGS))
    unused = {k: v for k, v in METHOD_FLAGS.items() if k not in used}
    reject_options(args, unused, f"does not apply to method {method}")
    case = with_thresholds(
        case, threshold_e=args.threshold_e, threshold_g=args.threshold_g, range_max=args.range_max
    )
    try:
        result = run_method(
            method, case.image1, case.image2, case.camera, case.motion,
            estimator=estimator_from_args(args), ranging=case.ranging,
        )  # fmt: skip
    except ValueError as exc:
        raise UserError(str(exc)) from None
    scene = case.scene
    figures: dict = {"method": method, "valid_fraction": result.valid_fraction}
    if scene is not None:
        rows = report.object_table(
            result.range, result.valid, scene.labels1, scene.objects, scene.depth1
        )
        overall = report.overall_metrics(result.range, result.valid, scene.depth1)
        figures.update(scene=scene.name, unit=scene.unit, table=rows, **overall)
    if args.out:
        with atomic_output_dir(Path(args.out)) as tmp:
            np.save(tmp / "range.npy", result.range)
            np.save(tmp / "valid.npy", result.valid)
            report.save_range_map_png(
                tmp / "range.png", result.range, result.valid, case.ranging.range_max, method
            )
            atomic_write_text(tmp / "summary.json", json.dumps(json_safe(figures), indent=2) + "\n")
    if args.json:
        print(json.dumps(json_safe(figures)))
    else:
        if scene is not None:
            print(
                report.table_markdown(figures["table"], scene.unit, title=f"{scene.name}: {method}")
            )
        print(f"valid-pixel fraction {result.valid_fraction:.3f}")
    return 0


def run_pipeline(pipeline: Pipeline, case: Case, args: argparse.Namespace) -> int:
    """``rangefx run --pipeline NAME``: range map + taps + report, beside its golden."""
    case = apply_case_options(pipeline, case, args)
    if case.scene is None:
        case = integer_case(case, (args.left, args.right))
    config = load_config(pipeline, args.config, **design_from_args(pipeline, args))
    signal = config.signals()[0]
    check_input_levels(
        {args.left or "image1": case.image1, args.right or "image2": case.image2},
        config.fmt(signal), signal, allow=args.allow_saturated_input,
    )  # fmt: skip
    timing = timing_from_args(args)
    result = run_case(pipeline, case, config, timing, taps=bool(args.out))
    golden = golden_case(pipeline, case, config).result
    figures = pipeline_figures(result, golden, case.scene)
    name = pipeline.name
    for reg in result.saturated_registers:
        requested, held = result.registers[reg]
        print(
            f"rangefx: warning: register {reg} saturates: {requested:g} is held as {held:g} "
            "(widen its format)",
            file=sys.stderr,
        )
    if args.out:
        with atomic_output_dir(Path(args.out)) as tmp:
            np.save(tmp / "range.npy", result.range)
            np.save(tmp / "valid.npy", result.valid)
            np.savez_compressed(tmp / "taps.npz", **result.taps)
            report.save_range_map_png(
                tmp / "range.png", result.range, result.valid, pipeline.range_max(case),
                f"{name.upper()} range",
            )  # fmt: skip
            atomic_write_text(tmp / "config.toml", config.to_toml())
            atomic_write_text(tmp / "summary.json", json.dumps(json_safe(figures), indent=2) + "\n")
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
    p.set_defaults(func=cmd_run)
