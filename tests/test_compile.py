"""Compile cost: no numba kernel or helper of the models is compiled once per constant.

A helper called from a kernel with a constant argument (a signal or site index) is
specialised by numba on that constant (``Literal[int]``) unless it has an explicit
signature: each distinct constant compiles another copy (a cold start compiled 20 copies of
P1's cast plan and 26 of its log merge, ~60 s of CPU in all). After every pipeline and
variant has run with and without taps and log in a process with an empty numba cache, no
dispatcher of ``rangefx`` may hold a signature with a literal argument.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from numba import njit, types
from numba.core.registry import CPUDispatcher

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.rtl_model.pipeline import Case
from rangefx.rtl_model.registry import PIPELINES


def dispatchers(prefix: str = "rangefx.") -> list[CPUDispatcher]:
    """Every numba dispatcher of the loaded modules whose name starts with ``prefix``."""
    found: dict[int, CPUDispatcher] = {}
    for name, module in list(sys.modules.items()):
        if name.startswith(prefix) and module is not None:
            for obj in vars(module).values():
                if isinstance(obj, CPUDispatcher):
                    found[id(obj)] = obj
    return list(found.values())


def literal_signatures(prefix: str = "rangefx.") -> dict[str, list[tuple]]:
    """Dispatcher name -> its compiled signatures with a ``Literal`` argument, over every
    loaded module whose name starts with ``prefix``."""
    found: dict[str, list[tuple]] = {}
    for name, module in list(sys.modules.items()):
        if not name.startswith(prefix) or module is None:
            continue
        for attr, obj in vars(module).items():
            if isinstance(obj, CPUDispatcher):
                bad = [s for s in obj.signatures if any(isinstance(t, types.Literal) for t in s)]
                if bad:
                    found[f"{obj.py_func.__module__}.{obj.py_func.__name__} ({name}.{attr})"] = bad
    return found


def _run_everything() -> None:
    rng = np.random.default_rng(3)
    a = rng.integers(0, 256, (12, 20))
    case = Case(a, np.roll(a, 1, axis=1), PinholeCamera(20, 12, 100.0),
                MotionIncrement.stereo(0.1))  # fmt: skip
    for pipeline in PIPELINES.values():
        for design in pipeline.variants.values():
            config = pipeline.default_config(**design)
            for taps in (False, True):
                for log in (False, True):
                    pipeline.run(case, config, taps=taps, log=log, threads=1)


COLD = """
import json
import test_compile as t
t._run_everything()
misses = sum(sum(d.stats.cache_misses.values()) for d in t.dispatchers())
print(json.dumps([misses, {k: [str(s) for s in v] for k, v in t.literal_signatures().items()}]))
"""


def test_no_kernel_is_compiled_per_constant(tmp_path):
    # a kernel loaded from the numba cache types none of its callees, so only a process
    # that compiles everything shows the specialisations: one with an empty cache (the
    # suite's own cache is warm once the README's first command has run the demo)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "empty-cache")}
    env["PYTHONPATH"] = os.pathsep.join([str(Path(__file__).parent), env.get("PYTHONPATH", "")])
    run = subprocess.run([sys.executable, "-c", COLD], env=env, capture_output=True,
                         text=True, check=True)  # fmt: skip
    misses, found = json.loads(run.stdout.splitlines()[-1])
    assert misses > 0, "nothing was compiled: the check would pass vacuously"
    assert found == {}


@njit(cache=False)
def _planted_helper(x, k):
    return x + k


@njit(cache=False)
def _planted_caller(x):
    return _planted_helper(x, 3) + _planted_helper(x, 4)


def test_the_check_finds_a_planted_per_constant_helper():
    assert _planted_caller(np.int64(1)) == 9
    found = literal_signatures(__name__)
    assert any("_planted_helper" in k for k in found), found
    assert len(next(v for k, v in found.items() if "_planted_helper" in k)) == 2
