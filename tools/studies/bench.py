"""``rangefx bench``: throughput of every registered pipeline beside its float64 golden,
and the unit costs that explain it (SPEC §4 "Speed matters").

Figures are medians of ``repeats`` timed runs after a warm-up, on the ``lab`` pair
(stereo); the machine's CPU model and vector extensions are reported with them, since
the machines here differ (some AVX-512, some only AVX2).
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from functools import partial
from typing import Any

import numba
import numpy as np
from numba import njit

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.rtl_model.config import WordLengthConfig
from rangefx.rtl_model.fixedpoint import (
    ANY_MODES,
    PLAIN_MODES,
    FixedFormat,
    Overflow,
    Quant,
    cast_array,
    cast_by_plan,
    cast_modes,
    cast_plan,
)
from rangefx.rtl_model.kernels import divide_row_lanes
from rangefx.rtl_model.p1 import P1_SIGNALS, P1Config
from rangefx.rtl_model.pipeline import Case, Pipeline
from rangefx.rtl_model.registry import PIPELINES
from rangefx.rtl_model.runtime import divider_setup, format_table, model_pool

from .cases import scene_case

__all__ = [
    "bench_figures",
    "calib_rowcol",
    "cold_run",
    "constant_cast_loop",
    "cpu_description",
    "divide_row_loop",
    "median_time",
    "minmax_loop",
    "over_calib",
    "plan_cast_loop",
    "thread_scaling",
]


def median_time(fn: Callable[[], Any], repeats: int) -> float:
    """Median wall seconds of ``repeats`` calls of ``fn``."""
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def cpu_description() -> dict[str, Any]:
    """CPU model name and the vector extensions numba may use (from /proc/cpuinfo)."""
    model, flags = "unknown", set()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                key, _, value = line.partition(":")
                if key.strip() == "model name" and model == "unknown":
                    model = value.strip()
                elif key.strip() == "flags" and not flags:
                    flags = set(value.split())
    except OSError:
        pass
    ext = [f for f in ("avx2", "avx512f", "avx512bw", "avx512dq", "avx512vl") if f in flags]
    return {
        "model": model,
        "vector_extensions": ext,
        "cpu_count": os.cpu_count(),
        "llvm_cpu": _llvm_cpu_name(),
        # LLVM's 256-bit preference lifted (by rangefx.numba_cpu_features or by the user)
        "prefer_512_bit": "-prefer-256-bit" in (numba.config.CPU_FEATURES or "").split(","),
    }


def _llvm_cpu_name() -> str:
    """The CPU numba compiles for (``NUMBA_CPU_NAME``, else LLVM's name of the host)."""
    if numba.config.CPU_NAME:
        return str(numba.config.CPU_NAME)
    from llvmlite import binding as llvm

    return str(llvm.get_host_cpu_name())


def _bench_pipeline(
    pipeline: Pipeline, case: Case, config: WordLengthConfig, variant: str, repeats: int
) -> dict[str, float]:
    """One pipeline variant's figures, keyed ``<name>_stereo[_<variant>]_...``."""
    pixels = case.image1.size
    stereo = f"{pipeline.name}_stereo" + (f"_{variant}" if variant else "")
    key = pipeline.name + (f"_{variant}" if variant else "")
    pipeline.run(case, config, taps=False)  # JIT warm-up
    cpu: list[dict[str, float]] = []

    def run(threads: int = 2, taps: bool = False, log: bool = False) -> None:
        cpu.append(pipeline.run(case, config, taps=taps, threads=threads, log=log).kernel_cpu_s)

    def mpix_s(**kw: Any) -> float:
        return pixels / median_time(lambda: run(**kw), repeats) / 1e6

    out = {f"{stereo}_mpix_s": mpix_s()}
    # where the time goes: CPU ns per pixel of each kernel, where the model reports it
    for kernel in cpu[0]:
        ns = statistics.median(c[kernel] for c in cpu) / pixels * 1e9
        out[f"{key}_{kernel}_cpu_ns_px"] = ns
    out[f"{stereo}_1thread_mpix_s"] = mpix_s(threads=1)
    out[f"{stereo}_logged_mpix_s"] = mpix_s(log=True)
    out[f"{stereo}_logged_1thread_mpix_s"] = mpix_s(threads=1, log=True)
    out[f"{stereo}_taps_mpix_s"] = mpix_s(taps=True, log=True)
    return out


def _bench_golden(
    pipeline: Pipeline, case: Case, config: WordLengthConfig, variant: str, repeats: int
) -> dict[str, float]:
    """The golden's Mpixel/s, keyed ``golden_<name>[_<variant>]_mpix_s``. Measured after
    every model figure: the golden's large NumPy matrix products start OpenBLAS's worker
    threads, which then spin on the second core for a while, and a two-thread model run
    timed next ran at one thread's speed (P1 paper 23.5 against 43.5 Mpix/s, measured)."""
    key = pipeline.name + (f"_{variant}" if variant else "")
    t = median_time(lambda: pipeline.golden(case, config), repeats)
    return {f"golden_{key}_mpix_s": case.image1.size / t / 1e6}


def bench_figures(
    repeats: int = 5, size: int = 512, names: Sequence[str] | None = None
) -> dict[str, Any]:
    """Mpixel/s of every pipeline and variant (stereo ``size``², default config: two
    threads without taps and without the min/max log, one thread, logged on two and one
    threads, with taps (and the log); per-kernel CPU ns/pixel where the model reports
    it) beside its golden on the same pair (timed after every kernel figure:
    :func:`_bench_golden`), the unit costs of a cast, and the cold start of a second
    process; ``names`` restricts the pipelines (default: all)."""
    case = scene_case("lab", (size, size) if size != 512 else None)
    out: dict[str, Any] = {"size": [size, size], "repeats": repeats, "cpu": cpu_description()}
    out["cpu_count"] = os.cpu_count()
    names = list(names or PIPELINES)
    runs = [(PIPELINES[n], variant, PIPELINES[n].default_config(**design))
            for n in names for variant, design in PIPELINES[n].variants.items()]  # fmt: skip
    for pipeline, variant, config in runs:
        out.update(_bench_pipeline(pipeline, case, config, variant, repeats))
    if "p1" in names:  # the headline figure: P1 paper
        out["p1_stereo_mpix_s"] = out["p1_stereo_paper_mpix_s"]
    image = np.asarray(case.image1, dtype=np.int64)
    out["calib_rowcol_mpix_s"] = _calib_mpix_s(image, repeats)
    # the machine's own two-thread scaling: the calibration kernel on two streams at once
    out["calib_rowcol_2threads_mpix_s"] = _calib_mpix_s(image, repeats, threads=2)
    # ...and for a throughput-bound SIMD loop, the fused kernels' kind
    out["calib_simd_gelem_s"] = _simd_gelem_s(repeats)
    out["calib_simd_2threads_gelem_s"] = _simd_gelem_s(repeats, threads=2)
    out.update(over_calib(out))
    out.update(thread_scaling(out))
    out["cast_ns"], out["cast_overflowing_row_ns"] = _cast_ns()
    out["log_floor_ns"] = _floor_ns(minmax_loop)
    out["constant_cast_floor_ns"] = _floor_ns(constant_cast_loop)
    # the unit costs of the fused kernels' datapath (docs/performance.md: its floor)
    out["cast_by_plan_ns"] = _floor_ns(partial(plan_cast_loop, modes=ANY_MODES)) / PLAN_CASTS
    out["cast_by_plan_plain_ns"] = (
        _floor_ns(partial(plan_cast_loop, modes=PLAIN_MODES)) / PLAN_CASTS
    )
    out["divide_row_lanes_ns"] = _divide_row_ns()
    for pipeline, variant, config in runs:  # after the kernels' figures: see _bench_golden
        out.update(_bench_golden(pipeline, case, config, variant, repeats))
    if "p1" in names:  # the headline golden figure: P1 paper
        out["golden_p1_mpix_s"] = out["golden_p1_paper_mpix_s"]
    code = (
        "import time; t=time.perf_counter(); import numpy as np;"
        "from rangefx.tools.studies.bench import cold_run; cold_run();"
        "print(time.perf_counter()-t)"
    )
    t = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
    out["cold_process_s"] = time.perf_counter() - t
    return out


#: Format of the calibration kernel's states: Q10.8 (s18.8), RND + SAT; the pole C = 0.5
#: with 8 fraction bits.
CALIB_FRAC = 8
CALIB_WORD = 18
CALIB_POLE_RAW = 128


@njit(cache=True, nogil=True)
def calib_rowcol(image, pole_raw, out):
    """The calibration kernel of ``calib_rowcol_mpix_s``: a bare bit-exact first-order row
    filter then column filter (line buffer, read before write) on one stream in strict
    scan order, states in s18.8 rounded half up (RND) and saturated (SAT) after every
    step, nothing logged or counted: the least a bit-exact model of P1's first stage
    can do per pixel. ``out`` receives the column filter's state; returns the number of
    saturations (so the work cannot be optimised away)."""
    m, n = image.shape
    f = CALIB_FRAC
    hi = (np.int64(1) << (CALIB_WORD - 1)) - 1
    lo = -hi - 1
    half = np.int64(1) << (f - 1)
    line = np.zeros(n, dtype=np.int64)
    sat = 0
    for j in range(m):
        p = image[j, 0] << f
        for i in range(n):
            b = image[j, i] << f
            pre = (p << f) + pole_raw * (b - p)  # exact, 2f fraction bits
            q = (pre + half) >> f
            p = min(max(q, lo), hi)
            sat += p != q
            c = p if j == 0 else line[i]
            pre = (c << f) + pole_raw * (p - c)
            q = (pre + half) >> f
            c = min(max(q, lo), hi)
            sat += c != q
            line[i] = c
            out[j, i] = c
    return sat


def _calib_mpix_s(image: np.ndarray, repeats: int, threads: int = 1) -> float:
    """Mpixel/s of :func:`calib_rowcol` on ``image`` (median of ``repeats``): one stream on
    one thread, or two streams at once on the models' two-thread pool (pixels of both
    counted)."""
    outs = [np.empty_like(image) for _ in range(threads)]
    calib_rowcol(image, CALIB_POLE_RAW, outs[0])  # JIT warm-up
    if threads == 1:
        t = median_time(lambda: calib_rowcol(image, CALIB_POLE_RAW, outs[0]), repeats)
        return image.size / t / 1e6
    pool = model_pool()  # the models' two threads, as for calib_simd
    t = median_time(lambda: list(pool.map(lambda o: calib_rowcol(image, CALIB_POLE_RAW, o),
                                          outs)), repeats)  # fmt: skip
    return threads * image.size / t / 1e6


#: Elements and passes of the SIMD calibration loop: a 4,096-element row stays in L1; one
#: call (~5 ms here) is long against the pool's dispatch (~0.1 ms).
SIMD_ELEMENTS, SIMD_PASSES = 4096, 12_000


@njit(cache=True, nogil=True)
def calib_simd(a, b, passes):
    """The SIMD calibration loop of ``calib_simd_gelem_s``: ``passes`` passes of an
    element-wise integer update over ``a`` (independent elements: vectorised,
    throughput-bound, as the models' fused loops), where :func:`calib_rowcol` is one
    dependency chain (latency-bound). Their two-thread scalings bracket what the machine
    gives the models' kernels. Returns ``a[0]`` (so the work cannot be dropped)."""
    for _ in range(passes):
        for i in range(a.shape[0]):
            a[i] = ((a[i] * 3 + b[i]) >> 2) ^ (b[i] << 1)
    return a[0]


def _simd_gelem_s(repeats: int, threads: int = 1) -> float:
    """Gelements/s of :func:`calib_simd` (median of ``repeats``) on one thread, or on two
    rows at once on the models' two-thread pool (elements of both counted)."""
    rows = [(np.arange(SIMD_ELEMENTS, dtype=np.int64), 7 * np.arange(SIMD_ELEMENTS,
             dtype=np.int64)) for _ in range(threads)]  # fmt: skip
    calib_simd(*rows[0], 1)  # JIT warm-up
    if threads == 1:
        t = median_time(lambda: calib_simd(*rows[0], SIMD_PASSES), repeats)
    else:
        pool = model_pool()
        t = median_time(lambda: list(pool.map(lambda r: calib_simd(*r, SIMD_PASSES), rows)),
                        repeats)  # fmt: skip
    return threads * SIMD_ELEMENTS * SIMD_PASSES / t / 1e9


def thread_scaling(figures: dict[str, Any]) -> dict[str, float]:
    """Two threads over one: the calibration kernel's (``calib_two_thread_scaling``: what
    this machine gives a latency-bound kernel with nothing to share, at this moment; and
    ``calib_simd_two_thread_scaling``, the same for a throughput-bound SIMD loop) and every
    pipeline variant's (``<name>_stereo[_<variant>]_two_thread_scaling``, no taps, log
    off), to be read against it."""
    out = {"calib_two_thread_scaling": figures["calib_rowcol_2threads_mpix_s"]
           / figures["calib_rowcol_mpix_s"],
           "calib_simd_two_thread_scaling": figures["calib_simd_2threads_gelem_s"]
           / figures["calib_simd_gelem_s"]}  # fmt: skip
    for key, value in figures.items():
        one = key.replace("_mpix_s", "_1thread_mpix_s")
        if key.endswith("_mpix_s") and "_stereo" in key and one in figures and one != key:
            out[key.removesuffix("_mpix_s") + "_two_thread_scaling"] = value / figures[one]
    return out


def over_calib(figures: dict[str, Any]) -> dict[str, float]:
    """Every pipeline throughput of ``figures`` (``<name>_stereo..._mpix_s``) divided by
    ``calib_rowcol_mpix_s`` measured in the same run: a property of the code, not of the
    machine (issue 18). Keys ``<figure>_over_calib``, plus ``p1_over_calib`` (paper, no
    taps, two threads) and ``p2_over_calib``."""
    calib = figures["calib_rowcol_mpix_s"]
    out = {}
    for key, value in figures.items():
        if key.endswith("_mpix_s") and "_stereo" in key and not key.startswith("golden"):
            out[key.removesuffix("_mpix_s") + "_over_calib"] = value / calib
    for name in PIPELINES:
        first = next((k for k in out if k.startswith(f"{name}_stereo")), None)
        if first is not None:
            out[f"{name}_over_calib"] = out[first]
    return out


def _cast_ns(size: int = 1 << 16, repeats: int = 21) -> tuple[float, float]:
    """CPU ns per element of one cast (``cast_array``, s16.4 RND/SAT from 8 more fraction
    bits): the unit cost the pipeline pays ~41 times per stereo pixel. Two figures: a
    row inside the format (the common case: overflow is decided on the row's extremes)
    and the same row with one element out of range (a second, element-wise pass)."""
    raw = np.random.default_rng(0).integers(-(2**22), 2**22, size)
    fmt = FixedFormat.from_string("s16.4", Quant.RND, Overflow.SAT)
    figures = []
    for row in (raw, np.concatenate([raw[:-1], [2**40]])):
        cast_array(row, 12, fmt)  # JIT warm-up
        times = []
        for _ in range(repeats):
            t = time.thread_time()
            cast_array(row, 12, fmt)
            times.append(time.thread_time() - t)
        figures.append(statistics.median(times) / size * 1e9)
    return figures[0], figures[1]


@njit(cache=True, nogil=True)
def minmax_loop(raw, out, reps):
    """Only the min/max log of an int64 row, ``reps`` times (a calibration: see below)."""
    lo, hi = raw[0], raw[0]
    for _ in range(reps):
        for i in range(raw.shape[0]):
            lo = min(lo, raw[i])
            hi = max(hi, raw[i])
    return lo, hi, 0


@njit(cache=True, nogil=True)
def constant_cast_loop(raw, out, reps):
    """A cast with its format folded in as constants (s16.4 RND/SAT from 8 more fraction
    bits), saturated element by element, logged and counted, ``reps`` times: what a kernel
    specialised on one config pays without the row-extremes overflow check of cast_row."""
    lo, hi, count = raw[0], raw[0], 0
    for _ in range(reps):
        for i in range(raw.shape[0]):
            r = raw[i]
            lo = min(lo, r)
            hi = max(hi, r)
            q = (r + 128) >> 8
            value = min(max(q, -32768), 32767)
            out[i] = value
            count += value != q
    return lo, hi, count


def _floor_ns(loop, size: int = 512, reps: int = 4000, repeats: int = 7) -> float:
    """CPU ns per element of a calibration ``loop`` over a 512-element int64 row (min of
    ``repeats``): floors for one logged cast on this CPU (AVX2 has no 64-bit vector
    min/max), to set beside ``cast_ns``."""
    raw = np.random.default_rng(1).integers(-(2**22), 2**22, size)
    out = np.empty_like(raw)
    return _min_ns_per_element(lambda r: loop(raw, out, r), size, reps, repeats)


def _min_ns_per_element(run: Callable[[int], Any], size: int, reps: int, repeats: int) -> float:
    """CPU ns per element of ``run(reps)``, a jitted loop of ``reps`` passes over ``size``
    elements (after one warm-up pass; min of ``repeats``)."""
    run(1)
    times = []
    for _ in range(repeats):
        t = time.thread_time()
        run(reps)
        times.append(time.thread_time() - t)
    return min(times) / (size * reps) * 1e9


#: Casts per element of :func:`plan_cast_loop`.
PLAN_CASTS = 6


@njit(cache=True, nogil=True)
def plan_cast_loop(raw, out, reps, modes):
    """:data:`PLAN_CASTS` independent casts of each element by run-time cast plans
    (``cast_by_plan``, as the fused kernels cast: right shifts of 2..12 bits into 12- to
    24-bit words, RND / RND_CONV / TRN, SAT / WRAP; with ``modes`` PLAIN_MODES the plain
    body and RND / TRN, SAT only), their sum stored and their overflows counted, ``reps``
    times: the unit cost of one cast in the models' SIMD loops (the ``cast_ns`` row cast
    logs and decides overflow on the row's extremes instead)."""
    plain = modes is None
    q2, o3 = (np.int64(2), np.int64(1)) if plain else (np.int64(6), np.int64(0))
    p0, p1 = cast_plan(2, 12, True, 2, 1), cast_plan(4, 16, True, 2, 1)
    p2, p3 = cast_plan(6, 20, True, q2, 1), cast_plan(8, 24, True, 0, o3)
    p4, p5 = cast_plan(10, 16, True, 2, 1), cast_plan(12, 12, True, 2, 1)
    count = 0
    for _ in range(reps):
        for i in range(raw.shape[0]):
            r = raw[i]
            v0, f0 = cast_by_plan(r, p0, modes)
            v1, f1 = cast_by_plan(r, p1, modes)
            v2, f2 = cast_by_plan(r, p2, modes)
            v3, f3 = cast_by_plan(r, p3, modes)
            v4, f4 = cast_by_plan(r, p4, modes)
            v5, f5 = cast_by_plan(r, p5, modes)
            out[i] = v0 + v1 + v2 + v3 + v4 + v5
            count += f0 + f1 + f2 + f3 + f4 + f5
    return out[0], out[-1], count


@njit(cache=True, nogil=True)
def divide_row_loop(num, fn, den, fd, s, lut, r_bits, fm, dst, ov, out, flags, reps, modes):
    """``reps`` calls of P1's ``divide_row_lanes`` (log off, cast body ``modes``) on one
    row."""
    for _ in range(reps):
        divide_row_lanes(num, fn, den, fd, s, lut, r_bits, fm, dst, ov, out, flags, False,
                         modes)  # fmt: skip
    return out[0]


def _divide_row_ns(size: int = 512, reps: int = 2000, repeats: int = 7) -> float:
    """CPU ns per element of ``divide_row_lanes`` (the reciprocal divider in SIMD lanes,
    log off) on a 512-element row of P1's x-derivative ``s1 r2 / r1`` in the default
    config's formats, random operands (min of ``repeats``)."""
    config = P1Config.default()
    fm = format_table(config)
    _, lut = divider_setup(config)
    rng = np.random.default_rng(2)
    num = rng.integers(-(2**24), 2**24, size)
    den = rng.integers(-(2**14), 2**14, size)
    names = ("col_s1", "row_r1", "row_r2", "div_quot")
    col_s1, row_r1, row_r2, quot = (P1_SIGNALS.index(k) for k in names)
    fn, fd = int(fm[col_s1, 1] + fm[row_r2, 1]), int(fm[row_r1, 1])
    dst, ov = np.zeros((fm.shape[0], 2)), np.zeros(fm.shape[0], dtype=np.int64)
    out, flags = np.empty(size, dtype=np.int64), np.empty(size, dtype=np.bool_)
    args = (num, fn, den, fd, quot, lut, config.recip_bits, fm, dst, ov, out, flags)
    modes = cast_modes(fm)  # the default config's: the plain cast body
    return _min_ns_per_element(lambda r: divide_row_loop(*args, r, modes), size, reps, repeats)


def cold_run() -> None:
    """A second process's first run of every pipeline on a 64x64 pair (numba cache warm)."""
    rng = np.random.default_rng(0)
    a = rng.integers(0, 256, (64, 64))
    cam = PinholeCamera(64, 64, 100.0)
    for pipeline in PIPELINES.values():
        pipeline.run(Case(a, np.roll(a, 1, axis=1), cam, MotionIncrement.stereo(0.1)), taps=False)
