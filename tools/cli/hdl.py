"""``rangefx hdl``: the P1 RTL of ``hdl/`` (issue 15).

* ``synth``: Yosys area (LUT, FF, carry, DSP, BRAM) of each stage and of the whole P1 as
  instantiated, for a word-length config and a target (:mod:`rangefx.tools.studies.synth`).
"""

from __future__ import annotations

import argparse
import json

from rangefx.rtl_model.registry import get_pipeline

from ..studies.runner import load_config
from ..studies.synth import AREA_KEYS, STAGES, TARGETS, synth_p1
from .options import add_design_args, design_from_args, int_at_least

__all__ = ["add_parser", "add_synth_parser", "cmd_synth"]


def cmd_synth(args: argparse.Namespace) -> int:
    pipeline = get_pipeline("p1")
    config = load_config(pipeline, args.config, **design_from_args(pipeline, args))
    stages = tuple(STAGES) if args.stage == "all" else (args.stage,)
    shape = (args.height, args.width)
    report = synth_p1(config, args.target, shape, args.mode, stages, use_cache=not args.no_cache)
    report = {"config": config.name, **report}
    if args.json:
        print(json.dumps(report))
        return 0
    print(f"P1 {args.mode} {shape[0]}x{shape[1]}, config {config.name}, Yosys {args.target}:")
    print(f"  {'stage':<8} {'inst':>4} " + " ".join(f"{k:>6}" for k in AREA_KEYS) + "  cached")
    for stage, a in report["stages"].items():
        cells = " ".join(f"{a[k]:>6}" for k in AREA_KEYS)
        print(f"  {stage:<8} {a['instances']:>4} {cells}  {'yes' if a['cached'] else 'no'}")
    print(f"  {'total':<8} {'':>4} " + " ".join(f"{report[k]:>6}" for k in AREA_KEYS))
    return 0


def add_synth_parser(hs) -> None:
    """``hdl synth``: added to the ``hdl`` group's subparsers ``hs``."""
    s = hs.add_parser("synth", help="Yosys area of the P1 RTL per stage and in all")
    add_design_args(s, estimator=False)
    s.add_argument("--target", choices=tuple(TARGETS), default="xcup",
                   help="Yosys flow: synth_xilinx -family xc7|xcup, synth_ecp5, synth_ice40 "
                   "(default xcup)")  # fmt: skip
    s.add_argument("--stage", choices=(*STAGES, "all"), default="all",
                   help="rowcol (one stream's bias/row/column filter), range, or all")  # fmt: skip
    s.add_argument("--mode", choices=("stereo", "motion"), default="stereo",
                   help="stereo: two rowcol stages, motion: one (default stereo)")  # fmt: skip
    s.add_argument("--width", type=int_at_least(2, "--width"), default=512,
                   help="line width the line buffers and counters are sized for (512)")  # fmt: skip
    s.add_argument("--height", type=int_at_least(2, "--height"), default=512,
                   help="frame height the row counter is sized for (512)")  # fmt: skip
    s.add_argument("--no-cache", action="store_true",
                   help="synthesise again even when the cache holds the result")  # fmt: skip
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.set_defaults(func=cmd_synth)


def add_parser(sub) -> None:
    p = sub.add_parser("hdl", help="the P1 RTL (hdl/): synthesis area")
    hs = p.add_subparsers(dest="hdl_command", required=True)
    add_synth_parser(hs)
