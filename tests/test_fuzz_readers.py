"""Fuzz tests of the readers of user files (issue 19): word-length config TOML, vector
manifest, sweep definition. Whatever the input, they raise nothing but the one user-error
type of their layer (``UserError`` in the tools layer, ``ValueError`` from ``vectors``,
which the command line turns into one ``rangefx: error:`` line).
"""

from __future__ import annotations

import contextlib
import functools
import io
import json
import shutil
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rangefx.rtl_model.registry import PIPELINES
from rangefx.tools.cli import main
from rangefx.tools.errors import UserError
from rangefx.tools.studies.cases import scene_case
from rangefx.tools.studies.runner import load_config
from rangefx.tools.studies.sweep import parse_sweep
from rangefx.vectors.generate import case_from_manifest, diff_dump, load_manifest

FUZZ = settings(
    max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
SWEEP = """[sweep]
name = "t"
base = "default"
variant = "paper"
scenes = ["lab"]
size = [32, 40]
seed = 0
combine = "one_at_a_time"
metrics = ["golden", "truth", "sqnr", "overflows"]
pareto_metric = "median_rel_range_diff"
buildup_hooks = []

[[axis]]
signals = "row_state"
param = "frac"
range = [5, 9]
step = 1
keep = "integer"

[[axis]]
signals = ["row_r1", "row_r2"]
param = "quant"
values = ["TRN", "RND"]
"""
TOML_VALUES = st.sampled_from(
    ['"x"', "0", "-1", "1e400", "nan", "true", "[]", "[1, 2]", "{}", '{ format = "s0.0" }',
     '{ format = 5 }', '{ quant = "RND" }', '"s99999999999999999999.0"', '"u8.-2000"',
     '"s62.0"', '"TRN"', "2000-01-01", '[[1], ["a"]]', '"🙂"', "1_000_000_000_000_000_000"]
)  # fmt: skip
JSON = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**70), 2**70) | st.floats() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner,
                                                                 max_size=3),
    max_leaves=8,
)  # fmt: skip


def _mutated_lines(text: str, data: st.DataObject) -> str:
    """``text`` with a few lines' values replaced, lines dropped, duplicated or cut."""
    lines = text.splitlines()
    for _ in range(data.draw(st.integers(1, 4))):
        if not lines:
            break
        k = data.draw(st.integers(0, len(lines) - 1))
        op = data.draw(st.sampled_from(["value", "drop", "dup", "cut", "key"]))
        line = lines[k]
        if op == "value" and "=" in line:
            lines[k] = line.split("=", 1)[0] + "= " + data.draw(TOML_VALUES)
        elif op == "drop":
            del lines[k]
        elif op == "dup":
            lines.insert(k, line)
        elif op == "cut":
            lines[k] = line[: data.draw(st.integers(0, len(line)))]
        elif "=" in line:
            lines[k] = data.draw(st.sampled_from(["x", "row_stat", "pix_in", "[", "axis"]))
            lines[k] += " =" + line.split("=", 1)[1]
    return "\n".join(lines) + "\n"


def _write(d: Path, name: str, payload: str | bytes) -> Path:
    p = d / name
    p.write_bytes(payload if isinstance(payload, bytes) else payload.encode("utf-8", "replace"))
    return p


@pytest.mark.parametrize("pipeline", list(PIPELINES))  # every registered pipeline (issue 40)
@FUZZ
@given(data=st.data())
def test_config_toml_reader_raises_only_user_errors(tmp_path, data, pipeline):
    pipe = PIPELINES[pipeline]
    base = pipe.default_config().to_toml()
    payload = data.draw(
        st.one_of(
            st.builds(lambda: _mutated_lines(base, data)),
            st.text(max_size=200),
            st.binary(max_size=200),
        )
    )
    path = _write(tmp_path, "c.toml", payload)
    with contextlib.suppress(UserError):
        load_config(pipe, str(path))


@FUZZ
@given(data=st.data())
def test_sweep_definition_reader_raises_only_user_errors(data):
    text = data.draw(st.one_of(st.builds(lambda: _mutated_lines(SWEEP, data)), st.text()))
    with contextlib.suppress(UserError):
        parse_sweep(text)


@functools.cache
def _vector_dir(pipeline: str = "p1") -> Path:
    d = Path(tempfile.mkdtemp(prefix="rangefx-fuzz-")) / "vec"
    with contextlib.redirect_stdout(io.StringIO()):
        argv = ["vectors", "gen", "--scene", "lab", "--crop", "240", "244", "100", "106"]
        assert main([*argv, "--pipeline", pipeline, "--out", str(d)]) == 0
    return d


def _a_tap_dump(d: Path) -> Path:
    """A tap's .mem file of the vectors in ``d`` (the dump a user would diff)."""
    files = json.loads((d / "manifest.json").read_text())["files"]
    taps = [e["path"] for e in files if e["kind"] != "stream" and e["path"].endswith(".mem")]
    return d / taps[0]


@functools.cache
def _lab():
    return scene_case("lab")


def _set_path(obj, path: list, value):
    """``obj`` with the element at ``path`` (keys / indices, wrapped) replaced by value."""
    if not path or not isinstance(obj, dict | list) or not obj:
        return value
    if isinstance(obj, dict):
        key = sorted(obj)[path[0] % len(obj)]
        return {**obj, key: _set_path(obj[key], path[1:], value)}
    k = path[0] % len(obj)
    return [*obj[:k], _set_path(obj[k], path[1:], value), *obj[k + 1 :]]


@pytest.mark.parametrize("pipeline", list(PIPELINES))  # every registered pipeline (issue 40)
@FUZZ
@given(
    where=st.lists(st.integers(0, 1000), min_size=1, max_size=4),
    value=JSON,
    drop=st.booleans(),
    raw=st.one_of(st.none(), st.binary(max_size=64), st.text(max_size=64)),
)
def test_manifest_reader_raises_only_value_errors(tmp_path, pipeline, where, value, drop, raw):
    src = _vector_dir(pipeline)
    d = tmp_path / "v"
    if d.exists():
        shutil.rmtree(d)
    shutil.copytree(src, d)
    manifest = json.loads((d / "manifest.json").read_text())
    if raw is not None:
        _write(d, "manifest.json", raw)
    else:
        changed = _set_path(manifest, where, value)
        if drop and isinstance(changed, dict) and changed:
            changed.pop(sorted(changed)[where[0] % len(changed)])
        (d / "manifest.json").write_text(json.dumps(changed))
    with contextlib.suppress(ValueError):
        m = load_manifest(d)
        with contextlib.suppress(ValueError):
            case_from_manifest(d, m)
        diff_dump(d, _a_tap_dump(src))
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["vectors", "check", str(d), "--no-rerun"]) in (0, 1, 2)
