"""rangefx: bit-accurate, cycle-faithful fixed-point model of FPGA pixel-streaming pipelines
for passive image-based ranging (NASA 1991 report), with its float64 golden models (SPEC §1).

The repository's top-level folders install as this package's subpackages:
``rangefx.golden``, ``rangefx.rtl_model``, ``rangefx.vectors``, ``rangefx.guidance`` and
``rangefx.tools``. A real top-level package (not a namespace) means a stray
``site-packages/rangefx`` directory cannot merge into it.

Numba's on-disk cache of the ``cache=True`` kernels goes to a per-user cache directory
(``$XDG_CACHE_HOME/rangefx/numba``, else ``~/.cache/rangefx/numba``; one subdirectory per
digest of the kernels' sources, see :func:`kernel_source_key`) unless ``NUMBA_CACHE_DIR``
is set, and under it by each module's place in the package, not on the disk
(``numba_cache.py``: the two installs of the README's two commands share one compile).
Beside the sources (numba's default) it would survive a ``pip uninstall`` as a
stale ``site-packages/rangefx`` directory that shadows a later editable install, and it
cannot be written in a read-only installation.

On a CPU with AVX-512, numba is also told to compile for 512-bit vectors
(``NUMBA_CPU_FEATURES``: the host's own features with LLVM's ``prefer-256-bit`` tuning
turned off, :func:`numba_cpu_features`) unless ``NUMBA_CPU_NAME``,
``NUMBA_CPU_FEATURES`` or ``NUMBA_ENABLE_AVX`` is set: LLVM's tuning for Intel's
AVX-512 cores stops its vectoriser at 256 bits, and the kernels' lane loops ran 9-14 %
faster with 512 (docs/performance.md, "How the kernels are built"). It applies to the
process and its children, as numba's own setting does. Both must run before numba is first imported,
which importing any ``rangefx`` subpackage ensures.

The Python API of the three jobs is :mod:`rangefx.api` (``from rangefx import api``); its
functions are also attributes of this package (``rangefx.run``, ``rangefx.scene_case``,
...). It is imported on first use, so ``import rangefx`` (and every ``rangefx`` command's
start) does not pay for numpy, numba and matplotlib.
"""

from __future__ import annotations

import hashlib
import os
import shutil

__all__ = [
    "KERNEL_SOURCES",
    "NUMBA_LOCATORS",
    "NUMBA_TARGET_SETTINGS",
    "PREFER_512_BIT",
    "kernel_source_key",
    "numba_cache_dir",
    "numba_cpu_features",
]

#: The sources numba's cached kernels are compiled from, relative to the package root:
#: every module with ``@njit`` code and the modules whose helpers and constants those
#: inline (``tests/test_packaging.py`` checks that no kernel module is missing).
KERNEL_SOURCES = ("rtl_model", "tools/studies/bench.py")
#: Cache directories kept beside the current one (the most recently used).
CACHE_KEEP = 8
_ROOT = os.path.dirname(os.path.abspath(__file__))
#: ``NUMBA_CACHE_LOCATOR_CLASSES``: rangefx's package-relative locator first (one cache
#: entry per kernel source text, wherever the package is installed: see
#: ``rangefx/numba_cache.py``), then numba's own locators in numba's order.
NUMBA_LOCATORS = ",".join(
    [
        "rangefx.numba_cache.PackageCacheLocator",
        "UserProvidedCacheLocator",
        "InTreeCacheLocator",
        "UserWideCacheLocator",
        "IPythonCacheLocator",
        "ZipCacheLocator",
    ]
)


def kernel_source_key(root: str = _ROOT) -> str:
    """A digest of the text of every ``.py`` file of :data:`KERNEL_SOURCES` under ``root``.

    numba (and :class:`rangefx.numba_cache.PackageCacheLocator`) stamps a cached kernel
    with its own file only, so a kernel that
    inlines a helper from another module (every fused kernel inlines the casts of
    ``rtl_model/fixedpoint.py``) would keep running the old helper after it changed; a
    cache directory per digest of all kernel sources cannot be stale."""
    digest = hashlib.blake2b(digest_size=8)
    for source in KERNEL_SOURCES:
        path = os.path.join(root, source)
        files = [path] if os.path.isfile(path) else sorted(
            os.path.join(d, f) for d, _, names in os.walk(path) for f in names
            if f.endswith(".py"))  # fmt: skip
        for name in sorted(files):
            digest.update(os.path.relpath(name, root).encode() + b"\0")
            with open(name, "rb") as fh:
                digest.update(fh.read())
    return digest.hexdigest()


