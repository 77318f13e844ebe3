"""Packaging (issue 19 item 1): ``rangefx`` is a real package, and numba's cache stays out
of the installed package, so an uninstall leaves no ``site-packages/rangefx`` behind to
shadow a later (editable) install, and a read-only install works."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import rangefx
from rangefx import CACHE_KEEP, KERNEL_SOURCES, kernel_source_key, numba_cpu_features
from rangefx.numba_cache import package_subpath

PROBE = """
import sys
import rangefx  # first, as any use of a rangefx subpackage imports it
import numba
sys.path.insert(0, sys.argv[1])
import probe_kernel
probe_kernel.twice(3)
print(numba.config.CACHE_DIR)
"""
KERNEL = """
from numba import njit


@njit(cache=True)
def twice(x):
    return 2 * x
"""


def _probe(tmp_path: Path, env: dict[str, str]) -> str:
    (tmp_path / "src").mkdir(exist_ok=True)
    (tmp_path / "src" / "probe_kernel.py").write_text(KERNEL)
    run = subprocess.run(
        [sys.executable, "-c", PROBE, str(tmp_path / "src")],
        env=env, capture_output=True, text=True, check=True,
    )  # fmt: skip
    return run.stdout.split()[-1]


def test_rangefx_is_a_regular_package():
    assert rangefx.__file__ is not None and Path(rangefx.__file__).name == "__init__.py"
    assert rangefx.__spec__.origin == rangefx.__file__  # not a namespace package


def _user_env(tmp_path: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(tmp_path / "cache")
    return env


def test_numba_cache_goes_to_the_user_cache_not_beside_the_sources(tmp_path):
    parent = tmp_path / "cache" / "rangefx" / "numba"
    assert _probe(tmp_path, _user_env(tmp_path)) == str(parent / f"src-{kernel_source_key()}")
    assert list(parent.rglob("probe_kernel.twice-*.nbi"))
    assert not list((tmp_path / "src").rglob("*.nbi"))  # nothing beside the sources


def _copy_kernel_sources(dst: Path) -> None:
    root = Path(rangefx.__file__).parent
    for source in KERNEL_SOURCES:
        path = root / source
        files = [path] if path.is_file() else sorted(path.rglob("*.py"))
        for f in files:
            (dst / f.relative_to(root)).parent.mkdir(parents=True, exist_ok=True)
            (dst / f.relative_to(root)).write_bytes(f.read_bytes())


def test_the_cache_key_changes_with_any_kernel_source_and_only_with_them(tmp_path):
    """numba keys a cached kernel by its own file only: a fused kernel that inlines a cast
    helper from fixedpoint.py kept running the old cast after it changed (seen in issue
    18). The cache directory's key covers every kernel source, so an edit of the helper
    alone gives a fresh directory."""
    _copy_kernel_sources(tmp_path)
    key = kernel_source_key(str(tmp_path))
    assert key == kernel_source_key()  # the same texts, wherever they are
    helper = tmp_path / "rtl_model" / "fixedpoint.py"
    helper.write_text(helper.read_text() + "\n# an edit of an inlined helper\n")
    assert kernel_source_key(str(tmp_path)) != key
    (tmp_path / "README.md").write_text("not a kernel source")
    edited = kernel_source_key(str(tmp_path))
    (tmp_path / "README.md").write_text("still not a kernel source")
    assert kernel_source_key(str(tmp_path)) == edited


def _package_modules(package: Path) -> list[Path]:
    """The ``.py`` files of a package and its subpackages (directories with an
    ``__init__.py``: not ``build/`` or ``tests/`` beside them in the source tree)."""
    files = sorted(package.glob("*.py"))
    for sub in sorted(d for d in package.iterdir() if (d / "__init__.py").is_file()):
        files += _package_modules(sub)
    return files


def test_every_module_with_numba_kernels_is_a_kernel_source():
    root = Path(rangefx.__file__).parent
    covered = {f for s in KERNEL_SOURCES for f in ([root / s] if (root / s).is_file()
               else (root / s).rglob("*.py"))}  # fmt: skip
    kernels = {f for f in _package_modules(root) if re.search(r"^@njit", f.read_text(), re.M)}
    assert kernels, "no kernel module found: the check would pass vacuously"
    assert kernels <= covered, sorted(str(f.relative_to(root)) for f in kernels - covered)


def test_old_cache_directories_beyond_the_kept_ones_are_removed(tmp_path):
    parent = tmp_path / "cache" / "rangefx" / "numba"
    old = [parent / f"src-{k:016x}" for k in range(CACHE_KEEP + 3)]
    for age, d in enumerate(old):  # old[0] the most recently used
        d.mkdir(parents=True)
        (d / "kernel.nbi").write_text("x")
        os.utime(d, (1e9 - age * 1000, 1e9 - age * 1000))
    other = parent / "not-ours"
    other.mkdir()
    _probe(tmp_path, _user_env(tmp_path))
    assert [d.exists() for d in old] == [True] * CACHE_KEEP + [False] * 3
    assert other.exists()  # only rangefx's own src-* directories are pruned


def test_an_explicit_numba_cache_dir_is_respected(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "mine")}
    assert _probe(tmp_path, env) == str(tmp_path / "mine")


VECTORS = """
import rangefx
import numba
import numpy as np


@numba.njit
def scale(a, out):
    for i in range(a.shape[0]):
        out[i] = a[i] * 3 + (a[i] >> 2)


