"""rangefx: bit-accurate, cycle-faithful fixed-point model of FPGA pixel-streaming pipelines
for passive image-based ranging (NASA 1991 report), with its float64 golden models (SPEC §1).

The repository's top-level folders install as this package's subpackages:
``rangefx.golden``, ``rangefx.rtl_model``, ``rangefx.vectors``, ``rangefx.guidance`` and
``rangefx.tools``. A real top-level package (not a namespace) means a stray
``site-packages/rangefx`` directory cannot merge into it.

Numba's on-disk cache of the ``cache=True`` kernels goes to a per-user cache directory
(``$XDG_CACHE_HOME/rangefx/numba``, else ``~/.cache/rangefx/numba``) unless
``NUMBA_CACHE_DIR`` is set: beside the sources (numba's default) it would survive a
``pip uninstall`` as a stale ``site-packages/rangefx`` directory that shadows a later
editable install, and it cannot be written in a read-only installation. This must run
before numba is first imported, which importing any ``rangefx`` subpackage ensures.
"""

from __future__ import annotations

import os

__all__ = ["numba_cache_dir"]


def numba_cache_dir() -> str | None:
    """The per-user directory for numba's cache, created if needed; None if unusable."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    path = os.path.join(base, "rangefx", "numba")
    try:
        os.makedirs(path, exist_ok=True)
    except OSError:
        return None
    return path if os.access(path, os.W_OK) else None


if "NUMBA_CACHE_DIR" not in os.environ:
    _cache = numba_cache_dir()
    if _cache is not None:  # otherwise numba's own default (beside the sources)
        os.environ["NUMBA_CACHE_DIR"] = _cache
