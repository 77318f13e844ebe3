"""Word-length sweeps of P1: definition, metrics, resumable parallel execution (SPEC §6).

A sweep definition (TOML, :func:`load_sweep`) names a base config, the scenes, the
metric groups and one or more *axes*; each axis moves one field (``frac``, ``word``,
``int``, their ``*_delta`` group moves, ``quant`` or ``overflow``) of one signal or of a
group of signals over a list or range of values. The axes combine as a cartesian
``grid`` or ``one_at_a_time`` (each axis alone, the others at the base: a sensitivity
study). Example (``tools/sweeps/p1_lab.toml``)::

    [sweep]
    name = "p1_lab"
    base = "default"              # or a word-length TOML, relative to this file
    variant = "paper"             # optional override of the base's variant
    scenes = ["lab"]
    metrics = ["golden", "truth", "sqnr", "overflows"]
    combine = "one_at_a_time"     # or "grid"

    [[axis]]
    signals = ["row_state"]       # or a group: "datapath", "frontend", "range_stage", ...
    param = "frac"                # frac | word | int | frac_delta | word_delta | int_delta
    range = [6, 14]               # inclusive, step 1 (or step = k); or values = [...]

``frac`` keeps the integer bits ``W - F`` (the word follows) unless ``keep = "word"``;
``int`` sets the integer bits keeping ``F``; ``*_delta`` add to every listed signal.

Every point is one (config, scene) pair keyed by a hash of the config TOML, the scene
and the metric groups (:func:`point_key`). Points run on local threads (numba kernels
release the GIL) or on a dask.distributed cluster, and each finished point is appended
as one JSON line to ``results.jsonl`` and flushed, so that an interrupted sweep resumes
where it stopped: finished points are never recomputed nor lost.

Metrics per point (:func:`evaluate_point`):

* ``golden``: :func:`rangefx.tools.pipeline.compare_ranges` against the float golden
  ``g4_<variant>`` (median / p95 relative range difference on pixels valid in both,
  validity agreement);
* ``truth``: :func:`rangefx.tools.report.overall_metrics` against the scene depth
  (prefixed ``truth_``);
* ``sqnr``: per tap, SQNR (dB) and max |fixed - golden| against the float counterpart of
  the tap (:func:`golden_taps`); ``None`` SQNR means no error at all;
* ``overflows``: total and per signal;
* cost proxies (:mod:`rangefx.tools.cost`) always.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
import sys
import threading
import time
import tomllib
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from rangefx.golden.estimator import EstimatorConfig, estimate_derivatives
from rangefx.golden.geometry import k_coefficients
from rangefx.golden.methods import SCENE_RANGING
from rangefx.golden.ranging import RangeResult
from rangefx.golden.scenes import SCENE_NAMES, render_scene
from rangefx.rtl_model.config import P1_SIGNALS, WordLengthConfig
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.p1 import P1Result, run_p1
from rangefx.vectors.taps import TAP_SIGNALS

from . import report
from .cost import config_cost
from .errors import UserError
from .pipeline import SCENE_MODE, P1Case, compare_ranges, golden_for

__all__ = [
    "METRIC_GROUPS",
    "SIGNAL_GROUPS",
    "TAP_SIGNAL",
    "Axis",
    "Point",
    "SweepDef",
    "SweepOutcome",
    "evaluate_point",
    "expand",
    "golden_taps",
    "load_results",
    "load_sweep",
    "pareto_front",
    "parse_sweep",
    "point_key",
    "run_sweep",
    "scene_case",
    "tap_errors",
]

RESULTS_NAME = "results.jsonl"
METRIC_GROUPS: tuple[str, ...] = ("golden", "truth", "sqnr", "overflows")
PARAMS: tuple[str, ...] = (
    "frac",
    "word",
    "int",
    "frac_delta",
    "word_delta",
    "int_delta",
    "quant",
    "overflow",
)
COMBINES = ("grid", "one_at_a_time")
_REGISTERS = ("bias_reg", "pole_coef", "f_reg", "k_t_reg", "k_m_reg", "tg2_reg")
_FRONTEND = (
    "bias_in",
    "row_state",
    "row_r1",
    "row_r2",
    "col_state",
    "col_s1",
    "col_s2",
    "col2_state",
    "col2_out",
    "div_quot",
)
#: Named groups of signals an axis may move together. ``datapath`` is every cast signal
#: but the input pixel (the sensor fixes it); ``registers`` the host-written constants.
SIGNAL_GROUPS: dict[str, tuple[str, ...]] = {
    "all": P1_SIGNALS,
    "datapath": tuple(s for s in P1_SIGNALS if s not in _REGISTERS and s != "pix_in"),
    "frontend": _FRONTEND,
    "range_stage": tuple(
        s for s in P1_SIGNALS if s not in _REGISTERS and s not in _FRONTEND and s != "pix_in"
    ),
    "registers": _REGISTERS,
}
#: Fixed-point tap -> the signal whose format holds it (``e1.``/``e2.`` prefixes dropped;
#: ``ex`` is ``div_quot`` or ``col2_out`` by variant and is resolved by the caller): the
#: one mapping of :mod:`rangefx.vectors.taps`, restricted to plain P1 signals.
TAP_SIGNAL: dict[str, str] = {tap: sig for tap, sig in TAP_SIGNALS.items() if sig in P1_SIGNALS}
_MAX_POINTS = 100_000


def _err(where: str, msg: str) -> UserError:
    return UserError(f"{where}: {msg}")


# ------------------------------------------------------------------------ definition
@dataclass(frozen=True)
class Axis:
    """One swept field of one signal or group (see the module docstring)."""

    signals: tuple[str, ...]
    param: str
    values: tuple[Any, ...]
    keep: str = "integer"
    label: str = ""

    def __post_init__(self) -> None:
        if not self.signals:
            raise ValueError("axis: 'signals' is empty")
        bad = [s for s in self.signals if s not in P1_SIGNALS]
        if bad:
            raise ValueError(f"axis: unknown signals {bad}; P1 signals: {', '.join(P1_SIGNALS)}")
        if self.param not in PARAMS:
            raise ValueError(f"axis: unknown param {self.param!r}; choose from {', '.join(PARAMS)}")
        if self.keep not in ("integer", "word"):
            raise ValueError(f"axis: keep must be 'integer' or 'word', not {self.keep!r}")
        if not self.values:
            raise ValueError(f"axis {self.label or self.param!r}: no values")
        names = {"quant": Quant, "overflow": Overflow}.get(self.param)
        for v in self.values:
            if names is not None:
                if not isinstance(v, str) or v not in names.__members__:
                    raise ValueError(
                        f"axis {self.label!r}: {v!r} is not a {self.param} mode; choose from "
                        f"{', '.join(names.__members__)}"
                    )
            elif isinstance(v, bool) or not isinstance(v, int):
                raise ValueError(f"axis {self.label!r}: value {v!r} is not an integer")
        if len(set(self.values)) != len(self.values):
            raise ValueError(f"axis {self.label!r}: repeated values")

    def apply(self, config: WordLengthConfig, value: Any) -> WordLengthConfig:
        """``config`` with this axis at ``value`` (raises ValueError if invalid)."""
        changes = {s: _move(config.formats[s], self.param, value, self.keep) for s in self.signals}
        return config.with_formats(**changes)


def _move(fmt: FixedFormat, param: str, value: Any, keep: str) -> FixedFormat:
    word, frac = fmt.word, fmt.frac
    if param == "quant":
        return replace(fmt, quant=Quant[value])
    if param == "overflow":
        return replace(fmt, overflow=Overflow[value])
    if param in ("frac", "frac_delta"):
        new = value if param == "frac" else frac + value
        word = word + (new - frac) if keep == "integer" else word
        frac = new
    elif param in ("word", "word_delta"):
        word = value if param == "word" else word + value
    else:  # int, int_delta: integer bits I = W - F, F kept
        integer = value if param == "int" else (word - frac) + value
        word = integer + frac
    return FixedFormat(fmt.signed, word, frac, fmt.quant, fmt.overflow)


@dataclass(frozen=True)
class SweepDef:
    """A parsed sweep definition."""

    name: str
    base: WordLengthConfig
    scenes: tuple[str, ...]
    axes: tuple[Axis, ...]
    metrics: tuple[str, ...] = METRIC_GROUPS
    combine: str = "grid"
    size: tuple[int, int] | None = None
    seed: int = 0
    pareto_metric: str = "median_rel_range_diff"
    buildup_hooks: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.scenes:
            raise ValueError("sweep: 'scenes' is empty")
        bad = [s for s in self.scenes if s not in SCENE_NAMES]
        if bad:
            raise ValueError(f"sweep: unknown scenes {bad}; choose from {', '.join(SCENE_NAMES)}")
        bad = [m for m in self.metrics if m not in METRIC_GROUPS]
        if bad:
            raise ValueError(f"sweep: unknown metrics {bad}; choose from {METRIC_GROUPS}")
        if self.combine not in COMBINES:
            raise ValueError(f"sweep: combine must be one of {COMBINES}, not {self.combine!r}")
        if not self.axes:
            raise ValueError("sweep: no [[axis]] tables")
        if self.size is not None and (len(self.size) != 2 or min(self.size) < 8):
            raise ValueError(f"sweep: size must be [height, width] >= 8, not {self.size!r}")
        if self.pareto_metric not in (
            "median_rel_range_diff",
            "p95_rel_range_diff",
            "truth_median_rel_error",
        ):
            raise ValueError(f"sweep: unsupported pareto_metric {self.pareto_metric!r}")
        from .wlplots import BUILDUP_HOOKS

        bad = [h for h in self.buildup_hooks if h not in BUILDUP_HOOKS]
        if bad:
            raise ValueError(
                f"sweep: unknown buildup_hooks {bad}; choose from {', '.join(BUILDUP_HOOKS)}"
            )
        if self.pareto_metric.startswith("truth") and "truth" not in self.metrics:
            raise ValueError("sweep: pareto_metric needs the 'truth' metrics")
        if not self.pareto_metric.startswith("truth") and "golden" not in self.metrics:
            raise ValueError("sweep: pareto_metric needs the 'golden' metrics")


def _int_list(raw: Any, where: str) -> tuple[int, ...]:
    if isinstance(raw, Mapping) or isinstance(raw, str) or not isinstance(raw, Sequence):
        raise _err(where, f"expected a list, not {raw!r}")
    return tuple(raw)


def _parse_axis(raw: Any, k: int, source: str) -> Axis:
    where = f"{source}: axis {k + 1}"
    if not isinstance(raw, Mapping):
        raise _err(where, "must be a table")
    unknown = set(raw) - {"signals", "param", "values", "range", "step", "keep"}
    if unknown:
        raise _err(where, f"unknown keys {sorted(unknown)}")
    for key in ("signals", "param"):
        if key not in raw:
            raise _err(where, f"missing {key!r}")
    sig = raw["signals"]
    if isinstance(sig, str):
        if sig in SIGNAL_GROUPS:
            signals, label = SIGNAL_GROUPS[sig], sig
        elif sig in P1_SIGNALS:
            signals, label = (sig,), sig
        else:
            raise _err(
                where,
                f"unknown signal or group {sig!r}; groups: {', '.join(SIGNAL_GROUPS)}",
            )
    else:
        signals = _int_list(sig, f"{where} signals")
        label = "+".join(str(s) for s in signals)
    if ("values" in raw) == ("range" in raw):
        raise _err(where, "give exactly one of 'values' or 'range'")
    if "values" in raw:
        values = _int_list(raw["values"], f"{where} values")
    else:
        rng = _int_list(raw["range"], f"{where} range")
        step = raw.get("step", 1)
        if (
            len(rng) != 2
            or not all(isinstance(v, int) and not isinstance(v, bool) for v in (*rng, step))
            or step < 1
            or rng[0] > rng[1]
        ):
            raise _err(where, f"range must be [lo, hi] integers, lo <= hi, step >= 1: {raw!r}")
        values = tuple(range(rng[0], rng[1] + 1, step))
    param = str(raw["param"])
    try:
        return Axis(
            tuple(str(s) for s in signals), param, values, str(raw.get("keep", "integer")),
            f"{label}.{param}",
        )  # fmt: skip
    except ValueError as exc:
        raise _err(where, str(exc)) from None


def parse_sweep(text: str, where: str = "sweep definition", root: Path | None = None) -> SweepDef:
    """Parse sweep TOML ``text``; errors are :class:`UserError` naming ``where``."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise _err(where, f"not valid TOML: {exc}") from None
    unknown = set(data) - {"sweep", "axis"}
    if unknown:
        raise _err(where, f"unknown tables {sorted(unknown)} (expected [sweep] and [[axis]])")
    head = data.get("sweep")
    if not isinstance(head, Mapping):
        raise _err(where, "missing the [sweep] table")
    keys = {"name", "base", "variant", "scenes", "metrics", "combine", "size", "seed",
            "pareto_metric", "buildup_hooks"}  # fmt: skip
    unknown = set(head) - keys
    if unknown:
        raise _err(where, f"[sweep]: unknown keys {sorted(unknown)}")
    axes_raw = data.get("axis", [])
    if not isinstance(axes_raw, list) or not axes_raw:
        raise _err(where, "no [[axis]] tables: nothing to sweep")
    try:
        base_name = str(head.get("base", "default"))
        if base_name == "default":
            base = WordLengthConfig.default()
        else:
            path = Path(base_name)
            if root is not None and not path.is_absolute():
                path = root / path
            base = WordLengthConfig.load(path)
        if "variant" in head:
            base = base.with_(variant=head["variant"])
    except ValueError as exc:
        raise _err(where, f"[sweep] base: {exc}") from None
    axes = tuple(_parse_axis(a, k, where) for k, a in enumerate(axes_raw))
    size = head.get("size")
    try:
        return SweepDef(
            name=str(head.get("name", "sweep")),
            base=base,
            scenes=tuple(head.get("scenes", ["lab"])),
            axes=axes,
            metrics=tuple(head.get("metrics", METRIC_GROUPS)),
            combine=str(head.get("combine", "grid")),
            size=tuple(size) if size is not None else None,
            seed=int(head.get("seed", 0)),
            pareto_metric=str(head.get("pareto_metric", "median_rel_range_diff")),
            buildup_hooks=tuple(head.get("buildup_hooks", ())),
        )
    except (ValueError, TypeError) as exc:
        raise _err(where, str(exc)) from None


