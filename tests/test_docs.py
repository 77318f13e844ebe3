"""The documentation site (issue 37 items 4-5): it builds with warnings as errors, the code
of the tutorial and the recipes runs, and every repository path README.md and docs/ name
exists.

Runnable pages (:data:`RUNNABLE_PAGES`) are executed block by block, in order, in one
temporary directory, as a reader would type them:

* a ```` ```python ```` block is executed in one namespace per page (later blocks see
  earlier names);
* a ```` ```bash ```` block is run by ``bash -euo pipefail`` (``rangefx`` of this
  interpreter's environment first on ``PATH``);
* a block of any language whose first line is ``# file: NAME`` or ``// file: NAME`` is
  written to ``NAME`` instead (a cocotb test module, a Verilog file);
* ```` ```console ```` and ```` ```text ```` blocks are shown, never run (the full-size
  ``rangefx demo``, which ``.ci/run`` runs verbatim anyway, and printed output).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
DOCS = REPO / "docs"
#: The pages whose code blocks are executed.
RUNNABLE_PAGES = (
    "index.md",
    "tutorial.md",
    "pipelines.md",
    "api/index.md",
    "recipes/testbench_vectors.md",
    "recipes/check_rtl_dump.md",
    "recipes/wordlength_study.md",
)
#: The top-level entries of the repository a path in the docs may start with.
TOP_LEVEL = ("golden", "rtl_model", "vectors", "guidance", "tools", "tests", "hdl", "docs", ".ci")
#: Paths the docs name that the reader's own commands create (the built site).
GENERATED = ("docs/_build/",)
#: Pages that other issues edit and that still name a path that does not exist:
#: (page, path) -> why it is kept. Empty when every page is current.
KNOWN_STALE: dict[tuple[str, str], str] = {}

FENCE = re.compile(r"^(`{3,})([\w+-]*)[^\n]*\n(.*?)^\1\s*$", re.M | re.S)
FILE_MARK = re.compile(r"^(?:#|//)\s*file:\s*(\S+)\s*$")


def code_blocks(page: Path) -> list[tuple[str, str]]:
    """(language, body) of every fenced code block of a Markdown page, in order."""
    return [(m.group(2), m.group(3)) for m in FENCE.finditer(page.read_text())]


def run_page(page: Path, workdir: Path) -> int:
    """Execute the runnable blocks of ``page`` in ``workdir``; the number of blocks run.

    Raises ``AssertionError`` naming the block (its index and first line) that failed."""
    namespace: dict[str, object] = {"__name__": "__docs__"}
    # a reader's shell: without pytest's PYTEST_CURRENT_TEST, which cocotb's runner would
    # use to name a results file beside hdl/ (rangefx hdl replay)
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_CURRENT_TEST"}
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    env.setdefault("MPLBACKEND", "Agg")
    ran = 0
    for index, (language, body) in enumerate(code_blocks(page)):
        first = body.splitlines()[0] if body.strip() else ""
        where = f"{page.name} block {index} ({first!r})"
        mark = FILE_MARK.match(first)
        if mark:
            (workdir / mark.group(1)).write_text(body.split("\n", 1)[1])
            ran += 1
        elif language == "python":
            cwd = os.getcwd()
            os.chdir(workdir)
            try:
                exec(compile(body, where, "exec"), namespace)
            except Exception as exc:
                raise AssertionError(f"{where} raised {exc!r}") from exc
            finally:
                os.chdir(cwd)
            ran += 1
        elif language == "bash":
            done = subprocess.run(
                ["bash", "-euo", "pipefail", "-c", body],
                cwd=workdir, env=env, capture_output=True, text=True, check=False,
            )  # fmt: skip
            output = (done.stdout + done.stderr)[-3000:]
            assert done.returncode == 0, f"{where} exited {done.returncode}:\n{output}"
            ran += 1
    return ran


def test_the_python_examples_of_the_readme_run(tmp_path):
    """README.md's ```python blocks (its ```bash block is the install, which CI runs)."""
    page = tmp_path / "README.md"
    blocks = [body for language, body in code_blocks(REPO / "README.md") if language == "python"]
    assert blocks, "README.md has no python example"
    page.write_text("".join(f"```python\n{body}```\n\n" for body in blocks))
    assert run_page(page, tmp_path) == len(blocks)


