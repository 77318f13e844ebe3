"""Word-length sweeps of any registered pipeline: definition, metrics, resumable parallel
execution (SPEC §6, §10).

A sweep definition (TOML, :func:`load_sweep`) names a pipeline of the registry
(:data:`rangefx.rtl_model.registry.PIPELINES`, default ``p1``), a base config of that
pipeline, the scenes, the metric groups and one or more *axes*; each axis moves one
field (``frac``, ``word``, ``int``, their ``*_delta`` group moves, ``quant`` or
``overflow``) of one signal or of a group of signals (the pipeline's
:attr:`~rangefx.rtl_model.pipeline.Pipeline.signal_groups`) over a list or range of
values. The axes combine as a cartesian ``grid`` or ``one_at_a_time`` (each axis alone,
the others at the base: a sensitivity study). Example (``tools/studies/sweeps/p1_lab.toml``;
a P2 one is ``p2_lab.toml``)::

    [sweep]
    name = "p1_lab"
    pipeline = "p1"               # a registry name (default p1)
    base = "default"              # or a word-length TOML of that pipeline, relative to this file
    variant = "paper"             # optional override of the base's variant (P1 only)
    scenes = ["lab"]
    metrics = ["golden", "truth", "sqnr", "overflows"]
    combine = "one_at_a_time"     # or "grid"

    [[axis]]
    signals = ["row_state"]       # or a group: "datapath", "frontend", "range_stage", ...
    param = "frac"                # frac | word | int | frac_delta | word_delta | int_delta
    range = [6, 14]               # inclusive, step 1 (or step = k); or values = [...]

``frac`` keeps the integer bits ``W - F`` (the word follows) unless ``keep = "word"``;
``int`` sets the integer bits keeping ``F``; ``*_delta`` add to every listed signal.

Every point is one (config, scene) pair keyed by a hash of the pipeline, the config
TOML, the scene and the metric groups (:func:`point_key`). Points run on local threads
(numba kernels release the GIL) or on a dask.distributed cluster, and each finished
point is appended as one JSON line to ``results.jsonl`` and flushed, so that an
interrupted sweep resumes where it stopped: finished points are never recomputed nor
lost.

Metrics per point (:func:`evaluate_point`), through the pipeline's interface only:

* ``golden``: :func:`rangefx.tools.studies.runner.compare_ranges` against
  :meth:`Pipeline.golden` (P1: ``g4_<variant>``, P2: G5; median / p95 relative range
  difference on pixels valid in both, validity agreement);
* ``truth``: :func:`rangefx.tools.report.overall_metrics` against the scene depth
  (prefixed ``truth_``);
* ``sqnr``: per tap, SQNR (dB) and max |fixed - golden| against the float value of the
  tap (:func:`rangefx.tools.studies.taps.tap_errors`, formats from
  :meth:`Pipeline.tap_table`); ``None`` SQNR means no error at all;
* ``overflows``: total and per signal;
* cost proxies (:meth:`Pipeline.cost`) always.

The golden of a scene is computed once per process and shared by every point whose
config has the same :meth:`Pipeline.golden_key` (P1: variant, pole, bias, init; P2's G5
reads no config field).
"""

from __future__ import annotations

import contextlib
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

from tqdm import tqdm

from rangefx.golden.scenes import SCENE_NAMES
from rangefx.rtl_model.config import WordLengthConfig, loads_json, loads_toml, near_hint
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.pipeline import Case, GoldenReference, Pipeline
from rangefx.rtl_model.registry import get_pipeline

from .. import report
from ..errors import UserError
from ..interrupts import raise_if_interrupted
from ..report.lock import output_lock
from ..report.outdir import refuse_links
from ..sweepbound import MAX_AXIS_VALUE, MAX_POINTS, count_points
from .buildup import buildup_for
from .cases import scene_case
from .runner import compare_ranges
from .taps import signal_of_taps, tap_errors

__all__ = [
    "MAX_AXIS_VALUE",
    "MAX_POINTS",
    "METRIC_GROUPS",
    "PARETO_METRICS",
    "Axis",
    "Point",
    "SweepDef",
    "SweepOutcome",
    "cached_golden",
    "check_signals",
    "evaluate_point",
    "expand",
    "load_results",
    "load_sweep",
    "pareto_front",
    "parse_sweep",
    "point_count",
    "point_key",
    "run_sweep",
    "scene_case",
    "tap_errors",
    "write_outputs",
]