a = np.arange(64, dtype=np.int64)
scale(a, np.empty_like(a))
asm = next(iter(scale.inspect_asm().values()))
print(rangefx.PREFER_512_BIT, "zmm" in asm, numba.config.CPU_FEATURES or "-")
"""


def _vectors(env: dict[str, str]) -> tuple[bool, bool, str]:
    run = subprocess.run([sys.executable, "-c", VECTORS], env=env, capture_output=True,
                         text=True, check=True)  # fmt: skip
    ours, zmm, features = run.stdout.split()
    return ours == "True", zmm == "True", features


def _host_features() -> str:
    from llvmlite import binding as llvm

    llvm.initialize_native_target()
    return llvm.get_host_cpu_features().flatten()


def test_numba_compiles_for_512_bit_vectors_where_the_cpu_has_avx512():
    host = _host_features()
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CPU_FEATURES"}
    ours, zmm, features = _vectors(env)
    if "+avx512f" in host.split(","):
        assert numba_cpu_features() == host + ",-prefer-256-bit"
        assert ours and features == host + ",-prefer-256-bit"
        assert zmm  # the loop's vectors are 512-bit
    else:
        assert numba_cpu_features() is None
        assert not ours and features == "-" and not zmm


def test_a_users_numba_cpu_features_are_kept():
    host = _host_features()
    ours, _, features = _vectors({**os.environ, "NUMBA_CPU_FEATURES": host})
    assert not ours and features == host


@pytest.mark.parametrize(("name", "value"), [("NUMBA_CPU_NAME", "generic"),
                                             ("NUMBA_ENABLE_AVX", "0")])  # fmt: skip
def test_a_users_numba_target_is_kept(name, value):
    """A named target CPU (a portable cache) or AVX turned off: rangefx sets no features."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CPU_FEATURES"}
    ours, _, features = _vectors({**env, name: value})
    assert not ours and features == "-"


def test_package_subpath_names_the_module_directory_inside_the_package_only(tmp_path):
    root = tmp_path / "rangefx"
    assert package_subpath(str(root / "fixedpoint.py"), str(root)) == "pkg"
    assert package_subpath(str(root / "rtl_model" / "p1" / "model.py"), str(root)) == (
        "pkg-rtl_model-p1"
    )
    assert package_subpath(str(tmp_path / "elsewhere.py"), str(root)) is None
    assert package_subpath(str(tmp_path / "rangefx2" / "m.py"), str(root)) is None


# the module is loaded from its file under its package name, without rangefx.rtl_model's
# __init__: that imports every pipeline, whose explicitly typed kernels compile at import
# (an empty cache: ~30 s per run, five runs); the cache's key is the same either way
SHARED = """
import importlib.util, json, os, sys
import numpy as np
import rangefx
name = "rangefx.rtl_model.fixedpoint"
path = os.path.join(os.path.dirname(rangefx.__file__), "rtl_model", "fixedpoint.py")
spec = importlib.util.spec_from_file_location(name, path)
fixedpoint = importlib.util.module_from_spec(spec)
sys.modules[name] = fixedpoint
spec.loader.exec_module(fixedpoint)
fixedpoint.quantise_shift(np.int64(77), np.int64(3), np.int64(2))
s = fixedpoint.quantise_shift.stats
print(json.dumps([rangefx.__file__, sum(s.cache_hits.values()), sum(s.cache_misses.values())]))
"""


def _copy_package(dst: Path) -> Path:
    """The package's modules (and nothing else) under ``dst/rangefx``, as an install
    would put them."""
    root = Path(rangefx.__file__).parent
    for f in _package_modules(root):
        (dst / "rangefx" / f.relative_to(root)).parent.mkdir(parents=True, exist_ok=True)
        (dst / "rangefx" / f.relative_to(root)).write_bytes(f.read_bytes())
    return dst / "rangefx"


def _shared_run(site: Path, cache: Path, **env: str) -> tuple[str, int, int]:
    run = subprocess.run(
        [sys.executable, "-c", SHARED],
        env={**os.environ, "PYTHONPATH": str(site), "NUMBA_CACHE_DIR": str(cache), **env},
        capture_output=True, text=True, check=True, cwd=site,
    )  # fmt: skip
    return tuple(json.loads(run.stdout.splitlines()[-1]))


def test_two_installs_of_the_same_sources_share_one_compiled_kernel(tmp_path):
    """The README's two commands install the package twice (site-packages, then an
    editable install): numba's own locators key the cache by the source's directory and
    compiled every kernel twice; rangefx's locator keys it by the place in the package
    and the source text, so the second install loads what the first compiled, and an
    edited text compiles afresh."""
    first, second = _copy_package(tmp_path / "a"), _copy_package(tmp_path / "b")
    cache = tmp_path / "cache"
    path, hits, misses = _shared_run(tmp_path / "a", cache)
    assert Path(path).parent == first and misses == 1
    path, hits, misses = _shared_run(tmp_path / "b", cache)
    assert Path(path).parent == second and (hits, misses) == (1, 0)
    # numba's own locator alone (what older numba does): the second install compiles
    other = tmp_path / "numba-default"
    _shared_run(tmp_path / "a", other, NUMBA_CACHE_LOCATOR_CLASSES="UserProvidedCacheLocator")
    assert _shared_run(
        tmp_path / "b", other, NUMBA_CACHE_LOCATOR_CLASSES="UserProvidedCacheLocator"
    )[1:] == (0, 1)
    # an edit of the kernel's own file is a new text: compiled, not loaded
    source = second / "rtl_model" / "fixedpoint.py"
    source.write_text(source.read_text() + "\n# edited\n")
    assert _shared_run(tmp_path / "b", cache)[1:] == (0, 1)
