"""The second table of docs/guarantees.md (issue 41): whose files rangefx touches, one
writer per output directory, special files; each row produced by running its case.

The test fails when the page's table differs from what the commands print now;
``python tests/test_docs_confinement.py`` rewrites the table in place. Temporary paths
print as ``DIR``, process ids as ``PID``, host names as ``HOST``, times as ``TIME``.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
from guarantee_tables import (
    DOC,
    check_rows_one_line,
    replace_table,
    run_rows,
    table_markdown,
)

from rangefx.tools.cli import main
from rangefx.tools.report.outdir import MARKER_NAME

BEGIN, END = "<!-- table 41: begin (generated) -->", "<!-- table 41: end -->"
CROP = ["--crop", "240", "256", "100", "124"]
PAIR = ["--left", "{d}/left.npy", "--right", "{d}/right.npy", "--f-px", "40", "--baseline", "0.1"]
LONG = "r" * 255  # the longest name a file may have


def _setup(d: Path) -> None:
    """An earlier output with an escaping marker entry, one with a linked sub-folder, a
    vector directory with a FIFO entry, one with a /dev/zero link, one marked incomplete."""
    rng = np.random.default_rng(0)
    left = rng.integers(0, 256, (24, 32))
    np.save(d / "left.npy", left)
    np.save(d / "right.npy", np.roll(left, 1, axis=1))
    (d / "precious.txt").write_text("the user's\n")
    pair = [a.replace("{d}", str(d)) for a in PAIR]
    for name in ("o", "linked"):
        assert main(["run", *pair, "--out", str(d / name)]) == 0
    with open(d / "o" / MARKER_NAME, "a", encoding="utf-8") as f:
        f.write("file: ../precious.txt\n")
    (d / "mine").mkdir()
    (d / "linked" / "summary.json").unlink()
    (d / "linked" / "summary.json").symlink_to(d / "precious.txt")
    assert main(["vectors", "gen", "--scene", "lab", *CROP, "--out", str(d / "vec")]) == 0
    for name in ("fifo", "zero", "incomplete"):
        shutil.copytree(d / "vec", d / name)
    os.unlink(d / "fifo" / "e1.row_r1.mem")
    os.mkfifo(d / "fifo" / "e1.row_r1.mem")
    os.unlink(d / "zero" / "e1.row_r1.mem")
    os.symlink("/dev/zero", d / "zero" / "e1.row_r1.mem")
    marker = d / "incomplete" / MARKER_NAME
    marker.write_text(marker.read_text().replace("state: complete", "state: incomplete"))


#: (case, argv with {d} for the case directory); the message and exit code are run.
CASES: tuple[tuple[str, list[str]], ...] = (
    ("a marker entry outside the output directory (`file: ../precious.txt`): ignored, the "
     "file kept byte for byte", ["run", *PAIR, "--out", "{d}/o"]),
    ("a symbolic link inside an earlier output (`summary.json` -> a user's file)",
     ["run", *PAIR, "--out", "{d}/linked"]),
    ("a second writer of one output directory", ["run", *PAIR, "--out", "{d}/held"]),
    ("a 255-character `--out` name", ["run", *PAIR, "--out", "{d}/" + LONG]),
    ("a manifest entry that is a FIFO", ["vectors", "check", "{d}/fifo"]),
    ("a manifest entry linked to `/dev/zero`", ["vectors", "check", "{d}/zero"]),
    ("a device as the RTL dump",
     ["vectors", "diff", "{d}/vec", "/dev/zero", "--signal", "e1.row_r1"]),
    ("an output marked `state: incomplete` (a run stopped while it moved its files in)",
     ["vectors", "check", "--no-rerun", "{d}/incomplete"]),
)  # fmt: skip


def _normalise(text: str, d: Path, holder: int) -> str:
    text = text.replace(str(d), "DIR").replace(LONG, "r" * 3 + "...(255 characters)")
    text = text.replace(f"PID {holder} on host {socket.gethostname()}", "PID PID on host HOST")
    text = re.sub(r"since \d{4}-\d\d-\d\d \d\d:\d\d:\d\d \w+", "since TIME", text)
    text = re.sub(r"`[^`]*holder[^`]*`", "`rangefx ...`", text)
    return text.strip().replace("|", "\\|").replace("\n", "<br>")


@contextlib.contextmanager
def _holder(directory: Path):
    """Another process holding ``directory``'s lock, as a running command would."""
    code = (
        "import sys, time\n"
        "from rangefx.tools.report.lock import output_lock\n"
        "with output_lock(sys.argv[1], 'holder'):\n"
        "    print('held', flush=True)\n"
        "    time.sleep(600)\n"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code, str(directory)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout.readline().strip() == "held"
        yield proc.pid
    finally:
        proc.kill()
        proc.wait()


def _printed(out: str, err: str) -> str:
    said = [line for line in out.splitlines()
            if line.startswith(("problem:", "results written")) or "FAILED" in line]  # fmt: skip
    return err or " ".join(said) or "(its usual report on stdout)"


def run_cases() -> list[tuple[str, str, str, int]]:
    """(case, command, what rangefx printed, exit code) of every case; the user's file
    outside every output directory is as it was."""
    precious: list[str] = []

    @contextlib.contextmanager
    def holding(d: Path):
        with _holder(d / "held") as pid:
            yield pid
        precious.append((d / "precious.txt").read_text())

    rows = run_rows(_setup, CASES, _normalise, printed=_printed, during=holding)
    assert precious == ["the user's\n"]
    return rows


def test_every_row_is_one_line_and_the_page_is_current():
    rows = run_cases()
    check_rows_one_line(rows)
    assert [code for *_, code in rows] == [0, 2, 2, 0, 2, 2, 2, 1]
    text = DOC.read_text(encoding="utf-8")
    assert text == replace_table(text, table_markdown(rows, "case"), BEGIN, END), (
        "docs/guarantees.md is stale: run python tests/test_docs_confinement.py"
    )


if __name__ == "__main__":
    page = DOC.read_text(encoding="utf-8")
    DOC.write_text(replace_table(page, table_markdown(run_cases(), "case"), BEGIN, END),
                   encoding="utf-8")  # fmt: skip
    sys.exit(0)
