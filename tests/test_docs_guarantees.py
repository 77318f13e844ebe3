"""The table of docs/guarantees.md: each bad input run through the command line (issue 19).

Every row is produced by running its case: the test fails when the page's table differs
from what the commands print now. ``python tests/test_docs_guarantees.py`` rewrites the
table in place. Temporary paths print as ``DIR``, this machine's free memory as ``N``.
"""

from __future__ import annotations

import json
import re
import shutil
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


def _normalise(text: str, d: Path, _: object = None) -> str:
    text = text.replace(str(d), "DIR")
    text = re.sub(r"more than the [\d.]+ ([GM]iB) available", r"more than the N \1 available", text)
    return text.strip().replace("|", "\\|").replace("\n", "<br>")


def run_cases() -> list[tuple[str, str, str, int]]:
    """(bad input, command, what rangefx printed, exit code) of every case."""
    return run_rows(_setup, CASES, _normalise)


def test_every_row_is_one_line_with_its_exit_code():
    rows = run_cases()
    check_rows_one_line(rows)
    for what, _, message, code in rows:
        assert code == (1 if "wider" in what else 2), (what, code)
        assert message.startswith("rangefx: error: ") or code == 1, (what, message)
    text = DOC.read_text(encoding="utf-8")
    assert text == replace_table(text, table_markdown(rows, "bad input"), BEGIN, END), (
        "docs/guarantees.md is stale: run python tests/test_docs_guarantees.py"
    )


# == issue 40: the verdict, malformed input, bounds, provenance ============================
# (its own table between its own markers, so that other issues' rows merge apart)
BEGIN_40, END_40 = "<!-- table issue 40: begin (generated) -->", "<!-- table issue 40: end -->"
P2_SWEEP = SWEEP.replace('scenes = ["lab"]', 'scenes = ["lab"]\npipeline = "p2"')


def _setup_40(d: Path) -> None:
    from numpy.lib.format import open_memmap

    _setup(d)
    exp = [int(w, 16) for w in (d / "vec" / "e1.col_s2.mem").read_text().splitlines()[1:]]
    wide = [(v - (1 << 21) if v >> 20 else v) & 0xFFFFFFFF for v in exp]  # 32-bit sign ext.
    k = next(i for i, v in enumerate(exp) if v >> 20)
    signext = [*wide[:k], exp[k] | 0x0FE00000, *wide[k + 1 :]]
    (d / "signext").mkdir()
    (d / "signext" / "e1.col_s2.mem").write_text("".join(f"{w:08x}\n" for w in signext))
    half = len(exp) // 2  # $writememh runs, the second half first
    runs = [
        f"@{half:x}",
        *(f"{w:06x}" for w in exp[half:]),
        "@0",
        *(f"{w:06x}" for w in exp[:half]),
    ]
    (d / "addr").mkdir()
    (d / "addr" / "e1.col_s2.mem").write_text("\n".join(runs) + "\n")
    with open(d / "e1.row_r1.mem", "wb") as f:
        f.truncate(100 * 2**30)  # a sparse 100 GiB dump
    (d / "deep.toml").write_text("x = " + "[" * 5000 + "]" * 5000 + "\n")
    assert main(["config", "show", "--pipeline", "p2", "--out", str(d / "p2.toml")]) == 0
    text = (d / "p2.toml").read_text()
    (d / "p2frac.toml").write_text(text.replace('format = "s9.0"', 'format = "s9.1000"', 1))
    text = (d / "p1.toml").read_text()
    (d / "bias.toml").write_text(text.replace("bias = 16.0", "bias = 1e300"))
    assert main(["config", "show", "--pipeline", "p3", "--out", str(d / "p3.toml")]) == 0
    text = (d / "p3.toml").read_text()
    tg = re.sub(r"(?m)^threshold_g = \S+", "threshold_g = 1e300", text)
    assert tg != text, "P3's config names no threshold_g"
    (d / "tg.toml").write_text(tg)
    (d / "int64.toml").write_text(
        SWEEP.format(name="i", size="[24, 32]", value=6).replace(
            "values = [6]", "range = [0, 9223372036854775807]"
        )
    )
    axes = "".join(f'[[axis]]\nsignals = "{s}"\nparam = "frac"\nrange = [-50, 49]\n'
                   for s in ("row_state", "col_s1", "row_r1", "row_r2"))  # fmt: skip
    (d / "grid.toml").write_text(
        '[sweep]\nname = "grid"\nscenes = ["lab"]\ncombine = "grid"\n' + axes
    )
    shutil.copytree(d / "sw", d / "tail")
    with open(d / "tail" / "results.jsonl", "ab") as f:
        f.write(b"\x00\xff\xfe binary\n")
    (d / "swdir" / "results.jsonl").mkdir(parents=True)
    for side in ("l", "r"):  # 12000 x 12000 grey levels (a sparse file)
        open_memmap(d / f"{side}12k.npy", mode="w+", dtype=np.uint8, shape=(12000, 12000))
    for name, change in (
        ("hblank", lambda m: m["timing"].__setitem__("hblank", 8 * 10**12)),
        ("moon", lambda m: m["case"].__setitem__("scene", "moon")),
        ("seed", lambda m: m["case"].__setitem__("seed", 1)),
    ):
        shutil.copytree(d / "vec", d / name)
        man = json.loads((d / name / "manifest.json").read_text())
        change(man)
        (d / name / "manifest.json").write_text(json.dumps(man))