RESULTS_NAME = "results.jsonl"
METRIC_GROUPS: tuple[str, ...] = ("golden", "truth", "sqnr", "overflows")
#: Metric groups a definition (or ``rangefx sweep --cost synth``) must ask for: ``synth``,
#: the Yosys area of the pipeline's RTL (any pipeline of
#: :data:`rangefx.tools.studies.synth.RTL_TOPS`; :func:`rangefx.tools.studies.synth.synth_record`),
#: which also makes ``synth_cost`` (LUT + FF) the cost axis of the Pareto fronts; ``timing``,
#: the place-and-route Fmax of that RTL (:func:`rangefx.tools.studies.timing.timing_record`;
#: what is timed: the ``[sweep]`` key ``timing``, a table of
#: :class:`~rangefx.tools.studies.timing.TimingOptions` fields, e.g.
#: ``timing = { stage = "frontend", speed = 8, seeds = 3 }``).
OPTIONAL_METRICS: tuple[str, ...] = ("synth", "timing")
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
PARETO_METRICS = ("median_rel_range_diff", "p95_rel_range_diff", "truth_median_rel_error")


def _err(where: str, msg: str) -> UserError:
    return UserError(f"{where}: {msg}")


def check_signals(signals: Iterable[str], config: WordLengthConfig) -> None:
    """``ValueError`` naming the first of ``signals`` that ``config``'s pipeline does not
    have, with the nearest name it has (:meth:`WordLengthConfig.fmt`'s message)."""
    for s in signals:
        config.fmt(s)