def load_sweep(path: str | Path) -> SweepDef:
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise UserError(f"cannot read sweep definition {str(p)!r}: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise UserError(f"{p}: not a text (UTF-8) sweep definition TOML") from None
    return parse_sweep(text, where=str(p), root=p.parent)


# ------------------------------------------------------------------------ expansion
@dataclass(frozen=True)
class Point:
    """One point of a sweep: a config on a scene, with the axis values that made it."""

    key: str
    scene: str
    config: WordLengthConfig | None  # None: the axis values give an invalid config
    labels: tuple[tuple[str, Any], ...]
    error: str = ""

    def spec(self, defn: SweepDef, threads: int = 1) -> dict[str, Any]:
        """Picklable description a worker evaluates (:func:`evaluate_point`)."""
        return {
            "key": self.key,
            "scene": self.scene,
            "size": list(defn.size) if defn.size else None,
            "seed": defn.seed,
            "metrics": list(defn.metrics),
            "config": self.config.to_toml() if self.config is not None else None,
            "error": self.error,
            "threads": threads,
        }


def point_key(
    config_toml: str | None, scene: str, size, seed: int, metrics: Iterable[str], extra: str = ""
) -> str:
    """Hash of everything that determines a point's result (16 hex digits)."""
    blob = json.dumps(
        {
            "config": config_toml,
            "scene": scene,
            "size": list(size) if size else None,
            "seed": seed,
            "metrics": sorted(metrics),
            "extra": extra,
            "v": 1,
        },
        sort_keys=True,
    )
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def _combos(defn: SweepDef) -> list[tuple[tuple[str, Any], ...]]:
    if defn.combine == "grid":
        return [
            tuple((a.label, v) for a, v in zip(defn.axes, vals, strict=True))
            for vals in itertools.product(*(a.values for a in defn.axes))
        ]
    combos: list[tuple[tuple[str, Any], ...]] = [()]  # the base config
    for a in defn.axes:
        combos += [((a.label, v),) for v in a.values]
    return combos


def expand(defn: SweepDef) -> list[Point]:
    """All points of ``defn`` in a stable order (duplicates keep their first labels)."""
    combos = _combos(defn)
    if len(combos) * len(defn.scenes) > _MAX_POINTS:
        raise UserError(
            f"sweep {defn.name!r}: {len(combos) * len(defn.scenes)} points, more than "
            f"{_MAX_POINTS}; narrow the axes"
        )
    by_label = {a.label: a for a in defn.axes}
    points: list[Point] = []
    for labels in combos:
        config: WordLengthConfig | None = defn.base
        error = ""
        try:
            for label, value in labels:
                config = by_label[label].apply(config, value)
        except ValueError as exc:
            config, error = None, str(exc)
        for scene in defn.scenes:
            toml = config.to_toml() if config is not None else None
            extra = "" if config is not None else json.dumps(labels)
            key = point_key(toml, scene, defn.size, defn.seed, defn.metrics, extra)
            points.append(Point(key, scene, config, labels, error))
    return points


# ------------------------------------------------------------------------ evaluation
_CACHE_LOCK = threading.Lock()
_SCENES: dict[tuple, P1Case] = {}
_GOLDEN: dict[tuple, tuple[RangeResult, dict[str, np.ndarray]]] = {}


def scene_case(scene: str, size: Sequence[int] | None = None, seed: int = 0) -> P1Case:
    """The P1 case of a scene preset (cached per process)."""
    key = (scene, tuple(size) if size else None, seed)
    with _CACHE_LOCK:
        if key not in _SCENES:
            try:
                s = render_scene(scene, seed=seed, size=tuple(size) if size else None)
            except ValueError as exc:
                raise UserError(str(exc)) from None
            _SCENES[key] = P1Case(
                s.image1, s.image2, s.camera, s.motion, SCENE_RANGING[scene],
                SCENE_MODE[scene], s,
            )  # fmt: skip
        return _SCENES[key]


def golden_taps(case: P1Case, config: WordLengthConfig) -> dict[str, np.ndarray]:
    """Float golden counterpart of every fixed-point tap that has one.

    From :func:`estimate_derivatives` (``r1, r2, s1, s2`` / ``u00, u01, u10``) of each
    image and the golden eq-28 terms: the row state after a pixel is ``r1 + r2``
    (``paper``: ``r1`` is the state before, ``r2`` the step) or ``r1 + r2/2``
    (``consistent``: ``r1`` is the mean of the states before and after), likewise the
    column state; ``ex`` is the estimator's ``Ex``; the range-stage taps follow eq 28.
    ``col2_state`` has no order-1 float counterpart and is left out.
    """
    est = EstimatorConfig(
        pole=config.pole, variant=config.variant, bias=config.bias, init=config.init
    )
    out: dict[str, np.ndarray] = {}
    half = 0.5 if config.variant == "consistent" else 1.0
    derivs = []
    for prefix, image in (("e1", case.image1), ("e2", case.image2)):
        d = estimate_derivatives(image, est)
        derivs.append(d)
        t = d.taps
        s1, s2 = (t["s1"], t["s2"]) if config.variant == "paper" else (t["u00"], t["u01"])
        out[f"{prefix}.bias_in"] = np.asarray(image, dtype=np.float64) + config.bias
        out[f"{prefix}.row_r1"] = t["r1"]
        out[f"{prefix}.row_r2"] = t["r2"]
        out[f"{prefix}.row_state"] = t["r1"] + half * t["r2"]
        out[f"{prefix}.col_s1"] = s1
        out[f"{prefix}.col_s2"] = s2
        out[f"{prefix}.col_state"] = s1 + half * s2
        out[f"{prefix}.ex"] = d.Ex
    d1, d2 = derivs
    xp, yp = case.camera.pixel_grid()
    f = case.camera.f_px
    (k0, k1, k2), (k3, k4, k5) = k_coefficients(case.motion, xp, yp, f)
    a1 = 0.5 * (d1.Ex + d2.Ex)
    b1 = 0.5 * (d1.Ey + d2.Ey)
    vx = f * k4 - xp * k3
    vy = f * k5 - yp * k3
    gv = a1 * vx + b1 * vy
    shape = a1.shape
    out.update(
        {
            "xp": np.asarray(xp, dtype=np.float64),
            "yp": np.asarray(yp, dtype=np.float64),
            "c1": d1.E - d2.E,
            "a1": a1,
            "b1": b1,
            "k0": np.broadcast_to(k0, shape),
            "k1": np.broadcast_to(k1, shape),
            "k2": np.broadcast_to(k2, shape),
            "vx": np.broadcast_to(vx, shape),
            "vy": np.broadcast_to(vy, shape),
            "wx": np.broadcast_to(f * k1 - xp * k0, shape),
            "wy": np.broadcast_to(f * k2 - yp * k0, shape),
            "w0": np.broadcast_to(1.0 + k0, shape),
            "gv": gv,
            "num": k3 * (d1.E - d2.E) - gv,
            "den": a1 * (f * k1 - xp * k0) + b1 * (f * k2 - yp * k0) - (d1.E - d2.E) * (1 + k0),
            "v_sq": np.broadcast_to(vx * vx + vy * vy, shape),
            "g_sq": gv * gv,
        }
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        out["range_q"] = out["num"] / out["den"]
    return out


def _golden(case: P1Case, config: WordLengthConfig, key: tuple, taps: bool):
    gkey = (*key, config.variant, config.pole, config.bias, config.init, taps)
    with _CACHE_LOCK:
        hit = _GOLDEN.get(gkey)
    if hit is None:
        g = golden_for(case, config)
        hit = (g, golden_taps(case, config) if taps else {})
        with _CACHE_LOCK:
            _GOLDEN[gkey] = hit
    return hit


def tap_float(result: P1Result, tap: str) -> np.ndarray:
    """A fixed-point tap as float values (raw times 2^-F of the tap's signal)."""
    name = tap.split(".", 1)[-1]
    config = result.config
    if name == "ex":
        signal = "col2_out" if config.variant == "consistent" else "div_quot"
    else:
        signal = TAP_SIGNAL[name]
    return np.ldexp(result.taps[tap].astype(np.float64), -config.formats[signal].frac)


def tap_errors(
    result: P1Result, gtaps: Mapping[str, np.ndarray], valid_both: np.ndarray
) -> dict[str, dict[str, float | None]]:
    """Per tap: SQNR in dB (``None``: exact) and max |fixed - golden|.

    ``range_q`` is scored on pixels valid in both (elsewhere the golden quotient may be
    unbounded); every other tap on all pixels.
    """
    out: dict[str, dict[str, float | None]] = {}
    for tap, g in gtaps.items():
        if tap not in result.taps:
            continue
        fx = tap_float(result, tap)
        if tap == "range_q":
            fx, g = fx[valid_both], np.asarray(g)[valid_both]
        err = fx - g
        if err.size == 0:
            continue
        noise = float(np.sum(err * err))
        power = float(np.sum(np.square(g)))
        sqnr = None if noise == 0 else (10 * math.log10(power / noise) if power > 0 else -math.inf)
        out[tap] = {"sqnr_db": sqnr, "max_abs_err": float(np.max(np.abs(err)))}
    return out


def _finite(x: Any) -> Any:
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    return x


def evaluate_point(spec: Mapping[str, Any]) -> dict[str, Any]:
    """Run one point (a :meth:`Point.spec`) and return its result record.

    Runs in any worker: it renders (and caches) the scene and its golden itself.
    """
    rec: dict[str, Any] = {"key": spec["key"], "scene": spec["scene"]}
    if spec["config"] is None:
        return {**rec, "status": "invalid", "error": spec["error"]}
    t0 = time.perf_counter()
    config = WordLengthConfig.from_toml(spec["config"])
    case = scene_case(spec["scene"], spec["size"], spec["seed"])
    metrics = set(spec["metrics"])
    want_taps = "sqnr" in metrics
    ckey = (spec["scene"], tuple(spec["size"]) if spec["size"] else None, spec["seed"])
    golden, gtaps = _golden(case, config, ckey, want_taps)
    try:
        result = run_p1(
            case.image1, case.image2, case.camera, case.motion, config, case.ranging,
            mode=case.mode, taps=want_taps, threads=int(spec.get("threads", 1)),
        )  # fmt: skip
    except ValueError as exc:
        return {**rec, "status": "invalid", "error": str(exc)}
    rec["status"] = "ok"
    rec.update(config_cost(config, case.image1.shape, case.mode).as_dict())
    if "golden" in metrics:
        rec.update(compare_ranges(result, golden))
    if "truth" in metrics and case.scene is not None:
        truth = report.overall_metrics(result.range, result.valid, case.scene.depth1)
        rec.update({f"truth_{k}": v for k, v in truth.items()})
        rec["valid_fraction"] = result.valid_fraction
    if "overflows" in metrics:
        rec["overflow_total"] = result.overflow_total
        rec["overflows"] = {k: v for k, v in result.overflows.items() if v}
    if want_taps:
        rec["taps"] = tap_errors(result, gtaps, result.valid & golden.valid)
    rec["seconds"] = time.perf_counter() - t0
    return _finite(rec)


# ------------------------------------------------------------------------ results file
def load_results(path: Path) -> dict[str, dict[str, Any]]:
    """Records of ``results.jsonl`` by key; a torn last line (a kill mid-write) is cut
    off the file so that appending continues on a clean line."""
    if not path.exists():
        return {}
    data = path.read_bytes()
    end = data.rfind(b"\n") + 1
    if end != len(data):
        with open(path, "r+b") as f:
            f.truncate(end)
    out: dict[str, dict[str, Any]] = {}
    for n, line in enumerate(data[:end].splitlines(), 1):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
            out[rec["key"]] = rec
        except (json.JSONDecodeError, KeyError, TypeError):
            raise UserError(f"{path}: line {n} is not a sweep result record") from None
    return out


class _Appender:
    """Appends one JSON line per record and flushes it to disk at once."""

    def __init__(self, path: Path) -> None:
        self._f = open(path, "a", encoding="utf-8")

    def write(self, rec: Mapping[str, Any]) -> None:
        self._f.write(json.dumps(rec, sort_keys=True) + "\n")
        self._f.flush()
        os.fsync(self._f.fileno())

    def close(self) -> None:
        self._f.close()


@dataclass(frozen=True)
class SweepOutcome:
    """Points of a finished sweep with their records; ``computed``: keys run this time."""

    points: tuple[Point, ...]
    records: dict[str, dict[str, Any]]
    computed: tuple[str, ...]
    seconds: float


def _run_local(
    specs: list[dict[str, Any]],
    workers: int,
    sink: Callable[[dict[str, Any]], None],
    record: Callable[[dict[str, Any]], None],
) -> None:
    with ThreadPoolExecutor(workers) as pool:
        pending: set[Future] = {pool.submit(evaluate_point, s) for s in specs}
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    sink(fut.result())
        except BaseException:
            # interrupted: drop what has not started, let what is running finish and
            # record it (without the callback), so that no computed point is lost
            for fut in pending:
                fut.cancel()
            for fut in pending:
                if not fut.cancelled():
                    try:
                        record(fut.result())
                    except Exception:
                        continue
            raise


def _run_dask(
    specs: list[dict[str, Any]],
    scheduler: str,
    sink: Callable[[dict[str, Any]], None],
    connect_timeout: float,
) -> None:
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise UserError(
            "--scheduler needs dask.distributed: pip install 'rangefx[sweep]'"
        ) from None
    try:
        client = Client(scheduler, timeout=connect_timeout)
    except (OSError, TimeoutError, ValueError) as exc:
        raise UserError(f"cannot connect to the dask scheduler {scheduler!r}: {exc}") from None
    try:
        if not client.scheduler_info().get("workers"):
            print(
                f"rangefx: warning: the dask scheduler {scheduler} has no workers; the sweep "
                "waits until one joins (Ctrl-C stops it; re-run the same command to resume)",
                file=sys.stderr,
            )
        futures = client.map(evaluate_point, specs, key=[f"rangefx-{s['key']}" for s in specs])
        try:
            for fut in as_completed(futures):
                sink(fut.result())
        except BaseException:
            client.cancel(futures)
            raise
    finally:
        client.close()


def run_sweep(
    defn: SweepDef,
    out_dir: str | Path,
    *,
    workers: int = 2,
    scheduler: str | None = None,
    on_point: Callable[[dict[str, Any]], None] | None = None,
    progress: bool = True,
    connect_timeout: float = 20.0,
) -> SweepOutcome:
    """Run every point of ``defn`` not yet in ``out_dir/results.jsonl``.

    ``on_point`` is called after each new record is written (an exception from it
    interrupts the sweep as a kill would, after the points in flight are recorded).
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise UserError(f"--workers must be a positive integer, not {workers!r}")
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"cannot create output directory {str(out)!r}: {exc.strerror}") from None
    path = out / RESULTS_NAME
    records = load_results(path)
    points = expand(defn)
    seen: set[str] = set()
    todo = []
    for p in points:
        if p.key not in records and p.key not in seen:
            todo.append(p)
        seen.add(p.key)
    threads = 2 if (workers == 1 and scheduler is None) else 1
    specs = [p.spec(defn, threads) for p in todo]
    computed: list[str] = []
    appender = _Appender(path)
    bar = tqdm(
        total=len(seen), initial=len(seen) - len(todo), desc=f"sweep {defn.name}",
        disable=not progress or not sys.stderr.isatty(), file=sys.stderr,
    )  # fmt: skip
    lock = threading.Lock()

    def record(rec: dict[str, Any]) -> None:
        with lock:
            if rec["key"] in records:
                return
            appender.write(rec)
            records[rec["key"]] = rec
            computed.append(rec["key"])
            bar.update(1)

    def sink(rec: dict[str, Any]) -> None:
        record(rec)
        if on_point is not None:
            on_point(rec)

    t0 = time.perf_counter()
    try:
        if scheduler:
            _run_dask(specs, scheduler, sink, connect_timeout)
        else:
            _run_local(specs, workers, sink, record)
    finally:
        bar.close()
        appender.close()
    return SweepOutcome(tuple(points), records, tuple(computed), time.perf_counter() - t0)


# ------------------------------------------------------------------------ Pareto
def pareto_front(costs: Sequence[float], errors: Sequence[float]) -> list[int]:
    """Indices of the non-dominated points (minimise both), by increasing cost.

    A point is dominated when another is no worse in both and better in one. NaN or
    infinite errors never belong to the front; equal (cost, error) pairs keep the first.
    """
    order = sorted(range(len(costs)), key=lambda i: (costs[i], errors[i], i))
    front: list[int] = []
    best = math.inf
    for i in order:
        e = errors[i]
        if not math.isfinite(e) or not math.isfinite(costs[i]):
            continue
        if e < best:
            front.append(i)
            best = e
    return front


# ------------------------------------------------------------------------ outputs
_POINT_FIELDS = (
    "key",
    "scene",
    "labels",
    "status",
    "cost_bits",
    "register_bits",
    "line_buffer_bits",
    "frame_store_bits",
    "bram18",
    "dsp",
    "median_rel_range_diff",
    "p95_rel_range_diff",
    "valid_agreement",
    "n_valid_both",
    "truth_median_rel_error",
    "truth_within_10pct",
    "valid_fraction",
    "overflow_total",
    "min_sqnr_db",
    "seconds",
    "error",
)


def _labels_text(labels: Sequence[tuple[str, Any]]) -> str:
    return ";".join(f"{k}={v}" for k, v in labels) or "base"


def _metric(rec: Mapping[str, Any], name: str) -> float:
    v = rec.get(name)
    return float(v) if isinstance(v, int | float) and not isinstance(v, bool) else math.nan


def _min_sqnr(rec: Mapping[str, Any]) -> float | None:
    vals = [t["sqnr_db"] for t in rec.get("taps", {}).values() if t.get("sqnr_db") is not None]
    return min(vals) if vals else None


def buildup_for(
    case: P1Case, config: WordLengthConfig, hooks: Iterable[str] = ()
) -> tuple[dict[str, dict[str, np.ndarray]], list[str]]:
    """Error build-up profiles of ``config`` on ``case`` plus those of the named
    :data:`BUILDUP_HOOKS`, and notes on hooks that produced nothing (an optional model
    absent or failing: it never stops a study)."""
    from .wlplots import BUILDUP_HOOKS, COL_TAPS, ROW_TAPS, buildup_profiles

    result = run_p1(
        case.image1, case.image2, case.camera, case.motion, config, case.ranging,
        mode=case.mode, taps=True,
    )  # fmt: skip
    gt = golden_taps(case, config)
    taps = [*ROW_TAPS, *COL_TAPS]
    fixed = {t: tap_float(result, t) for t in taps}
    lsb = {t: 2.0 ** -config.formats[TAP_SIGNAL[t.split(".", 1)[1]]].frac for t in taps}
    profiles = buildup_profiles(fixed, {t: gt[t] for t in taps}, lsb)
    notes = []
    for name in hooks:
        hook = BUILDUP_HOOKS.get(name)
        if hook is None:
            notes.append(f"{name}: no such build-up hook (known: {', '.join(BUILDUP_HOOKS)})")
            continue
        try:
            prof = hook(case, config)
        except Exception as exc:  # an optional model (P2, in progress) must not stop a study
            notes.append(f"{name}: {type(exc).__name__}: {exc}")
            continue
        if prof:
            profiles[name] = dict(prof)
        else:
            notes.append(f"{name}: not available for this case")
    return profiles, notes


def write_outputs(defn: SweepDef, outcome: SweepOutcome, out_dir: str | Path) -> dict[str, Any]:
    """points.csv, Pareto / sensitivity / build-up PNG + CSV and summary.json."""
    from .wlplots import save_buildup, save_pareto, save_sensitivity, write_csv

    out = Path(out_dir)
    rows = []
    for p in outcome.points:
        rec = outcome.records[p.key]
        rows.append({**rec, "labels": _labels_text(p.labels), "min_sqnr_db": _min_sqnr(rec)})
    write_csv(out / "points.csv", rows, _POINT_FIELDS)
    metric = defn.pareto_metric
    summary: dict[str, Any] = {"pareto": {}, "sensitivity": [], "buildup": []}
    unique: dict[str, dict[str, Any]] = {}
    for r in rows:
        unique.setdefault(r["key"], r)
    for scene in defn.scenes:
        pts = [r for r in unique.values() if r["scene"] == scene and r["status"] == "ok"]
        costs = [float(r["cost_bits"]) for r in pts]
        errs = [_metric(r, metric) for r in pts]
        front = pareto_front(costs, errs)
        write_csv(out / f"pareto_{scene}.csv", [pts[i] for i in front], _POINT_FIELDS)
        base = next((r for r in rows if r["labels"] == "base" and r["scene"] == scene), None)
        marks = {}
        if base is not None and base["status"] == "ok":
            marks["base config"] = (float(base["cost_bits"]), _metric(base, metric))
        save_pareto(
            out / f"pareto_{scene}.png", costs, errs, front, ylabel=metric.replace("_", " "),
            title=f"{defn.name}: {scene} ({defn.base.variant})", marks=marks,
        )  # fmt: skip
        summary["pareto"][scene] = [
            {k: pts[i][k] for k in ("key", "labels", "cost_bits", metric)} for i in front
        ]
    # sensitivity: single-signal bit axes, each point differing from the base in that axis
    sens_rows = []
    curves: dict[str, list[tuple[float, float]]] = {}
    for p, r in zip(outcome.points, rows, strict=True):
        if len(p.labels) != 1:
            continue
        label, value = p.labels[0]
        axis = next(a for a in defn.axes if a.label == label)
        if len(axis.signals) != 1 or axis.param not in ("frac", "word", "int"):
            continue
        sig = axis.signals[0]
        own = [
            t["sqnr_db"]
            for name, t in outcome.records[p.key].get("taps", {}).items()
            if TAP_SIGNAL.get(name.split(".", 1)[-1]) == sig
            or (name.endswith(".ex") and sig in ("div_quot", "col2_out"))
        ]
        own_vals = [v for v in own if v is not None]
        sens_rows.append(
            {
                "signal": sig, "param": axis.param, "value": value, **r,
                "signal_min_sqnr_db": min(own_vals) if own_vals else None,
            }
        )  # fmt: skip
        if r["status"] == "ok" and p.scene == defn.scenes[0]:
            curves.setdefault(f"{sig}.{axis.param}", []).append((value, _metric(r, metric)))
    if sens_rows:
        fields = ("signal", "param", "value", "signal_min_sqnr_db", *_POINT_FIELDS)
        write_csv(out / "sensitivity.csv", sens_rows, fields)
        save_sensitivity(
            out / "sensitivity.png", curves, xlabel="bits of the swept signal (others at base)",
            ylabel=metric.replace("_", " ") + f" ({defn.scenes[0]})",
        )  # fmt: skip
        summary["sensitivity"] = sorted(curves)
    case = scene_case(defn.scenes[0], defn.size, defn.seed)
    profiles, notes = buildup_for(case, defn.base, defn.buildup_hooks)
    written = save_buildup(
        out, "buildup_base", profiles, f"error build-up, base config ({defn.scenes[0]})"
    )
    summary["buildup"] = [p.name for p in written]
    summary["buildup_notes"] = notes
    n_ok = sum(1 for r in unique.values() if r["status"] == "ok")
    summary.update(
        {
            "name": defn.name,
            "complete": True,
            "n_points": len(unique),
            "n_ok": n_ok,
            "n_invalid": len(unique) - n_ok,
            "computed_this_run": len(outcome.computed),
            "wall_seconds_this_run": outcome.seconds,
            "variant": defn.base.variant,
            "scenes": list(defn.scenes),
            "pareto_metric": metric,
        }
    )
    from .outdir import atomic_write_text

    atomic_write_text(out / "summary.json", json.dumps(_finite(summary), indent=2) + "\n")
    return summary
