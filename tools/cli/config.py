"""``rangefx config show|propose --pipeline NAME``: a word-length config of any registered
pipeline.

``show`` prints (or writes) the shipped default TOML, or ``--config``'s; ``export``
writes it as an HLS header (``--hls``) and/or a VHDL ``fixed_pkg`` package (``--vhdl``);
``propose``
runs the pipeline on ``--scene`` cases (and ``--real`` pairs), logs every signal's
pre-quantisation range and widens integer bits to hold it plus ``--guard-bits``,
iterated to a fixpoint (MATLAB's "propose word lengths").
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from rangefx.rtl_model.config import WordLengthConfig
from rangefx.vectors.export import hls_header, vhdl_inexact, vhdl_package

from ..errors import UserError
from ..report import atomic_write_text, json_safe
from ..report.outdir import check_output_file
from ..studies.cases import REAL_PAIRS, real_pair_case, scene_case
from ..studies.runner import load_config, propose_from_cases
from .options import (
    add_design_args,
    add_pipeline_arg,
    design_from_args,
    out_path,
    pipeline_from_args,
)

__all__ = ["DEFAULT_SCENES", "add_parser", "cmd_config"]

#: Scenes ``propose`` logs by default (those whose mode the pipeline models).
DEFAULT_SCENES = ("lab", "runway")


#: First bytes of each file kind rangefx writes here: an existing file is replaced only
#: if it starts with them (a user's file is never overwritten).
HEADERS = {"toml": b"# rangefx ", "hls": b"// rangefx ", "vhdl": b"-- rangefx "}


def _checked(path: str | None, kind: str, option: str) -> Path | None:
    """``path`` checked before any work: writable, not a directory, not a user's file."""
    return None if path is None else check_output_file(path, HEADERS[kind], option)


def _write_text(path: Path, text: str, option: str) -> None:
    try:
        atomic_write_text(path, text)
    except OSError as exc:
        raise UserError(f"cannot write {option} {str(path)!r}: {exc.strerror}") from None


def _export(config: WordLengthConfig, args: argparse.Namespace) -> int:
    if not (args.hls or args.vhdl):
        raise UserError("config export needs --hls FILE.h and/or --vhdl FILE.vhd")
    hls, vhdl = _checked(args.hls, "hls", "--hls"), _checked(args.vhdl, "vhdl", "--vhdl")
    if hls is not None:
        _write_text(hls, hls_header(config), "--hls")
    if vhdl is not None:
        _write_text(vhdl, vhdl_package(config), "--vhdl")
        inexact = vhdl_inexact(config)
        if inexact:
            modes = sorted({m for v in inexact.values() for m in v.split(", ")})
            print(
                f"rangefx: warning: {len(inexact)} of {len(config.signals())} signals use "
                f"modes fixed_pkg lacks ({', '.join(modes)}): the VHDL package gives them the "
                "nearest style, marked NOT EXACT",
                file=sys.stderr,
            )
    written = [p for p in (args.hls, args.vhdl) if p]
    if args.json:
        print(json.dumps({"pipeline": config.PIPELINE, "written": written,
                          "vhdl_inexact": vhdl_inexact(config)}))  # fmt: skip
    else:
        print(f"wrote {', '.join(written)}")
    return 0


def cmd_config(args: argparse.Namespace) -> int:
    pipeline = pipeline_from_args(args)
    config = load_config(pipeline, args.config, **design_from_args(pipeline, args))
    if args.action == "export":
        return _export(config, args)
    out = _checked(args.out, "toml", "--out")
    if args.action == "show":
        text = config.to_toml()
        if out is not None:
            _write_text(out, text, "--out")
        else:
            sys.stdout.write(text)
        return 0
    if args.scene is None:  # every preset the pipeline models
        cases = [c for c in map(scene_case, DEFAULT_SCENES) if c.mode in pipeline.modes]
    else:
        cases = [scene_case(name) for name in args.scene]
    cases += [real_pair_case(name) for name in args.real or ()]
    for case in cases:
        try:
            pipeline.check_mode(case)
        except ValueError as exc:
            raise UserError(str(exc)) from None
    proposed, minmax, overflows = propose_from_cases(
        pipeline, config, cases, guard_bits=args.guard_bits
    )
    if out is not None:
        _write_text(out, proposed.to_toml(), "--out")
    rows = {
        sig: {
            "min": minmax.get(sig, (None, None))[0],
            "max": minmax.get(sig, (None, None))[1],
            "current": str(config.formats[sig]),
            "proposed": str(proposed.formats[sig]),
        }
        for sig in config.signals()
    }
    if args.json:
        print(json.dumps(json_safe({"pipeline": pipeline.name, "overflows": overflows,
                                    "signals": rows})))  # fmt: skip
    else:
        for sig, r in rows.items():
            lo, hi = r["min"], r["max"]
            print(f"{sig:12s} {r['current']:>8s} -> {r['proposed']:>8s}  range [{lo}, {hi}]")
        print(f"overflows on the cases under the proposed config: {overflows}")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("config", help="a pipeline's word-length config: show, or propose")
    p.add_argument("action", choices=("show", "propose", "export"))
    add_pipeline_arg(p)
    add_design_args(p)
    p.add_argument(
        "--scene", nargs="+", help="scenes to log (default: lab and runway, as the mode allows)"
    )
    p.add_argument("--real", nargs="*", choices=REAL_PAIRS, help="real pairs to log too")
    p.add_argument("--guard-bits", type=int, default=1, help="extra integer bits (propose)")
    p.add_argument("--out", type=out_path, help="write the TOML here")
    p.add_argument("--hls", help="export: C++ header, one ap_[u]fixed typedef per signal")
    p.add_argument("--vhdl", help="export: VHDL-2008 package of fixed_pkg subtypes")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_config)
