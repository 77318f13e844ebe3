"""``rangefx hdl``: the Verilog of P1 and P2 (``hdl/``, docs/hdl.md).

* ``replay``: build ``hdl/p1_top.v`` or ``hdl/p2_top.v`` with a vector directory's
  parameters, replay its input streams under Icarus or Verilator (the cocotb bench or the
  plain Verilog bench) and check every tap value for value and cycle for cycle, the
  AXI4-Stream output and the overflow counters against the manifest (exit 0 when all
  match, 1 otherwise).
* ``synth``: Yosys area (LUT, FF, carry, DSP, BRAM) of the whole P1 synthesised flat
  without its probes (the headline), what the taps and overflow counters add, and each
  stage, for a word-length config and a target (:mod:`rangefx.tools.studies.synth`).
* ``timing``: Yosys + nextpnr place and route of the whole P1 on a device: Fmax per clock
  (median over seeds), critical path, utilisation (:mod:`rangefx.tools.studies.timing`).

``synth`` and ``timing`` take ``--pipeline p1|p2``: P2's whole ``p2_top`` through the same
code (:data:`rangefx.tools.studies.synth.RTL_TOPS`); a pipeline without RTL is one error.

One function per subcommand adds its parser (``add_replay_parser``, ``add_synth_parser``,
``add_timing_parser``); ``add_parser`` registers the group.
"""

from __future__ import annotations

import argparse
import json

from rangefx.rtl_model.p1.config import FILTER_FORMS
from rangefx.vectors.replay import BENCHES, SIMULATORS

from ..studies.synth import AREA_KEYS, STAGES, TARGETS
from ..studies.timing import STAGES as TIMING_STAGES
from ..studies.timing import TARGETS as TIMING_TARGETS
from ..studies.timing import TimingResult
from .options import add_design_args, design_from_args, int_at_least, pipeline_from_args

__all__ = [
    "add_filter_args",
    "add_parser",
    "add_replay_parser",
    "add_synth_parser",
    "add_timing_parser",
    "cmd_replay",
    "cmd_synth",
    "cmd_timing",
]


def add_parser(sub) -> None:
    """Register ``rangefx hdl`` and its subcommands on ``sub``."""
    p = sub.add_parser("hdl", help="the Verilog of P1 and P2: vector replay, synthesis area, "
                       "timing")  # fmt: skip
    hs = p.add_subparsers(dest="hdl_command", required=True)
    add_replay_parser(hs)
    add_synth_parser(hs)
    add_timing_parser(hs)


def add_replay_parser(hs) -> None:
    """``rangefx hdl replay DIR [--sim S] [--bench B] [--dump OUT] [--time-model] [--json]``."""
    r = hs.add_parser(
        "replay", help="replay a P1 or P2 vector directory through hdl/p1_top.v or p2_top.v"
    )
    r.add_argument("dir", help="P1 or P2 vector directory (rangefx vectors gen)")
    r.add_argument("--sim", choices=tuple(SIMULATORS), default="icarus", help="HDL simulator")
    r.add_argument(
        "--bench", choices=("auto", *BENCHES), default="auto",
        help="cocotb (hdl/test_top.py, Icarus) or plain (the Verilog bench hdl/tb_top.v); "
        "auto: cocotb under Icarus, plain under Verilator",
    )  # fmt: skip
    r.add_argument("--dump", help="keep the RTL dumps (<tap>.mem, taps.npz, status.json) here")
    r.add_argument(
        "--time-model", action="store_true",
        help="also time the model on the same case (all taps, after a warm-up run) and "
        "report its Mpix/s beside the simulator's Mcycles/s",
    )  # fmt: skip
    r.add_argument("--json", action="store_true", help="print one JSON object")
    r.set_defaults(func=cmd_replay)


def cmd_replay(args: argparse.Namespace) -> int:
    from rangefx import api

    result = api.replay(
        args.dir, args.sim, bench=args.bench, dump=args.dump, time_model=args.time_model
    )
    if args.json:
        print(json.dumps(result.figures, indent=1))
    else:
        print(_text(result.figures))
    return 0 if result.ok else 1