@pytest.mark.parametrize("name", RUNNABLE_PAGES)
def test_the_code_of_the_tutorial_and_recipes_runs(name, tmp_path, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    assert run_page(DOCS / name, tmp_path) > 0, f"{name} has no runnable block"


def test_a_broken_snippet_fails_the_page(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```python\nx = 1\n```\n\n```python\nassert x == 2, 'planted'\n```\n")
    with pytest.raises(AssertionError, match=r"block 1 .*planted"):
        run_page(page, tmp_path)
    page.write_text("```bash\ntrue\n```\n\n```bash\nrangefx no-such-command\n```\n")
    with pytest.raises(AssertionError, match=r"block 1 .*exited 2"):
        run_page(page, tmp_path)


# -- every path the docs name exists ---------------------------------------------------------
BACKTICKED = re.compile(r"`([^`\s]+)`")
LINK = re.compile(r"\]\(([^)\s]+)\)")


def _clean(token: str) -> str:
    token = token.split("#", 1)[0].rstrip(".,;:)")
    return re.sub(r":\d+(-\d+)?$", "", token)  # file.py:123


def _exists(path: Path) -> bool:
    """``path`` exists; ``file.py::name``, ``file.py:name`` (a test or function in a
    file) and ``module.name`` / ``package.name`` (an object in a module) exist when the
    file does and defines or assigns ``name``."""
    text = str(path)
    name = None
    if "::" in text or re.search(r"\.py:\w", text):
        text, name = re.split(r"::|(?<=\.py):", text, maxsplit=1)
        name = name.split("::")[-1].split("[")[0]
    if Path(text).exists() and name is None:
        return True
    if name is None:
        stem, dot, name = text.rpartition(".")
        if not dot or "/" in name:
            return False
        text = next((c for c in (stem + ".py", stem + "/__init__.py") if Path(c).exists()), "")
    if not text or not Path(text).is_file():
        return False
    return re.search(rf"^\s*(?:def|class|async def)\s+{name}\b|^\s*{name}\s*[:=]",
                     Path(text).read_text(), re.M) is not None  # fmt: skip


def _backticked_path(token: str) -> Path | None:
    """The repository path a backticked ``token`` names (``rtl_model/p1/cost.py``,
    ``rangefx/numba_cache.py``, ``README.md``), or None when it is not one."""
    token = _clean(token)
    if not token or "://" in token or any(c in token for c in "*<>{}$|=,()[]~"):
        return None
    if token.startswith("rangefx/"):
        token = token[len("rangefx/") :]
    head = token.split("/", 1)[0]
    if token.startswith(GENERATED):
        return None
    if head in TOP_LEVEL and "/" in token:
        return REPO / token
    if token in ("README.md", "LICENSE", "CHANGELOG.md", "pyproject.toml"):
        return REPO / token
    return None


def _link_path(target: str, page: Path) -> Path | None:
    """The file a Markdown link's target names, relative to its page; None for a URL or
    an anchor on the same page."""
    if "://" in target or target.startswith(("#", "mailto:")):
        return None
    path = _clean(target)
    return (page.parent / path).resolve() if path else None


def missing_paths(page: Path) -> list[str]:
    """Paths a page names in backticks or as link targets, outside code blocks (code
    blocks hold commands and output, with paths the reader creates), that do not exist."""
    text = FENCE.sub("", page.read_text())
    missing = set()
    for token in BACKTICKED.findall(text):
        path = _backticked_path(token)
        if path is not None and not _exists(path):
            missing.add(token)
    for target in LINK.findall(text):
        path = _link_path(target, page)
        if path is not None and not _exists(path):
            missing.add(target)
    return sorted(missing)


PAGES = [REPO / "README.md", REPO / "CHANGELOG.md", *sorted(DOCS.rglob("*.md"))]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(REPO)))
def test_every_path_the_docs_name_exists(page):
    rel = str(page.relative_to(REPO))
    stale = [p for p in missing_paths(page) if (rel, p) not in KNOWN_STALE]
    assert not stale, f"{rel} names paths that do not exist: {stale}"


def test_the_path_check_finds_a_stale_path(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "See `vectors/cocotb_axis.py`, `rtl_model/p1/model.py`, [x](../no_such_page.md)\n"
        "and `./rangefx-out/` (made by the reader), `e1.row_r1.mem`.\n"
        "```bash\nls vectors/not_checked_in_code\n```\n"
    )
    assert missing_paths(page) == ["../no_such_page.md", "vectors/cocotb_axis.py"]


def test_the_readme_is_short_and_starts_with_the_two_commands():
    lines = (REPO / "README.md").read_text().splitlines()
    assert len(lines) <= 150, f"README.md has {len(lines)} lines"
    commands = [line for line in lines if line.startswith("python3 -m pip install")]
    assert commands[:2] == [
        "python3 -m pip install . && rangefx demo",
        "python3 -m pip install -e '.[test]' && python3 -m pytest",
    ]


# -- the site builds ----------------------------------------------------------------------------
def test_the_site_builds_without_warnings(tmp_path):
    """``python -m sphinx -W --keep-going -b html docs OUT`` (the ``docs`` extra). ``.ci/run``
    builds the site with that command just before the suite and says where
    (``RANGEFX_DOCS_BUILT``): then only its front page and references are checked here."""
    built = os.environ.get("RANGEFX_DOCS_BUILT")
    if built:
        out = Path(built)
    else:
        missing = [m for m in ("sphinx", "furo", "myst_parser", "sphinxarg") if not _importable(m)]
        if missing:
            pytest.skip(f"the docs extra is not installed ({missing}): pip install -e '.[docs]'")
        out = tmp_path / "html"
        done = subprocess.run(
            [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
             str(DOCS), str(out), "-d", str(tmp_path / "doctrees")],
            capture_output=True, text=True, check=False, env={**os.environ, "MPLBACKEND": "Agg"},
        )  # fmt: skip
        assert done.returncode == 0, done.stderr[-5000:]
    assert (out / "index.html").exists() and (out / "tutorial.html").exists()
    cli = (out / "cli.html").read_text()
    assert "vectors gen" in cli and "--crop" in cli  # generated from the parser
    api = "".join(p.read_text() for p in (out / "api" / "generated").glob("*.html"))
    assert "build_vectors" in api and "PipelineResult" in api  # generated from docstrings
    # autodoc's reStructuredText rendered, not shown as text (as in a MyST page)
    assert ".. automodule::" not in api and "py:module::" not in api


def _importable(module: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(module) is not None