# ------------------------------------------------------------------------ definition
@dataclass(frozen=True)
class Axis:
    """One swept field of one signal or group (see the module docstring). Its signals
    are checked against the sweep's pipeline by :class:`SweepDef`."""

    signals: tuple[str, ...]
    param: str
    values: tuple[Any, ...]
    keep: str = "integer"
    label: str = ""

    def __post_init__(self) -> None:
        if not self.signals:
            raise ValueError("axis: 'signals' is empty")
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
            elif abs(v) > MAX_AXIS_VALUE:
                raise ValueError(
                    f"axis {self.label!r}: value {v} lies outside -{MAX_AXIS_VALUE}.."
                    f"{MAX_AXIS_VALUE}; no format of the int64 models has it"
                )
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
    """A parsed sweep definition: ``pipeline`` is a registry name, ``base`` a config of
    that pipeline."""

    name: str
    base: WordLengthConfig
    scenes: tuple[str, ...]
    axes: tuple[Axis, ...]
    metrics: tuple[str, ...] = METRIC_GROUPS
    combine: str = "grid"
    size: tuple[int, int] | None = None
    seed: int = 0
    pareto_metric: str = "median_rel_range_diff"
    pipeline: str = "p1"
    #: the ``timing`` metrics' options (:class:`~rangefx.tools.studies.timing.TimingOptions`
    #: fields; empty: the defaults, the whole P1 at speed 6, one seed)
    timing: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        pipe = get_pipeline(self.pipeline)
        pipe.check_config(self.base)
        for axis in self.axes:
            check_signals(axis.signals, self.base)
        if not self.scenes:
            raise ValueError("sweep: 'scenes' is empty")
        bad = [s for s in self.scenes if s not in SCENE_NAMES]
        if bad:
            raise ValueError(f"sweep: unknown scenes {bad}; choose from {', '.join(SCENE_NAMES)}")
        bad = [m for m in self.metrics if m not in (*METRIC_GROUPS, *OPTIONAL_METRICS)]
        if bad:
            raise ValueError(
                f"sweep: unknown metrics {bad}; choose from {(*METRIC_GROUPS, *OPTIONAL_METRICS)}"
            )
        rtl = [m for m in OPTIONAL_METRICS if m in self.metrics]
        if rtl:
            from .synth import RTL_TOPS  # on use: it loads the HDL glue

            if self.pipeline not in RTL_TOPS:
                raise ValueError(f"sweep: the {rtl[0]} metrics need RTL: {self.pipeline} has "
                                 f"none in hdl/ (only {', '.join(RTL_TOPS)})")  # fmt: skip
        if self.timing:
            if "timing" not in self.metrics:
                raise ValueError("sweep: a 'timing' table needs the 'timing' metrics")
            self.timing_options()  # its fields' errors now, not at the first point
        if "timing" in self.metrics:
            from .timing import TIMED_TOPS

            stage, stages = self.timing_options().stage, TIMED_TOPS[self.pipeline].wrappers
            if stage not in stages:
                raise ValueError(f"sweep: {self.pipeline} has no timing stage {stage!r} "
                                 f"(it has {', '.join(stages)})")  # fmt: skip
        if self.combine not in COMBINES:
            raise ValueError(f"sweep: combine must be one of {COMBINES}, not {self.combine!r}")
        if not self.axes:
            raise ValueError("sweep: no [[axis]] tables")
        if self.size is not None and (len(self.size) != 2 or min(self.size) < 8):
            raise ValueError(f"sweep: size must be [height, width] >= 8, not {self.size!r}")
        if self.pareto_metric not in PARETO_METRICS:
            raise ValueError(f"sweep: unsupported pareto_metric {self.pareto_metric!r}")
        if self.pareto_metric.startswith("truth") and "truth" not in self.metrics:
            raise ValueError("sweep: pareto_metric needs the 'truth' metrics")
        if not self.pareto_metric.startswith("truth") and "golden" not in self.metrics:
            raise ValueError("sweep: pareto_metric needs the 'golden' metrics")

    @property
    def cost_key(self) -> str:
        """The cost axis of the Pareto fronts: ``synth_cost`` with the synth metrics, else
        the proxy's ``cost_bits``."""
        return "synth_cost" if "synth" in self.metrics else "cost_bits"

    def timing_options(self):  # -> TimingOptions (imported on use: it loads the HDL glue)
        """The :class:`~rangefx.tools.studies.timing.TimingOptions` of the ``timing``
        metrics; an unknown or bad field is a ``ValueError``."""
        from .timing import TimingOptions

        try:
            return TimingOptions(**dict(self.timing))
        except TypeError:
            known = ", ".join(TimingOptions.__dataclass_fields__)
            raise ValueError(f"sweep: timing keys are {known}, not {dict(self.timing)}") from None

    @property
    def pipe(self) -> Pipeline:
        """The registered pipeline this sweep runs."""
        return get_pipeline(self.pipeline)


def _int_list(raw: Any, where: str) -> tuple[int, ...]:
    if isinstance(raw, Mapping) or isinstance(raw, str) or not isinstance(raw, Sequence):
        raise _err(where, f"expected a list, not {raw!r}")
    return tuple(raw)