def numba_cache_dir() -> str | None:
    """The per-user directory for numba's cache (``.../rangefx/numba/src-<key>``, see
    :func:`kernel_source_key`), created if needed, the least recently used beyond
    :data:`CACHE_KEEP` of its siblings removed; None if unusable."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    parent = os.path.join(base, "rangefx", "numba")
    path = os.path.join(parent, "src-" + kernel_source_key())
    try:
        new = not os.path.isdir(path)
        os.makedirs(path, exist_ok=True)
        os.utime(path)  # marks it used, for the pruning below
        if new:
            _prune(parent, keep=path)
    except OSError:
        return None
    return path if os.access(path, os.W_OK) else None


def _prune(parent: str, keep: str) -> None:
    """Remove the least recently used ``src-*`` cache directories (rangefx's own) beyond
    :data:`CACHE_KEEP`; best effort (another process may be using or removing one)."""
    dirs = [os.path.join(parent, d) for d in os.listdir(parent) if d.startswith("src-")]
    dirs = [d for d in dirs if d != keep and os.path.isdir(d)]
    dirs.sort(key=lambda d: os.stat(d).st_mtime, reverse=True)
    for old in dirs[CACHE_KEEP:]:
        shutil.rmtree(old, ignore_errors=True)


if "NUMBA_CACHE_DIR" not in os.environ:
    _cache = numba_cache_dir()
    if _cache is not None:  # otherwise numba's own default (beside the sources)
        os.environ["NUMBA_CACHE_DIR"] = _cache


def numba_cpu_features() -> str | None:
    """``NUMBA_CPU_FEATURES`` for 512-bit vectors: the host's LLVM features with
    ``-prefer-256-bit`` appended, on an x86 CPU with AVX-512 F; None elsewhere (or if
    LLVM cannot tell), where numba's default is kept. The flag only lifts a tuning
    preference: the instructions are those the host has either way."""
    try:
        from llvmlite import binding as llvm

        llvm.initialize_native_target()
        features = llvm.get_host_cpu_features().flatten()
    except Exception:  # llvmlite raises RuntimeError where the host cannot be read
        return None
    if "+avx512f" not in features.split(","):
        return None
    return features + ",-prefer-256-bit"


#: The user's own choice of numba's target, which rangefx leaves alone: a CPU name (a
#: portable cache, say), its features, or AVX turned off.
NUMBA_TARGET_SETTINGS = ("NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES", "NUMBA_ENABLE_AVX")
#: Whether this import set ``NUMBA_CPU_FEATURES`` (child processes inherit the variable
#: and compile the same code; ``rangefx bench`` reports what numba compiles for, from
#: ``numba.config``, as ``cpu.prefer_512_bit``).
PREFER_512_BIT = False
if not any(name in os.environ for name in NUMBA_TARGET_SETTINGS):
    _features = numba_cpu_features()
    if _features is not None:
        os.environ["NUMBA_CPU_FEATURES"] = _features
        PREFER_512_BIT = True
# a user's own choice of locators is kept (rangefx's kernels then cache as numba places them)
os.environ.setdefault("NUMBA_CACHE_LOCATOR_CLASSES", NUMBA_LOCATORS)


#: Names of :mod:`rangefx.api` this package gives as its own attributes (imported lazily).
API_NAMES = (
    "Case", "CheckReport", "DegreesResult", "DemoResult", "DiffReport", "EvalResult",
    "GuideResult", "HdlReport", "OptimiseReport", "ReplayResult", "RunResult", "SweepResult",
    "TrackResult", "UserError", "VectorsResult", "check_vectors", "degrees", "demo",
    "diff_vectors", "evaluate", "generate_vectors", "guide", "image_case", "optimise",
    "real_pair_case", "replay", "run", "scene_case", "sweep", "synth", "timing", "track",
)  # fmt: skip


def __getattr__(name: str) -> object:
    """``rangefx.api`` and its names (:data:`API_NAMES`), imported on first use (PEP 562)."""
    if name == "api" or name in API_NAMES:
        import importlib

        api = importlib.import_module(f"{__name__}.api")
        return api if name == "api" else getattr(api, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), "api", *API_NAMES})