def _text(r: dict) -> str:
    shape = f"{r['shape'][0]}x{r['shape'][1]}"
    lines = [
        f"{r['dir']}: {r['sim']} replay ({r['bench']} bench) of {r['mode']} {shape}, "
        f"{r['cycles']} cycles in {r['sim_s']:.2f} s ({r['mcycles_per_s']:.4f} Mcycles/s)"
    ]
    for tap, t in r["taps"].items():
        lines.append(
            f"  {tap}: {t['samples']} samples, {t['value_mismatches']} value mismatches, "
            f"{t['cycle_mismatches']} cycle mismatches"
        )
    bad = {k: v for k, v in r["overflows"].items() if v["rtl"] != v["model"]}
    counted = {k: v["rtl"] for k, v in r["overflows"].items() if v["rtl"]}
    lines.append(f"overflow counts: {'equal to' if not bad else 'DIFFER from'} the manifest's "
                 f"{counted or '(none)'}" + (f"; differing: {bad}" if bad else ""))  # fmt: skip
    a = r["m_axis"]
    lines.append(f"AXI4-Stream output: {a['words']} words, {a['mismatches']} mismatches "
                 f"({a['value_mismatches']} in value, {a['cycle_mismatches']} in cycle"
                 f"{'' if a['framing_ok'] else ', framing wrong'})")  # fmt: skip
    raised = [k for k, v in r["flags"].items() if v]
    if raised:
        lines.append(f"flags raised: {', '.join(raised)}")
    f = r["first_mismatch"]
    if f:
        lines.append(
            f"first mismatch: tap {f['tap']}, cycle {f['cycle']} (RTL {f['got_cycle']}), "
            f"row {f['row']}, col {f['col']}, expected {f['expected']}, got {f['got']}"
        )
    if "model_mpix_s" in r:
        lines.append(f"model on the same case: {r['model_s']:.3f} s, {r['model_mpix_s']} Mpix/s")
    lines.append(
        f"total: {r['value_mismatches']} value mismatches, {r['cycle_mismatches']} cycle "
        f"mismatches: {'OK' if r['ok'] else 'FAIL'}"
    )
    return "\n".join(lines)


def cmd_synth(args: argparse.Namespace) -> int:
    from rangefx import api

    pipeline = pipeline_from_args(args)
    report = api.synth(
        pipeline, args.config, target=args.target, shape=(args.height, args.width),
        mode=args.mode, stage=args.stage, use_cache=not args.no_cache, probes=not args.no_probes,
        **design_from_args(pipeline, args),
    ).figures  # fmt: skip
    if args.json:
        print(json.dumps(report))
        return 0
    print(f"{pipeline.name.upper()} {args.mode} {args.height}x{args.width}, config "
          f"{report['config']}, Yosys {args.target}:")  # fmt: skip
    print(f"  {'':<22} " + " ".join(f"{k:>6}" for k in AREA_KEYS) + "  cached")
    top = report["headline"]  # the whole top's module, or "stages"
    if top != "stages":
        print(f"  {'whole ' + top:<22} " + " ".join(f"{report[k]:>6}" for k in AREA_KEYS)
              + f"  {'yes' if report['cached'] else 'no'}")  # fmt: skip
    if "probes" in report:
        p = report["probes"]
        print(f"  {'+ taps, ovf counters':<22} " + " ".join(f"{p[k]:>+6}" for k in AREA_KEYS)
              + f"  {'yes' if p['cached'] else 'no'}")  # fmt: skip
    if report["stages"]:
        print("  stages, each with its probes:")
    for stage, a in report["stages"].items():
        cells = " ".join(f"{a[k]:>6}" for k in AREA_KEYS)
        name = f"{stage} x{a['instances']}"
        print(f"  {name:<22} {cells}  {'yes' if a['cached'] else 'no'}")
    if report["stages"]:
        print(f"  {'stages as instantiated':<22} "
              + " ".join(f"{report['stages_sum'][k]:>6}" for k in AREA_KEYS))  # fmt: skip
    return 0


def add_filter_args(p) -> None:
    """``--filter-form`` and ``--pole``: the filters' structure is hardware (the direct
    form holds a multiplier per filter, the shift form wires the pole 2^-k)."""
    p.add_argument("--filter-form", choices=FILTER_FORMS,
                   help="P1 filters: multiply by the pole register, or shift by k for a pole "
                   "2^-k (default: the config's, shift)")  # fmt: skip
    p.add_argument("--pole", type=float, help="filter pole (default: the config's, 0.5)")


def _add_rtl_args(p, target: tuple[tuple[str, ...], str, str],
                  stage: tuple[tuple[str, ...], str, str]) -> None:  # fmt: skip
    """The arguments ``hdl synth`` and ``hdl timing`` share: the pipeline, its design and
    filter options, ``--target`` and ``--stage`` (each ``(choices, default, help)``), the
    mode, the frame the RTL is sized for, ``--no-cache`` and ``--json``."""
    p.add_argument("--pipeline", default="p1", help="pipeline with RTL in hdl/: p1 or p2 "
                   "(default p1)")  # fmt: skip
    add_design_args(p, estimator=False)
    add_filter_args(p)
    p.add_argument("--target", choices=target[0], default=target[1], help=target[2])
    p.add_argument("--stage", choices=stage[0], default=stage[1], help=stage[2])
    p.add_argument("--mode", choices=("stereo", "motion"), default="stereo",
                   help="stereo: two front ends, motion: one and the frame store (default "
                   "stereo)")  # fmt: skip
    p.add_argument("--width", type=int_at_least(2, "--width"), default=512,
                   help="line width the line buffers and counters are sized for (512)")  # fmt: skip
    p.add_argument("--height", type=int_at_least(2, "--height"), default=512,
                   help="frame height the row counter is sized for (512)")  # fmt: skip
    p.add_argument("--no-cache", action="store_true",
                   help="run the tools again even when the cache holds the result")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print one JSON object")