def _parse_axis(raw: Any, k: int, source: str, pipe: Pipeline, base: WordLengthConfig) -> Axis:
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
    groups = pipe.signal_groups
    if isinstance(sig, str):
        if sig in groups:
            signals, label = groups[sig], sig
        elif sig in base.signals():
            signals, label = (sig,), sig
        else:
            raise _err(
                where,
                f"unknown signal or group {sig!r} of {pipe.name}"
                f"{near_hint(sig, (*groups, *base.signals()))}; groups: {', '.join(groups)}; "
                f"signals: {', '.join(base.signals())}",
            )
    else:
        signals = _int_list(sig, f"{where} signals")
        label = "+".join(str(s) for s in signals)
        try:
            check_signals((str(s) for s in signals), base)
        except ValueError as exc:
            raise _err(where, str(exc)) from None
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
        if max(abs(rng[0]), abs(rng[1])) > MAX_AXIS_VALUE:  # before materialising it
            raise _err(
                where,
                f"range [{rng[0]}, {rng[1]}] reaches outside -{MAX_AXIS_VALUE}..{MAX_AXIS_VALUE}; "
                "no format of the int64 models has such a value",
            )
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
        data = loads_toml(text)
    except tomllib.TOMLDecodeError as exc:
        raise _err(where, f"not valid TOML: {exc}") from None
    except ValueError as exc:  # nested too deep
        raise _err(where, str(exc)) from None
    unknown = set(data) - {"sweep", "axis"}
    if unknown:
        raise _err(where, f"unknown tables {sorted(unknown)} (expected [sweep] and [[axis]])")
    head = data.get("sweep")
    if not isinstance(head, Mapping):
        raise _err(where, "missing the [sweep] table")
    keys = {"name", "pipeline", "base", "variant", "scenes", "metrics", "combine", "size",
            "seed", "pareto_metric", "timing"}  # fmt: skip
    if "buildup_hooks" in head:
        raise _err(
            where,
            "[sweep] buildup_hooks is no longer a key: every sweep writes its pipeline's own "
            "build-up (the Riccati sweep's is P2's: a sweep with pipeline = \"p2\"); remove it",
        )
    unknown = set(head) - keys
    if unknown:
        raise _err(where, f"[sweep]: unknown keys {sorted(unknown)}")
    axes_raw = data.get("axis", [])
    if not isinstance(axes_raw, list) or not axes_raw:
        raise _err(where, "no [[axis]] tables: nothing to sweep")
    try:
        pipe = get_pipeline(head.get("pipeline", "p1"))
    except ValueError as exc:
        raise _err(where, f"[sweep] pipeline: {exc}") from None
    try:
        base_name = str(head.get("base", "default"))
        if base_name == "default":
            base = pipe.default_config()
        else:
            path = Path(base_name)
            if root is not None and not path.is_absolute():
                path = root / path
            base = pipe.load_config(str(path))
        if "variant" in head:
            if "variant" not in base.design_fields():
                raise ValueError(
                    f"variant does not apply to pipeline {pipe.name} (its design fields: "
                    f"{', '.join(base.design_fields())})"
                )
            base = base.with_(variant=head["variant"])
    except ValueError as exc:
        raise _err(where, f"[sweep] base: {exc}") from None
    axes = tuple(_parse_axis(a, k, where, pipe, base) for k, a in enumerate(axes_raw))
    size = head.get("size")
    timing = head.get("timing", {})
    if not isinstance(timing, Mapping):
        raise _err(where, f"[sweep] timing must be a table, not {timing!r}")
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
            pipeline=pipe.name,
            timing=tuple(sorted(timing.items())),
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
            "pipeline": defn.pipeline,
            "scene": self.scene,
            "size": list(defn.size) if defn.size else None,
            "seed": defn.seed,
            "metrics": list(defn.metrics),
            "timing": dict(defn.timing),
            "config": self.config.to_toml() if self.config is not None else None,
            "error": self.error,
            "threads": threads,
        }


