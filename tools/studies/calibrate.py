"""Calibration of P1's area proxy against the whole-top synthesis (issue 35;
``python -m rangefx.tools.studies.calibrate``).

The proxy (:func:`rangefx.rtl_model.p1.cost.config_cost`) counts register bits, DSP
slices and RAMB18 from the word lengths alone; Yosys synthesises the whole ``p1_top``
without its probes (:func:`rangefx.tools.studies.synth.synth_top`). For each target, each
area class is fitted as a straight line of one proxy term over the fit configs
(:data:`FIT_CONFIGS`), by least squares:

* LUT and FF from ``register_bits`` (the datapath's width: its adders, casts and the
  pipeline registers that repeat each signal scale with it; the intercept is the
  control, counters and the host-register chain),
* DSP from the proxy's DSP slices (the slope absorbs the device's multiplier tiling:
  27 x 18 on xcup, 18 x 18 on ECP5),
* BRAM from the proxy's RAMB18 (the intercept is the reciprocal divider's seed ROM,
  which the proxy does not count).

The fit is then scored on configs it did not see (:data:`HELD_OUT_CONFIGS`): proxy /
synthesis ratios before (the raw proxy terms, as ``hdl synth`` reports them) and after
(the calibrated estimate, :func:`rangefx.rtl_model.p1.cost.estimated_area`). ``--write``
stores the coefficients in ``rtl_model/p1/synth_calibration.toml`` with the RTL's commit
and the SHA-256 of its sources, so that a change of the RTL is one command away from a
new calibration, never hand-typed numbers.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
from collections.abc import Callable, Mapping, Sequence
from importlib import resources

import numpy as np

from rangefx.rtl_model.p1.config import P1Config
from rangefx.rtl_model.p1.cost import (
    AREA_FEATURES,
    CALIBRATION_FILE,
    config_cost,
    estimated_area,
)
from rangefx.rtl_model.registry import get_pipeline
from rangefx.vectors.hdl import HDL_DIR, HDL_SOURCES

from .synth import synth_top, yosys_version

__all__ = [
    "FIT_CONFIGS",
    "HELD_OUT_CONFIGS",
    "TARGETS",
    "calibrate",
    "calibration_toml",
    "main",
    "named_config",
    "rtl_identity",
]

#: Configs the coefficients are fitted on: name -> (shipped sweep config or None for the
#: default, design overrides). Two at the default widths, two narrowed by the optimiser.
FIT_CONFIGS: dict[str, tuple[str | None, dict]] = {
    "default": (None, {}),
    "lab-optimised": ("p1_lab_optimised_1pct.toml", {}),
    "default-consistent": (None, {"variant": "consistent"}),
    "lab-runway-optimised": ("p1_lab_runway_optimised_1pct.toml", {}),
}
#: Configs the fit is scored on and never sees.
HELD_OUT_CONFIGS: dict[str, tuple[str | None, dict]] = {
    "default-direct": (None, {"filter_form": "direct"}),
    "motorcycle-margin50": ("p1_lab_runway_motorcycle_margin50_1pct.toml", {}),
    "default-restoring": (None, {"divider": "restoring"}),
}
#: Yosys targets calibrated.
TARGETS: tuple[str, ...] = ("xcup", "ecp5")
_PROXY_TERMS = {"ff": "register_bits", "dsp": "dsp", "bram": "bram18"}  # hdl synth's ratios

SynthFn = Callable[[P1Config, str, tuple[int, int], str], Mapping[str, int]]


def named_config(name: str) -> P1Config:
    """A calibration config by its name in :data:`FIT_CONFIGS` / :data:`HELD_OUT_CONFIGS`."""
    path, design = (FIT_CONFIGS | HELD_OUT_CONFIGS)[name]
    pipe = get_pipeline("p1")
    if path is None:
        config = pipe.default_config()
    else:
        sweeps = resources.files("rangefx.tools.studies").joinpath("sweeps", path)
        config = pipe.load_config(str(sweeps))
    return config.with_(**design) if design else config


def rtl_identity() -> dict[str, str]:
    """The RTL calibrated: the SHA-256 of ``hdl/``'s sources and headers and, in a git
    checkout, the commit (``unknown`` otherwise)."""
    h = hashlib.sha256()
    for path in (*(HDL_DIR / s for s in HDL_SOURCES), *sorted(HDL_DIR.glob("*.vh"))):
        h.update(path.read_bytes())
    run = subprocess.run(["git", "-C", str(HDL_DIR), "log", "-1", "--format=%h", "--", "."],
                         capture_output=True, text=True, check=False)  # fmt: skip
    commit = run.stdout.strip() if run.returncode == 0 and run.stdout.strip() else "unknown"
    return {"rtl_commit": commit, "rtl_sha256": h.hexdigest()[:16]}


def _synth(config: P1Config, target: str, shape: tuple[int, int], mode: str) -> dict[str, int]:
    area, _cached = synth_top(config, target, shape, mode)
    return {k: getattr(area, k) for k in AREA_FEATURES}


def _ratio(a: float, b: float) -> float | None:
    return round(a / b, 3) if b else None


def calibrate(
    targets: Sequence[str] = TARGETS,
    shape: tuple[int, int] = (512, 512),
    mode: str = "stereo",
    *,
    synth: SynthFn | None = None,
) -> dict:
    """Fit the proxy to the whole-top synthesis on :data:`FIT_CONFIGS` and score it on
    :data:`HELD_OUT_CONFIGS` (module docstring). ``synth(config, target, shape, mode)``
    gives the synthesised ``lut``, ``ff``, ``dsp``, ``bram`` (default: Yosys, cached).

    Returns a JSON-able dict: ``shape``, ``mode``, ``fit_configs``, ``held_out_configs``,
    ``coefficients`` {target: {area class: [slope, intercept]}} and ``configs`` {target:
    {config: {``fit`` (bool), ``synth``, ``proxy`` (the proxy's terms), ``before``
    (raw proxy / synthesis: register bits / FF, DSP / DSP, RAMB18 / BRAM), ``estimate``
    and ``after`` (estimate / synthesis, every class)}}}."""
    names = [*FIT_CONFIGS, *HELD_OUT_CONFIGS]
    configs = {n: named_config(n) for n in names}
    proxies = {n: config_cost(c, shape, mode).as_dict() for n, c in configs.items()}
    coefficients: dict[str, dict[str, list[float]]] = {}
    rows: dict[str, dict] = {}
    for target in targets:
        areas = {n: dict((synth or _synth)(c, target, shape, mode)) for n, c in configs.items()}
        coef = {}
        for cls, term in AREA_FEATURES.items():
            x = np.array([proxies[n][term] for n in FIT_CONFIGS], dtype=float)
            y = np.array([areas[n][cls] for n in FIT_CONFIGS], dtype=float)
            if np.ptp(x) == 0:  # one proxy value: the mean ratio (the mean, if it is 0)
                slope = float(y.mean() / x[0]) if x[0] else 0.0
                intercept = 0.0 if x[0] else float(y.mean())
            else:
                slope, intercept = (float(v) for v in np.polyfit(x, y, 1))
            coef[cls] = [round(slope, 6), round(intercept, 3)]
        coefficients[target] = coef
        rows[target] = {}
        for n in names:
            est = estimated_area(configs[n], shape, mode, target, {"targets": {target: coef}})
            before = {cls: _ratio(proxies[n][t], areas[n][cls]) for cls, t in _PROXY_TERMS.items()}
            rows[target][n] = {
                "fit": n in FIT_CONFIGS,
                "synth": areas[n],
                "proxy": {t: proxies[n][t] for t in ("register_bits", "dsp", "bram18")},
                "before": before | {"lut": None},
                "estimate": est,
                "after": {cls: _ratio(est[cls], areas[n][cls]) for cls in AREA_FEATURES},
            }
    return {
        "shape": list(shape),
        "mode": mode,
        "fit_configs": list(FIT_CONFIGS),
        "held_out_configs": list(HELD_OUT_CONFIGS),
        "coefficients": coefficients,
        "configs": rows,
    }


def calibration_toml(result: Mapping, yosys: str, rtl: Mapping[str, str]) -> str:
    """The calibration file's text (``rtl_model/p1/synth_calibration.toml``)."""
    lines = [
        "# P1 area proxy calibrated against the whole-top synthesis (Yosys, p1_top flat,",
        "# no probes). Generated by `python -m rangefx.tools.studies.calibrate --write`;",
        "# re-run it after a change of hdl/ (rtl_sha256 below no longer matches).",
        "# Each class: [slope, intercept] of a straight line in one proxy term:",
        "# " + ", ".join(f"{c} <- {t}" for c, t in AREA_FEATURES.items()) + ".",
        "[meta]",
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
        lines += [f"{cls} = [{slope!r}, {intercept!r}]" for cls, (slope, intercept) in coef.items()]
    return "\n".join(lines) + "\n"


def _table(result: Mapping) -> str:
    out = []
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
    return "\n".join(out)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m rangefx.tools.studies.calibrate [--target T ...] [--write] [--json]``."""
    p = argparse.ArgumentParser(prog="python -m rangefx.tools.studies.calibrate",
                                description=__doc__.split("\n\n")[0])  # fmt: skip
    p.add_argument("--target", nargs="+", choices=TARGETS, default=list(TARGETS))
    p.add_argument("--write", action="store_true",
                   help=f"store the coefficients in {CALIBRATION_FILE.name}")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    args = p.parse_args(argv)
    from ..errors import UserError

    try:
        version = yosys_version()
        result = calibrate(tuple(args.target))
    except UserError as exc:
        print(f"rangefx: error: {exc}", file=sys.stderr)
        return 2
    rtl = rtl_identity()
    result |= {"yosys": version, **rtl}
    if args.write:
        tmp = CALIBRATION_FILE.with_suffix(".tmp")
        tmp.write_text(calibration_toml(result, version, rtl))
        tmp.replace(CALIBRATION_FILE)
    print(json.dumps(result) if args.json else _table(result))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
