"""Studies: cases (from ``Scene.kind``, real pairs, held-out scenes), the generic runner
over the pipeline registry, word-length sweeps, the optimiser and the benchmark."""

from .cases import (
    HELD_OUT_SCENES,
    REAL_PAIRS,
    held_out_case,
    integer_case,
    real_pair_case,
    scene_case,
    with_thresholds,
)
from .runner import (
    compare_ranges,
    golden_case,
    load_config,
    pipeline_figures,
    propose_from_cases,
    range_source,
    run_case,
)

__all__ = [
    "HELD_OUT_SCENES",
    "REAL_PAIRS",
    "compare_ranges",
    "golden_case",
    "held_out_case",
    "integer_case",
    "load_config",
    "pipeline_figures",
    "propose_from_cases",
    "range_source",
    "real_pair_case",
    "run_case",
    "scene_case",
    "with_thresholds",
]
