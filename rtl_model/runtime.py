"""Host-side runtime pieces shared by every pipeline model (SPEC §4, §10).

One place for what P1, P2 and later pipelines all need around their kernels: the divider
kinds, latencies and the reciprocal divider's seed ROM, the format table the kernels
read, the per-signal statistics (new and merged across threads), the quantisation of
host registers, the checks of an input image pair, their conversion on the worker threads
(:func:`kernel_image`) and the one pass that fills a band's float range map and cycle
maps (:func:`finish_band`). The shared numba cast and divider
kernels are :mod:`rangefx.rtl_model.kernels`.
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor, wait
from typing import Any, TypeVar

import numpy as np
from numba import njit, types

from rangefx.golden.geometry import PinholeCamera

from .config import WordLengthConfig
from .fixedpoint import FixedFormat

__all__ = [
    "DIVIDERS",
    "DIV_RECIPROCAL",
    "DIV_RESTORING",
    "FMT_COLS",
    "KERNEL_BOOL",
    "KERNEL_FLAGS",
    "KERNEL_FLOAT_PLANE",
    "KERNEL_INT",
    "KERNEL_PLANE",
    "KERNEL_ROW",
    "RegisterFile",
    "SignalStats",
    "check_image_pair",
    "check_threads",
    "divider_code",
    "divider_latency",
    "divider_roms",
    "divider_setup",
    "finish_band",
    "format_table",
    "kernel_image",
    "model_pool",
    "reciprocal_lut",
    "run_two",
    "scratch",
]

#: Hardware divider models (a config's ``divider``).
DIVIDERS = ("restoring", "reciprocal")
#: Their codes in the kernels.
DIV_RESTORING, DIV_RECIPROCAL = 0, 1
#: Columns of :func:`format_table`: word, frac, signed, quant, overflow.
FMT_COLS = 5
#: Argument types of the numba helpers that kernels call with constant signal and site
#: indices. Such a helper takes an explicit signature built from these: without one,
#: numba compiles a copy per distinct constant (``Literal[int]``); a cold start compiled
#: 20 copies of P1's cast plan, 26 of its log merge and 17 of its row cast (measured).
KERNEL_INT, KERNEL_BOOL = types.int64, types.boolean
#: a C-contiguous int64 row, plane (also the format table and the log), float64 plane
KERNEL_ROW, KERNEL_PLANE = types.int64[::1], types.int64[:, ::1]
KERNEL_FLOAT_PLANE, KERNEL_FLAGS = types.float64[:, ::1], types.boolean[::1]
#: Declared latency of the reciprocal divider (``hdl/fx_divide.v`` fx_div_reciprocal:
#: operand normalisation, the seed ROM's two-cycle read (address and data out registered,
#: the block RAM's output register), two Newton products, the final product and its
#: cast); the restoring divider takes ``W + 4`` for a ``W``-bit quotient. Every pipeline's
#: schedule (P1, P2, P3) takes its divider latency from :func:`divider_latency`.
RECIPROCAL_LATENCY = 9


def divider_code(divider: str) -> int:
    """Kernel code of a divider model name."""
    if divider not in DIVIDERS:
        raise ValueError(f"unknown divider {divider!r}; choose from {', '.join(DIVIDERS)}")
    return DIV_RESTORING if divider == "restoring" else DIV_RECIPROCAL


def divider_latency(divider: str, quotient_word: int) -> int:
    """Declared latency in cycles: restoring ``W + 4`` (one quotient bit per cycle plus
    guard, sticky, sign and the output cast), reciprocal :data:`RECIPROCAL_LATENCY`."""
    divider_code(divider)
    return quotient_word + 4 if divider == "restoring" else RECIPROCAL_LATENCY


# host side
def reciprocal_lut(lut_bits: int, r_bits: int) -> np.ndarray:
    """``y0[idx] = round_half_up(2^(R+L+1) / (2^(L+1) + 2 idx + 1))``: 1/m at the midpoint.

    The reciprocal divider's seed ROM (int64; exact: ``2^(R+L+2)`` stays below ``2^47``
    for the largest L = 16, R = 28 a config accepts).
    """
    idx = np.arange(1 << lut_bits, dtype=np.int64)
    num = np.int64(1) << (r_bits + lut_bits + 1)
    den = (np.int64(1) << (lut_bits + 1)) + 2 * idx + 1
    return (2 * num + den) // (2 * den)


def divider_setup(config: WordLengthConfig) -> tuple[int, np.ndarray]:
    """What the kernels need of a config's divider: its kernel code and the reciprocal
    seed ROM (built for either model, read only by the reciprocal one)."""
    return divider_code(config.divider), reciprocal_lut(config.recip_lut_bits, config.recip_bits)


def check_threads(threads: object) -> None:
    """The models run on 1 or 2 threads (the two streams, or two row bands)."""
    if threads not in (1, 2):
        raise ValueError(f"threads must be 1 or 2, not {threads!r}")


def divider_roms(config: WordLengthConfig) -> dict[str, np.ndarray]:
    """The ROMs a config's divider reads: the reciprocal divider's seed table
    (``recip_rom``, :func:`reciprocal_lut`, ``2**recip_lut_bits`` unsigned words); none
    for the restoring divider or a config without a divider."""
    if getattr(config, "divider", None) != "reciprocal":
        return {}
    return {"recip_rom": reciprocal_lut(config.recip_lut_bits, config.recip_bits)}


def format_table(config: WordLengthConfig) -> np.ndarray:
    """(signals, :data:`FMT_COLS`) int64 table of a config's formats, in signal order:
    what the kernels read (indices are positions in ``config.signals()``)."""
    names = config.signals()
    fm = np.zeros((len(names), FMT_COLS), dtype=np.int64)
    for k, name in enumerate(names):
        f = config.formats[name]
        fm[k] = (f.word, f.frac, int(f.signed), int(f.quant), int(f.overflow))
    return fm


_I64 = np.iinfo(np.int64)


class SignalStats:
    """Per-signal instrumentation of one kernel call (one thread, one band).

    ``sites``: per cast site the raw (min, max) before quantisation, its ``frac_in`` and
    signal index (kept as raw integers in the kernels, turned into values here);
    ``values``: per signal a float (min, max) logged by dividers; ``overflows``: per signal
    count. The three arrays are passed to the kernels as they are.
    """

    def __init__(self, n_sites: int, n_signals: int) -> None:
        self.sites = np.zeros((n_sites, 4), dtype=np.int64)
        self.sites[:, 0] = _I64.max
        self.sites[:, 1] = _I64.min
        self.sites[:, 3] = -1
        self.values = np.empty((n_signals, 2))
        self.values[:, 0] = np.inf
        self.values[:, 1] = -np.inf
        self.overflows = np.zeros(n_signals, dtype=np.int64)

    @property
    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(sites, values, overflows)``, the kernels' ``st, dst, ov`` arguments."""
        return self.sites, self.values, self.overflows

    @staticmethod
    def merge(
        parts: Sequence[SignalStats], signals: Sequence[str]
    ) -> tuple[dict[str, int], dict[str, tuple[float, float]]]:
        """Overflow counts and value (min, max) per signal over several calls; signals
        never logged are absent from the min/max."""
        k = len(signals)
        lo, hi = np.full(k, np.inf), np.full(k, -np.inf)
        ovf = np.zeros(k, dtype=np.int64)
        for part in parts:
            ovf += part.overflows
            lo = np.minimum(lo, part.values[:, 0])
            hi = np.maximum(hi, part.values[:, 1])
            # Python ints: iterating the array's rows cost ~0.1 ms a part (P3: 74 sites)
            for raw_lo, raw_hi, frac, sig in part.sites.tolist():
                if sig >= 0:
                    lo[sig] = min(lo[sig], math.ldexp(float(raw_lo), -int(frac)))
                    hi[sig] = max(hi[sig], math.ldexp(float(raw_hi), -int(frac)))
        overflows = {name: int(ovf[i]) for i, name in enumerate(signals)}
        minmax = {
            name: (float(lo[i]), float(hi[i])) for i, name in enumerate(signals) if lo[i] <= hi[i]
        }
        return overflows, minmax


