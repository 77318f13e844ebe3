"""P3, the streaming multi-scale G6 datapath: config, model, taps, cost, interface."""

from .config import P3_SIGNALS, P3Config
from .model import keys_rom, p3_schedule, run_p3, stage_latencies
from .pipeline import P3Pipeline

__all__ = [
    "P3_SIGNALS",
    "P3Config",
    "P3Pipeline",
    "keys_rom",
    "p3_schedule",
    "run_p3",
    "stage_latencies",
]
