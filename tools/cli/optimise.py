"""``rangefx optimise``: the cheapest word lengths of any pipeline of the registry
meeting an accuracy budget (SPEC §6, §8, §10).

``rangefx optimise``: word-length studies of every pipeline of
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
import json
import sys

from rangefx.rtl_model.registry import PIPELINES

from ..studies.runner import load_config
from ..studies.tuning import DEFAULT_MARGIN, TUNING_SCENES, VERIFY_SCENES
from .options import (
    add_design_args,
    add_pipeline_arg,
    design_from_args,
    int_at_least,
    out_path,
    pipeline_from_args,
)

_positive_int = int_at_least(1)

__all__ = ["DEFAULT_MARGIN", "TUNING_SCENES", "VERIFY_SCENES", "add_parser", "cmd_optimise"]


def cmd_optimise(args: argparse.Namespace) -> int:
    from rangefx import api

    pipe = pipeline_from_args(args)
    start = load_config(pipe, args.config, **design_from_args(pipe, args))
    report = api.optimise(
        pipe, args.scene, config=start,
        budget=args.budget, agreement=args.agreement, margin=args.margin, verify=args.verify,
        size=args.size, signals=args.signals, tune_registers=args.tune_registers,
        workers=args.workers, cost=args.cost, synth_target=args.synth_target,
        fmax_min=args.fmax_min, timing_stage=args.timing_stage, timing_speed=args.timing_speed,
        progress=not args.json,
    )  # fmt: skip
    if args.out:
        report.write(args.out)
    figures = report.figures
    if args.json:
        print(json.dumps(report.to_dict()))
        return 0
    res, name = report.result, figures["pipeline"]
    cost, dcost = figures["cost"], figures["default_cost"]
    sys.stdout.write(res.config.to_toml())
    print(
        f"# {name} cost_bits on {figures['scene']} {cost['cost_bits']} (default "
        f"{dcost['cost_bits']}, saved {figures['bits_saved']}); DSP {cost['dsp']} (default "
        f"{dcost['dsp']}); BRAM18 {cost['bram18']} (default {dcost['bram18']}); "
        f"{res.evaluations} runs, {res.seconds:.1f} s"
    )
    if "fmax" in figures:
        f = figures["fmax"]
        print(f"# Fmax ({f['stage']}, speed {f['speed']}) {f['optimised']:.1f} MHz (start "
              f"{f['start']:.1f}; floor --fmax-min {args.fmax_min:g})")  # fmt: skip
    if args.margin:
        tuning, budget = figures["tuning_budget"], figures["budget"]
        print(
            f"# tuned with margin {args.margin}: median_rel_range_diff <= "
            f"{tuning['median_rel_range_diff']:.4g}, valid_agreement >= "
            f"{tuning['valid_agreement']:.6g} on every tuning scene (budget "
            f"{budget['median_rel_range_diff']:.4g}, {budget['valid_agreement']:.6g})"
        )
    for scene, sf in figures["scenes"].items():
        print(
            f"# {scene} ({sf['mode']}): median_rel_range_diff {sf['median_rel_range_diff']:.3e}, "
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


def add_parser(sub: argparse._SubParsersAction) -> None:
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
                   "of the pipeline's whole RTL top, P1 or P2: a narrowing that does not "
                   "lower it is not kept)")  # fmt: skip
    p.add_argument("--synth-target", choices=("xc7", "xcup", "ecp5", "ice40"), default="xcup",
                   help="Yosys target of --cost synth (default xcup)")  # fmt: skip
    p.add_argument("--fmax-min", type=float, metavar="MHZ",
                   help="P1, P2: keep a narrowing only if the RTL still places and routes at "
                   ">= MHZ (Yosys + nextpnr-ecp5, LFE5U-85F, one seed, cached; the start must "
                   "meet it too)")  # fmt: skip
    p.add_argument("--timing-stage", choices=("top", "frontend"), default="top",
                   help="what --fmax-min times: the whole top (default) or P1's one "
                   "front end")  # fmt: skip
    p.add_argument("--timing-speed", type=int, choices=(6, 7, 8), default=6,
                   help="ECP5 speed grade of --fmax-min (default 6)")  # fmt: skip
    p.add_argument(
        "--out", type=out_path, help="write optimised.toml, build-up plots and summary.json here"
    )
    p.add_argument("--json", action="store_true",
                   help="print the figures as one JSON object (top-level accuracy: worst case "
                   "over the tuning scenes; per scene under 'scenes')")  # fmt: skip
    p.set_defaults(func=cmd_optimise)
