"""A large frame run in bands of lines, with bounded memory (SPEC §8; docs/guarantees.md,
"Which commands stream").

A pipeline whose lines are independent (:attr:`Pipeline.line_independent`: P2, whose
sweep and golden G5 run along each line) runs a frame band by band
(:meth:`Pipeline.run` with ``lines``, :meth:`Pipeline.golden_lines`); each band's rows go into
the frame's arrays, which live in memory-mapped ``.npy`` files of a temporary directory
(unlinked at once: nothing is left on disk) rather than in the heap, so a band's work
arrays and the model's taps are all that is held at once. The result is the whole-frame
run's, bit for bit: every map, tap, cycle stamp and overflow count
(``tests/test_banded.py``).
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import numpy as np

from rangefx.golden.ranging import RangeResult
from rangefx.rtl_model.config import TimingConfig, WordLengthConfig
from rangefx.rtl_model.pipeline import Case, Pipeline, PipelineResult

__all__ = [
    "BAND_BYTES_PER_PIXEL",
    "FRAME_BYTES_PER_PIXEL",
    "band_lines_for",
    "plan_bands",
    "require_input_memory",
    "run_in_bands",
]

#: Peak heap bytes per pixel of one band of a line-independent pipeline beside its
#: golden (P2 and G5: the unbanded ``run`` measured 146 B a pixel above its base;
#: docs/guarantees.md), with a third of headroom.
BAND_BYTES_PER_PIXEL = 200


#: Heap a band may take when a frame is banded for want of memory (or half of what is
#: available, if less): larger bands save little time, as each band's fixed cost is its
#: schedule's and golden's set-up.
BAND_BUDGET_BYTES = 512 * 2**20
#: Resident bytes per pixel of the whole frame a banded run still holds beside its band:
#: its two int64 input images (the sensor's integer codes, 16 B) and the pages of the
#: mapped maps the figures read (range, golden range, both valid flags). Measured: P2 on
#: a random 8192x8192 pair in bands of 327 lines, 3.79 GB peak RSS = the base, the band
#: and 45 B a pixel (``/usr/bin/time -f %M``; docs/guarantees.md); with headroom.
FRAME_BYTES_PER_PIXEL = 48


def band_lines_for(width: int, budget_bytes: int) -> int:
    """Lines a band of a ``width``-pixel frame may hold within ``budget_bytes``."""
    return max(1, budget_bytes // max(1, width * BAND_BYTES_PER_PIXEL))


def plan_bands(
    pipeline: Pipeline, shape: tuple[int, int], band_lines: int | None = None
) -> int | None:
    """Lines per band for a ``run`` of ``pipeline`` on a frame of ``shape``: ``band_lines``
    if given, else None (the whole frame at once) when :func:`require_run_memory`'s
    estimate fits in the memory available (half of it for a pipeline that can band),
    else bands that fit in half of what is left
    after the frame's own inputs (at most :data:`BAND_BUDGET_BYTES`). :class:`UserError`
    (one line, the figure and the limit) when the frame does not fit even so, or a
    pipeline that runs whole frames does not."""
    from ..errors import UserError, available_memory_bytes, require_memory
    from .runner import RUN_BASE_BYTES, run_memory_bytes

    m, n = shape
    what = f"{pipeline.name} run on {m}x{n} pixels"
    if band_lines is not None:
        if band_lines < 1:
            raise UserError(f"band lines must be >= 1, not {band_lines}")
        if not pipeline.line_independent:
            raise UserError(
                f"{pipeline.name} cannot run in bands of lines: its lines are not independent"
            )
        return band_lines
    whole = run_memory_bytes(m * n, pipeline.name)
    # a pipeline that can band does so above half of what is available: the rest is the
    # other processes' (a shared machine's free memory moves while a run grows), and
    # bands cost little time (2048x2048 P2: 14.8 s in bands, 14.1 s whole)
    if not pipeline.line_independent or whole <= available_memory_bytes() // 2:
        require_memory(what, whole)
        return None
    frame = RUN_BASE_BYTES + m * n * FRAME_BYTES_PER_PIXEL
    require_memory(f"{what} in bands of one line", frame + n * BAND_BYTES_PER_PIXEL)
    return band_lines_for(n, min(BAND_BUDGET_BYTES, (available_memory_bytes() - frame) // 2))


def require_input_memory(pipeline: Pipeline | None, what: str, pixels: int) -> None:
    """Refuse, before decoding, a frame of ``pixels`` pixels that a ``run`` of ``pipeline``
    (None: a golden method) could not hold: the whole run's estimate, or for a pipeline
    whose lines are independent (run in bands when large) the whole frame it still holds
    beside a band (:data:`FRAME_BYTES_PER_PIXEL`)."""
    from ..errors import require_memory
    from .runner import RUN_BASE_BYTES, require_run_memory

    if pipeline is not None and pipeline.line_independent:
        require_memory(what, RUN_BASE_BYTES + pixels * FRAME_BYTES_PER_PIXEL)
    else:
        require_run_memory(what, pixels, pipeline=pipeline.name if pipeline else "golden")


def run_in_bands(
    pipeline: Pipeline,
    case: Case,
    config: WordLengthConfig,
    timing: TimingConfig,
    band_lines: int,
    *,
    taps: bool = False,
    threads: int = 2,
    in_memory: bool = False,
) -> tuple[PipelineResult, RangeResult]:
    """Run ``pipeline`` on ``case`` in bands of ``band_lines`` lines; return the frame's
    result and its golden's range map, equal to :meth:`Pipeline.run` and
    :meth:`Pipeline.golden` on the whole frame. The frame's arrays are memory-mapped
    files (``in_memory``: ordinary arrays). ``ValueError`` for a pipeline whose lines are
    not independent or a band size below 1."""
    if not pipeline.line_independent:
        raise ValueError(f"{pipeline.name}'s lines are not independent: it runs whole frames")
    if band_lines < 1:
        raise ValueError(f"band_lines must be >= 1, not {band_lines}")
    m, n = case.image1.shape
    sink = _FrameArrays(m, n, in_memory)
    first: PipelineResult | None = None
    overflows: dict[str, int] = {}
    minmax: dict[str, tuple[float, float]] = {}
    latency, last_cycle, cpu = -(2**62), -(2**62), 0.0
    try:
        for j0 in range(0, m, band_lines):
            j1 = min(m, j0 + band_lines)
            res = pipeline.run(case, config, timing, taps=taps, threads=threads, lines=(j0, j1))
            gold = pipeline.golden_lines(case, (j0, j1), config)
            first = first or res
            for name, count in res.overflows.items():
                overflows[name] = overflows.get(name, 0) + count
            for name, (lo, hi) in res.minmax.items():
                old = minmax.get(name)
                minmax[name] = (lo, hi) if old is None else (min(old[0], lo), max(old[1], hi))
            latency = max(latency, res.latency)
            last_cycle = max(last_cycle, res.total_cycles - 1)
            cpu += sum(res.kernel_cpu_s.values())
            rows = {
                "range": res.range, "valid": res.valid, "range_raw": res.range_raw,
                "in_cycles": res.in_cycles, "out_cycles": res.out_cycles,
                "golden_range": gold.range, "golden_valid": gold.valid,
                **{f"tap.{k}": v for k, v in res.taps.items()},
            }  # fmt: skip
            sink.write(j0, j1, rows)
            del res, gold, rows
        maps = sink.finish()
    finally:
        sink.close()
    assert first is not None  # m >= 1: a checked image has a line
    result = dataclasses.replace(
        first,
        range=maps["range"], valid=maps["valid"], range_raw=maps["range_raw"],
        in_cycles=maps["in_cycles"], out_cycles=maps["out_cycles"],
        taps={k.removeprefix("tap."): v for k, v in maps.items() if k.startswith("tap.")},
        overflows=overflows, minmax=minmax, latency=latency, total_cycles=last_cycle + 1,
        kernel_cpu_s={"sweep": cpu},
    )  # fmt: skip
    golden = RangeResult(range=maps["golden_range"], valid=maps["golden_valid"], terms={})
    return result, golden


class _FrameArrays:
    """The frame's arrays, filled band by band: ``.npy`` files mapped only while a band
    is written (so their pages are not held), then mapped read-only and unlinked."""

    def __init__(self, m: int, n: int, in_memory: bool) -> None:
        self.shape = (m, n)
        self.arrays: dict[str, np.ndarray] = {}
        self.dir = None if in_memory else tempfile.TemporaryDirectory(prefix="rangefx-bands-")

    def _path(self, name: str) -> Path:
        assert self.dir is not None
        return Path(self.dir.name) / f"{name}.npy"

    def write(self, j0: int, j1: int, rows: dict[str, np.ndarray]) -> None:
        for name, band in rows.items():
            if self.dir is None:
                if name not in self.arrays:
                    self.arrays[name] = np.empty(self.shape, dtype=band.dtype)
                self.arrays[name][j0:j1] = band
                continue
            path = self._path(name)
            mode = "r+" if path.exists() else "w+"
            out = np.lib.format.open_memmap(path, mode=mode, dtype=band.dtype, shape=self.shape)
            out[j0:j1] = band
            out.flush()
            del out  # unmapped: the band's pages are the page cache's, not this process's

    def finish(self) -> dict[str, np.ndarray]:
        if self.dir is None:
            return self.arrays
        names = [p.stem for p in Path(self.dir.name).glob("*.npy")]
        # mapped read-only; the files are unlinked by close(), the mappings stay valid
        return {name: np.load(self._path(name), mmap_mode="r") for name in names}

    def close(self) -> None:
        if self.dir is not None:
            self.dir.cleanup()
