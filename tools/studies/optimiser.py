"""Word-length optimiser: the cheapest config of any registered pipeline meeting an
accuracy budget (SPEC §6, §10).

The pipeline is the one of the start config (``WordLengthConfig.PIPELINE``, looked up in
the registry) unless given; it runs only through its interface (:meth:`Pipeline.run`,
:meth:`Pipeline.golden`, :meth:`Pipeline.cost_weights`), so P1 and P2 are optimised alike.

Coordinate descent from a safe configuration (the default, which meets the budget by a
wide margin). Signals are visited in decreasing order of their cost weight (bits of
``cost_bits`` per bit of word: line-buffer signals first, :meth:`Pipeline.cost_weights`). For
each signal, first its fraction bits are lowered (integer bits kept, so the word
shrinks), then its integer bits (fraction kept), each to the smallest value for which
the *whole* config still meets the budget, found by a k-ary search (``workers``
candidates evaluated concurrently per round; monotone error in the bits is assumed to
steer the search, never to accept: every accepted config was run and met the budget).
Hence the result meets the budget on the tuning scenes by construction; it is then run
on a verification scene it was not tuned on.

Host-written registers (the config type's ``HOST_REGISTERS``; P1: bias, filter pole,
focal length, translation and rotation terms, T_g^2; P2: ``KA = 1 / (f dx)`` and
``M = alpha / beta``) keep the start config's formats unless ``tune_registers`` (or they
are named in ``signals``): their values are host constants whose range is set by the
cameras and geometries to serve, not by image content, so narrowing them to fit a few
tuning scenes fails on others (a 5 mm baseline in P1's ``k_t_reg`` s13.9 is 3 LSB). The
input pixel (the first signal of the table) is fixed by the sensor and never tuned.

Several tuning scenes (one pipeline that must serve all of them, e.g. the stereo ``lab``
and the motion ``runway`` with rotation for P1; P2 is stereo only): a candidate is
accepted only if it meets the budget on *every* scene (worst case). Scenes are run in the
given order and a candidate stops at its first failing scene, so put the scene that fails
most often first. The
cost minimised is ``cost_bits`` on the *first* scene's shape and mode (the signals are
visited in the order of their weights there); signals that cost nothing there but
something on another tuning scene are still narrowed, after the others. Narrowing a
word never raises any scene's cost, so every scene's cost falls or stays.

The budget (:class:`Budget`): median relative range difference vs the float golden on
pixels valid in both ``<= median`` and validity agreement ``>= agreement``. A candidate
that saturates a host register the start config does not saturate on that scene is
rejected whatever its figures: the register then holds another value than the host
wrote, a silent scale error no overflow counter sees (e.g. P2's ``RMAX`` register, held
in a ``p2_z`` word, once ``p2_z``'s integer bits are cut below the case's ``range_max``).

Guard band (``margin`` M, ``0 <= M < 1``): during tuning a candidate must meet the
tightened budget :meth:`Budget.tightened` — median ``<= median·(1 − M)`` and
disagreement ``1 − agreement' <= (1 − agreement)·(1 − M)`` — so the result keeps a
reserve for scenes it was not tuned on; the result is still reported against the
user's budget. ``M = 0`` is the plain budget (the same object: same decisions).

A clock-rate floor (:class:`FmaxConstraint`, ``rangefx optimise --fmax-min``): the start
must meet it, and a narrowing that meets the budget is kept only if the narrowed
config's measured Fmax (place and route, :func:`rangefx.tools.studies.timing.timing_record`)
still does. It is measured once per narrowing that meets the budget, not per candidate
(a place-and-route run costs as much as many model runs); every kept step and every
step refused for its Fmax logs ``fmax_mhz``.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

from tqdm import tqdm

from rangefx.golden.ranging import RangeResult
from rangefx.rtl_model.config import WordLengthConfig
from rangefx.rtl_model.fixedpoint import FixedFormat
from rangefx.rtl_model.pipeline import Case, Pipeline
from rangefx.rtl_model.registry import get_pipeline

from ..errors import UserError
from ..interrupts import raise_if_interrupted
from .runner import compare_ranges
from .sweep import check_signals

__all__ = [
    "Budget",
    "FmaxConstraint",
    "OptimiseResult",
    "check_margin",
    "evaluate",
    "evaluate_scenes",
    "optimise",
    "pipeline_of",
    "worst_case",
]


@dataclass(frozen=True)
class Budget:
    """Accuracy budget against the float golden."""

    median: float = 0.01
    agreement: float = 0.99

    def __post_init__(self) -> None:
        if not (isinstance(self.median, int | float) and 0 < self.median < math.inf):
            raise ValueError(f"budget must be a positive number, not {self.median!r}")
        if not (isinstance(self.agreement, int | float) and 0 <= self.agreement <= 1):
            raise ValueError(f"agreement must be in [0, 1], not {self.agreement!r}")

    def tightened(self, margin: float) -> Budget:
        """The budget a tuning candidate must meet with guard band ``margin``: median
        ``<= median·(1 − margin)``, disagreement ``<= (1 − agreement)·(1 − margin)``.
        ``margin == 0`` returns this budget itself."""
        check_margin(margin)
        if margin == 0:
            return self
        return Budget(self.median * (1 - margin), 1 - (1 - self.agreement) * (1 - margin))

    def met(self, figures: dict[str, Any]) -> bool:
        med = figures.get("median_rel_range_diff")
        agr = figures.get("valid_agreement")
        if med is None or agr is None or not math.isfinite(med):
            return False
        return med <= self.median and agr >= self.agreement


@dataclass(frozen=True)
class FmaxConstraint:
    """A floor on the clock rate of a config: ``measure(config)`` gives its Fmax in MHz
    (``rangefx optimise --fmax-min``: :func:`rangefx.tools.studies.timing.timing_record`
    on the first tuning scene's shape and mode), which must be ``>= minimum_mhz``."""

    minimum_mhz: float
    measure: Callable[[WordLengthConfig], float]

    def __post_init__(self) -> None:
        ok = isinstance(self.minimum_mhz, int | float) and not isinstance(self.minimum_mhz, bool)
        if not (ok and 0 < self.minimum_mhz < math.inf):
            raise ValueError(f"the Fmax floor must be a positive number of MHz, not "
                             f"{self.minimum_mhz!r}")  # fmt: skip

    def met(self, fmax_mhz: float) -> bool:
        return math.isfinite(fmax_mhz) and fmax_mhz >= self.minimum_mhz


def check_margin(margin: float) -> float:
    """``margin`` if it is a number in ``[0, 1)``; a one-line :class:`UserError` otherwise."""
    ok = isinstance(margin, int | float) and not isinstance(margin, bool)
    if not (ok and 0 <= margin < 1):
        raise UserError(f"--margin must be a number in [0, 1), not {margin!r}")
    return margin


@dataclass(frozen=True)
class OptimiseResult:
    """The optimised config and its figures.

    ``figures`` / ``start_figures`` are the worst case over the tuning scenes
    (:func:`worst_case`); ``scene_figures`` / ``start_scene_figures`` hold each tuning
    scene's own figures, in the order of the scenes given to :func:`optimise`.
    ``evaluations`` counts candidate configs, ``scene_runs`` the pipeline's runs on each scene
    (a candidate stops at its first failing scene, so later scenes run less often).
    ``tuning_budget`` is the budget candidates had to meet (``Budget.tightened`` by the
    margin; the user's budget when the margin is 0).
    """

    config: WordLengthConfig
    start: WordLengthConfig
    figures: dict[str, Any]
    start_figures: dict[str, Any]
    evaluations: int
    seconds: float
    steps: list[dict[str, Any]] = field(default_factory=list)
    scene_figures: list[dict[str, Any]] = field(default_factory=list)
    start_scene_figures: list[dict[str, Any]] = field(default_factory=list)
    scene_runs: list[int] = field(default_factory=list)
    tuning_budget: Budget | None = None
    #: with an :class:`FmaxConstraint`: the measured Fmax (MHz) of the start and the result
    fmax_mhz: dict[str, float] | None = None


def worst_case(scene_figures: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The worst of several scenes' figures: largest median and p95 relative range
    difference, smallest validity agreement, total overflows. A config meets a budget on
    every scene exactly when it meets it on this worst case."""

    def worst(key: str, pick: Callable[[Sequence[float]], float]) -> float:
        vals = [f[key] for f in scene_figures]
        if any(v is None or not math.isfinite(v) for v in vals):
            return math.nan
        return pick(vals)

    out: dict[str, Any] = {
        "median_rel_range_diff": worst("median_rel_range_diff", max),
        "p95_rel_range_diff": worst("p95_rel_range_diff", max),
        "valid_agreement": worst("valid_agreement", min),
        "n_valid_both": min(f["n_valid_both"] for f in scene_figures),
    }
    if all("overflow_total" in f for f in scene_figures):
        out["overflow_total"] = sum(f["overflow_total"] for f in scene_figures)
    return out


def pipeline_of(config: WordLengthConfig) -> Pipeline:
    """The registered pipeline whose config type ``config`` is."""
    return get_pipeline(config.PIPELINE)


def evaluate(
    case: Case,
    config: WordLengthConfig,
    golden: RangeResult,
    threads: int = 2,
    *,
    pipeline: Pipeline | None = None,
) -> dict[str, Any] | None:
    """Fixed vs golden figures of ``config`` (``None`` if the config cannot run), with the
    run's overflow total and the host registers it saturated (a silent scale error)."""
    pipe = pipeline or pipeline_of(config)
    try:
        result = pipe.run(case, config, taps=False, threads=threads)
    except ValueError:
        return None
    figs: dict[str, Any] = compare_ranges(result, golden)
    figs["overflow_total"] = result.overflow_total
    figs["saturated_registers"] = list(result.saturated_registers)
    return figs


def _candidates(lo: int, hi: int, k: int) -> list[int]:
    """Up to ``k`` probe points in ``[lo, hi)`` splitting it into ``k + 1`` parts."""
    return sorted({lo + ((hi - lo) * i) // (k + 1) for i in range(1, k + 1)})


def _with(config: WordLengthConfig, name: str, word: int, frac: int) -> WordLengthConfig | None:
    if word < 1 or word > 62:
        return None
    f = config.formats[name]
    try:
        return config.with_formats(**{name: FixedFormat(f.signed, word, frac, f.quant, f.overflow)})
    except ValueError:
        return None


def _label(case: Case, index: int) -> str:
    if case.scene is not None:
        return case.scene.name
    return case.label or f"scene {index + 1}"


def evaluate_scenes(
    cases: Sequence[Case],
    config: WordLengthConfig,
    goldens: Sequence[RangeResult],
    budget: Budget,
    threads: int = 2,
    *,
    pipeline: Pipeline | None = None,
) -> list[dict[str, Any] | None]:
    """:func:`evaluate` on each case in order, stopping after the first that misses
    ``budget`` (a rejected candidate need not pay for the other scenes). The list is as
    long as the scenes run; its last entry is ``None`` if the config cannot run there."""
    pipe = pipeline or pipeline_of(config)
    out: list[dict[str, Any] | None] = []
    for case, golden in zip(cases, goldens, strict=True):
        figs = evaluate(case, config, golden, threads=threads, pipeline=pipe)
        out.append(figs)
        if figs is None or not budget.met(figs):
            break
    return out


def optimise(
    cases: Case | Sequence[Case],
    start: WordLengthConfig,
    budget: Budget,
    *,
    pipeline: Pipeline | None = None,
    margin: float = 0.0,
    signals: Sequence[str] | None = None,
    tune_registers: bool = False,
    workers: int = 2,
    max_frac_drop: int = 40,
    progress: bool = True,
    on_eval: Callable[[WordLengthConfig, list[dict | None]], None] | None = None,
    cost_fn: Callable[[WordLengthConfig], float] | None = None,
    fmax: FmaxConstraint | None = None,
) -> OptimiseResult:
    """Cheapest config reachable from ``start`` meeting ``budget`` on every case.

    ``pipeline``: the pipeline to tune (default: ``start``'s, :func:`pipeline_of`); a
    case it does not model (P2 on a motion case) is a :class:`UserError`.
    ``cases``: one tuning case or several (worst case, module docstring); the cost
    minimised is ``cost_bits`` on the first case's shape and mode. ``margin``: guard band,
    candidates must meet ``budget.tightened(margin)`` (module docstring). ``signals``: only
    these (default: all but the input pixel and, unless ``tune_registers``, the config
    type's ``HOST_REGISTERS``; a register named in ``signals`` is tuned). ``on_eval`` sees
    each candidate with the figures of the scenes it was run on (it stops at the first
    miss). ``cost_fn``: a measured cost to minimise (``rangefx optimise --cost synth``:
    the Yosys LUT + FF of the whole P1): each signal's narrowing that meets the budget is
    kept only if it does not raise ``cost_fn`` (the step is then logged with
    ``"kept": False``); the signals are still visited in the order of the proxy weights.
    ``fmax``: a clock-rate floor the start and every kept narrowing must meet (module
    docstring); a start below it is a :class:`UserError`.
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise UserError(f"--workers must be a positive integer, not {workers!r}")
    tuning = budget.tightened(margin)
    cases = [cases] if isinstance(cases, Case) else list(cases)
    if not cases:
        raise ValueError("optimise needs at least one tuning case")
    pipe = pipeline or pipeline_of(start)
    try:
        pipe.check_config(start)
        for case in cases:
            pipe.check_mode(case)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    all_signals = start.signals()
    if signals:
        try:
            check_signals(signals, start)
        except ValueError as exc:
            raise UserError(f"--signals: {exc}") from None
    t0 = time.perf_counter()
    goldens = [pipe.golden(case, start).result for case in cases]
    threads = 2 if workers == 1 else 1
    n_evals = 0
    scene_runs = [0] * len(cases)

    def run(cfgs: list[WordLengthConfig]) -> list[list[dict | None]]:
        nonlocal n_evals
        raise_if_interrupted()  # a stop signal swallowed on its way stops at the next batch
        n_evals += len(cfgs)
        if not cfgs:  # a move that proposes no config evaluates nothing
            return []
        if len(cfgs) == 1 or workers == 1:
            figs = [
                evaluate_scenes(cases, c, goldens, tuning, threads=2, pipeline=pipe) for c in cfgs
            ]
        else:
            with ThreadPoolExecutor(min(workers, len(cfgs))) as pool:
                figs = list(
                    pool.map(
                        lambda c: evaluate_scenes(
                            cases, c, goldens, tuning, threads, pipeline=pipe
                        ),
                        cfgs,
                    )
                )
        for f in figs:
            for k in range(len(f)):
                scene_runs[k] += 1
        if on_eval is not None:
            for c, f in zip(cfgs, figs, strict=True):
                on_eval(c, f)
        return figs

    start_saturated: list[set[str]] | None = None  # known once the start has run

    def met(scene_figs: list[dict | None]) -> bool:
        if len(scene_figs) != len(cases):
            return False
        for k, f in enumerate(scene_figs):
            if f is None or not tuning.met(f):
                return False
            if (
                start_saturated is not None
                and not set(f["saturated_registers"]) <= (start_saturated[k])
            ):
                return False
        return True

    start_figs = run([start])[0]
    if not met(start_figs):
        k = len(start_figs) - 1
        band = "" if tuning is budget else f" tightened by the margin {margin}"
        raise UserError(
            f"the starting config {start.name!r} misses the budget{band} on "
            f"{_label(cases[k], k)!r} (figures {start_figs[k]}); start from a wider config"
        )
    start_saturated = [set(f["saturated_registers"]) for f in start_figs if f is not None]
    fmax_now = None
    if fmax is not None:
        fmax_now = start_fmax = fmax.measure(start)
        if not fmax.met(start_fmax):
            raise UserError(
                f"the starting config {start.name!r} runs at {start_fmax:.1f} MHz, below "
                f"--fmax-min {fmax.minimum_mhz:g}; start from a faster config or lower the floor"
            )
    # Weights on every tuning scene; the first scene's cost is the one minimised.
    all_weights = [pipe.cost_weights(start, case.shape, case.mode) for case in cases]
    weights = all_weights[0]
    others = {s: sum(w.get(s, 0) for w in all_weights[1:]) for s in all_signals}
    pixel = all_signals[0]  # the sensor's input: never tuned
    if signals:
        pool = list(signals)
    else:
        skip = (pixel,) if tune_registers else (pixel, *start.HOST_REGISTERS)
        pool = [s for s in all_signals if s not in skip]
    names = [s for s in pool if s != pixel and (weights.get(s, 0) > 0 or others[s] > 0)]
    names.sort(key=lambda s: (-weights[s], -others[s], all_signals.index(s)))
    current, cur_figs = start, start_figs
    steps: list[dict[str, Any]] = []
    bar = tqdm(
        total=2 * len(names), desc="optimise", disable=not progress or not sys.stderr.isatty(),
        file=sys.stderr,
    )  # fmt: skip
    try:
        for name in names:
            for dim in ("frac", "int"):
                f = current.formats[name]
                integer = f.word - f.frac
                if dim == "frac":
                    lo, hi = max(f.frac - max_frac_drop, f.frac - f.word + 1), f.frac

                    def make(v: int, c=current, n=name, i=integer) -> WordLengthConfig | None:
                        return _with(c, n, i + v, v)
                else:
                    lo, hi = max(integer - 62, 1 - f.frac), integer

                    def make(v: int, c=current, n=name, fr=f.frac) -> WordLengthConfig | None:
                        return _with(c, n, v + fr, fr)

                best, best_figs = hi, cur_figs
                while lo < hi:
                    cands = _candidates(lo, hi, workers)
                    cfgs = [make(v) for v in cands]
                    figs: list[list[dict | None]] = [[None]] * len(cands)
                    runnable = [k for k, c in enumerate(cfgs) if c is not None]
                    for k, r in zip(runnable, run([cfgs[k] for k in runnable]), strict=True):
                        figs[k] = r
                    passing = [k for k, r in enumerate(figs) if met(r)]
                    if passing:
                        k = passing[0]
                        hi = cands[k]
                        best, best_figs = hi, figs[k]
                    failing = [cands[k] for k in range(len(cands)) if k not in passing]
                    below = [v for v in failing if v < hi]
                    lo = max(below) + 1 if below else lo
                    if not passing and not below:
                        break
                if best != (f.frac if dim == "frac" else integer):
                    new = make(best)
                    assert new is not None
                    old = str(current.formats[name])
                    if cost_fn is not None:
                        measured = (cost_fn(current), cost_fn(new))
                        if measured[1] > measured[0]:
                            rejected = {"signal": name, "dim": dim, "from": old,
                                        "to": str(new.formats[name]), "kept": False}  # fmt: skip
                            rejected |= {"cost_from": measured[0], "cost_to": measured[1]}
                            steps.append(rejected)
                            bar.update(1)
                            continue
                    if fmax is not None:
                        new_fmax = fmax.measure(new)
                        if not fmax.met(new_fmax):
                            steps.append({"signal": name, "dim": dim, "from": old,
                                          "to": str(new.formats[name]), "kept": False,
                                          "fmax_mhz": new_fmax})  # fmt: skip
                            bar.update(1)
                            continue
                        fmax_now = new_fmax
                    current, cur_figs = new, best_figs
                    worst = worst_case(cur_figs)
                    steps.append(
                        {
                            "signal": name, "dim": dim, "from": old,
                            "to": str(current.formats[name]),
                            "median_rel_range_diff": worst["median_rel_range_diff"],
                            "valid_agreement": worst["valid_agreement"],
                        }
                    )  # fmt: skip
                    if cost_fn is not None:
                        steps[-1] |= {"kept": True, "cost_from": measured[0],
                                      "cost_to": measured[1]}  # fmt: skip
                    if fmax is not None:
                        steps[-1] |= {"kept": True, "fmax_mhz": fmax_now}
                bar.update(1)
    finally:
        bar.close()
    final = current.with_(name=f"{start.name}-optimised")
    return OptimiseResult(
        final, start, worst_case(cur_figs), worst_case(start_figs), n_evals,
        time.perf_counter() - t0, steps, list(cur_figs), list(start_figs), scene_runs, tuning,
        None if fmax is None else {"start": start_fmax, "optimised": fmax_now},
    )  # fmt: skip
