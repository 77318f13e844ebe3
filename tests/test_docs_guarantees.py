"""The table of docs/guarantees.md: each bad input run through the command line (issue 19).

Every row is produced by running its case: the test fails when the page's table differs
from what the commands print now. ``python tests/test_docs_guarantees.py`` rewrites the
table in place. Temporary paths print as ``DIR``, this machine's free memory as ``N``.
"""

from __future__ import annotations

import contextlib
import io
import json
import re
import shutil
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from rangefx.tools.cli import main

DOC = Path(__file__).resolve().parent.parent / "docs" / "guarantees.md"
BEGIN, END = "<!-- table: begin (generated) -->", "<!-- table: end -->"
CROP = ["--crop", "240", "256", "100", "124"]
SWEEP = """[sweep]
name = "{name}"
scenes = ["lab"]
size = {size}
metrics = ["golden"]
[[axis]]
signals = "row_state"
param = "frac"
values = [{value}]
"""


def _setup(d: Path) -> None:
    """The files the cases read: images, configs, a vector directory, two sweeps."""
    rng = np.random.default_rng(0)
    left = rng.integers(0, 256, (24, 32))
    np.save(d / "left.npy", left)
    np.save(d / "right.npy", np.roll(left, 1, axis=1))
    left[0, 0] = 300
    np.save(d / "sat.npy", left)
    (d / "empty.png").write_bytes(b"")
    (d / "notes.png").write_text("not an image\n")
    (d / "thesis").mkdir()
    (d / "thesis" / "chapter1.tex").write_text("precious\n")
    (d / "mine.toml").write_text("# my own notes\n")
    (d / "bin.toml").write_bytes(bytes(range(256)))
    assert main(["config", "show", "--out", str(d / "p1.toml")]) == 0
    text = (d / "p1.toml").read_text().replace("\nrow_state =", "\nrow_stat =")
    (d / "typo.toml").write_text(text)
    assert main(["vectors", "gen", "--scene", "lab", *CROP, "--out", str(d / "vec")]) == 0
    for name, change in (
        ("nofiles", lambda m: m.pop("files")),
        ("nosha", lambda m: m["files"][0].pop("sha256")),
    ):
        shutil.copytree(d / "vec", d / name)
        man = json.loads((d / name / "manifest.json").read_text())
        change(man)
        (d / name / "manifest.json").write_text(json.dumps(man))
    lines = (d / "vec" / "e1.col_s2.mem").read_text().splitlines()
    lines[1] = f"{int(lines[1], 16) | 0xFF000000:08x}"
    (d / "e1.col_s2.mem").write_text("\n".join(lines) + "\n")
    (d / "a.toml").write_text(SWEEP.format(name="a", size="[24, 32]", value=6))
    (d / "b.toml").write_text(SWEEP.format(name="b", size="[24, 32]", value=7))
    (d / "big.toml").write_text(SWEEP.format(name="big", size="[100000, 100000]", value=6))
    assert main(["sweep", str(d / "a.toml"), "--out", str(d / "sw"), "--json"]) == 0


PAIR = ["--f-px", "40", "--baseline", "0.1"]
#: (bad input, argv with {d} for the case directory); the message and exit code are run.
CASES: tuple[tuple[str, list[str]], ...] = (
    ("unknown scene preset", ["run", "--scene", "moon"]),
    ("missing image file", ["run", "--left", "{d}/gone.png", "--right", "{d}/right.npy", *PAIR]),
    ("empty image file", ["run", "--left", "{d}/empty.png", "--right", "{d}/empty.png", *PAIR]),
    ("a .png that is not an image",
     ["run", "--left", "{d}/notes.png", "--right", "{d}/notes.png", *PAIR]),
    ("grey levels outside the input format (300 in u8.0)",
     ["run", "--pipeline", "p1", "--left", "{d}/sat.npy", "--right", "{d}/right.npy", *PAIR]),
    ("misspelt signal in a config", ["config", "show", "--config", "{d}/typo.toml"]),
    ("binary file as a config TOML", ["config", "show", "--config", "{d}/bin.toml"]),
    ("`--out` a directory where a file is expected", ["config", "show", "--out", "{d}"]),
    ("`--out` a file rangefx did not write", ["config", "show", "--out", "{d}/mine.toml"]),
    ("`--out` a non-empty directory rangefx did not write",
     ["run", "--scene", "lab", "--out", "{d}/thesis"]),
    ("blanking that would not fit in memory",
     ["vectors", "gen", "--scene", "lab", "--hblank", "1000000000", "--out", "{d}/v2"]),
    ("sweep size that would not fit in memory", ["sweep", "{d}/big.toml", "--out", "{d}/s2"]),
    ("another sweep definition into a sweep directory", ["sweep", "{d}/b.toml", "--out", "{d}/sw"]),
    ("manifest without `files`", ["vectors", "check", "{d}/nofiles"]),
    ("manifest entry without `sha256`", ["vectors", "check", "{d}/nosha"]),
    ("missing RTL dump file", ["vectors", "diff", "{d}/vec", "{d}/e1.row_r1.mem"]),
    ("RTL dump word wider than the tap (`ff...` on a 21-bit tap)",
     ["vectors", "diff", "{d}/vec", "{d}/e1.col_s2.mem"]),
)  # fmt: skip


def _normalise(text: str, d: Path) -> str:
    text = text.replace(str(d), "DIR")
    text = re.sub(r"more than the [\d.]+ ([GM]iB) available", r"more than the N \1 available", text)
    return text.strip().replace("|", "\\|").replace("\n", "<br>")


def run_cases(run: Callable[[list[str]], int] = main) -> list[tuple[str, str, str, int]]:
    """(bad input, command, what rangefx printed, exit code) of every case."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            _setup(d)
        for what, argv in CASES:
            args = [a.replace("{d}", str(d)) for a in argv]
            out, err = io.StringIO(), io.StringIO()
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                code = run(args)
            printed = err.getvalue() or " ".join(out.getvalue().splitlines())
            command = "rangefx " + " ".join(a.replace(str(d), "DIR") for a in args)
            rows.append((what, f"`{command}`", _normalise(printed, d), code))
    return rows


def table_markdown(rows: list[tuple[str, str, str, int]]) -> str:
    lines = ["| bad input | command | what rangefx prints | exit |", "|---|---|---|---|"]
    lines += [f"| {w} | {c} | {m} | {code} |" for w, c, m, code in rows]
    return "\n".join(lines) + "\n"


def _replace_table(text: str, table: str) -> str:
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    return f"{head}{BEGIN}\n{table}{END}{tail}"


def test_every_row_is_one_line_with_its_exit_code():
    rows = run_cases()
    for what, _, message, code in rows:
        assert "<br>" not in message and "Traceback" not in message, (what, message)
        assert code == (1 if "wider" in what else 2), (what, code)
        assert message.startswith("rangefx: error: ") or code == 1, (what, message)
    text = DOC.read_text(encoding="utf-8")
    assert text == _replace_table(text, table_markdown(rows)), (
        "docs/guarantees.md is stale: run python tests/test_docs_guarantees.py"
    )


if __name__ == "__main__":
    page = DOC.read_text(encoding="utf-8")
    DOC.write_text(_replace_table(page, table_markdown(run_cases())), encoding="utf-8")
    sys.exit(0)
