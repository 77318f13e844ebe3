"""Where numba caches rangefx's kernels: by their place in the package, not on the disk.

numba's own locators key a cached kernel by the absolute directory of its source file, so
the same kernels installed twice (``pip install .`` beside an editable install of the
same tree, as the README's two commands do one after the other) compile twice: a cold
compile costs 100-180 s of CPU. :class:`PackageCacheLocator` keys them by the module's
path inside the package instead, under ``NUMBA_CACHE_DIR`` (which ``rangefx/__init__.py``
points to a directory per digest of all kernel sources), and stamps each entry with the
digest of its own source file's text, so a kernel is reused only where the text it was
compiled from is the same. ``rangefx/__init__.py`` names it first in
``NUMBA_CACHE_LOCATOR_CLASSES`` (:data:`rangefx.NUMBA_LOCATORS`; numba ≥ 0.68 reads it,
older versions ignore it and keep their path-keyed cache); files outside the package fall
through to numba's own locators, in numba's order. This module imports numba: numba
imports it, when it first caches a kernel.
"""

from __future__ import annotations

import hashlib
import os
from functools import cache

from numba.core import caching, config

__all__ = ["PackageCacheLocator", "package_subpath"]

_ROOT = os.path.dirname(os.path.abspath(__file__))


def package_subpath(py_file: str, root: str = _ROOT) -> str | None:
    """The directory of ``py_file`` relative to the package root ``root`` (``"."`` for a
    module at the root), as a cache subdirectory name; None outside the package."""
    here = os.path.dirname(os.path.abspath(py_file))
    rel = os.path.relpath(here, root)
    if rel == os.pardir or rel.startswith(os.pardir + os.sep) or os.path.isabs(rel):
        return None
    return "pkg" if rel == "." else "pkg-" + rel.replace(os.sep, "-")


@cache
def _text_digest(path: str, mtime_ns: int, size: int) -> str:
    # mtime and size in the key only re-hash a file edited while the process runs
    with open(path, "rb") as fh:
        return hashlib.sha256(fh.read()).hexdigest()


class PackageCacheLocator(caching.UserProvidedCacheLocator):
    """numba's user-directory locator with a package-relative subdirectory and a stamp
    of the source text (not of the file's place or time)."""

    def __init__(self, py_func, py_file: str) -> None:
        super().__init__(py_func, py_file)
        self._cache_path = os.path.join(config.CACHE_DIR, package_subpath(py_file))

    def get_source_stamp(self) -> str:
        st = os.stat(self._py_file)
        return _text_digest(self._py_file, st.st_mtime_ns, st.st_size)

    @classmethod
    def from_function(cls, py_func, py_file: str):
        if not config.CACHE_DIR or package_subpath(py_file) is None:
            return None
        return super().from_function(py_func, py_file)