class RegisterFile:
    """The host's per-frame constants quantised into their register formats.

    :meth:`write` quantises one float into a signal's format with the signal's modes
    (:meth:`FixedFormat.from_float`) and records ``name -> (float requested, value
    held)`` in :attr:`values`, and in :attr:`saturated` every register whose value lies
    outside its format's range: its overflow mode acts (SAT holds it at the format's
    limit, WRAP wraps it), silently changing whatever depends on it, and no datapath
    overflow counter sees it.
    """

    def __init__(self, config: WordLengthConfig) -> None:
        self.config = config
        self.values: dict[str, tuple[float, float]] = {}
        self.codes: dict[str, tuple[str, int]] = {}
        self.saturated: list[str] = []

    def write(self, name: str, value: float, signal: str) -> int:
        fmt: FixedFormat = self.config.fmt(signal)
        raw = fmt.from_float(value)
        lo, hi = float(fmt.to_float(fmt.raw_min)), float(fmt.to_float(fmt.raw_max))
        if not lo <= value <= hi:
            self.saturated.append(name)
        self.values[name] = (float(value), float(fmt.to_float(raw)))
        self.codes[name] = (signal, int(raw))
        return raw

    def hold(self, name: str, raw: int, signal: str, requested: float) -> int:
        """Record a register whose code the host computes otherwise (e.g. a threshold
        rounded up), held at ``signal``'s fraction bits."""
        fmt = self.config.fmt(signal)
        self.values[name] = (float(requested), float(raw) * 2.0**-fmt.frac)
        self.codes[name] = (signal, int(raw))
        return raw