#: (bad input, argv, exit code expected).
CASES_40: tuple[tuple[str, list[str], int], ...] = (
    ("32-bit dump word `v \\| 0x0FE00000` of a negative s21.11 `v` (not a sign extension)",
     ["vectors", "diff", "{d}/vec", "{d}/signext/e1.col_s2.mem"], 1),
    ("`$writememh` dump with `@address` runs (second half first)",
     ["vectors", "diff", "{d}/vec", "{d}/addr/e1.col_s2.mem"], 0),
    ("sparse 100 GiB dump", ["vectors", "diff", "{d}/vec", "{d}/e1.row_r1.mem"], 2),
    ("config nested 5000 levels deep", ["config", "show", "--config", "{d}/deep.toml"], 2),
    ("`s9.1000` in a P2 config",
     ["config", "show", "--pipeline", "p2", "--config", "{d}/p2frac.toml"], 2),
    ("`bias = 1e300` in a P1 config", ["config", "show", "--config", "{d}/bias.toml"], 2),
    ("`threshold_g = 1e300` in a P3 config (was an OverflowError traceback in `run`)",
     ["config", "show", "--pipeline", "p3", "--config", "{d}/tg.toml"], 2),
    ("sweep axis `range = [0, 2**63 - 1]`", ["sweep", "{d}/int64.toml", "--out", "{d}/s3"], 2),
    ("sweep grid of 10^8 points", ["sweep", "{d}/grid.toml", "--out", "{d}/s4"], 2),
    ("resumed sweep whose results.jsonl has a binary tail",
     ["sweep", "{d}/a.toml", "--out", "{d}/tail"], 2),
    ("resumed sweep whose results.jsonl is a directory",
     ["sweep", "{d}/a.toml", "--out", "{d}/swdir"], 2),
    ("`--scene` with image files",
     ["run", "--scene", "lab", "--left", "{d}/left.npy", "--right", "{d}/right.npy", *PAIR], 2),
    ("empty `--formats`", ["vectors", "gen", "--formats", "", "--out", "{d}/v3"], 2),
    ("empty `--out`", ["run", "--out", ""], 2),
    ("`--size 100000`", ["bench", "--size", "100000"], 2),
    ("a 12000x12000 image pair",
     ["run", "--pipeline", "p1", "--left", "{d}/l12k.npy", "--right", "{d}/r12k.npy", *PAIR], 2),
    ("manifest with `hblank` 8e12", ["vectors", "check", "{d}/hblank"], 2),
    ("manifest whose scene was edited to `moon`", ["vectors", "check", "{d}/moon"], 1),
    ("manifest whose seed was edited", ["vectors", "check", "{d}/seed"], 1),
)  # fmt: skip


def run_cases_40() -> list[tuple[str, str, str, int]]:
    return run_rows(_setup_40, [(what, argv) for what, argv, _ in CASES_40], _normalise)


def test_issue40_rows_print_one_line_with_their_exit_code():
    rows = run_cases_40()
    check_rows_one_line(rows)
    for (what, _, message, code), (_, _, want) in zip(rows, CASES_40, strict=True):
        assert code == want, (what, code, message)
        assert code != 2 or message.startswith("rangefx: error: "), (what, message)
    text = DOC.read_text(encoding="utf-8")
    assert text == replace_table(text, table_markdown(rows, "bad input"), BEGIN_40, END_40), (
        "docs/guarantees.md is stale: run python tests/test_docs_guarantees.py"
    )


if __name__ == "__main__":
    page = DOC.read_text(encoding="utf-8")
    page = replace_table(page, table_markdown(run_cases(), "bad input"), BEGIN, END)
    page = replace_table(page, table_markdown(run_cases_40(), "bad input"), BEGIN_40, END_40)
    DOC.write_text(page, encoding="utf-8")
    sys.exit(0)
