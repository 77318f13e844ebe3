"""The bit-accurate, cycle-faithful pipeline models (SPEC §4, §10).

Shared core: :mod:`.fixedpoint` (formats, casts), :mod:`.config` (the one word-length
config type, timing), :mod:`.stream` (AXI4-Stream-video beats), :mod:`.runtime` (the
shared kernels and host pieces), :mod:`.cost` (cost primitives), :mod:`.pipeline` (the
interface, case and result types) and :mod:`.registry` (``PIPELINES``,
``register_pipeline``); one subpackage
per pipeline: :mod:`.p1`, :mod:`.p2`, :mod:`.p3`.
"""

from .config import TimingConfig, WordLengthConfig, propose_config
from .cost import CostReport
from .fixedpoint import FixedFormat, Overflow, Quant
from .pipeline import Case, GoldenReference, Pipeline, PipelineResult, TapSpec
from .registry import PIPELINES, get_pipeline, register_pipeline, unregister_pipeline

__all__ = [
    "PIPELINES",
    "Case",
    "CostReport",
    "FixedFormat",
    "GoldenReference",
    "Overflow",
    "Pipeline",
    "PipelineResult",
    "Quant",
    "TapSpec",
    "TimingConfig",
    "WordLengthConfig",
    "get_pipeline",
    "propose_config",
    "register_pipeline",
    "unregister_pipeline",
]
