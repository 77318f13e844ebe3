"""Error build-up of a pipeline along its scan: a simulation beside its golden (SPEC §6).

A recursive stage accumulates quantisation error where a per-signal min/max cannot show
it, so a study plots the RMS fixed-vs-golden error of the recursive stages' taps along
the direction of their recursion (:mod:`rangefx.tools.report.wlplots` draws them). Each
pipeline computes its own profiles (:meth:`Pipeline.buildup_profiles`, what each index
counts in :attr:`Pipeline.buildup_axes`): P1 its row and column filters', P2 its
backward Riccati sweep's, P3 its level-0 Gauss-Newton stages'.

A profile is ``{"index": positions, "<curve>": values, "<curve>.lsb_rms": ...}``; the
profiles of one run are keyed by name (``row``, ``col``, ``riccati``, ``warps``).
"""

from __future__ import annotations

from rangefx.rtl_model.config import WordLengthConfig
from rangefx.rtl_model.pipeline import Case, Pipeline, Profiles

from .runner import golden_case, run_case

__all__ = ["Profiles", "buildup_for"]


def buildup_for(
    pipeline: Pipeline, case: Case, config: WordLengthConfig, *, threads: int = 2
) -> Profiles:
    """The build-up profiles of ``config`` on ``case``: the pipeline runs with taps beside
    its golden with tap values. A pipeline without profiles has none (an empty dict); a
    bad case or config is a :class:`~rangefx.tools.errors.UserError`."""
    if not pipeline.buildup_axes:
        return {}
    result = run_case(pipeline, case, config, taps=True, threads=threads)
    golden = golden_case(pipeline, case, config, taps=True)
    return pipeline.buildup_profiles(result, golden)
