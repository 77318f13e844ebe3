"""Packaging (issue 19 item 1): ``rangefx`` is a real package, and numba's cache stays out
of the installed package, so an uninstall leaves no ``site-packages/rangefx`` behind to
shadow a later (editable) install, and a read-only install works."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import rangefx

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


def test_numba_cache_goes_to_the_user_cache_not_beside_the_sources(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(tmp_path / "cache")
    assert _probe(tmp_path, env) == str(tmp_path / "cache" / "rangefx" / "numba")
    assert list((tmp_path / "cache" / "rangefx" / "numba").rglob("probe_kernel.twice-*.nbi"))
    assert not list((tmp_path / "src").rglob("*.nbi"))  # nothing beside the sources


def test_an_explicit_numba_cache_dir_is_respected(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "mine")}
    assert _probe(tmp_path, env) == str(tmp_path / "mine")
