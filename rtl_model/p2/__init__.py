"""P2, the line-buffered Riccati sweep: config, model, taps, cost, interface."""

from .config import P2_SIGNALS, P2Config, loop_latency
from .model import P2_TAPS, p2_registers, p2_schedule, run_p2, stage_latencies
from .pipeline import P2Pipeline

__all__ = [
    "P2_SIGNALS",
    "P2_TAPS",
    "P2Config",
    "P2Pipeline",
    "loop_latency",
    "p2_registers",
    "p2_schedule",
    "run_p2",
    "stage_latencies",
]
