"""P1, the derivative-based ranging pipeline: config, model, taps, cost, interface."""

from .config import HOST_REGISTERS, P1_SIGNALS, P1Config
from .model import FRONTEND_TAPS, RANGE_TAPS, frame_registers, run_p1, stage_latencies
from .pipeline import P1Pipeline

__all__ = [
    "FRONTEND_TAPS",
    "HOST_REGISTERS",
    "P1_SIGNALS",
    "RANGE_TAPS",
    "P1Config",
    "P1Pipeline",
    "frame_registers",
    "run_p1",
    "stage_latencies",
]
