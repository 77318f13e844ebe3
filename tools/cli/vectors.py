"""``rangefx vectors gen|check|diff``: hardware test vectors of any pipeline (SPEC §5, §10).

Each subcommand is one call of :mod:`rangefx.api`:

* ``gen``: render a scene (optionally cropped), run ``--pipeline`` (any registered one) with every
  tap and write the vector directory atomically (``docs/vectors.md``); prints the time
  (:func:`rangefx.api.generate_vectors`).
* ``check``: verify sizes and SHA-256 of every file, then re-run the model from the
  manifest and require byte-identical files (exit 1 on any problem).
* ``diff``: an RTL dump (``.mem`` or ``.csv``) against the expected tap: the first
  mismatch (cycle, row, col, signal, expected, got, format) and the count (exit 1 if any).
"""

from __future__ import annotations

import argparse
import json

from rangefx.vectors.generate import FORMATS

from ..errors import UserError
from ..studies.runner import load_config
from .options import (
    add_design_args,
    add_pipeline_arg,
    add_timing_args,
    design_from_args,
    out_path,
    pipeline_from_args,
    timing_from_args,
)

__all__ = ["add_parser", "cmd_check", "cmd_diff", "cmd_gen"]


def _formats(text: str) -> list[str]:
    items = [s.strip() for s in text.split(",") if s.strip()]
    if not items:  # not the default: the user asked for something and named nothing
        raise UserError(f"--formats {text!r} names no format; choose from {', '.join(FORMATS)}")
    bad = [s for s in items if s not in FORMATS]
    if bad:
        raise UserError(f"--formats: unknown {', '.join(bad)}; choose from {', '.join(FORMATS)}")
    return items


def cmd_gen(args: argparse.Namespace) -> int:
    from rangefx import api

    formats = _formats(args.formats)
    pipeline = pipeline_from_args(args)
    config = load_config(pipeline, args.config, **design_from_args(pipeline, args))
    result = api.generate_vectors(
        args.scene, args.out, pipeline=pipeline, config=config, timing=timing_from_args(args),
        formats=formats, seed=args.seed, crop=args.crop,
    )  # fmt: skip
    figures = result.figures
    if args.json:
        print(json.dumps(figures))
    else:
        m, n = figures["shape"]
        print(
            f"wrote {figures['files']} files ({figures['total_bytes']} bytes) for a {m}x{n} "
            f"{pipeline.name.upper()} {figures['mode']} case to {figures['out']}/ in "
            f"{figures['vectors_s']:.2f} s "
            f"(model + encode {figures['build_s']:.2f} s, write {figures['write_s']:.2f} s; "
            f"scene render {figures['render_s']:.2f} s not included)"
        )
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    from rangefx import api

    report = api.check_vectors(args.dir, rerun=not args.no_rerun, provenance=True)
    if args.json:
        print(json.dumps(report.to_dict()))
    else:
        for p in report.problems:
            print(f"problem: {p}")
        for p in report.notes:
            print(f"note: {p}")
        rerun = "model re-run identical" if report.rerun else "model not re-run"
        if report.provenance:
            rerun = "inputs reproduced from the manifest's case, " + rerun
        verdict = "OK" if report.ok else f"FAILED ({len(report.problems)} problems)"
        print(f"{args.dir}: {report.files} files, {report.bytes} bytes, {rerun}: {verdict}")
    return 0 if report.ok else 1


def cmd_diff(args: argparse.Namespace) -> int:
    from rangefx import api

    report = api.diff_vectors(args.dir, args.dump, args.signal)
    print(json.dumps(report.to_dict()) if args.json else report.text())
    return 0 if report.ok else 1


def add_parser(sub) -> None:
    """Register ``rangefx vectors`` and its sub-commands on ``sub``."""
    p = sub.add_parser("vectors", help="hardware test vectors: gen, check, diff (SPEC §5)")
    vs = p.add_subparsers(dest="vectors_command", required=True)
    g = vs.add_parser("gen", help="write the vector directory of a scene case")
    g.add_argument("--scene", default="lab", help="scene preset (lab: stereo, runway: motion)")
    g.add_argument("--seed", type=int, default=0, help="scene noise seed")
    g.add_argument("--out", type=out_path, required=True, help="output vector directory")
    g.add_argument(
        "--crop", type=int, nargs=4, metavar=("R0", "R1", "C0", "C1"),
        help="rows R0:R1 and columns C0:C1 of the rendered scene",
    )  # fmt: skip
    add_pipeline_arg(g)
    add_design_args(g)
    add_timing_args(g)
    g.add_argument(
        "--formats", default="mem", help=f"per-tap formats, comma separated: {','.join(FORMATS)}"
    )
    g.add_argument("--json", action="store_true", help="print one JSON object (with timings)")
    g.set_defaults(func=cmd_gen)
    c = vs.add_parser("check", help="verify checksums and re-run the model")
    c.add_argument("dir", help="vector directory")
    c.add_argument("--no-rerun", action="store_true", help="checksums and sizes only")
    c.add_argument("--json", action="store_true", help="print one JSON object")
    c.set_defaults(func=cmd_check)
    d = vs.add_parser("diff", help="first mismatch of an RTL dump against an expected tap")
    d.add_argument("dir", help="vector directory")
    d.add_argument("dump", help="RTL dump, .mem ($readmemh words) or .csv (value column)")
    d.add_argument("--signal", help="tap name (default: the dump's file name, e.g. e1.row_r1)")
    d.add_argument("--json", action="store_true", help="print one JSON object")
    d.set_defaults(func=cmd_diff)