def add_synth_parser(hs) -> None:
    """``hdl synth``: added to the ``hdl`` group's subparsers ``hs``."""
    s = hs.add_parser("synth", help="Yosys area of the whole P1 or P2 RTL, its probes and "
                      "its stages")  # fmt: skip
    _add_rtl_args(
        s,
        target=(tuple(TARGETS), "xcup", "Yosys flow: synth_xilinx -family xc7|xcup, "
                "synth_ecp5, synth_ice40 (default xcup)"),
        stage=(("top", *STAGES, "all"), "all", "what to synthesise: top (the whole p1_top or "
               "p2_top, and its probes apart), P1's frontend (one stream, x-derivative "
               "included) or range, or all (P2: the top)"),
    )  # fmt: skip
    s.add_argument("--no-probes", action="store_true",
                   help="skip the third synthesis that measures what the taps and overflow "
                   "counters cost")  # fmt: skip
    s.set_defaults(func=cmd_synth)


def cmd_timing(args: argparse.Namespace) -> int:
    from rangefx import api

    pipeline = pipeline_from_args(args)
    result = api.timing(
        pipeline, args.config, target=args.target, device=args.device, package=args.package,
        speed=args.speed, seeds=args.seeds, freq_mhz=args.freq, shape=(args.height, args.width),
        mode=args.mode, stage=args.stage, use_cache=not args.no_cache,
        **design_from_args(pipeline, args),
    ).result  # fmt: skip
    if args.json:
        print(json.dumps(result.to_dict()))
    else:
        print(_timing_text(result))
    return 0


def _timing_text(r: TimingResult) -> str:
    lines = [
        f"{r.pipeline.upper()} {r.stage} {r.mode} {r.shape[0]}x{r.shape[1]}, config {r.config}, "
        f"{r.target} {r.device} {r.package}{'' if r.speed is None else f' speed {r.speed}'} "
        f"({r.pins} pins), aiming at "
        f"{r.freq_mhz:g} MHz:"
    ]
    for clock, fmax in r.fmax_mhz.items():
        each = ", ".join(f"{s.fmax_mhz.get(clock, 0):.1f}" for s in r.seeds)
        lines.append(f"  {clock}: Fmax {fmax:.1f} MHz (median of seeds: {each})")
        p = r.critical_path.get(clock)
        if p is not None:
            lines.append(
                f"    critical path {p.delay_ns:.2f} ns ({p.logic_ns:.2f} logic, "
                f"{p.routing_ns:.2f} routing): {p.from_cell} -> {p.to_cell}"
            )
    family = TIMING_TARGETS[r.target]
    # a cell key counts every cell it prefixes (SB_DFF: SB_DFFE, SB_DFFSR, ...)
    cells = {k: sum(v for c, v in r.cells.items() if c.startswith(k)) for k in family.cell_keys}
    lines.append("  cells: " + ", ".join(f"{k} {v}" for k, v in cells.items()))
    lines.append("  placed: " + ", ".join(f"{k} {r.utilisation.get(k, 0)}"
                                          for k in family.bel_keys))  # fmt: skip
    return "\n".join(lines)


def add_timing_parser(hs) -> None:
    """``hdl timing``: added to the ``hdl`` group's subparsers ``hs``."""
    t = hs.add_parser("timing", help="place-and-route Fmax, critical path and utilisation "
                      "of the P1 or P2 RTL (Yosys + nextpnr)")  # fmt: skip
    _add_rtl_args(
        t,
        target=(tuple(TIMING_TARGETS), "ecp5", "FPGA family: ecp5 (Yosys synth_ecp5, "
                "nextpnr-ecp5; default) or ice40 (synth_ice40, nextpnr-ice40)"),
        stage=(TIMING_STAGES, "top", "top: the whole P1 or P2 (default), frontend: one P1 "
               "stream's"),
    )  # fmt: skip
    devices = {d: t for t, f in TIMING_TARGETS.items() for d in f.devices}
    t.add_argument("--device", choices=tuple(devices),
                   help="ecp5: 25k, 45k, 85k (LFE5U-25F/-45F/-85F; default 85k); ice40: up5k, "
                   "hx8k (default up5k)")  # fmt: skip
    t.add_argument("--package", help="package (default: the device's first: CABGA381 on "
                   "ECP5, sg48 on the UP5K, ct256 on the HX8K)")  # fmt: skip
    t.add_argument("--speed", type=int, choices=(6, 7, 8),
                   help="ECP5 speed grade (default 6, the slowest); iCE40 has none")  # fmt: skip
    t.add_argument("--seeds", type=int_at_least(1, "--seeds"), default=3,
                   help="nextpnr runs (seeds 1..N); Fmax is their median (default 3)")  # fmt: skip
    t.add_argument("--freq", type=float, default=148.5,
                   help="frequency nextpnr aims at, MHz (default 148.5, 1080p60)")  # fmt: skip
    t.set_defaults(func=cmd_timing)
