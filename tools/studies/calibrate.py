"""Calibration of a pipeline's area proxy against the whole-top synthesis of its RTL
(issues 35, 36; ``python -m rangefx.tools.studies.calibrate``).

One function for every pipeline with RTL (:data:`rangefx.tools.studies.synth.RTL_TOPS`),
written against the :class:`~rangefx.rtl_model.pipeline.Pipeline` interface: each
pipeline declares the configs synthesised (``calibration_configs``: fitted on, or held
out to score the fit), the proxy terms each area class is fitted on (``area_features``,
values of ``area_terms``) and where the coefficients live (``area_calibration``).

The proxy (``Pipeline.area_terms``: register bits, DSP slices, RAMB18, the restoring
dividers' cells) comes from the word lengths alone; Yosys synthesises the whole top
without its probes (:func:`rangefx.tools.studies.synth.synth_pipeline_top`). For each
target each area class is fitted by least squares as an intercept plus a slope per term:

* LUT and FF on ``register_bits`` (the datapath's width: adders, casts and the pipeline
  registers that repeat each signal scale with it; the intercept is the control,
  counters and host registers) and ``restoring_cells`` (quotient bits x divisor bits of
  the restoring dividers: one subtractor and remainder register per quotient bit, where
  the reciprocal divider has three products and a ROM instead),
* DSP on the proxy's DSP slices (the slope absorbs the device's multiplier tiling: 18 x
  18 on ECP5, 27 x 18 on xcup),
* BRAM on the proxy's RAMB18 (line buffers) and ``recip_roms`` (the reciprocal
  dividers' seed ROMs, block RAM on ECP5, which the RAMB18 count leaves out).

A term constant over the fit configs cannot be told from the intercept: it gets no
slope, and a class whose every term is constant is the mean ratio to its first term.
The fit is scored on the held-out configs: proxy / synthesis ratios before (the raw
proxy terms, as ``hdl synth`` reports them) and after (the calibrated estimate,
``Pipeline.estimated_area``). ``--write`` stores the coefficients with the RTL's commit
and the SHA-256 of its sources, so that a change of the RTL is one command away from a
new calibration, never hand-typed numbers.

The reference target is ECP5 (``synth_ecp5``): the family ``hdl timing`` places and
routes on, and the issue's LFE5U-85F; ``--target ecp5 xcup`` adds the UltraScale+.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from rangefx.rtl_model.cost import load_area_calibration
from rangefx.rtl_model.pipeline import Pipeline
from rangefx.rtl_model.registry import get_pipeline
from rangefx.vectors.hdl import HDL_DIR, rtl_files

from .synth import AREA_KEYS, RTL_TOPS, synth_pipeline_top, yosys_version

__all__ = [
    "DEFAULT_TARGETS",
    "TARGETS",
    "calibrate",
    "calibrated_pipelines",
    "calibration_toml",
    "fit_area_class",
    "main",
    "rtl_identity",
    "write_calibration",
]

#: Yosys targets a calibration may fit.
TARGETS: tuple[str, ...] = ("ecp5", "xcup")
#: The reference: ECP5, the family the timing flow places on (module docstring).
DEFAULT_TARGETS: tuple[str, ...] = ("ecp5",)
#: What ``before`` compares, as ``hdl synth``'s ``proxy_ratio``: area class -> proxy term.
_PROXY_TERMS = {"ff": "register_bits", "dsp": "dsp", "bram": "bram18"}

SynthFn = Callable[[str, object, str, tuple[int, int], str], Mapping[str, int]]


def calibrated_pipelines() -> tuple[str, ...]:
    """The pipelines with RTL and declared calibration configs."""
    return tuple(n for n in RTL_TOPS if get_pipeline(n).calibration_configs)


def rtl_identity(pipeline: str) -> dict[str, str]:
    """The RTL calibrated: the SHA-256 of the pipeline's Verilog sources and the headers
    they include (:func:`rangefx.vectors.hdl.rtl_files`) and, in a git checkout, the last
    commit that touched one of them (``unknown`` otherwise)."""
    h = hashlib.sha256()
    files = rtl_files(RTL_TOPS[pipeline].sources)
    for path in files:
        h.update(path.read_bytes())
    run = subprocess.run(["git", "-C", str(HDL_DIR), "log", "-1", "--format=%h", "--",
                          *(p.name for p in files)],
                         capture_output=True, text=True, check=False)  # fmt: skip
    commit = run.stdout.strip() if run.returncode == 0 and run.stdout.strip() else "unknown"
    return {"rtl_commit": commit, "rtl_sha256": h.hexdigest()[:16]}


def _synth(pipeline: str, config, target: str, shape: tuple[int, int], mode: str) -> dict:
    area, _cached = synth_pipeline_top(pipeline, config, target, shape, mode)
    return {k: getattr(area, k) for k in AREA_KEYS}


def _ratio(a: float, b: float) -> float | None:
    return round(a / b, 3) if b else None


def fit_area_class(
    terms: Sequence[Mapping[str, float]], areas: Sequence[float], features: Sequence[str]
) -> dict[str, float]:
    """Least-squares coefficients of one area class: ``areas[i] ~ intercept + sum over
    features of slope * terms[i][feature]``. A feature constant over the configs gets
    no slope (it cannot be told from the intercept); if every feature is, the class is
    the mean ratio to the first feature (the mean itself if that feature is 0).

    Returns ``{"intercept": c, feature: slope, ...}`` (every feature named)."""
    y = np.asarray(areas, dtype=float)
    x = np.array([[t[f] for f in features] for t in terms], dtype=float).reshape(len(y), -1)
    varying = [j for j in range(x.shape[1]) if np.ptp(x[:, j]) > 0]
    coef = dict.fromkeys(features, 0.0)
    if not varying:
        first = x[0, 0]
        coef[features[0]] = round(float(y.mean() / first), 6) if first else 0.0
        return {"intercept": 0.0 if first else round(float(y.mean()), 3)} | coef
    design = np.column_stack([x[:, varying], np.ones(len(y))])
    solution, *_ = np.linalg.lstsq(design, y, rcond=None)
    for j, slope in zip(varying, solution[:-1], strict=True):
        coef[features[j]] = round(float(slope), 6)
    return {"intercept": round(float(solution[-1]), 3)} | coef


def calibrate(
    pipeline: str | Pipeline,
    targets: Sequence[str] = DEFAULT_TARGETS,
    shape: tuple[int, int] = (512, 512),
    mode: str = "stereo",
    *,
    synth: SynthFn | None = None,
    jobs: int = 2,
) -> dict:
    """Fit ``pipeline``'s proxy to the whole-top synthesis on its fit configs and score
    it on its held-out configs (module docstring). ``synth(pipeline, config, target,
    shape, mode)`` gives the synthesised ``lut``, ``ff``, ``dsp``, ``bram`` (default:
    Yosys, cached; ``jobs`` syntheses at once).

    Returns a JSON-able dict: ``pipeline``, ``shape``, ``mode``, ``fit_configs``,
    ``held_out_configs``, ``coefficients`` {target: {area class: {``intercept``, term:
    slope}}}, ``configs`` {target: {config: {``fit`` (bool), ``synth``, ``proxy`` (the
    proxy's terms), ``before`` (raw proxy / synthesis: register bits / FF, DSP / DSP,
    RAMB18 / BRAM), ``estimate`` and ``after`` (estimate / synthesis, every class)}}} and
    ``summary`` {target: {``before``, ``after``: {class: [min, max] over the held-out
    configs}}}."""
    pipe = get_pipeline(pipeline) if isinstance(pipeline, str) else pipeline
    if not pipe.calibration_configs or not pipe.area_features:
        raise ValueError(f"pipeline {pipe.name} declares no area calibration")
    names = list(pipe.calibration_configs)
    fit = [n for n in names if pipe.calibration_configs[n][2]]
    held = [n for n in names if not pipe.calibration_configs[n][2]]
    configs = {n: pipe.calibration_config(n) for n in names}
    terms = {n: pipe.area_terms(c, shape, mode) for n, c in configs.items()}
    run = synth or _synth
    jobs_list = [(t, n) for t in targets for n in names]
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        done = pool.map(lambda tn: dict(run(pipe.name, configs[tn[1]], tn[0], shape, mode)),
                        jobs_list)  # fmt: skip
        areas = dict(zip(jobs_list, done, strict=True))
    coefficients: dict[str, dict[str, dict[str, float]]] = {}
    rows: dict[str, dict] = {}
    summary: dict[str, dict] = {}
    for target in targets:
        coef = {cls: fit_area_class([terms[n] for n in fit], [areas[target, n][cls] for n in fit],
                                    features)
                for cls, features in pipe.area_features.items()}  # fmt: skip
        coefficients[target] = coef
        cal = {"targets": {target: coef}}
        rows[target] = {}
        for n in names:
            synthesised = areas[target, n]
            est = pipe.estimated_area(configs[n], shape, mode, target, cal)
            before = {c: _ratio(terms[n][t], synthesised[c]) for c, t in _PROXY_TERMS.items()}
            rows[target][n] = {
                "fit": n in fit,
                "synth": synthesised,
                "proxy": {
                    t: terms[n][t]
                    for t in sorted({t for f in pipe.area_features.values() for t in f})
                },
                "before": before | {"lut": None},
                "estimate": est,
                "after": {c: _ratio(est[c], synthesised[c]) for c in pipe.area_features},
            }
        summary[target] = {
            when: {c: _span([rows[target][n][when][c] for n in held])
                   for c in pipe.area_features}
            for when in ("before", "after")
        }  # fmt: skip
    return {
        "pipeline": pipe.name,
        "shape": list(shape),
        "mode": mode,
        "fit_configs": fit,
        "held_out_configs": held,
        "coefficients": coefficients,
        "configs": rows,
        "summary": summary,
    }


def _span(values: Sequence[float | None]) -> list[float] | None:
    known = [v for v in values if v is not None]
    return [min(known), max(known)] if known else None


def calibration_toml(result: Mapping, yosys: str, rtl: Mapping[str, str]) -> str:
    """The calibration file's text (the pipeline's ``area_calibration``)."""
    pipe = get_pipeline(result["pipeline"])
    top = RTL_TOPS[pipe.name].module
    lines = [
        f"# {pipe.name.upper()} area proxy calibrated against the whole-top synthesis (Yosys, "
        f"{top} flat,",
        f"# no probes). Generated by `python -m rangefx.tools.studies.calibrate --pipeline "
        f"{pipe.name} --write`;",
        "# re-run it after a change of hdl/ (rtl_sha256 below no longer matches).",
        "# Each class: intercept + slope * proxy term (Pipeline.area_terms), summed over",
        "# " + "; ".join(f"{c}: {', '.join(t)}" for c, t in pipe.area_features.items()) + ".",
        "[meta]",
        f'pipeline = "{pipe.name}"',
        f'rtl_commit = "{rtl["rtl_commit"]}"',
        f'rtl_sha256 = "{rtl["rtl_sha256"]}"',
        f"yosys = {json.dumps(yosys)}",
        f"shape = {list(result['shape'])}",
        f'mode = "{result["mode"]}"',
        f"fit_configs = {json.dumps(result['fit_configs'])}",
        f"held_out_configs = {json.dumps(result['held_out_configs'])}",
    ]
    for target, coef in result["coefficients"].items():
        lines.append(f"\n[targets.{target}]")
        for cls, terms in coef.items():
            inner = ", ".join(f"{t} = {v!r}" for t, v in terms.items())
            lines.append(f"{cls} = {{ {inner} }}")
    return "\n".join(lines) + "\n"


def write_calibration(result: Mapping, yosys: str, rtl: Mapping[str, str]) -> str:
    """Write the calibration file of ``result``'s pipeline (atomically: a temporary file
    renamed over it) and return its path."""
    path = get_pipeline(result["pipeline"]).area_calibration_path()
    if path is None:
        raise ValueError(f"pipeline {result['pipeline']} has no area calibration file")
    tmp = path.with_suffix(".tmp")
    tmp.write_text(calibration_toml(result, yosys, rtl))
    tmp.replace(path)
    load_area_calibration(path)  # it reads back
    return str(path)


def _table(result: Mapping) -> str:
    out = [f"{result['pipeline'].upper()} {result['shape'][0]}x{result['shape'][1]} "
           f"{result['mode']}:"]  # fmt: skip
    for target, rows in result["configs"].items():
        out.append(f"{target}: config (fit/held out): synth LUT/FF/DSP/BRAM; proxy/synth "
                   "before (FF, DSP, BRAM); estimate/synth after (LUT, FF, DSP, BRAM)")  # fmt: skip
        for name, r in rows.items():
            s, b, a = r["synth"], r["before"], r["after"]
            out.append(
                f"  {name} ({'fit' if r['fit'] else 'held out'}): "
                f"{s['lut']}/{s['ff']}/{s['dsp']}/{s['bram']}; "
                f"{b['ff']}, {b['dsp']}, {b['bram']}; "
                f"{a['lut']}, {a['ff']}, {a['dsp']}, {a['bram']}"
            )
        summary = result["summary"][target]
        for when in ("before", "after"):
            spans = ", ".join(f"{c} {s[0]}-{s[1]}" for c, s in summary[when].items() if s)
            out.append(f"  held out, {when}: {spans}")
    return "\n".join(out)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m rangefx.tools.studies.calibrate [--pipeline P ...] [--target T ...]
    [--jobs N] [--write] [--json]``."""
    p = argparse.ArgumentParser(prog="python -m rangefx.tools.studies.calibrate",
                                description=__doc__.split("\n\n")[0])  # fmt: skip
    p.add_argument("--pipeline", nargs="+", choices=calibrated_pipelines(),
                   default=list(calibrated_pipelines()),
                   help="pipelines to calibrate (default: every one with RTL)")  # fmt: skip
    p.add_argument("--target", nargs="+", choices=TARGETS, default=list(DEFAULT_TARGETS),
                   help="Yosys targets (default ecp5, the reference)")  # fmt: skip
    p.add_argument("--jobs", type=int, default=2, help="syntheses at once (default 2)")
    p.add_argument("--write", action="store_true",
                   help="write each pipeline's synth_calibration.toml")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print one JSON object per pipeline")
    args = p.parse_args(argv)
    from ..errors import UserError

    results = []
    try:
        version = yosys_version()
        for name in args.pipeline:
            results.append(calibrate(name, tuple(args.target), jobs=args.jobs))
    except UserError as exc:
        print(f"rangefx: error: {exc}", file=sys.stderr)
        return 2
    for result in results:
        rtl = rtl_identity(result["pipeline"])
        result |= {"yosys": version, **rtl}
        if args.write:
            result["written"] = write_calibration(result, version, rtl)
        print(json.dumps(result) if args.json else _table(result))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