def point_key(
    pipeline: str,
    config_toml: str | None,
    scene: str,
    size: Sequence[int] | None,
    seed: int,
    metrics: Iterable[str],
    extra: str = "",
) -> str:
    """Hash of everything that determines a point's result (16 hex digits): the
    pipeline, its config, the scene, size, seed and metric groups."""
    blob = json.dumps(
        {
            "pipeline": pipeline,
            "config": config_toml,
            "scene": scene,
            "size": list(size) if size else None,
            "seed": seed,
            "metrics": sorted(metrics),
            "extra": extra,
            "v": 2,
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


def point_count(defn: SweepDef) -> int:
    """Points of ``defn`` (scenes times axis combinations), counted without listing them."""
    return count_points(defn.combine, (len(a.values) for a in defn.axes), len(defn.scenes))


def expand(defn: SweepDef, max_points: int = MAX_POINTS) -> list[Point]:
    """All points of ``defn`` in a stable order (duplicates keep their first labels);
    more than ``max_points`` is a :class:`UserError` before any is listed."""
    count = point_count(defn)
    if count > max_points:
        raise UserError(
            f"sweep {defn.name!r}: {count} points, more than --max-points {max_points}; "
            "narrow the axes or raise --max-points"
        )
    combos = _combos(defn)
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
            if defn.timing:  # what is timed changes a timing point's result
                extra += json.dumps(sorted(defn.timing))
            key = point_key(defn.pipeline, toml, scene, defn.size, defn.seed, defn.metrics, extra)
            points.append(Point(key, scene, config, labels, error))
    return points


# ------------------------------------------------------------------------ evaluation
_CACHE_LOCK = threading.Lock()
_GOLDEN: dict[tuple, GoldenReference] = {}


def cached_golden(
    pipe: Pipeline, case: Case, config: WordLengthConfig, case_key: tuple, taps: bool
) -> GoldenReference:
    """:meth:`Pipeline.golden` of ``case`` (identified by ``case_key``), computed once per
    process for every config with the same :meth:`Pipeline.golden_key`."""
    key = (pipe.name, *case_key, pipe.golden_key(config), taps)
    with _CACHE_LOCK:
        hit = _GOLDEN.get(key)
    if hit is None:
        hit = pipe.golden(case, config, taps=taps)
        with _CACHE_LOCK:
            _GOLDEN[key] = hit
    return hit


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
    pipe = get_pipeline(spec["pipeline"])
    rec: dict[str, Any] = {"key": spec["key"], "pipeline": pipe.name, "scene": spec["scene"]}
    if spec["config"] is None:
        return {**rec, "status": "invalid", "error": spec["error"]}
    t0 = time.perf_counter()
    config = pipe.config_from_toml(spec["config"])
    case = scene_case(spec["scene"], spec["size"], spec["seed"])
    metrics = set(spec["metrics"])
    want_taps = "sqnr" in metrics
    ckey = (spec["scene"], tuple(spec["size"]) if spec["size"] else None, spec["seed"])
    golden = cached_golden(pipe, case, config, ckey, want_taps)
    try:
        result = pipe.run(case, config, taps=want_taps, threads=int(spec.get("threads", 1)))
    except ValueError as exc:
        return {**rec, "status": "invalid", "error": str(exc)}
    rec["status"] = "ok"
    rec.update(pipe.cost(config, case.shape, case.mode).as_dict())
    if "golden" in metrics:
        rec.update(compare_ranges(result, golden.result))
    if "truth" in metrics and case.scene is not None:
        truth = report.overall_metrics(result.range, result.valid, case.scene.depth1)
        rec.update({f"truth_{k}": v for k, v in truth.items()})
        rec["valid_fraction"] = result.valid_fraction
    if "overflows" in metrics:
        rec["overflow_total"] = result.overflow_total
        rec["overflows"] = {k: v for k, v in result.overflows.items() if v}
    if want_taps:
        rec["taps"] = tap_errors(result, golden, pipe.tap_table(config, case.mode))
    if "synth" in metrics:
        from .synth import synth_record

        rec.update(synth_record(config, case.shape, case.mode, pipeline=pipe.name))
    if "timing" in metrics:
        from .timing import TimingOptions, timing_record

        options = TimingOptions(**spec.get("timing", {}))
        rec.update(timing_record(config, case.shape, case.mode, options, pipe.name))
    rec["seconds"] = time.perf_counter() - t0
    return _finite(rec)


# ------------------------------------------------------------------------ results file
def load_results(path: Path) -> dict[str, dict[str, Any]]:
    """Records of ``results.jsonl`` by key; a torn last line (a kill mid-write) is cut
    off the file so that appending continues on a clean line."""
    if not path.exists():
        return {}
    if not path.is_file():  # rangefx writes a file there; whatever this is, it is not ours
        raise UserError(
            f"{path} is not a file (rangefx writes its sweep results there); move it away "
            "or choose another --out"
        )
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
            rec = loads_json(line)
            out[rec["key"]] = rec
        except (ValueError, KeyError, TypeError, IndexError):  # JSON, UTF-8, nesting, shape
            raise UserError(
                f"{path}: line {n} is not a sweep result record ({line[:20]!r}...); delete "
                f"line {n} and those after it to resume from the {len(out)} records before "
                "it, or add --restart to delete the results and start over"
            ) from None
    return out


class _Appender:
    """Appends one JSON line per record and syncs it to disk at once. A line is written
    whole or not at all: when a write fails (disk full) the file is cut back to where
    the line began, so that ``results.jsonl`` holds finished records only and a resume
    continues exactly; nothing is buffered, so closing cannot fail later."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)

    def write(self, rec: Mapping[str, Any]) -> None:
        data = (json.dumps(rec, sort_keys=True) + "\n").encode()
        start = os.fstat(self._fd).st_size
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(self._fd, view) :]
            os.fsync(self._fd)
        except OSError:
            with contextlib.suppress(OSError):
                os.ftruncate(self._fd, start)
            raise

    def close(self) -> None:
        with contextlib.suppress(OSError):
            os.close(self._fd)


@dataclass(frozen=True)
class SweepOutcome:
    """Points of a finished sweep with their records; ``computed``: keys run this time."""

    points: tuple[Point, ...]
    records: dict[str, dict[str, Any]]
    computed: tuple[str, ...]
    seconds: float


#: After an interrupt, how long the points already running may take to finish and be
#: recorded; the command exits within about 2 s (docs/guarantees.md).
INTERRUPT_GRACE_S = 0.5


def _run_local(
    specs: list[dict[str, Any]],
    workers: int,
    sink: Callable[[dict[str, Any]], None],
    record: Callable[[dict[str, Any]], None],
) -> None:
    pool = ThreadPoolExecutor(workers)
    pending: set[Future] = {pool.submit(evaluate_point, s) for s in specs}
    try:
        while pending:
            # short waits: an untimed one in the main thread can miss a signal
            done, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
            for fut in done:
                sink(fut.result())
            raise_if_interrupted()  # one swallowed on its way (numba, a finaliser)
    except BaseException:
        # interrupted: drop what has not started; what is running gets a short grace to
        # finish and be recorded (without the callback), then is abandoned (its point is
        # computed again by the next run)
        pool.shutdown(wait=False, cancel_futures=True)
        done, _ = wait(pending, timeout=INTERRUPT_GRACE_S)
        for fut in done:
            if not fut.cancelled() and fut.exception() is None:
                record(fut.result())
        raise
    pool.shutdown()


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


class _ResultsNotWritten(Exception):
    """A record could not be appended to ``results.jsonl`` (the OS error's text)."""


def _lost_scheduler_errors() -> tuple[type[BaseException], ...]:
    """What a dask client raises when its scheduler goes away mid-sweep (its futures are
    cancelled: ``FutureCancelledError``, a ``CancelledError``; or the comm closes)."""
    import asyncio

    errors: list[type[BaseException]] = [asyncio.CancelledError]
    try:
        from distributed.client import FutureCancelledError  # dask >= 2024.8
        from distributed.comm import CommClosedError

        errors += [FutureCancelledError, CommClosedError]
    except ImportError:
        pass
    return tuple(errors)


def run_sweep(
    defn: SweepDef,
    out_dir: str | Path,
    *,
    workers: int = 2,
    scheduler: str | None = None,
    on_point: Callable[[dict[str, Any]], None] | None = None,
    progress: bool = True,
    connect_timeout: float = 20.0,
    max_points: int = MAX_POINTS,
) -> SweepOutcome:
    """Run every point of ``defn`` not yet in ``out_dir/results.jsonl``.

    ``on_point`` is called after each new record is written (an exception from it
    interrupts the sweep as a kill would, after the points in flight are recorded).
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise UserError(f"--workers must be a positive integer, not {workers!r}")
    pipe = defn.pipe
    for scene in defn.scenes:  # renders each scene once (cached for the local workers)
        try:
            pipe.check_mode(scene_case(scene, defn.size, defn.seed))
        except ValueError as exc:
            raise UserError(f"sweep {defn.name!r}: {exc}") from None
    out = Path(out_dir)
    with output_lock(out):  # one writer per sweep directory (re-entered under the CLI's)
        return _run_sweep_locked(
            defn, out, workers, scheduler, on_point, progress, connect_timeout, max_points
        )


def _run_sweep_locked(
    defn: SweepDef,
    out: Path,
    workers: int,
    scheduler: str | None,
    on_point: Callable[[dict[str, Any]], None] | None,
    progress: bool,
    connect_timeout: float,
    max_points: int,
) -> SweepOutcome:
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"cannot create output directory {str(out)!r}: {exc.strerror}") from None
    path = out / RESULTS_NAME
    refuse_links(out, (RESULTS_NAME,))
    records = load_results(path)
    points = expand(defn, max_points)
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
            try:
                appender.write(rec)
            except OSError as exc:
                raise _ResultsNotWritten(exc.strerror or str(exc)) from None
            records[rec["key"]] = rec
            computed.append(rec["key"])
            bar.update(1)

    def sink(rec: dict[str, Any]) -> None:
        record(rec)
        if on_point is not None:
            on_point(rec)

    t0 = time.perf_counter()
    resume = (
        "re-run the same command to resume" if scheduler is None
        else "re-run the same command (with a live --scheduler, or without one) to resume"
    )  # fmt: skip
    try:
        if scheduler:
            _run_dask(specs, scheduler, sink, connect_timeout)
        else:
            _run_local(specs, workers, sink, record)
    except _ResultsNotWritten as exc:  # results.jsonl cannot grow (disk full, quota, I/O)
        raise UserError(
            f"cannot write {path}: {exc}; the {len(records)} points finished "
            f"({len(computed)} this run) are saved: free space, then {resume}"
        ) from None
    except _lost_scheduler_errors() as exc:
        raise UserError(
            f"lost the dask scheduler {scheduler} ({type(exc).__name__}); the "
            f"{len(records)} points finished ({len(computed)} this run) are saved in {path}: "
            f"{resume}"
        ) from None
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
    "pipeline",
    "scene",
    "labels",
    "status",
    "cost_bits",
    "register_bits",
    "line_buffer_bits",
    "frame_store_bits",
    "bram18",
    "dsp",
    "synth_cost",
    "synth_lut",
    "synth_ff",
    "synth_carry",
    "synth_dsp",
    "synth_bram",
    "fmax_mhz",
    "critical_logic_ns",
    "critical_routing_ns",
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


def write_outputs(defn: SweepDef, outcome: SweepOutcome, out_dir: str | Path) -> dict[str, Any]:
    """points.csv, Pareto / sensitivity / build-up PNG + CSV and summary.json."""
    from ..report.wlplots import save_buildup, save_pareto, save_sensitivity, write_csv

    out = Path(out_dir)
    pipe = defn.pipe
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
        cost_key = defn.cost_key
        costs = [float(r[cost_key]) for r in pts]
        errs = [_metric(r, metric) for r in pts]
        front = pareto_front(costs, errs)
        write_csv(out / f"pareto_{scene}.csv", [pts[i] for i in front], _POINT_FIELDS)
        base = next((r for r in rows if r["labels"] == "base" and r["scene"] == scene), None)
        marks = {}
        if base is not None and base["status"] == "ok":
            marks["base config"] = (float(base[cost_key]), _metric(base, metric))
        save_pareto(
            out / f"pareto_{scene}.png", costs, errs, front, ylabel=metric.replace("_", " "),
            title=f"{defn.name}: {scene} ({pipe.name}, golden {pipe.golden_label(defn.base)})",
            marks=marks, **({"xlabel": "Yosys xcup LUT + FF"} if cost_key != "cost_bits" else {}),
        )  # fmt: skip
        summary["pareto"][scene] = [
            {k: pts[i][k] for k in ("key", "labels", "cost_bits", cost_key, metric)} for i in front
        ]
    # sensitivity: single-signal bit axes, each point differing from the base in that axis;
    # a tap belongs to the signal whose format it carries (the base's tap table)
    first = scene_case(defn.scenes[0], defn.size, defn.seed)
    signal_of = signal_of_taps(pipe.tap_table(defn.base, first.mode))
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
            if signal_of.get(name) == sig
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
    profiles = buildup_for(pipe, first, defn.base)
    written = save_buildup(
        out, "buildup_base", profiles,
        f"{pipe.name} error build-up, base config ({defn.scenes[0]})", xlabels=pipe.buildup_axes,
    )  # fmt: skip
    summary["buildup"] = [p.name for p in written]
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
            "pipeline": pipe.name,
            "design": defn.base.design(),
            **({"variant": defn.base.variant} if "variant" in defn.base.design_fields() else {}),
            "golden": pipe.golden_label(defn.base),
            "scenes": list(defn.scenes),
            "pareto_metric": metric,
        }
    )
    from ..report.outdir import atomic_write_text

    atomic_write_text(out / "summary.json", json.dumps(_finite(summary), indent=2) + "\n")
    return summary
