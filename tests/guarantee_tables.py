"""What the guarantee tests share (docs/guarantees.md): the generated tables' writer (each
row a case run through the command line, the page's table between its markers compared
with or rewritten from it), a small sweep definition and an image pair on disk.

``tests/test_docs_guarantees.py`` and ``tests/test_docs_confinement.py`` write tables;
``tests/test_guarantees.py`` and ``tests/test_confinement.py`` use the inputs.
"""

from __future__ import annotations

import contextlib
import io
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rangefx.tools.cli import main

#: The page the tables live in.
DOC = Path(__file__).resolve().parent.parent / "docs" / "guarantees.md"
#: A one-axis sweep of the lab scene at 24x32 (format with ``name`` and ``values``).
SWEEP = """
[sweep]
name = "{name}"
scenes = ["lab"]
size = [24, 32]
combine = "one_at_a_time"
metrics = ["golden", "overflows"]

[[axis]]
signals = "row_state"
param = "frac"
values = {values}
"""

#: (case, command, what rangefx printed, exit code) of one row.
Row = tuple[str, str, str, int]


def write_pair(directory: Path) -> list[str]:
    """A random 24x32 stereo pair (E2 = E1 shifted a pixel) as ``l.npy``, ``r.npy`` in
    ``directory``; the ``run`` options that read it."""
    rng = np.random.default_rng(0)
    left = rng.integers(0, 256, (24, 32)).astype(np.float64)
    np.save(directory / "l.npy", left)
    np.save(directory / "r.npy", np.roll(left, 1, axis=1))
    return ["--left", str(directory / "l.npy"), "--right", str(directory / "r.npy"),
            "--f-px", "40", "--baseline", "0.1"]  # fmt: skip


def stderr_or_stdout(out: str, err: str) -> str:
    """What a row shows by default: the error stream, else stdout on one line."""
    return err or " ".join(out.splitlines())


@contextlib.contextmanager
def _nothing(directory: Path) -> Iterator[None]:
    yield None


def run_rows(
    setup: Callable[[Path], None],
    cases: Sequence[tuple[str, list[str]]],
    normalise: Callable[[str, Path, Any], str],
    *,
    printed: Callable[[str, str], str] = stderr_or_stdout,
    during: Callable[[Path], contextlib.AbstractContextManager[Any]] = _nothing,
    run: Callable[[list[str]], int] = main,
) -> list[Row]:
    """Every case (what, argv with ``{d}`` for a fresh directory that ``setup`` filled)
    run once: its command and what it printed (``printed(stdout, stderr)``), both through
    ``normalise(text, d, v)``, and its exit code; ``v`` is the value of the ``during(d)``
    context held while the cases run (another process holding a lock, say)."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            setup(d)
        with during(d) as v:
            for what, argv in cases:
                args = [a.replace("{d}", str(d)) for a in argv]
                out, err = io.StringIO(), io.StringIO()
                with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                    try:
                        code = run(args)
                    except SystemExit as exc:  # argparse's refusal of an argument
                        code = exc.code
                command = "rangefx " + " ".join(normalise(a, d, v) for a in args)
                shown = printed(out.getvalue(), err.getvalue())
                rows.append((what, f"`{command}`", normalise(shown, d, v), code))
    return rows


def table_markdown(rows: Sequence[Row], first: str) -> str:
    """The rows as a Markdown table whose first column is headed ``first``."""
    lines = [f"| {first} | command | what rangefx prints | exit |", "|---|---|---|---|"]
    lines += [f"| {w} | {c} | {m} | {code} |" for w, c, m, code in rows]
    return "\n".join(lines) + "\n"


def replace_table(text: str, table: str, begin: str, end: str) -> str:
    """``text`` with what lies between the markers ``begin`` and ``end`` replaced."""
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    return f"{head}{begin}\n{table}{end}{tail}"


def check_rows_one_line(rows: Sequence[Row]) -> None:
    """No row printed more than one line or a traceback."""
    for what, _, message, _ in rows:
        assert "<br>" not in message and "Traceback" not in message, (what, message)
