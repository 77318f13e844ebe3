"""The point-count bound of a word-length sweep (SPEC §6, §8; docs/guarantees.md), in a
module that imports neither numpy nor numba nor the pipeline registry.

``rangefx sweep`` refuses a definition of more than ``--max-points`` points before it
loads a model: :func:`precheck_definition` counts the points from a light parse of the
definition TOML (its axes' ranges and value lists, its scenes; nothing is validated
against a pipeline), so the refusal of a 10^8-point grid does not wait for numba's first
cache load (1-2.6 s). A definition this parse cannot count is left to the full load
(:func:`rangefx.tools.studies.sweep.load_sweep`), which names what is wrong, and the
full count (:func:`rangefx.tools.studies.sweep.point_count`) is checked again there.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Iterable, Mapping
from pathlib import Path

from .errors import UserError

__all__ = [
    "DEFAULT_SIZE",
    "MAX_AXIS_VALUE",
    "MAX_POINTS",
    "SWEEP_SECONDS_PER_PIXEL",
    "count_points",
    "light_point_count",
    "precheck_definition",
    "refuse_too_many_points",
]

#: Largest magnitude of an integer axis value: no format of the int64 models has a
#: word, fraction or integer part (or a change of one) beyond it.
MAX_AXIS_VALUE = 128
#: Points a sweep may have unless ``--max-points`` raises it (``rangefx sweep``).
MAX_POINTS = 100_000
#: The presets' size (height, width) a definition without ``size`` renders its scenes at.
DEFAULT_SIZE = (512, 512)
#: Seconds of one point per pixel, per pipeline, with the golden, truth, sqnr and overflow
#: metrics on lab at 256x256 (AMD EPYC, 2 cores): P1 a median of 0.057 s a point on the
#: idle machine (``rangefx sweep`` of row_state.frac 6..11); P2 by its ratio to P1 in one
#: run of ``rangefx sweep --workers 1`` of 6-7 points each on the shared machine (P1
#: 0.166 s, P2 0.089 s: 0.54); P3 (the box form of the vertical term, its default) by its
#: ratio to P1 over seven alternating runs of 6 points each (p3_warp.frac 1..6 against
#: row_state.frac 6..11, ``--workers 1``, load ~1): median 2.36 (2.08-2.51). A pipeline
#: not listed is estimated at the slowest's cost.
SWEEP_SECONDS_PER_PIXEL: dict[str, float] = {"p1": 0.9e-6, "p2": 0.48e-6, "p3": 2.1e-6}


def count_points(combine: str, axis_lengths: Iterable[int], scenes: int) -> int:
    """Points of a sweep: scenes times the axis combinations (``grid``: their product;
    ``one_at_a_time``: the base plus each axis value alone)."""
    lengths = list(axis_lengths)
    combos = math.prod(lengths) if combine == "grid" else 1 + sum(lengths)
    return combos * scenes


def refuse_too_many_points(
    name: str, pipeline: str, count: int, pixels: int, max_points: int, workers: int
) -> None:
    """:class:`UserError` naming the count, the estimated time (from the pipeline's measured
    cost a pixel) and the option that raises the bound, if ``count > max_points``."""
    if count <= max_points:
        return
    per_pixel = SWEEP_SECONDS_PER_PIXEL.get(pipeline, max(SWEEP_SECONDS_PER_PIXEL.values()))
    hours = count * pixels * per_pixel / workers / 3600
    raise UserError(
        f"sweep {name!r}: {count} points (about {hours:.3g} hours at "
        f"{pixels * per_pixel:.2g} s a point with {workers} workers), more "
        f"than --max-points {max_points}; narrow the axes or raise --max-points"
    )


def _is_int(v: object) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _length_of(raw: Mapping) -> int | None:
    """Values of one raw ``[[axis]]`` table, or None where the full parse must judge it
    (no or both of ``values``/``range``, a malformed or out-of-bounds range, repeats)."""
    if ("values" in raw) == ("range" in raw):
        return None
    if "values" in raw:
        values = raw["values"]
        if not isinstance(values, list) or not values:
            return None
        try:
            distinct = len(set(values)) == len(values)
        except TypeError:  # an unhashable value: the full parse names it
            return None
        return len(values) if distinct else None
    rng, step = raw["range"], raw.get("step", 1)
    if not (isinstance(rng, list) and len(rng) == 2 and all(map(_is_int, (*rng, step)))):
        return None
    lo, hi = rng
    if step < 1 or lo > hi or max(abs(lo), abs(hi)) > MAX_AXIS_VALUE:
        return None
    return len(range(lo, hi + 1, step))


def light_point_count(text: str) -> tuple[str, str, int, int] | None:
    """``(name, pipeline, points, pixels a point)`` of sweep definition TOML ``text``
    from its ``[sweep]`` head and ``[[axis]]`` ranges and value lists alone; None if
    any of them is not of a countable form (the full parse then says what is wrong)."""
    try:
        data = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError, ValueError):
        return None
    head, axes = data.get("sweep"), data.get("axis")
    if not isinstance(head, Mapping) or not isinstance(axes, list) or not axes:
        return None
    scenes = head.get("scenes", ["lab"])
    combine = head.get("combine", "grid")
    size = head.get("size", list(DEFAULT_SIZE))
    pipeline = head.get("pipeline", "p1")
    if (
        not isinstance(scenes, list)
        or not scenes
        or combine not in ("grid", "one_at_a_time")
        or not (isinstance(size, list) and len(size) == 2 and all(map(_is_int, size)))
        or not isinstance(pipeline, str)
    ):
        return None
    lengths = [_length_of(a) if isinstance(a, Mapping) else None for a in axes]
    if None in lengths:
        return None
    count = count_points(combine, lengths, len(scenes))  # type: ignore[arg-type]
    return str(head.get("name", "sweep")), pipeline, count, max(size[0] * size[1], 0)


def precheck_definition(path: str | Path, max_points: int, workers: int) -> None:
    """Refuse the sweep definition at ``path`` if its light count
    (:func:`light_point_count`) is above ``max_points``; a file that cannot be read or
    counted here is left to the full load, which names what is wrong."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return
    counted = light_point_count(text)
    if counted is not None:
        name, pipeline, count, pixels = counted
        refuse_too_many_points(name, pipeline, count, pixels, max_points, workers)