def check_image_pair(
    image1: np.ndarray,
    image2: np.ndarray,
    camera: PinholeCamera,
    *,
    pipeline: str,
    min_shape: tuple[int, int],
    convert: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Both images as contiguous int64 grey levels, or ``ValueError`` naming the problem:
    not 2-D, not integer, smaller than ``min_shape`` (rows, columns) for ``pipeline``,
    differing shapes, or not the camera's size. ``convert=False``: the checked images as
    given (integer arrays), for a model that converts them on its worker threads with
    :func:`kernel_image`."""
    out = []
    rows, cols = min_shape
    for name, im in (("image1", image1), ("image2", image2)):
        a = np.asarray(im)
        if a.ndim != 2:
            raise ValueError(f"{name} must be a 2-D array, got shape {a.shape}")
        if a.dtype.kind not in "iu":
            raise ValueError(
                f"{name} must hold integer grey levels for the fixed-point pipeline, "
                f"not dtype {a.dtype}"
            )
        if a.shape[0] < rows or a.shape[1] < cols:
            raise ValueError(
                f"{name} must be at least {rows}x{cols} for {pipeline.upper()}, got shape {a.shape}"
            )
        out.append(np.ascontiguousarray(a, dtype=np.int64) if convert else a)
    if out[0].shape != out[1].shape:
        raise ValueError(f"image pair shapes differ: {out[0].shape} vs {out[1].shape}")
    if out[0].shape != (camera.height, camera.width):
        raise ValueError(
            f"images are {out[0].shape} but the camera is {camera.height}x{camera.width}"
        )
    return out[0], out[1]


@njit(
    types.UniTuple(types.int64, 2)(KERNEL_PLANE, types.float64, KERNEL_FLOAT_PLANE, KERNEL_PLANE,
                                   KERNEL_ROW, KERNEL_PLANE, KERNEL_ROW, KERNEL_INT, KERNEL_INT),
    cache=True, nogil=True,
)  # fmt: skip
def _finish_band(raw, scale, range_f, in_cycles, in_starts, out_cycles, out_starts, out_step,
                 latency):  # fmt: skip
    m, n = raw.shape
    worst = np.int64(-(1 << 62))
    last = np.int64(-(1 << 62))
    for j in range(m):
        for i in range(n):  # exact: a product by 2**-F (|F| <= 1022)
            range_f[j, i] = raw[j, i] * scale
        if in_starts.size:
            start = in_starts[j]
            for i in range(n):
                in_cycles[j, i] = start + i
        if out_starts.size:
            start = out_starts[j]
            for i in range(n):
                out_cycles[j, i] = start + i * out_step
        else:
            for i in range(n):
                out_cycles[j, i] = in_cycles[j, i] + latency
        for i in range(n):
            worst = max(worst, out_cycles[j, i] - in_cycles[j, i])
            last = max(last, out_cycles[j, i])
    return worst, last


def finish_band(
    range_raw: np.ndarray,
    frac: int,
    range_f: np.ndarray,
    in_cycles: np.ndarray,
    out_cycles: np.ndarray,
    *,
    in_starts: np.ndarray | None = None,
    out_starts: np.ndarray | None = None,
    out_step: int = 1,
    latency: int = 0,
) -> tuple[int, int]:
    """A band of lines' host-side result arrays in one pass, on the thread that ran the
    band's kernel (NumPy's three passes and a max took 0.34 ms against 0.07 for a 256x512
    band, measured): the float range map ``range_f = range_raw * 2**-frac``; with ``in_starts``
    (each line's first input cycle, the closed form without gaps) the input cycles
    ``in_cycles[j, i] = in_starts[j] + i``, else ``in_cycles`` is read as given; the
    output cycles ``out_starts[j] + i * out_step`` with ``out_starts``, else
    ``in_cycles + latency``. Returns the band's largest ``out_cycles - in_cycles`` and its
    last output cycle (``-2**62`` for an empty band, below any other band's). Every array
    is C-contiguous, shape (lines, n); ``frac`` within ±1022."""
    if abs(frac) > 1022:
        raise ValueError(f"frac must be within ±1022 for an exact conversion, not {frac}")
    empty = np.empty(0, dtype=np.int64)
    starts_in = empty if in_starts is None else np.ascontiguousarray(in_starts, dtype=np.int64)
    starts_out = empty if out_starts is None else np.ascontiguousarray(out_starts, dtype=np.int64)
    lines = range_raw.shape[0]
    for name, a in (("in_starts", in_starts), ("out_starts", out_starts)):
        if a is not None and a.shape != (lines,):
            raise ValueError(f"{name} must have one entry per line ({lines}), not {a.shape}")
    worst, last = _finish_band(range_raw, 2.0**-frac, range_f, in_cycles, starts_in, out_cycles,
                               starts_out, out_step, latency)  # fmt: skip
    return int(worst), int(last)


def kernel_image(image: np.ndarray, key: str, rows: tuple[int, int] | None = None) -> np.ndarray:
    """A checked integer image (:func:`check_image_pair` with ``convert=False``) as the
    kernels read it, contiguous int64: the image itself if it is one, else a
    :func:`scratch` buffer ``key`` of the calling thread with lines ``rows[0] <= j <
    rows[1]`` (default all) converted and the others left as garbage, for a kernel that
    reads only those lines. Called on the worker thread that runs the kernel, so that the
    two threads convert their own lines (the two 512x512 uint8 images took ~0.1-0.3 ms
    before every run, serially)."""
    if image.dtype == np.int64 and image.flags.c_contiguous:
        return image
    buf = scratch(key, image.shape)
    j0, j1 = (0, image.shape[0]) if rows is None else rows
    np.copyto(buf[j0:j1], image[j0:j1], casting="unsafe")
    return buf


_SCRATCH = threading.local()


def scratch(key: str, shape: tuple[int, ...], dtype: type = np.int64) -> np.ndarray:
    """A model's internal buffer (never handed to the user), kept for the calling thread
    and reused by its next run of the same shape: a 512x512 P1 run allocated ~16 MB of
    such buffers afresh each time, and when the allocator had returned them to the OS,
    every page faulted again (~3,000 faults, 4-6 ms of a 12-25 ms run, measured). The
    contents are garbage; one buffer per ``key`` is kept (the last shape)."""
    cache = getattr(_SCRATCH, "buffers", None)
    if cache is None:
        cache = _SCRATCH.buffers = {}
    buf = cache.get(key)
    if buf is None or buf.shape != shape or buf.dtype != dtype:
        buf = cache[key] = np.empty(shape, dtype=dtype)
    return buf


_POOL: ThreadPoolExecutor | None = None
_POOL_LOCK = threading.Lock()


def model_pool() -> ThreadPoolExecutor:
    """The two worker threads every model's ``threads=2`` runs on, created once per process
    (a pool made and joined per run cost 0.43 ms against 0.13 ms for the same two maps on
    a kept pool, measured: ~3 % of a two-thread P1 run, ~5 % of P2's). The tasks only run
    kernels and never wait on one another, so runs from several calling threads share it
    without deadlock (their tasks queue); a forked child makes its own."""
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(2, thread_name_prefix="rangefx-model")
        return _POOL


_T = TypeVar("_T")


def run_two(fn: Callable[..., _T], first: Sequence[Any], second: Sequence[Any]) -> list[_T]:
    """``[fn(*first), fn(*second)]``, concurrently: the first on a :func:`model_pool`
    worker, the second on the calling thread (the kernels release the GIL). Handing both
    to the pool cost a second thread hand-off per call and left the calling thread idle.
    If the calling thread's call raises, the worker's is waited for before the error
    propagates, so that no kernel is left writing into the caller's arrays."""
    future = model_pool().submit(fn, *first)
    try:
        result = fn(*second)
    except BaseException:
        wait([future])
        raise
    return [future.result(), result]


def _forget_pool_after_fork() -> None:
    global _POOL, _POOL_LOCK
    _POOL, _POOL_LOCK = None, threading.Lock()


os.register_at_fork(after_in_child=_forget_pool_after_fork)
