"""Reports: tables (Table 1 style), figures (Figs 3, 4, 8), word-length study plots and
the output directories rangefx writes (atomic, marked, never a user's file replaced).

The package's names are those of :mod:`.tables` and :mod:`.plots` (each module's
``__all__``) and the atomic writers of :mod:`.outdir`."""

from . import plots, tables
from .outdir import MARKER_NAME, atomic_output_dir, atomic_write_bytes, atomic_write_text
from .plots import *  # noqa: F403 (re-exported: its __all__)
from .tables import *  # noqa: F403 (re-exported: its __all__)

__all__ = ["MARKER_NAME", "atomic_output_dir", "atomic_write_bytes", "atomic_write_text"]
__all__ += plots.__all__
__all__ += tables.__all__
